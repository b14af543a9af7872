// The label run of runExtract (job/extract_job.cpp): every selected label's surface from one pass
// over a label map, through the label complex (extract/label_extractor.h) split per label
// (process/label_surfaces.h) into each label's writer and measures.
#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "core/error.h"
#include "core/interrupt.h"
#include "encode/draco_writers.h"
#include "encode/glb_scene.h"
#include "encode/mesh_writer.h"
#include "encode/ply_writer.h"
#include "encode/threemf_writer.h"
#include "extract/label_extractor.h"
#include "extract/surface_set_extractor.h"
#include "io/label_source.h"
#include "io/label_table.h"
#include "io/pad_source.h"
#include "job/extract_steps.h"
#include "metrics/mesh_stats.h"
#include "metrics/report.h"
#include "process/decimation.h"
#include "process/label_surfaces.h"
#include "process/smoothing.h"
#include "stream/pipeline.h"
#include "stream/rank_group.h"

namespace isoslab {
namespace {

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

// One label's sinks: its writer (pattern outputs or the .glb's mesh); the split measures it.
struct LabelChain {
  std::unique_ptr<MeshFileSink> writer;
  std::unique_ptr<TeeSink> tee;
  std::string path;
};

// One run of a surface set: the labels of a label map, or several iso values of a field.
class SurfaceSetRun {
 public:
  SurfaceSetRun(const ExtractSettings& settings, ExtractReport& report, const WriterOptions& writing)
      : settings_(settings), report_(report), writing_(writing), isoSet_(!settings.isos.empty()) {}

  // Names and colours (the table given, else the file's own), the selection, then the source,
  // extractor and header of the stream.
  void open(OpenedInput input, const SlabHook& onComponentSlice, int& threads) {
    info_ = input.source->info();
    std::string tableName = settings_.labelTable;
    if (!settings_.labelTable.empty()) {
      table_ = readLabelTable(settings_.labelTable);
    } else if (!info_.labels.empty()) {
      // The file's own names, by layered label where it has several layers.
      table_.emplace();
      for (const VolumeInfo::Label& l : info_.labels) {
        table_->entries.push_back(
            LabelEntry{info_.layers > 1 ? layeredLabel(l.layer, l.value) : l.value, l.name, l.color});
      }
      tableName = info_.source;
      tableKeys_ = true;
    }
    request_ = settings_.labels.value_or(LabelRequest{});
    keep_ = selectedLabels(request_, table_ ? &*table_ : nullptr, tableName, info_.layers, tableKeys_);
    frame_ = LatticeFrame::forSpace(info_, std::string(outputSpaceName(settings_.space)));
    if (isoSet_) {
      // The field as it is (padded with NaN for --close-boundary); each value's surface a "label"
      // from 1, all extracted slab by slab (extract/surface_set_extractor.h).
      ExtractOptions o;
      o.method = settings_.method;
      o.closeBoundary = settings_.closeBoundary;
      o.cellVolumes = false;
      extractor_ = makeMultiIsoExtractor(o, settings_.isos, info_, frame_);
      header_ = extractionHeader(o, info_, frame_, *extractor_);
      header_.labels = true;
      source_ = std::move(input.source);
      if (settings_.closeBoundary) source_ = std::make_unique<PadSource>(std::move(source_));
      if (!extractor_->makeWorker()) threads = 1;
      if (settings_.components.any()) {
        // Component rules, each surface its own: a first pass finds and chooses, the second filters.
        keepPart_ = chooseComponents(*source_, *extractor_, header_, pipelineOptions(onComponentSlice, threads),
                                     settings_, settings_.components, primary(), report_);
        source_ = reopenInput(settings_, input);
        if (settings_.closeBoundary) source_ = std::make_unique<PadSource>(std::move(source_));
        extractor_ = makeMultiIsoExtractor(o, settings_.isos, info_, frame_);
      }
    } else {
      // Labels: checked and counted, padded with background; each layer a label complex.
      const std::string what = settings_.inputs.empty() ? info_.source : settings_.inputs.front();
      std::optional<LabelRelabelling> relabelling;
      if (settings_.components.any()) {
        // Per-label component rules: a first pass finds and chooses, the second relabels.
        LabelSource first(std::move(input.source), what, keep_);
        relabelling = chooseLabelComponents(first, what, settings_, frame_.cellVolume(),
                                            primary() ? onComponentSlice : SlabHook(), report_);
        input.source = reopenInput(settings_, input);
      }
      auto labels = std::make_unique<LabelSource>(std::move(input.source), what, keep_);
      counter_ = labels.get();
      source_ = std::move(labels);
      if (relabelling) {
        changes_ = relabelling->changes;
        source_ = std::make_unique<RelabelSource>(std::move(source_), what, std::move(*relabelling));
      }
      source_ = std::make_unique<PadSource>(std::move(source_), 0.0f);
      extractor_ = makeLayeredLabelExtractor(info_, frame_);
      header_ = labelHeader(info_, frame_);
    }
  }

