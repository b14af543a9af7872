// JSON pieces shared by the isoslab commands' reports.
#pragma once

#include <nlohmann/json.hpp>

#include "extract/sphere_metrics.h"

namespace isoslab {

/// The paper's measures: {"centre", "radius", "vertex": {...}, "centroid": {...}, "area_error", ...}.
nlohmann::ordered_json sphereJson(const SphereReport& r);

}  // namespace isoslab
