// Steps of the label run (job/label_job.cpp): the selection of labels, and the per-label component
// rules' first pass.
#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <limits>
#include <set>
#include <utility>
#include <vector>

#include "core/error.h"
#include "core/interrupt.h"
#include "io/label_source.h"
#include "job/extract_steps.h"
#include "metrics/report.h"

namespace isoslab {

std::optional<std::set<std::int32_t>> selectedLabels(const LabelRequest& request, const LabelTable* table,
                                                     const std::string& tableName, int layers, bool tableKeys) {
  if (request.all) return std::nullopt;
  std::set<std::int32_t> keep;
  const auto keepValue = [&](std::int32_t value) {
    for (int layer = 0; layer < layers; ++layer) keep.insert(layeredLabel(layer, value));
  };
  // The selection is a set of every label it names, per layer: ranges that name millions take
  // gigabytes (`1-16777215` took 2.4 GB), so they are capped.
  constexpr std::int64_t kMostSelected = 1000000;
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;  // merged, to count each value once
  for (const auto& [lo, hi] : request.ranges) ranges.emplace_back(lo, hi);
  std::sort(ranges.begin(), ranges.end());
  std::int64_t selected = 0, covered = std::numeric_limits<std::int64_t>::min();  // the last value counted
  for (const auto& [lo, hi] : ranges) {
    const std::int64_t from = std::max(lo, covered + 1);
    if (hi < from) continue;
    selected += (hi - from + 1 - (from <= 0 && 0 <= hi ? 1 : 0)) * layers;  // 0 is never kept
    covered = hi;
  }
  if (selected > kMostSelected) {
    throw SettingError(fmt::format("`labels` ranges select {} labels{}; a selection holds at most {} (use all)",
                                   selected, layers > 1 ? " over the layers" : "", kMostSelected));
  }
  for (const auto& [lo, hi] : request.ranges) {
    for (std::int64_t v = lo; v <= hi; ++v) {
      if (v != 0) keepValue(static_cast<std::int32_t>(v));
    }
  }
  for (const std::string& name : request.names) {
    if (table == nullptr) {
      throw SettingError(fmt::format("`labels` names '{}', but no label table gives names (`label_table`)", name));
    }
    const LabelEntry* e = table->findName(name);
    if (e == nullptr) {
      const LabelEntry* near = table->nearest(name);
      throw SettingError(fmt::format("`labels` names '{}', which {} does not hold; the nearest is '{}' ({})", name,
                                     tableName, near->name, near->value));
    }
    if (tableKeys) {
      keep.insert(e->value);
    } else if (e->value != 0) {
      keepValue(e->value);
    }
  }
  keep.erase(0);
  return keep;
}

LabelRelabelling chooseLabelComponents(SliceSource& labels, const std::string& what, const ExtractSettings& settings,
                                       double voxelVolume, const SlabHook& onSlice, ExtractReport& report) {
  const auto start = std::chrono::steady_clock::now();
  const VolumeInfo& info = labels.info();
  LabelComponentFinder finder(info, what);
  std::vector<float> slice;
  for (std::int64_t z = 0; readSliceInto(labels, slice); ++z) {
    finder.addSlice(slice);
    throwIfInterrupted();
    if (onSlice) onSlice(z + 1, info.dims[2]);
  }
  const ComponentRules& given = settings.components;
  LabelComponentRules rules;
  rules.keepLargest = given.keepLargest;
  rules.largestByVoxels = given.measure == ComponentMeasure::kVolume;
  rules.minTriangles = given.minTriangles;
  rules.minVolume = given.minVolume;
  rules.voxelVolume = voxelVolume;
  const std::vector<LabelComponent>& components = finder.components();
  const std::vector<bool> keep = selectLabelComponents(components, rules);
  struct Sum {
    std::uint64_t count = 0;
    std::int64_t voxels = 0, triangles = 0;
  } sums[2];
  for (std::size_t i = 0; i < components.size(); ++i) {
    Sum& s = sums[keep[i] ? 0 : 1];
    ++s.count;
    s.voxels += components[i].voxels;
    s.triangles += 2 * components[i].faces;
  }
  const auto json = [&](const Sum& s) {
    return nlohmann::ordered_json{{"count", s.count},
                                  {"voxels", s.voxels},
                                  {"voxel_volume", static_cast<double>(s.voxels) * voxelVolume},
                                  {"triangles", s.triangles}};
  };
  nlohmann::ordered_json j;
  j["rules"] = given.text();
  j["per"] = "label";
  j["connectivity"] = 6;
  j["passes"] = 2;
  j["parts"] = finder.parts();
  j["kept"] = json(sums[0]);
  j["dropped"] = json(sums[1]);
  report.componentFilterJson = reportText(j, settings.reportPath, -1);
  LabelRelabelling relabelling = finder.relabelling(keep);
  report.seconds.componentPass = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return relabelling;
}

std::vector<std::string> droppedLabelWarnings(const std::map<std::int32_t, LabelChange>& changes,
                                              const std::function<bool(std::int32_t)>& hasSurface,
                                              const std::function<std::string(std::int32_t)>& nameOf) {
  std::vector<std::int32_t> gone;
  for (const auto& [label, c] : changes) {
    if (labelValue(label) != 0 && c.dropped > 0 && !hasSurface(label)) gone.push_back(label);
  }
  if (gone.empty()) return {};
  if (gone.size() == 1) {
    return {fmt::format("label {} ('{}'): the component rules dropped every component of it", labelValue(gone[0]),
                        nameOf(gone[0]))};
  }
  return {fmt::format("the component rules dropped every component of {} labels (the first: {})", gone.size(),
                      labelValue(gone[0]))};
}

}  // namespace isoslab
