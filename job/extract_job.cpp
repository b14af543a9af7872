#include "job/extract_job.h"

#include <fmt/format.h>
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <thread>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "encode/mesh_writer.h"
#include "encode/ply_writer.h"
#include "extract/frame.h"
#include "io/crop_source.h"
#include "io/image_writer.h"
#include "io/pad_source.h"
#include "job/extract_steps.h"
#include "metrics/components.h"
#include "metrics/measure.h"
#include "metrics/report.h"
#include "process/decimation.h"
#include "render/rasterizer.h"
#include "stream/pipeline.h"
#include "stream/progress.h"
#include "stream/rank_group.h"

namespace isoslab {
namespace {

// What a run reports to its observer: progress over one or two passes, and stops.
class Reporting {
 public:
  Reporting(ExtractObserver& observer, int passes) : observer_(observer), passes_(passes) {}

  /// Throws Interrupted when a signal or the observer asks the run to stop.
  void checkStop() {
    throwIfInterrupted();
    if (observer_.stopRequested()) throw Interrupted(0);
  }

  /// The pipeline's per-slab hook for pass `pass` (from 0), named `stage`.
  std::function<void(std::int64_t, std::int64_t)> slabHook(int pass, const char* stage) {
    return [this, pass, stage](std::int64_t done, std::int64_t total) {
      ExtractProgress p;
      p.stage = stage;
      p.done = done;
      p.total = total;
      p.fraction = (pass + static_cast<double>(done) / static_cast<double>(std::max<std::int64_t>(1, total))) / passes_;
      // The last slab of the last pass is not yet the end: 1 comes once the outputs are committed.
      p.fraction = std::min(p.fraction, std::nextafter(1.0, 0.0));
      observer_.progress(p);
      checkStop();
    };
  }

  void finished(std::int64_t slabs) {
    ExtractProgress p;
    p.done = slabs;
    p.total = slabs;
    p.fraction = 1;
    observer_.progress(p);
  }

 private:
  ExtractObserver& observer_;
  int passes_;
};

// The writer's settings: --max-memory allows half its budget to .glb encoders on threads.
WriterOptions writerOptions(const ExtractSettings& settings, const VolumeInfo& info, int threads) {
  WriterOptions w;
  // With threads, the writer gathers chunks while others encode them: encoding then overlaps
  // everything else (it is the slowest stage). Each encoder holds about 200 bytes per triangle of
  // its chunk (docs/performance.md), so --max-memory allows half its budget to as many encoders
  // as fit, at most one per thread; when none fits, chunks encode in the emit stage, as with
  // one thread. The other half goes to slices in flight and the threads' caches.
  const auto budget = static_cast<std::size_t>(settings.maxMemoryMiB) << 20;
  const auto encoderBytes = static_cast<std::size_t>(std::max<std::int64_t>(1, settings.chunkTriangles)) * 200;
  w.encodeThreads =
      threads > 1
          ? static_cast<int>(std::min<std::size_t>(budget / 2 / encoderBytes, static_cast<std::size_t>(threads)))
          : 0;
  w.dracoLevel = settings.dracoLevel;
  w.quantBits = settings.quantBits;
  w.chunkTriangles = settings.chunkTriangles;
  w.draco = settings.draco;
  w.gltfFrame = settings.gltfFrame;
  w.voxelSize =
      settings.space == OutputSpace::kVoxel ? 1.0 : std::min({info.spacing[0], info.spacing[1], info.spacing[2]});
  return w;
}

// The sinks of the extraction pass, from the extractor to the writer and the measures:
// component filter -> smoothing -> decimation -> tee(writer, stats, components, sphere, preview).
struct SinkChain {
  MeshStatsSink stats;
  std::optional<ComponentSink> components;
  std::optional<SphereErrorSink> sphereErrors;
  std::optional<render::RenderSink> preview;
  std::optional<TeeSink> tee;
  std::optional<DecimationSink> decimation;
  std::optional<SmoothingSink> smoothing;
  std::optional<ComponentFilterSink> filter;
  MeshSink* head = nullptr;

