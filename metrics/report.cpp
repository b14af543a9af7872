#include "metrics/report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "core/error.h"

namespace isoslab {
namespace {

nlohmann::ordered_json errorJson(const ErrorStats& e, std::uint64_t triangles) {
  nlohmann::ordered_json j;
  j["count"] = e.count;
  j["sum"] = e.sum;
  j["sum_per_triangle"] = triangles ? e.sum / static_cast<double>(triangles) : 0.0;
  j["mean"] = e.mean();
  j["mean_abs"] = e.meanAbs();
  j["rms"] = e.rms();
  j["max_abs"] = e.maxAbs;
  return j;
}

}  // namespace

void addStatsJson(nlohmann::ordered_json& r, const MeshStats& s) {
  r["vertices"] = s.vertices;
  r["triangles"] = s.triangles;
  r["degenerate_triangles"] = s.degenerateTriangles;
  r["bounds"] = s.bounds;
  r["area"] = s.area;
  r["volume"] = s.volume;
  if (s.cellVolume) {
    r["volume_cells"] = *s.cellVolume;
  } else {
    r["volume_cells"] = nullptr;
  }
  r["edges"] = s.edges;
  r["boundary_edges"] = s.boundaryEdges;
  r["interior_boundary_edges"] = s.interiorBoundaryEdges;
  r["nonmanifold_edges"] = s.nonManifoldEdges;
  r["inconsistent_edges"] = s.inconsistentEdges;
  r["euler"] = s.euler;
  r["closed"] = s.closed();
}

namespace {

// A listed component of the report.
nlohmann::ordered_json listedJson(const Component& c) {
  nlohmann::ordered_json e;
  e["id"] = c.id;
  if (c.label != 0) e["label"] = c.label;
  e["triangles"] = c.triangles;
  e["area"] = c.area;
  e["volume"] = c.volume;
  e["bounds"] = c.bounds;
  e["closed"] = c.closed();
  return e;
}

}  // namespace

nlohmann::ordered_json componentsJson(const std::vector<Component>& components, std::size_t listed,
                                      const std::vector<bool>* kept) {
  nlohmann::ordered_json j;
  j["count"] = components.size();
  j["closed"] = std::count_if(components.begin(), components.end(), [](const Component& c) { return c.closed(); });
  std::vector<std::size_t> order(components.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  const auto shown = static_cast<std::ptrdiff_t>(std::min(listed, order.size()));
  std::partial_sort(order.begin(), order.begin() + shown, order.end(), [&](std::size_t a, std::size_t b) {
    return components[a].triangles != components[b].triangles ? components[a].triangles > components[b].triangles
                                                              : a < b;
  });
  nlohmann::ordered_json largest = nlohmann::ordered_json::array();
  for (auto i = order.begin(); i != order.begin() + shown; ++i) {
    nlohmann::ordered_json e = listedJson(components[*i]);
    if (kept != nullptr) e["kept"] = static_cast<bool>((*kept)[*i]);
    largest.push_back(std::move(e));
  }
  j["largest"] = std::move(largest);
  return j;
}

nlohmann::ordered_json componentsJson(const ComponentSummary& summary) {
  nlohmann::ordered_json j;
  j["count"] = summary.count;
  j["closed"] = summary.closed;
  nlohmann::ordered_json largest = nlohmann::ordered_json::array();
  for (const Component& c : summary.largest) largest.push_back(listedJson(c));
  j["largest"] = std::move(largest);
  return j;
}

nlohmann::ordered_json componentFilterJson(const ComponentRules& rules, const std::vector<Component>& components,
                                           const std::vector<bool>& kept, std::uint64_t parts) {
  struct Sum {
    std::uint64_t count = 0, triangles = 0;
    double area = 0, volume = 0;
  } sums[2];
  for (std::size_t i = 0; i < components.size(); ++i) {
    Sum& s = sums[kept[i] ? 0 : 1];
    ++s.count;
    s.triangles += components[i].triangles;
    s.area += components[i].area;
    s.volume += components[i].volume;
  }
  const auto json = [](const Sum& s) {
    return nlohmann::ordered_json{
        {"count", s.count}, {"triangles", s.triangles}, {"area", s.area}, {"volume", s.volume}};
  };
  nlohmann::ordered_json j;
  j["rules"] = rules.text();
  j["passes"] = 2;
  j["parts"] = parts;
  j["kept"] = json(sums[0]);
  j["dropped"] = json(sums[1]);
  return j;
}

nlohmann::ordered_json sphereJson(const SphereReport& r) {
  nlohmann::ordered_json j;
  j["centre"] = r.sphere.centre;
  j["radius"] = r.sphere.radius;
  j["triangles"] = r.triangles;
  j["vertices"] = r.vertices;
  j["radius_error_vertex"] = errorJson(r.vertex, r.triangles);
  j["radius_error_centroid"] = errorJson(r.centroid, r.triangles);
  j["area_error"] = r.areaError;
  j["volume_error"] = r.volumeError;
  if (r.volumeCellsError) {
    j["volume_cells_error"] = *r.volumeCellsError;
  } else {
    j["volume_cells_error"] = nullptr;
  }
  return j;
}

namespace {

// The first non-finite number in `j`, as its JSON pointer ("/bounds/3"), or empty.
std::string firstNonFinite(const nlohmann::ordered_json& j, const std::string& at, double& value) {
  if (j.is_number_float()) {
    const double v = j.get<double>();
    if (!std::isfinite(v)) {
      value = v;
      return at.empty() ? "/" : at;
    }
    return "";
  }
  if (j.is_object()) {
    for (const auto& [key, item] : j.items()) {
      if (std::string found = firstNonFinite(item, at + "/" + key, value); !found.empty()) return found;
    }
  } else if (j.is_array()) {
    for (std::size_t k = 0; k < j.size(); ++k) {
      if (std::string found = firstNonFinite(j[k], fmt::format("{}/{}", at, k), value); !found.empty()) return found;
    }
  }
  return "";
}

}  // namespace

std::string reportText(const nlohmann::ordered_json& report, const std::string& what, int indent) {
  double value = 0;
  if (const std::string field = firstNonFinite(report, "", value); !field.empty()) {
    throw Error(fmt::format("{}: the report's {} is {}, not a finite number", what, field, value));
  }
  // Strings from the input (paths, header values) that are not UTF-8 get U+FFFD: JSON holds UTF-8 only.
  return report.dump(indent, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace isoslab
