// The label run of runExtract (job/extract_job.cpp): every selected label's surface from one pass
// over a label map, through the label complex (extract/label_extractor.h) split per label
// (process/label_surfaces.h) into each label's writer and measures.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <optional>
#include <cmath>
#include <map>
#include <memory>
#include <set>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/draco_writers.h"
#include "encode/mesh_writer.h"
#include "encode/ply_writer.h"
#include "extract/label_extractor.h"
#include "io/label_source.h"
#include "io/label_table.h"
#include "io/pad_source.h"
#include "job/extract_steps.h"
#include "metrics/mesh_stats.h"
#include "metrics/report.h"
#include "process/label_surfaces.h"
#include "stream/pipeline.h"
#include "stream/rank_group.h"

namespace isoslab {
namespace {

// The labels that a request keeps (nothing: every label), with names resolved through the table.
std::optional<std::set<std::int32_t>> selectedLabels(const LabelRequest& request, const LabelTable* table,
                                                     const std::string& tableName) {
  if (request.all) return std::nullopt;
  std::set<std::int32_t> keep;
  for (const auto& [lo, hi] : request.ranges) {
    if (static_cast<std::int64_t>(hi) - lo > 16777216) throw SettingError("`labels` range is too wide");
    for (std::int64_t v = lo; v <= hi; ++v) keep.insert(static_cast<std::int32_t>(v));
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
    keep.insert(e->value);
  }
  keep.erase(0);
  return keep;
}

// A name fit for a file name: path separators and control characters become '_'.
std::string fileSafe(const std::string& name) {
  std::string out = name;
  for (char& c : out) {
    if (c == '/' || c == '\\' || static_cast<unsigned char>(c) < 32 || c == ':') c = '_';
  }
  if (out.empty() || out == "." || out == "..") out = "_" + out;
  return out;
}

std::string expandPattern(const std::string& pattern, std::int32_t value, const std::string& name) {
  std::string out;
  for (std::size_t at = 0; at < pattern.size();) {
    if (pattern.compare(at, 6, "{name}") == 0) {
      out += fileSafe(name);
      at += 6;
    } else if (pattern.compare(at, 7, "{label}") == 0) {
      out += std::to_string(value);
      at += 7;
    } else {
      out += pattern[at++];
    }
  }
  return out;
}

// Counts the complex's vertices and triangles.
class ComplexCounter final : public MeshSink {
 public:
  void begin(const MeshHeader&) override {}
  void consume(const MeshChunk& chunk) override {
    stats_.vertices += chunk.positions.size();
    stats_.triangles += chunk.triangles.size();
  }
  void finish() override {}
  const MeshStats& stats() const noexcept { return stats_; }