  SinkChain(const ExtractSettings& settings, MeshFileSink* writer, const std::optional<Sphere>& sphere,
            bool listComponents, double voxelSize, std::vector<bool>* keepPart, int threads) {
    std::vector<MeshSink*> sinks{&stats};
    if (writer != nullptr) sinks.insert(sinks.begin(), writer);
    // The report lists the connected components (memory: the live front, 4 bytes a component).
    if (listComponents) {
      sinks.push_back(&components.emplace());
      components->summarize(10);  // what the report lists: not every component of a foam
    }
    if (sphere) sinks.push_back(&sphereErrors.emplace(*sphere));
    // The preview keeps the image and two slabs' vertices, never the mesh.
    const PreviewSettings& p = settings.preview;
    if (!p.path.empty()) {
      render::Style style;
      style.smooth = p.smooth.value_or(settings.normals);
      style.background = p.background;
      sinks.push_back(&preview.emplace(p.view, p.width, p.height, style));
    }
    head = &tee.emplace(sinks);
    // Decimation, last before the writer and the measures: on the smoothed surface.
    if (decimates(settings)) head = &decimation.emplace(*head, decimateOptions(settings, voxelSize, threads));
    // Smoothing runs on what the filter keeps; its output feeds the writer and the measures.
    if (settings.smoothing.iterations > 0) head = &smoothing.emplace(*head, settings.smoothing, threads);
    if (keepPart != nullptr) head = &filter.emplace(*head, std::move(*keepPart));
  }
};

// The report's description of the volume and the mesh's frame.
void describeVolume(const ExtractSettings& settings, const VolumeInfo& info, const MeshHeader& header,
                    const PipelineResult& run, ExtractReport& report) {
  report.reader = info.reader;
  report.method = header.method;
  report.dims = info.dims;
  report.spacing = info.spacing;
  report.volumeBounds = header.volumeBounds;
  report.voxelType = std::string(voxelTypeName(info.type));
  report.space = header.space;
  report.normals = settings.normals;
  if (run.valueRange) report.valueRange = std::array{asFloat((*run.valueRange)[0]), asFloat((*run.valueRange)[1])};
}

// The report's parts from the sinks: smoothing, decimation, components, sphere, times, output.
void describeFinishing(const ExtractSettings& settings, const SinkChain& chain, const std::optional<Sphere>& sphere,
                       const PipelineResult& run, const MeshFileSink* writer, const MeshHeader& header,
                       double voxelSize, ExtractReport& report) {
  if (settings.smoothing.iterations > 0) {
    report.smoothing =
        ExtractReport::Smoothing{settings.smoothing, chain.smoothing->peakChunks(), chain.smoothing->peakVertices()};
  }
  if (chain.decimation) report.decimation = decimationReport(settings, voxelSize, *chain.decimation);
  if (!settings.components.any()) {
    const ComponentSummary none;
    report.componentsJson =
        reportText(componentsJson(chain.components ? chain.components->summary() : none), settings.reportPath, -1);
  }
  if (sphere) {
    report.sphereJson =
        reportText(sphereJson(sphereReport(*sphere, report.stats, *chain.sphereErrors)), settings.reportPath, -1);
  }
  report.seconds.read = run.readSeconds;
  report.seconds.extract = run.extractSeconds;
  report.seconds.write = run.writeSeconds;
  report.seconds.total = run.totalSeconds + report.seconds.componentPass.value_or(0);
  report.ringBytes = run.ringBytes;
  if (writer) {
    report.output.path = settings.output;
    report.output.bytes = writer->bytes();
    report.output.binaryPlyBytes = PlyWriter::binaryBytes(report.stats.vertices, report.stats.triangles, header);
    report.output.details = writer->details();
  }
}

ExtractOptions extractOptions(const ExtractSettings& settings, double iso, bool sphere) {
  ExtractOptions options;
  options.method = settings.method;
  options.iso = iso;
  options.normals = settings.normals;
  // The per-tetrahedron inside volume (volume_cells) costs a quarter of mt6's time: only for a
  // report or sphere measures.
  options.cellVolumes = !settings.reportPath.empty() || sphere;
  options.closeBoundary = settings.closeBoundary;
  return options;
}

// The warnings after the run (and after the report's finishing parts): the readers' (this rank's,
// then the other ranks'), then an empty surface's, then a decimation's that stopped short; handed
// to `observer` (nullptr: a rank that does not report).
void collectWarnings(const ExtractSettings& settings, SliceSource& source, const PipelineResult& run,
                     ExtractObserver* observer, ExtractReport& report) {
  for (std::string& w : source.warnings()) report.warnings.push_back(std::move(w));
  for (const std::string& w : run.rankWarnings) report.warnings.push_back(w);
  if (auto w = emptySurfaceWarning(settings, report)) report.warnings.push_back(*w);
  if (auto w = decimationShortWarning(report)) report.warnings.push_back(*w);
  if (observer == nullptr) return;
  for (std::size_t n = report.openingWarnings; n < report.warnings.size(); ++n) observer->warning(report.warnings[n]);
}

// Every rank ends here together: a rank that failed after the last extraction (rank 0 writing the
// report) tells the others.
void agreeAtTheEnd(RankGroup& ranks) {
  if (const int failed = ranks.agree(true); failed >= 0) {
    ranks.setFailureShared();
    throw RankFailed(failed);
  }
}

}  // namespace

int defaultExtractThreads(bool ranked);

namespace {

// The labels of a label map, or several iso values, in one pass (job/label_job.cpp), with the
// report written and everything committed together.
void runSurfaceSet(const ExtractSettings& settings, ExtractObserver& observer, OpenedInput input, Reporting& reporting,
                   RankGroup* ranks, ExtractReport& report) {
  const VolumeInfo info = input.source->info();
  const int threads = settings.threads > 0 ? settings.threads : defaultExtractThreads(ranks != nullptr);
  CommitGroup outputs;
  const bool components = settings.components.any();
  runLabelExtract(settings, observer, std::move(input), report, reporting.slabHook(0, "components"),
                  reporting.slabHook(components ? 1 : 0, "extract"), threads, writerOptions(settings, info, threads));
  report.peakRssMib = peakRssMib();
  const bool primary = ranks == nullptr || ranks->rank() == 0;
  if (!settings.reportPath.empty() && primary) {
    const auto spell = [&](const std::string& t) { return observer.spell(t); };
    writeReportFile(settings.reportPath, extractReportText(report, settings.reportPath, spell) + "\n");
  }
  reporting.checkStop();
  outputs.commit();
  if (ranks != nullptr) agreeAtTheEnd(*ranks);
  if (primary) reporting.finished(info.dims[2] + 1);
}

}  // namespace

int defaultExtractThreads(bool ranked) {
  // The cores this process may run on (mpirun binds ranks to cores or sockets).
  const unsigned machine = std::clamp(std::thread::hardware_concurrency(), 1u, 1024u);
  unsigned cores = machine;
  cpu_set_t set;
  if (::sched_getaffinity(0, sizeof set, &set) == 0) {
    cores = std::clamp(static_cast<unsigned>(CPU_COUNT(&set)), 1u, machine);
  }
  if (ranked && cores == machine) {
    // Unbound ranks share the machine (Open MPI's OMPI_COMM_WORLD_LOCAL_SIZE).
    const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
    if (local == nullptr) local = std::getenv("MPI_LOCALNRANKS");
    const long n = local != nullptr ? std::strtol(local, nullptr, 10) : 0;
    if (n > 0) cores = std::max(1u, cores / static_cast<unsigned>(n));
  }
  return static_cast<int>(std::min(cores, 8u));
}

ExtractReport runExtract(const ExtractSettings& settings) {
  ExtractObserver quiet;
  return runExtract(settings, quiet);
}

ExtractReport runExtract(const ExtractSettings& settings, ExtractObserver& observer) {
  checkExtractSettings(settings);
  // Under mpirun every rank runs this; rank 0 alone writes and reports (runPipeline).
  RankGroup* ranks = settings.ranks != nullptr && settings.ranks->size() > 1 ? settings.ranks : nullptr;
  const bool primary = ranks == nullptr || ranks->rank() == 0;
  ExtractReport report;
  report.inputs = settings.inputs;
  report.ranks = ranks != nullptr ? ranks->size() : 1;
  const bool wantsComponents = settings.components.any();
  Reporting reporting(observer, wantsComponents ? 2 : 1);
  OpenedInput input = openInput(settings, primary ? &observer : nullptr, report);
  // Labels (asked, or the input says it holds them), or several iso values: a surface set.
  if (settings.labels || !settings.isos.empty() || (!settings.iso && input.source->info().labelMap)) {
    runSurfaceSet(settings, observer, std::move(input), reporting, ranks, report);
    return report;
  }
  std::unique_ptr<SliceSource>& source = input.source;
  const IsoChoice isoChoice = chooseIsoValue(settings, input);
  if (!isoChoice.note.empty() && primary) observer.note(isoChoice.note);
  reporting.checkStop();
  const VolumeInfo info = source->info();  // a copy: a component filter reopens the source
  const double iso = isoChoice.value;
  const std::string spaceName(outputSpaceName(settings.space));
  const LatticeFrame frame = LatticeFrame::forSpace(info, spaceName);
  const int threads = settings.threads > 0 ? settings.threads : defaultExtractThreads(ranks != nullptr);
  const WriterOptions writing = writerOptions(settings, info, threads);
  // The mesh and the report appear together or not at all: both are completed under temporary
  // names, and renamed into place only once the report is written.
  CommitGroup outputs;
  std::unique_ptr<MeshFileSink> writer;
  if (primary) writer = makeOutputWriter(settings.output, writing, settings);
  std::optional<Sphere> sphere = phantomSphere(info);
  if (settings.sphere) sphere = settings.sphere;
  const ExtractOptions options = extractOptions(settings, iso, sphere.has_value());
  auto extractor = makeExtractor(options, info, frame);
  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  // The caps need the field beyond the faces: one NaN point around the volume (header, frame and
  // value range stay the volume's own).
  if (settings.closeBoundary) source = std::make_unique<PadSource>(std::move(source));
  PipelineOptions pipelineOptions = pipelineOptionsOf(settings, ranks, threads);

  // Component filters: a first pass finds and measures the components, and chooses; the second
  // (the run below) extracts again from the input reopened, and keeps only the chosen ones.
  std::vector<bool> keepPart;
  if (wantsComponents) {
    ComponentRules rules = settings.components;
    rules.seedReach = seedReach(settings, info);
    pipelineOptions.onSlab = reporting.slabHook(0, "components");
    keepPart = chooseComponents(*source, *extractor, header, pipelineOptions, settings, rules, primary, report);
    reporting.checkStop();
    source = reopenInput(settings, input);
    if (settings.closeBoundary) source = std::make_unique<PadSource>(std::move(source));
    extractor = makeExtractor(options, info, frame);
  }
  SinkChain chain(settings, writer.get(), sphere, !settings.reportPath.empty() && !wantsComponents, writing.voxelSize,
                  wantsComponents ? &keepPart : nullptr, threads);
  pipelineOptions.onSlab = reporting.slabHook(wantsComponents ? 1 : 0, "extract");
  const PipelineResult run = runPipeline(*source, *extractor, *chain.head, header, pipelineOptions);
  if (chain.preview && primary) {
    const render::Image image = chain.preview->image();
    writePng(settings.preview.path, image.width, image.height, image.rgb);
  }

  report.stats = chain.stats.stats();
  report.iso = iso;
  fillIsoReport(settings, isoChoice, report);
  describeVolume(settings, info, header, run, report);
  describeFinishing(settings, chain, sphere, run, writer.get(), header, writing.voxelSize, report);
  collectWarnings(settings, *source, run, primary ? &observer : nullptr, report);
  report.peakRssMib = peakRssMib();
  if (!settings.reportPath.empty() && primary) {
    const auto spell = [&](const std::string& t) { return observer.spell(t); };
    writeReportFile(settings.reportPath, extractReportText(report, settings.reportPath, spell) + "\n");
  }
  reporting.checkStop();
  outputs.commit();
  if (ranks != nullptr) agreeAtTheEnd(*ranks);
  if (primary) reporting.finished(info.dims[2] - 1);
  return report;
}

}  // namespace isoslab
