#include "job/extract_steps.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <vector>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "extract/frame.h"
#include "io/crop_source.h"
#include "io/open_source.h"
#include "metrics/component_filter.h"
#include "metrics/components.h"
#include "metrics/report.h"
#include "process/degenerate.h"
#include "stream/pipeline.h"

namespace isoslab {
namespace {

// The numbers of a box as given, for messages: "0,0,0,39,39,39".
std::string roiText(const std::array<double, 6>& v) {
  return fmt::format("{}", fmt::join(v, ","));
}

// The source cut to settings.roi. A voxel box is clipped to the lattice (with a note); a physical
// box, in the output coordinates of the space, selects the lattice points that lie in it
// (LatticeFrame::latticeBox). A box that leaves fewer than 2 points on an axis is an error naming
// the input.
std::unique_ptr<SliceSource> cropToRoi(std::unique_ptr<SliceSource> source, const ExtractSettings& settings,
                                       ExtractObserver* observer, ExtractReport::Roi& roi) {
  const VolumeInfo& info = source->info();
  const std::string& input = settings.inputs.front();
  const std::array<double, 6>& v = *settings.roi;
  const std::string text = roiText(v);
  roi.requested.assign(v.begin(), v.end());
  roi.inputDims = info.dims;
  std::string note;
  if (settings.roiSpace == RoiSpace::kVoxel) {
    roi.space = "voxel";
    LatticeBox asked;
    for (std::size_t a = 0; a < 6; ++a) {
      if (v[a] != std::floor(v[a]) || std::abs(v[a]) > 9.0e15) {
        throw SettingError(
            fmt::format("`roi` '{}' needs whole numbers (lattice indices) with `roi_space` voxel", text));
      }
      (a < 3 ? asked.lo[a] : asked.hi[a - 3]) = static_cast<std::int64_t>(v[a]);
    }
    roi.box = clipLatticeBox(asked, info.dims, input, &roi.clipped);
    if (roi.clipped) {
      note = fmt::format("`roi` {} reaches past the volume's {}x{}x{} lattice points: clipped to {}", text,
                         info.dims[0], info.dims[1], info.dims[2], latticeBoxText(roi.box));
    }
  } else {
    roi.space = "physical";
    const std::string spaceName(outputSpaceName(settings.space));
    const std::string box = fmt::format("`roi` {} ({} coordinates)", text, spaceName);
    const LatticeFrame frame = LatticeFrame::forSpace(info, spaceName);
    const auto found = frame.latticeBox(v, info.dims);
    if (!found) {
      const auto b = frame.bounds(info.dims);
      throw Error(
          fmt::format("{}: {} holds no lattice point of the volume, whose lattice points lie in {:g}..{:g}, "
                      "{:g}..{:g}, {:g}..{:g}",
                      input, box, b[0], b[3], b[1], b[4], b[2], b[5]));
    }
    const auto dims = found->dims();
    for (std::size_t a = 0; a < 3; ++a) {
      if (dims[a] < 2) {
        throw Error(
            fmt::format("{}: {} holds lattice points {}, {} along axis {}; a surface needs at least 2 on every "
                        "axis",
                        input, box, latticeBoxText(*found), dims[a], a));
      }
    }
    roi.box = *found;
    note =
        fmt::format("{} selects lattice points {} ({}x{}x{})", box, latticeBoxText(roi.box), dims[0], dims[1], dims[2]);
  }
  if (observer != nullptr && !note.empty()) observer->note(note);
  return std::make_unique<CropSource>(std::move(source), roi.box);
}

bool isCt(std::string modality) {
  std::transform(modality.begin(), modality.end(), modality.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return modality == "ct";
}

// A writer behind the degenerate-triangle collapse: the counts join the writer's details.
class CollapsingWriter final : public MeshFileSink {
 public:
  CollapsingWriter(std::unique_ptr<MeshFileSink> writer, bool remap)
      : writer_(std::move(writer)), collapse_(*writer_, remap) {}
  void begin(const MeshHeader& header) override { collapse_.begin(header); }
  void consume(const MeshChunk& chunk) override { collapse_.consume(chunk); }
  void finish() override { collapse_.finish(); }
  std::int64_t bytes() const noexcept override { return writer_->bytes(); }
  std::vector<std::pair<std::string, double>> details() const override {
    auto d = writer_->details();
    const DegenerateCounts& c = collapse_.counts();
    const std::array<std::int64_t, 5> counts{c.triangles, c.vertices, c.splits, c.refused, c.separated};
    for (std::size_t k = 0; k < counts.size(); ++k) {
      d.emplace_back(kDegenerateDetails[k], static_cast<double>(counts[k]));
    }
    return d;
  }

 private:
  std::unique_ptr<MeshFileSink> writer_;
  DegenerateCollapseSink collapse_;
};

// A missing iso value, with the input's value range (one pass through it) and, for CT (DICOM
// Modality CT, or values down to air's -1000 HU), typical Hounsfield values.
std::string missingIsoMessage(const std::string& input, SliceSource& source) {
  const VolumeInfo& info = source.info();
  const std::array<double, 2> range = info.valueRange ? *info.valueRange : scanValueRange(source);
  std::string text = fmt::format("{}: `iso` is required for this input", input);
  if (!(range[0] <= range[1])) return text + " (it holds no values but NaN)";
  text += fmt::format(", whose values range from {} to {}", asFloat(range[0]), asFloat(range[1]));
  if (isCt(info.modality) || range[0] <= -1000) {
    text += "; for CT in Hounsfield units try about 300..400 for bone, -500..-200 for skin or 40 for soft tissue";
  }
  return text + "; `iso` auto takes Otsu's threshold";
}

// The iso request as the user named it: "auto" or a name; empty for a number.
std::string requestName(const std::optional<IsoRequest>& request) {
  if (!request || request->kind == IsoRequest::Kind::kValue) return {};
  return request->kind == IsoRequest::Kind::kAuto ? "auto" : request->named.name;
}

}  // namespace

std::array<double, 2> scanValueRange(SliceSource& source) {
  std::vector<float> slice;
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  while (readSliceInto(source, slice)) {
    throwIfInterrupted();  // a slice boundary
    for (float v : slice) {
      lo = std::min(lo, static_cast<double>(v));
      hi = std::max(hi, static_cast<double>(v));
    }
  }
  return {lo, hi};
}

double asFloat(double value) {
  return std::strtod(fmt::format("{}", static_cast<float>(value)).c_str(), nullptr);
}

OpenedInput openInput(const ExtractSettings& settings, ExtractObserver* observer, ExtractReport& report) {
  std::vector<std::string> notes;
  OpenedInput opened;
  // A run that may mesh labels reads a segmentation's layers in one pass when no channel picks one.
  SourceOptions& source = opened.options;
  source = settings.source;
  const bool labelRun = settings.labels.has_value() || (!settings.iso && settings.isos.empty());
  if (labelRun && source.dicom.channel < 0) source.dicom.channel = kEveryLayer;
  opened.source = settings.openVolume ? settings.openVolume() : openSource(settings.inputs, source, &notes);
  // The mesh's coordinates are float32: a physical box they cannot hold is refused before the
  // first slice (voxel coordinates always fit).
  if (settings.space != OutputSpace::kVoxel) {
    const VolumeInfo& info = opened.source->info();
    validateFloat32Geometry(info, info.source.empty() ? settings.inputs.front() : info.source);
  }
  // Readers' notes that are warnings go to the report too.
  for (const std::string& n : notes) {
    if (n.rfind("warning: ", 0) == 0) {
      report.warnings.push_back(n.substr(9));
      if (observer != nullptr) observer->warning(report.warnings.back());
    } else if (observer != nullptr) {
      observer->note(n);
    }
  }
  report.openingWarnings = report.warnings.size();
  if (settings.roi) {
    ExtractReport::Roi& roi = report.roi.emplace();
    opened.source = cropToRoi(std::move(opened.source), settings, observer, roi);
    opened.roiBox = roi.box;
  }
  return opened;
}

PipelineOptions pipelineOptionsOf(const ExtractSettings& settings, RankGroup* ranks, int threads) {
  PipelineOptions p;
  p.ranks = ranks;
  p.threads = threads;
  p.maxThreadBytes = (static_cast<std::size_t>(settings.maxMemoryMiB) << 20) / 2;
  if (settings.sequentialVoxels >= 0) p.sequentialVoxels = settings.sequentialVoxels;
  return p;
}

std::vector<bool> chooseComponents(SliceSource& source, Extractor& extractor, const MeshHeader& header,
                                   const PipelineOptions& options, const ExtractSettings& settings,
                                   const ComponentRules& rules, bool primary, ExtractReport& report) {
  ComponentSink found;
  found.setSeed(rules.seed);
  report.seconds.componentPass = runPipeline(source, extractor, found, header, options).totalSeconds;
  throwIfInterrupted();
  std::vector<bool> keepPart;
  if (primary) {
    const std::vector<bool> kept = selectComponents(found.components(), rules);
    keepPart = keptParts(found, kept);
    // The report's pieces now, so that the second pass holds a bit per part and no list.
    const std::string& what = settings.reportPath;
    report.componentsJson = reportText(componentsJson(found.components(), 10, &kept), what, -1);
    report.componentFilterJson =
        reportText(componentFilterJson(rules, found.components(), kept, found.parts()), what, -1);
  }
  return keepPart;
}

std::unique_ptr<SliceSource> reopenInput(const ExtractSettings& settings, const OpenedInput& input) {
  auto reopened = settings.openVolume ? settings.openVolume() : openSource(settings.inputs, input.options);
  if (input.roiBox) return std::make_unique<CropSource>(std::move(reopened), *input.roiBox);
  return reopened;
}

IsoChoice chooseIsoValue(const ExtractSettings& settings, OpenedInput& input) {
  std::unique_ptr<SliceSource>& source = input.source;
  if (!settings.iso) {
    if (!source->info().suggestedIso) throw SettingError(missingIsoMessage(settings.inputs.front(), *source));
    IsoChoice choice;
    choice.value = *source->info().suggestedIso;
    choice.source = "suggested by the input";
    return choice;
  }
  const SourceOpener reopen = [&]() { return reopenInput(settings, input); };
  IsoChoice choice = chooseIso(*settings.iso, settings.inputs.front(), *source, reopen);
  if (choice.sourceRead) source = reopen();
  return choice;
}

void fillIsoReport(const ExtractSettings& settings, const IsoChoice& choice, ExtractReport& report) {
  report.isoSource = choice.source;
  report.isoRequest = requestName(settings.iso);
  report.isoNote = choice.note;
  if (choice.histogram && choice.split) {
    const ValueHistogram& h = *choice.histogram;
    report.isoHistogram =
        ExtractReport::IsoHistogram{h.bins(), {h.lo, h.hi}, h.rangeFromReader, h.passes, choice.split->firstUpperBin};
  }
}

std::optional<std::string> emptySurfaceWarning(const ExtractSettings& settings, const ExtractReport& report) {
  if (report.stats.triangles > 0) return std::nullopt;
  const double iso = report.iso;
  const std::string name = !settings.iso               ? fmt::format("the suggested iso {}", iso)
                           : report.isoRequest.empty() ? fmt::format("`iso` {}", iso)
                                                       : fmt::format("`iso` {} ({})", report.isoRequest, iso);
  if (!report.valueRange) return "0 triangles: the input holds no values but NaN";
  const auto [lo, hi] = *report.valueRange;  // already in the float slices' shortest form
  if (iso > hi) {
    return fmt::format(
        "{} is above the input's value range {} .. {}: no voxel is inside, so the surface is empty "
        "(0 triangles)",
        name, lo, hi);
  }
  if (iso <= lo) {
    return fmt::format(
        "{} is not above the input's smallest value (range {} .. {}): every voxel is inside, so the "
        "surface is empty (0 triangles)",
        name, lo, hi);
  }
  return fmt::format("0 triangles: no cell crosses {} (value range {} .. {})", name, lo, hi);
}

std::optional<std::string> decimationShortWarning(const ExtractReport& report) {
  if (!report.decimation) return std::nullopt;
  const ExtractDecimation& d = *report.decimation;
  const DecimationReport& r = d.result;
  if (r.trianglesIn == 0) return std::nullopt;
  const double kept = static_cast<double>(r.trianglesOut) / static_cast<double>(r.trianglesIn);
  if (kept <= 1.2 * d.ratio) return std::nullopt;  // --max-error alone (ratio 1) never warns
  const std::string bound = fmt::format("{} voxel{}", d.distanceBoundVoxels, d.distanceBoundVoxels == 1 ? "" : "s");
  // What stops it is not known here: the bound (by default a distance, with each collapse's quadric
  // error held to half of it; `max_error` sets both), or the tests that keep the mesh closed and
  // manifold (a noisy phantom of 1,236 components keeps 17.5% at `decimate` 0.05, `max_error` 50).
  return fmt::format(
      "`decimate` {} kept {:.1f}% of the triangles, more than asked: a collapse is made only within the {}error "
      "bound ({}; `max_error` sets it) and where the mesh stays closed and manifold",
      d.ratio, 100 * kept, d.maxError > 0 ? "" : "default ", bound);
}

double seedReach(const ExtractSettings& settings, const VolumeInfo& info) {
  const auto& sp = info.spacing;
  return settings.space == OutputSpace::kVoxel ? std::sqrt(3.0)
                                               : std::sqrt(sp[0] * sp[0] + sp[1] * sp[1] + sp[2] * sp[2]);
}

bool decimates(const ExtractSettings& settings) {
  return settings.decimate != 1.0 || settings.maxError != 0;
}

ExtractDecimation decimationReport(const ExtractSettings& settings, double voxelSize, const DecimationSink& sink) {
  return ExtractDecimation{settings.decimate, settings.maxError, sink.options().maxDistance, voxelSize, sink.report()};
}

DecimateOptions decimateOptions(const ExtractSettings& settings, double voxelSize, int threads) {
  DecimateOptions d;
  d.threads = threads;
  d.pairBytes = (static_cast<std::size_t>(settings.maxMemoryMiB) << 20) / 2;
  d.ratio = settings.decimate;
  d.maxError = settings.maxError;
  // Every decimated triangle stays within the error bound of the surface, or half a voxel.
  d.maxDistance = settings.maxError > 0 ? settings.maxError : 0.5;
  d.voxelSize = voxelSize;
  d.measure = settings.measureDecimation;
  return d;
}

namespace {

std::string lowerExtension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
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

}  // namespace

std::string expandPattern(const std::string& pattern, std::int32_t value, const std::string& name,
                          const std::string& iso) {
  std::string out;
  for (std::size_t at = 0; at < pattern.size();) {
    if (pattern.compare(at, 6, "{name}") == 0) {
      out += fileSafe(name);
      at += 6;
    } else if (pattern.compare(at, 5, "{iso}") == 0) {
      out += fileSafe(iso);
      at += 5;
    } else if (pattern.compare(at, 7, "{label}") == 0) {
      out += std::to_string(value);
      at += 7;
    } else {
      out += pattern[at++];
    }
  }
  return out;
}

bool printableOutput(const std::string& path) {
  const std::string ext = lowerExtension(path);
  return ext == ".stl" || ext == ".3mf";
}

std::unique_ptr<MeshFileSink> collapsingWriter(std::unique_ptr<MeshFileSink> writer, bool remap) {
  return std::make_unique<CollapsingWriter>(std::move(writer), remap);
}

std::unique_ptr<MeshFileSink> makeOutputWriter(const std::string& path, const WriterOptions& writing,
                                               const ExtractSettings& settings) {
  auto writer = makeMeshWriter(path, writing);
  if (settings.keepDegenerate || !printableOutput(path)) return writer;
  // The 3MF writer holds the whole mesh, so it takes the merged vertices' survivors by id.
  return collapsingWriter(std::move(writer), lowerExtension(path) == ".3mf");
}

void writeReportFile(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.write(text.data(), text.size());
  f.commit();
}

}  // namespace isoslab