 private:
  MeshStats stats_;
};

// One label's sinks: its writer (pattern outputs) and its measures.
struct LabelChain {
  std::unique_ptr<MeshFileSink> writer;
  MeshStatsSink stats;
  std::unique_ptr<TeeSink> tee;
  std::string path;
};

}  // namespace

void runLabelExtract(const ExtractSettings& settings, ExtractObserver& observer, OpenedInput input,
                     ExtractReport& report, const std::function<void(std::int64_t, std::int64_t)>& onSlab, int threads,
                     const WriterOptions& writing) {
  checkLabelSettings(settings);
  if (settings.ranks != nullptr && settings.ranks->size() > 1) {
    throw SettingError("label surfaces under mpirun are not supported yet: run one process");
  }
  report.labelRun = true;
  std::optional<LabelTable> table;
  if (!settings.labelTable.empty()) table = readLabelTable(settings.labelTable);
  const LabelRequest request = settings.labels.value_or(LabelRequest{});
  const auto keep = selectedLabels(request, table ? &*table : nullptr, settings.labelTable);
  const VolumeInfo info = input.source->info();
  const std::string what = settings.inputs.empty() ? info.source : settings.inputs.front();
  auto labelSource = std::make_unique<LabelSource>(std::move(input.source), what, keep);
  LabelSource* counter = labelSource.get();
  std::unique_ptr<SliceSource> source = std::make_unique<PadSource>(std::move(labelSource), 0.0f);
  const LatticeFrame frame = LatticeFrame::forSpace(info, std::string(outputSpaceName(settings.space)));
  auto extractor = makeLabelExtractor(info, frame);
  const MeshHeader header = labelHeader(info, frame);

  const bool pattern = isOutputPattern(settings.output);
  std::string extension = std::filesystem::path(settings.output).extension().string();
  for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // A .glb: one mesh per label in one file, its chunks encoded as they close.
  std::optional<GlbScene> scene;
  WriterOptions labelWriting = writing;
  if (!pattern && extension == ".glb") {
    labelWriting.encodeThreads = 0;
    scene.emplace(settings.output, labelWriting);
    scene->begin(header);
  }
  std::map<std::int32_t, LabelChain> chains;
  std::map<std::string, std::int32_t> paths;
  const auto nameOf = [&](std::int32_t value) {
    const LabelEntry* e = table ? table->find(value) : nullptr;
    return e != nullptr ? e->name : std::to_string(value);
  };
  const auto colorOf = [&](std::int32_t value) {
    const LabelEntry* e = table ? table->find(value) : nullptr;
    return e != nullptr && e->color ? *e->color : defaultLabelColor(value);
  };
  LabelSplitSink split([&](std::int32_t label) -> MeshSink* {
    LabelChain& chain = chains[label];
    std::vector<MeshSink*> sinks;
    if (settings.labelTopology) sinks.push_back(&chain.stats);
    if (pattern) {
      chain.path = expandPattern(settings.output, label, nameOf(label));
      const auto [it, fresh] = paths.emplace(chain.path, label);
      if (!fresh) {
        throw SettingError(fmt::format("`output` pattern '{}' gives '{}' to labels {} and {}", settings.output,
                                       chain.path, it->second, label));
      }
      chain.writer = makeMeshWriter(chain.path, writing);
      sinks.insert(sinks.begin(), chain.writer.get());
    } else if (scene) {
      chain.writer = std::make_unique<GlbDracoWriter>(settings.output, labelWriting, *scene, nameOf(label),
                                                      colorOf(label));
      sinks.insert(sinks.begin(), chain.writer.get());
    }
    chain.tee = std::make_unique<TeeSink>(sinks);
    return chain.tee.get();
  });
  // The complex as a whole is counted, not measured: its measures are the labels'.
  ComplexCounter complexStats;
  std::unique_ptr<MeshFileSink> complexWriter;
  std::vector<MeshSink*> heads{&split, &complexStats};
  if (!pattern && !scene) {
    complexWriter = makeMeshWriter(settings.output, writing);
    heads.insert(heads.begin(), complexWriter.get());
  }
  TeeSink tee(heads);
  PipelineOptions options;
  options.threads = threads;
  options.maxThreadBytes = (static_cast<std::size_t>(settings.maxMemoryMiB) << 20) / 2;
  if (settings.sequentialVoxels >= 0) options.sequentialVoxels = settings.sequentialVoxels;
  options.onSlab = onSlab;
  const PipelineResult run = runPipeline(*source, *extractor, tee, header, options);

  // The report: the complex as a whole, each label, and the interfaces.
  report.stats = complexStats.stats();
  report.method = "labels";
  report.isoSource = "labels";
  report.reader = info.reader;
  report.dims = info.dims;
  report.spacing = info.spacing;
  report.volumeBounds = header.volumeBounds;
  report.voxelType = std::string(voxelTypeName(info.type));
  report.space = header.space;
  if (run.valueRange) report.valueRange = std::array{asFloat((*run.valueRange)[0]), asFloat((*run.valueRange)[1])};
  const auto counts = counter->voxelCounts();
  const double voxelVolume = frame.cellVolume();
  const auto measures = split.measures();
  for (auto& [value, chain] : chains) {
    ExtractLabel l;
    l.value = value;
    l.name = nameOf(value);
    const LabelEntry* e = table ? table->find(value) : nullptr;
    l.colorFromTable = e != nullptr && e->color.has_value();
    l.color = colorOf(value);
    const auto n = counts.find(value);
    l.voxels = n != counts.end() ? n->second : 0;
    l.voxelVolume = static_cast<double>(l.voxels) * voxelVolume;
    l.topology = settings.labelTopology;
    if (l.topology) l.stats = chain.stats.stats();
    const LabelSplitSink::Measures& m = measures.at(value);
    l.stats.vertices = m.vertices;
    l.stats.triangles = m.triangles;
    l.stats.area = m.area;
    l.stats.volume = m.volume;
    l.stats.bounds = m.bounds;
    if (const auto s = split.splits().find(value); s != split.splits().end()) l.splits = s->second;
    if (const auto p = split.pinches().find(value); p != split.pinches().end()) l.pinches = p->second;
    l.path = chain.path;
    report.labels.push_back(std::move(l));
  }
  for (const auto& [pair, face] : split.interfaces()) {
    if (pair.first == 0) continue;  // a label's boundary with the background is in its own area
    report.interfaces.push_back(ExtractInterface{pair.first, pair.second, face.triangles, face.area});
  }
  // Requested labels that the volume lacks: one warning each, or one for many.
  if (keep) {
    std::vector<std::int32_t> absent;
    for (std::int32_t value : *keep) {
      if (counts.count(value) == 0) absent.push_back(value);
    }
    if (absent.size() <= 8) {
      for (std::int32_t value : absent) {
        report.warnings.push_back(fmt::format("label {} ('{}') is not in the volume", value, nameOf(value)));
      }
    } else {
      report.warnings.push_back(fmt::format("{} of the {} requested labels are not in the volume (the first: {})",
                                            absent.size(), keep->size(), absent.front()));
    }
  }
  if (chains.empty()) report.warnings.push_back("no selected label is in the volume: nothing was written");
  for (std::string& w : source->warnings()) report.warnings.push_back(std::move(w));
  for (std::size_t n = report.openingWarnings; n < report.warnings.size(); ++n) observer.warning(report.warnings[n]);
  report.seconds.read = run.readSeconds;
  report.seconds.extract = run.extractSeconds;
  report.seconds.write = run.writeSeconds;
  report.seconds.total = run.totalSeconds;
  report.ringBytes = run.ringBytes;
  if (scene) {
    // Each label's node carries its value and measures.
    for (std::size_t k = 0; k < report.labels.size() && k < scene->meshes().size(); ++k) {
      const ExtractLabel& l = report.labels[k];
      scene->meshes()[k].extras = {{"label", l.value},    {"voxels", l.voxels},
                                   {"voxel_volume", l.voxelVolume}, {"mesh_volume", l.stats.volume},
                                   {"area", l.stats.area}, {"triangles", l.stats.triangles}};
    }
    report.output.path = settings.output;
    report.output.bytes = scene->write({{"labels", report.labels.size()}});
  } else if (complexWriter) {
    report.output.path = settings.output;
    report.output.bytes = complexWriter->bytes();
    report.output.details = complexWriter->details();
  } else {
    report.output.path = settings.output;
    for (const auto& [value, chain] : chains) report.output.bytes += chain.writer->bytes();
  }
  report.output.binaryPlyBytes = PlyWriter::binaryBytes(report.stats.vertices, report.stats.triangles, header);
}

}  // namespace isoslab