  PipelineResult run(const SlabHook& onSlab, int threads) {
    pattern_ = !settings_.labelSinks && isOutputPattern(settings_.output);
    std::string extension = std::filesystem::path(settings_.output).extension().string();
    for (char& c : extension) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    // A .glb: one mesh per label in one file, its chunks encoded as they close.
    labelWriting_ = writing_;
    if (!pattern_ && !settings_.labelSinks && extension == ".glb" && primary()) {
      labelWriting_.encodeThreads = 0;
      scene_.emplace(settings_.output, labelWriting_);
      scene_->begin(header_);
    }
    // A .3mf: one object per label, named and coloured, for printers.
    if (!pattern_ && !settings_.labelSinks && extension == ".3mf" && primary()) {
      model_.emplace(settings_.output);
      model_->begin();
    }
    perLabel_ = pattern_ || scene_ || model_ || settings_.labelSinks || settings_.labelTopology;
    // Areas, volumes and interfaces go to the report and the .glb's extras only.
    split_.emplace([this](std::int32_t label) { return sinkFor(label); }, perLabel_, settings_.labelTopology,
                   scene_.has_value() || settings_.labelMeasures);
    if (isoSet_) split_->setIsoValues(settings_.isos);
    // The complex as a whole is counted, not measured: its measures are the labels'.
    std::vector<MeshSink*> heads{&*split_, &complexStats_};
    if (!pattern_ && !scene_ && !model_ && !settings_.labelSinks && primary()) {
      complexWriter_ = makeOutputWriter(settings_.output, writing_, settings_);
      heads.insert(heads.begin(), complexWriter_.get());
    }
    TeeSink tee(heads);
    // Smoothing, then decimation: the complex, each interface once, so that a vertex moves once for
    // every label around it (process/smoothing.h: sheets, lines where three regions meet, fixed
    // corners) and a collapse is made for both sides (process/decimation.h: where three or more
    // labels meet, nothing moves).
    MeshSink* head = &tee;
    if (decimates(settings_)) {
      DecimateOptions d = decimateOptions(settings_, writing_.voxelSize, threads);
      if (!isoSet_ && settings_.maxError == 0) d.maxDistance = kLabelDistanceBound;
      head = &decimation_.emplace(tee, d);
    }
    if (settings_.smoothing.iterations > 0) {
      SmoothOptions smooth = settings_.smoothing;
      smooth.maxDisplacement = 0.5 * frame_.smallestEdge();
      if (!settings_.passBandGiven) smooth.passBand = kLabelPassBand;
      smoothing_.emplace(*head, smooth, threads);
      head = &*smoothing_;
    }
    if (isoSet_ && settings_.components.any()) head = &filter_.emplace(*head, std::move(keepPart_));
    PipelineOptions options = pipelineOptions(onSlab, threads);
    if (ranked()) {
      if (counter_ != nullptr) {
        // Each rank counts the voxels of its own slabs' top slices (slab z's is slice z of the
        // input), so that every slice is counted once; rank 0 adds the others' counts.
        RankGroup& group = *settings_.ranks;
        const SlabRange range = rankSlabs(source_->info().dims[2] - 1, group.rank(), group.size());
        counter_->countOnly(range.first, range.end);
        options.rankSummary = [this] { return counter_->countsText(); };
        options.mergeRankSummary = [this](int, const std::string& counts) { counter_->addCounts(counts); };
      }
    }
    return runPipeline(*source_, *extractor_, *head, header_, options);
  }

