// JSON pieces shared by the isoslab commands' reports.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "metrics/component_filter.h"
#include "metrics/components.h"
#include "metrics/mesh_stats.h"
#include "metrics/sphere_metrics.h"

namespace isoslab {

/// Adds the mesh measures to a report: vertices, triangles, degenerate_triangles, bounds, area,
/// volume, volume_cells (null without tetrahedra), edges, boundary_edges, interior_boundary_edges,
/// nonmanifold_edges, inconsistent_edges, euler, closed.
void addStatsJson(nlohmann::ordered_json& r, const MeshStats& s);

/// The connected components: {"count", "closed" (how many are), "largest": up to `listed` of
/// them by triangle count (ties by id), each {"id", "triangles", "area", "volume", "bounds",
/// "closed"}}. With `kept` (per id, from a component filter), each listed one also says whether it
/// was kept.
nlohmann::ordered_json componentsJson(const std::vector<Component>& components, std::size_t listed = 10,
                                      const std::vector<bool>* kept = nullptr);
/// The same from a summary (ComponentSink::summarize), which lists its `largest` in their order.
nlohmann::ordered_json componentsJson(const ComponentSummary& summary);

/// A component filter's work: {"rules", "passes": 2, "parts" (the first pass's part serials), "kept":
/// {"count", "triangles", "area", "volume"}, "dropped": {the same}}.
nlohmann::ordered_json componentFilterJson(const ComponentRules& rules, const std::vector<Component>& components,
                                           const std::vector<bool>& kept, std::uint64_t parts);

/// The paper's measures: {"centre", "radius", "vertex": {...}, "centroid": {...}, "area_error", ...}.
nlohmann::ordered_json sphereJson(const SphereReport& r);

/// The report as text (indented by `indent`, -1 for one line), once every number in it is checked
/// to be finite: JSON has no infinity or NaN (nlohmann would write null, which reads as "not
/// measured"). Throws isoslab::Error "WHAT: the report's FIELD is VALUE, not a finite number"
/// otherwise, so that the run fails rather than commit a report that hides the problem.
std::string reportText(const nlohmann::ordered_json& report, const std::string& what, int indent = 2);

}  // namespace isoslab
