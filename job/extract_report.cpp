#include "job/extract_report.h"

#include <fmt/format.h>

#include <nlohmann/json.hpp>

#include "metrics/report.h"

namespace isoslab {
namespace {

using Json = nlohmann::ordered_json;

Json array3(const std::array<double, 3>& a) {
  return Json::array({a[0], a[1], a[2]});
}

const char* smoothMethodName(SmoothMethod m) {
  return m == SmoothMethod::kTaubin ? "taubin" : "sinc";
}

Json decimationJson(const ExtractReport::Decimation& dec) {
  const DecimationReport& d = dec.result;
  Json j = {{"ratio", dec.ratio},
            {"max_error", dec.maxError},
            {"triangles_before", d.trianglesIn},
            {"triangles_after", d.trianglesOut},
            {"kept_fraction",
             d.trianglesIn > 0 ? static_cast<double>(d.trianglesOut) / static_cast<double>(d.trianglesIn) : 1.0},
            {"distance_bound_voxels", dec.distanceBoundVoxels},
            {"blocks", d.blocks},
            {"regions", d.regions},
            {"regions_repaired", d.repairedRegions},
            {"triangles_frozen", d.frozenTriangles},
            {"regions_kept_whole", d.keptRegions},
            {"simplify_calls", d.attempts},
            {"calls_broken_shape", d.brokenShape},
            {"calls_beyond_bound", d.beyondBound},
            {"calls_crossing", d.crossing}};
  if (d.measured) {  // the one-sided distance to the original surface, when it was measured
    j.update(Json{{"distance_mean", d.distanceMean},
                  {"distance_max", d.distanceMax},
                  {"distance_mean_voxels", d.distanceMean / dec.voxelSize},
                  {"distance_max_voxels", d.distanceMax / dec.voxelSize},
                  {"distance_samples", d.samples}});
  }
  return j;
}

Json outputJson(const ExtractReport& report) {
  const ExtractReport::Output& o = report.output;
  Json output = {{"path", o.path}, {"bytes", o.bytes}};
  if (report.stats.triangles > 0) {
    output["bits_per_triangle"] = 8.0 * static_cast<double>(o.bytes) / static_cast<double>(report.stats.triangles);
  }
  output["ratio_to_binary_ply"] = static_cast<double>(o.bytes) / static_cast<double>(o.binaryPlyBytes);
  for (const auto& [key, value] : o.details) output[key] = value;
  return output;
}

// A label run's surfaces and the interfaces between them.
void addLabelsJson(Json& r, const ExtractReport& report) {
  Json labels = Json::array();
  for (const ExtractLabel& l : report.labels) {
    Json j = {{"value", l.value}, {"name", l.name}};
    if (l.iso) j["iso"] = *l.iso;
    j.update(Json{{"color", {l.color[0], l.color[1], l.color[2]}},
                  {"color_from", l.colorFromTable ? "table" : "default"},
                  {"layer", l.layer},
                  {"voxels", l.voxels},
                  {"voxel_volume", l.voxelVolume}});
    if (l.measured) j.update(Json{{"mesh_volume", l.stats.volume}, {"area", l.stats.area}});
    j.update(Json{{"vertices", l.stats.vertices}, {"triangles", l.stats.triangles}});
    if (l.topology) {
      j["closed"] = l.stats.closed();
      j["oriented"] = l.stats.oriented();
      j["boundary_edges"] = l.stats.boundaryEdges;
      j["nonmanifold_edges"] = l.stats.nonManifoldEdges;
      j["euler"] = l.stats.euler;
    }
    if (const auto& c = l.components) {
      j["components"] = {{"found", c->components},
                         {"dropped", c->dropped},
                         {"voxels_given", c->voxelsGiven},
                         {"voxels_taken", c->voxelsTaken}};
    }
    j["splits"] = l.splits;
    j["pinches"] = l.pinches;
    if (l.smoothing) {
      if (l.measured && l.voxelVolume > 0) j["volume_change"] = l.stats.volume / l.voxelVolume - 1;
      j["largest_displacement"] = l.smoothing->first;
      j["held_back"] = l.smoothing->second;
    }
    j["bounds"] = l.stats.bounds;
    if (!l.path.empty()) j["path"] = l.path;
    labels.push_back(j);
  }
  r["labels"] = labels;
  Json interfaces = Json::array();
  for (const ExtractInterface& i : report.interfaces) {
    interfaces.push_back({{"labels", {i.a, i.b}}, {"triangles", i.triangles}, {"area", i.area}});
    if (report.layers > 1) interfaces.back()["layer"] = i.layer;
  }
  r["label_interfaces"] = interfaces;
  if (report.layers > 1) r["layers"] = report.layers;
}

}  // namespace

std::string extractReportText(const ExtractReport& report, const std::string& what,
                              const std::function<std::string(const std::string&)>& spell) {
  const auto spelled = [&](const std::string& text) { return spell ? spell(text) : text; };
  Json r;
  r["generator"] = fmt::format("isoslab {}", ISOSLAB_VERSION);
  r["input"] = report.inputs.size() == 1 ? Json(report.inputs.front()) : Json(report.inputs);
  r["reader"] = report.reader;
  r["method"] = report.method;
  r["iso"] = report.iso;
  r["iso_source"] = report.isoSource;
  if (!report.isoNote.empty()) r["iso_note"] = spelled(report.isoNote);
  if (const auto& h = report.isoHistogram) {
    r["iso_histogram"] = {{"bins", h->bins},
                          {"range", {h->range[0], h->range[1]}},
                          {"range_from", h->rangeFromReader ? "reader" : "data"},
                          {"passes", h->passes},
                          {"first_inside_bin", h->firstInsideBin}};
  }
  r["dims"] = {report.dims[0], report.dims[1], report.dims[2]};
  if (const auto& roi = report.roi) {
    const LatticeBox& b = roi->box;
    r["roi"] = {{"box", {b.lo[0], b.lo[1], b.lo[2], b.hi[0], b.hi[1], b.hi[2]}},
                {"requested", roi->requested},
                {"space", roi->space},
                {"clipped", roi->clipped},
                {"input_dims", {roi->inputDims[0], roi->inputDims[1], roi->inputDims[2]}}};
  }
  r["spacing"] = array3(report.spacing);
  r["volume_bounds"] = report.volumeBounds;
  r["voxel_type"] = report.voxelType;
  r["space"] = report.space;
  r["normals"] = report.normals;
  r["value_range"] = report.valueRange ? Json::array({(*report.valueRange)[0], (*report.valueRange)[1]}) : Json();
  Json warnings = Json::array();
  for (const std::string& w : report.warnings) warnings.push_back(spelled(w));
  r["warnings"] = warnings;
  addStatsJson(r, report.stats);
  if (const auto& s = report.smoothing) {
    r["smoothing"] = {{"iterations", s->options.iterations},
                      {"method", smoothMethodName(s->options.method)},
                      {"pass_band", s->options.passBand},
                      {"faces", s->options.faces == FaceVertices::kLock ? "lock" : "slide"},
                      {"normals", !report.normals               ? "none"
                                  : s->options.recomputeNormals ? "smoothed"
                                                                : "field"},
                      {"peak_chunks", s->peakChunks},
                      {"peak_vertices", s->peakVertices}};
  }
  if (report.decimation) r["decimation"] = decimationJson(*report.decimation);
  if (!report.componentsJson.empty()) r["components"] = Json::parse(report.componentsJson);
  if (!report.componentFilterJson.empty()) r["component_filter"] = Json::parse(report.componentFilterJson);
  if (!report.sphereJson.empty()) r["sphere"] = Json::parse(report.sphereJson);
  r["seconds"] = {{"read", report.seconds.read},
                  {"extract", report.seconds.extract},
                  {"write", report.seconds.write},
                  {"total", report.seconds.total}};
  if (report.seconds.componentPass) r["seconds"]["component_pass"] = *report.seconds.componentPass;
  if (report.decimation) {
    const DecimationReport::Seconds& d = report.decimation->result.seconds;
    r["seconds"]["decimation"] = {{"calls", d.calls},       {"simplifier", d.simplifier}, {"checks", d.checks},
                                  {"crossing", d.crossing}, {"grids", d.grids},           {"measure", d.measure}};
  }
  if (report.ranks > 1) r["ranks"] = report.ranks;
  r["ring_bytes"] = report.ringBytes;
  r["peak_rss_mib"] = report.peakRssMib;
  r["output"] = outputJson(report);
  if (report.labelRun) addLabelsJson(r, report);
  return reportText(r, what);
}

}  // namespace isoslab