  PipelineOptions pipelineOptions(const SlabHook& onSlab, int threads) const {
    PipelineOptions options = pipelineOptionsOf(settings_, ranked() ? settings_.ranks : nullptr, threads);
    options.onSlab = onSlab;
    return options;
  }

  // The report: the complex as a whole, each label, the interfaces and the warnings.
  void describe(const PipelineResult& run, ExtractObserver& observer) {
    report_.stats = complexStats_.stats();
    report_.method = isoSet_ ? header_.method : "labels";
    report_.isoSource = isoSet_ ? "values" : "labels";
    report_.reader = info_.reader;
    report_.dims = info_.dims;
    report_.spacing = info_.spacing;
    report_.volumeBounds = header_.volumeBounds;
    report_.voxelType = std::string(voxelTypeName(info_.type));
    report_.space = header_.space;
    if (run.valueRange) report_.valueRange = std::array{asFloat((*run.valueRange)[0]), asFloat((*run.valueRange)[1])};
    const auto counts = counter_ != nullptr ? counter_->voxelCounts() : std::map<std::int32_t, std::int64_t>{};
    const auto measures = split_->measures();
    for (auto& [value, chain] : chains_) report_.labels.push_back(describeLabel(value, chain, counts, measures));
    for (const auto& [pair, face] : split_->interfaces()) {
      if (pair.first == 0) continue;  // a label's boundary with the background is in its own area
      report_.interfaces.push_back(ExtractInterface{labelValue(pair.first), labelValue(pair.second), face.triangles,
                                                    face.area, labelLayer(pair.first)});
    }
    report_.layers = info_.layers;
    if (decimation_) report_.decimation = decimationReport(settings_, writing_.voxelSize, *decimation_);
    if (!primary()) return;
    warnAbsent(counts);
    for (std::string& w : source_->warnings()) report_.warnings.push_back(std::move(w));
    for (const std::string& w : run.rankWarnings) report_.warnings.push_back(w);
    if (auto w = decimationShortWarning(report_)) report_.warnings.push_back(*w);
    for (std::size_t n = report_.openingWarnings; n < report_.warnings.size(); ++n) {
      observer.warning(report_.warnings[n]);
    }
    report_.seconds.read = run.readSeconds;
    report_.seconds.extract = run.extractSeconds;
    report_.seconds.write = run.writeSeconds;
    report_.seconds.total = run.totalSeconds;
    report_.ringBytes = run.ringBytes;
  }

  // The .glb is written last, with each label's node carrying its value and measures.
  void finishOutputs() {
    report_.output.path = settings_.output;
    if (scene_) {
      for (std::size_t k = 0; k < report_.labels.size() && k < scene_->meshes().size(); ++k) {
        const ExtractLabel& l = report_.labels[k];
        scene_->meshes()[k].extras = {{"label", l.value},
                                      {"layer", l.layer},
                                      {"voxels", l.voxels},
                                      {"voxel_volume", l.voxelVolume},
                                      {"mesh_volume", l.stats.volume},
                                      {"area", l.stats.area},
                                      {"triangles", l.stats.triangles}};
      }
      report_.output.bytes = scene_->write({{"labels", report_.labels.size()}});
    } else if (model_) {
      report_.output.bytes = model_->write();
      addDegenerateCounts();
    } else if (complexWriter_) {
      report_.output.bytes = complexWriter_->bytes();
      report_.output.details = complexWriter_->details();
    } else {
      for (const auto& [value, chain] : chains_) report_.output.bytes += chain.writer ? chain.writer->bytes() : 0;
      addDegenerateCounts();
    }
    report_.output.binaryPlyBytes = PlyWriter::binaryBytes(report_.stats.vertices, report_.stats.triangles, header_);
  }

 private:
  bool ranked() const { return settings_.ranks != nullptr && settings_.ranks->size() > 1; }
  bool primary() const { return !ranked() || settings_.ranks->rank() == 0; }

  // A label's entry in the table: the file's own by its layered label, a table given by value.
  const LabelEntry* entryOf(std::int32_t label) const {
    if (!table_) return nullptr;
    return table_->find(tableKeys_ ? label : labelValue(label));
  }
  std::string nameOf(std::int32_t label) const {
    if (isoSet_) return fmt::format("{}", settings_.isos[static_cast<std::size_t>(label - 1)]);
    const LabelEntry* e = entryOf(label);
    return e != nullptr ? e->name : std::to_string(labelValue(label));
  }
  std::array<std::uint8_t, 3> colorOf(std::int32_t label) const {
    const LabelEntry* e = entryOf(label);
    return e != nullptr && e->color ? *e->color : defaultLabelColor(labelValue(label));
  }

  // A label's sinks, when its first triangle arrives: its writer (a pattern's file or the .glb's
  // mesh).
  MeshSink* sinkFor(std::int32_t label) {
    LabelChain& chain = chains_[label];
    std::vector<MeshSink*> sinks;
    if (pattern_) {
      chain.path = expandPattern(settings_.output, labelValue(label), nameOf(label), isoSet_ ? nameOf(label) : "");
      const auto [it, fresh] = paths_.emplace(chain.path, label);
      if (!fresh) {
        const auto said = [](std::int32_t key) {  // by value and layer, not by key (core/volume_info.h)
          return labelLayer(key) == 0 ? std::to_string(key)
                                      : fmt::format("{} of layer {}", labelValue(key), labelLayer(key));
        };
        throw SettingError(fmt::format("`output` pattern '{}' gives '{}' to labels {} and {}", settings_.output,
                                       chain.path, said(it->second), said(label)));
      }
      chain.writer = makeOutputWriter(chain.path, writing_, settings_);
    } else if (scene_) {
      chain.writer =
          std::make_unique<GlbDracoWriter>(settings_.output, labelWriting_, *scene_, nameOf(label), colorOf(label));
    } else if (model_) {
      chain.writer = std::make_unique<ThreeMfWriter>(*model_, nameOf(label), colorOf(label));
      if (!settings_.keepDegenerate) chain.writer = collapsingWriter(std::move(chain.writer), true);
    }
    if (chain.writer) sinks.insert(sinks.begin(), chain.writer.get());
    if (settings_.labelSinks && primary()) {
      if (MeshSink* sink = settings_.labelSinks(label, nameOf(label))) sinks.push_back(sink);
    }
    chain.tee = std::make_unique<TeeSink>(sinks);
    return chain.tee.get();
  }

  ExtractLabel describeLabel(std::int32_t value, const LabelChain& chain,
                             const std::map<std::int32_t, std::int64_t>& counts,
                             const std::map<std::int32_t, LabelSplitSink::Measures>& measures) const {
    ExtractLabel l;
    l.value = labelValue(value);
    l.name = nameOf(value);
    if (isoSet_) l.iso = settings_.isos[static_cast<std::size_t>(value - 1)];
    const LabelEntry* e = entryOf(value);
    l.colorFromTable = e != nullptr && e->color.has_value();
    l.color = colorOf(value);
    if (info_.layers > 1) {
      l.layer = labelLayer(value);
    } else {
      for (const VolumeInfo::Label& named : info_.labels) {
        if (named.value == value) l.layer = named.layer;
      }
    }
    const auto n = counts.find(value);
    l.voxels = n != counts.end() ? n->second : 0;
    if (const auto c = changes_.find(value); c != changes_.end()) {
      l.components = c->second;
      l.voxels += c->second.voxelsTaken - c->second.voxelsGiven;
    }
    l.voxelVolume = static_cast<double>(l.voxels) * frame_.cellVolume();
    l.topology = settings_.labelTopology;
    l.measured = scene_.has_value() || settings_.labelMeasures;
    const LabelSplitSink::Measures& m = measures.at(value);
    l.stats.edges = m.topology.edges;
    l.stats.boundaryEdges = m.topology.boundaryEdges;
    l.stats.nonManifoldEdges = m.topology.nonManifoldEdges;
    l.stats.inconsistentEdges = m.topology.inconsistentEdges;
    l.stats.euler = m.topology.euler;
    l.stats.vertices = m.vertices;
    l.stats.triangles = m.triangles;
    l.stats.area = m.area;
    l.stats.volume = m.volume;
    l.stats.bounds = m.bounds;
    if (const auto s = split_->splits().find(value); s != split_->splits().end()) l.splits = s->second;
    if (const auto p = split_->pinches().find(value); p != split_->pinches().end()) l.pinches = p->second;
    l.path = chain.path;
    if (smoothing_) {
      const auto s = smoothing_->labels().find(value);
      l.smoothing = s != smoothing_->labels().end() ? std::pair{s->second.largestDisplacement, s->second.heldBack}
                                                    : std::pair{0.0, std::int64_t{0}};
    }
    return l;
  }

  // The per-label writers' degenerate-triangle counts (printable outputs), summed.
  void addDegenerateCounts() {
    std::map<std::string, double> sums;
    for (const auto& [value, chain] : chains_) {
      if (!chain.writer) continue;
      for (const auto& [key, number] : chain.writer->details()) sums[key] += number;
    }
    for (const char* key : kDegenerateDetails) {
      if (const auto it = sums.find(key); it != sums.end()) report_.output.details.emplace_back(key, it->second);
    }
  }

  // Requested labels that the volume lacks: one warning each, or one for many.
  void warnAbsent(const std::map<std::int32_t, std::int64_t>& counts) {
    if (keep_) {
      // A label is absent when no layer holds it.
      std::map<std::int32_t, bool> present;  // by value
      for (const std::int32_t key : *keep_) present[labelValue(key)] |= counts.count(key) != 0;
      std::vector<std::int32_t> absent;
      for (const auto& [id, found] : present) {
        if (!found) absent.push_back(id);
      }
      if (absent.size() <= 8) {
        for (std::int32_t value : absent) {
          report_.warnings.push_back(fmt::format("label {} ('{}') is not in the volume", value, nameOf(value)));
        }
      } else {
        report_.warnings.push_back(fmt::format("{} of the {} requested labels are not in the volume (the first: {})",
                                               absent.size(), present.size(), absent.front()));
      }
    }
    for (std::string& w : droppedLabelWarnings(
             changes_, [this](std::int32_t l) { return chains_.count(l) != 0; },
             [this](std::int32_t l) { return nameOf(l); })) {
      report_.warnings.push_back(std::move(w));
    }
    if (chains_.empty()) {
      report_.warnings.push_back(isoSet_ ? "no value's surface crosses the volume: nothing was written"
                                         : "no selected label is in the volume: nothing was written");
    }
  }

  const ExtractSettings& settings_;
  ExtractReport& report_;
  WriterOptions writing_;
  WriterOptions labelWriting_;
  const bool isoSet_;
  VolumeInfo info_;
  std::optional<LabelTable> table_;
  bool tableKeys_ = false;  // the table is the file's own, by layered label
  LabelRequest request_;
  std::optional<std::set<std::int32_t>> keep_;
  std::map<std::int32_t, LabelChange> changes_;  // by the per-label component rules
  LatticeFrame frame_;
  LabelSource* counter_ = nullptr;
  std::unique_ptr<SliceSource> source_;
  std::unique_ptr<Extractor> extractor_;
  MeshHeader header_;
  bool pattern_ = false;
  bool perLabel_ = true;  // the split builds each label's chunks
  std::optional<GlbScene> scene_;
  std::optional<ThreeMfModel> model_;
  std::map<std::int32_t, LabelChain> chains_;  // before split_: the split's sinks outlive it
  std::map<std::string, std::int32_t> paths_;
  std::optional<LabelSplitSink> split_;
  std::optional<DecimationSink> decimation_;
  std::optional<SmoothingSink> smoothing_;
  std::vector<bool> keepPart_;  // several iso values: the component rules' first pass's choice
  std::optional<ComponentFilterSink> filter_;
  ComplexCounter complexStats_;
  std::unique_ptr<MeshFileSink> complexWriter_;
};

}  // namespace

void runLabelExtract(const ExtractSettings& settings, ExtractObserver& observer, OpenedInput input,
                     ExtractReport& report, const SlabHook& onComponentSlice, const SlabHook& onSlab, int threads,
                     const WriterOptions& writing) {
  checkLabelSettings(settings);
  report.labelRun = true;
  SurfaceSetRun run(settings, report, writing);
  run.open(std::move(input), onComponentSlice, threads);
  const PipelineResult result = run.run(onSlab, threads);
  run.describe(result, observer);
  run.finishOutputs();
}

}  // namespace isoslab
