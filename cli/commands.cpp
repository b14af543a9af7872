#include "cli/commands.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>

#include "cli/arguments.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "io/dicom_seg.h"
#include "io/dicom_series.h"
#include "io/label_source.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "io/volume_formats.h"
#include "io/volume_writer.h"
#include "job/extract_steps.h"
#include "metrics/components.h"
#include "metrics/mesh_stats.h"
#include "metrics/report.h"
#include "metrics/sphere_metrics.h"
#include "stream/iso_choice.h"
#include "stream/value_histogram.h"

namespace isoslab::cli {
namespace {

void writeText(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.write(text.data(), text.size());
  f.commit();
}

void printGeometry(const VolumeInfo& info) {
  const auto& d = info.direction;
  std::printf("reader     %s\n", info.reader.c_str());
  std::printf("dims       %lld x %lld x %lld\n", static_cast<long long>(info.dims[0]),
              static_cast<long long>(info.dims[1]), static_cast<long long>(info.dims[2]));
  std::printf("type       %s\n", std::string(voxelTypeName(info.type)).c_str());
  std::printf("spacing    %g %g %g\n", info.spacing[0], info.spacing[1], info.spacing[2]);
  std::printf("origin     %g %g %g\n", info.origin[0], info.origin[1], info.origin[2]);
  std::printf("direction  %g %g %g  %g %g %g  %g %g %g\n", d[0], d[3], d[6], d[1], d[4], d[7], d[2], d[5], d[8]);
  std::printf("frame      %s\n", info.frame.c_str());
}

// `info --histogram`: every bin (empty ones too), the values no bin holds, and Otsu's threshold.
// Labels take `width` columns after `indent`, as the lines around them do.
void printHistogram(const ValueHistogram& h, const std::string& indent, int width) {
  const auto line = [&](const std::string& label, const std::string& text) {
    std::printf("%s\n", fmt::format("{}{:<{}}{}", indent, label, width, text).c_str());
  };
  line("histogram", fmt::format("{} bins of {} over {} .. {} ({}); {} {} over the input", h.bins(),
                                (h.hi - h.lo) / static_cast<double>(h.bins()), h.lo, h.hi,
                                h.rangeFromReader ? "the reader's value range" : "the finite values' range", h.passes,
                                h.passes == 1 ? "pass" : "passes"));
  line("", fmt::format("{:<7}{:<24}{:<24}{}", "bin", "from", "to", "count"));
  for (std::size_t b = 0; b < h.bins(); ++b) {
    line("", fmt::format("{:<7}{:<24}{:<24}{}", b, h.edge(b), h.edge(b + 1), h.counts[b]));
  }
  line("", "(a bin holds from <= value < to; the last one also holds its upper edge)");
  line("non-finite", fmt::format("NaN {}, -inf {}, +inf {}", h.nan, h.negativeInfinity, h.positiveInfinity));
  if (h.below + h.above > 0) {
    line("outside",
         fmt::format("{} below {}, {} above {} (outside the reader's value range)", h.below, h.lo, h.above, h.hi));
  }
  if (const auto split = otsuSplit(h)) {
    line("otsu", fmt::format("{} (over these bins: bins {} .. {} are at or above it; --iso auto takes it over {} bins)",
                             split->iso, split->firstUpperBin, h.bins() - 1, kAutoIsoBins));
  } else {
    line("otsu", "none (fewer than two bins hold values)");
  }
}

}  // namespace

int runInfo(const std::vector<std::string>& inputs, const RawArgs& raw, std::size_t histogramBins) {
  const SourceOptions options = sourceOptions(raw);
  const bool segmentation = !options.raw && inputs.size() == 1 && isDicomSegmentation(inputs.front());
  const bool dicom = !options.raw && !segmentation && !PhantomSource::isPhantom(inputs.front()) &&
                     std::all_of(inputs.begin(), inputs.end(), [](const std::string& in) { return isDicomInput(in); });
  if (!dicom) {
    std::vector<std::string> notes;
    SourceOptions sourceOptions = options;
    // A segmentation whose segments overlap is shown by its first layer (the note says how many).
    if (segmentation && sourceOptions.dicom.channel < 0) sourceOptions.dicom.channel = 0;
    auto source = openSource(inputs, sourceOptions, &notes);
    std::printf("input      %s\n", inputs.front().c_str());
    printGeometry(source->info());
    std::optional<ValueHistogram> histogram;
    if (source->info().labelMap && histogramBins == 0) {
      // A label map: its labels counted as its slices stream past (the background 0 not counted).
      LabelSource labels(std::move(source), inputs.front(), std::nullopt);
      std::vector<float> slice;
      while (readSliceInto(labels, slice)) {
      }
      const auto counts = labels.voxelCounts();
      const std::size_t n = counts.size() - (counts.count(0) != 0 ? 1 : 0);
      std::printf("range      %d .. %d\n", counts.empty() ? 0 : counts.begin()->first,
                  counts.empty() ? 0 : counts.rbegin()->first);
      std::printf("labels     %zu (a label map: extract meshes every label, or those --labels names)\n", n);
      for (const std::string& note : notes) std::printf("note       %s\n", withFlags(note).c_str());
      for (const std::string& w : labels.warnings()) std::printf("warning    %s\n", withFlags(w).c_str());
      return 0;
    }
    if (histogramBins > 0)
      histogram = streamHistogram(*source, histogramBins, [&] { return openSource(inputs, options); });
    const auto range = !histogram              ? scanValueRange(*source)
                       : histogram->valueRange ? *histogram->valueRange
                                               : std::array<double, 2>{std::numeric_limits<double>::infinity(),
                                                                       -std::numeric_limits<double>::infinity()};
    std::printf("range      %g .. %g\n", range[0], range[1]);
    if (histogram) printHistogram(*histogram, "", 11);
    for (std::string& n : notes) {
      n = withFlags(n);
      const bool warning = n.rfind("warning: ", 0) == 0;
      std::printf("%s%s\n", warning ? "warning    " : "note       ", n.c_str() + (warning ? 9 : 0));
    }
    for (const std::string& w : source->warnings()) std::printf("warning    %s\n", withFlags(w).c_str());
    if (source->info().suggestedIso) std::printf("iso        %g (suggested)\n", *source->info().suggestedIso);
    return 0;
  }
  const DicomScan scan = scanDicom(inputs, options.dicom);
  std::printf("%zu DICOM series; %d %s skipped (not DICOM images)\n", scan.series.size(), scan.skipped,
              scan.skipped == 1 ? "file" : "files");
  for (const std::string& w : scan.warnings) std::printf("warning: %s\n", w.c_str());
  for (std::size_t n = 0; n < scan.series.size(); ++n) {
    const DicomSeries& s = scan.series[n];
    std::printf("\nseries %zu   %s\n", n, s.uid.c_str());
    std::printf("  description    %s\n", s.description.c_str());
    std::printf("  modality       %s\n", s.modality.c_str());
    std::printf("  images         %zu%s\n", s.slices.size(), s.multiFrame ? " (frames of a multi-frame file)" : "");
    std::printf("  size           %u x %u (columns x rows), %u bits (%u stored), %s, %s\n", s.columns, s.rows,
                s.bitsAllocated, s.bitsStored, s.pixelRepresentation ? "signed" : "unsigned", s.photometric.c_str());
    std::printf("  pixel spacing  %g %g (row, column)\n", s.pixelSpacing[0], s.pixelSpacing[1]);
    if (!s.gaps.empty()) {
      std::vector<double> g = s.gaps;
      std::sort(g.begin(), g.end());
      std::printf("  slice spacing  min %g, median %g, max %g\n", g.front(), g[g.size() / 2], g.back());
    }
    std::optional<std::array<double, 2>> thickness;
    for (const DicomSlice& slice : s.slices) {
      if (!slice.thickness) continue;
      const double t = *slice.thickness;
      thickness = thickness ? std::array<double, 2>{std::min((*thickness)[0], t), std::max((*thickness)[1], t)}
                            : std::array<double, 2>{t, t};
    }
    if (thickness) {
      const auto& t = *thickness;
      std::printf("  thickness      %s mm (SliceThickness)\n",
                  t[0] == t[1] ? fmt::format("{:g}", t[0]).c_str() : fmt::format("{:g} .. {:g}", t[0], t[1]).c_str());
    }
    const auto& o = s.orientation;
    std::printf("  orientation    %g %g %g  %g %g %g\n", o[0], o[1], o[2], o[3], o[4], o[5]);
    const std::string headerTilt =
        s.gantryTilt ? fmt::format("{:g} degrees (GantryDetectorTilt)", *s.gantryTilt) : "not in the headers";
    const auto tilt = geometricTilt(s);
    std::printf("  gantry tilt    %s; %s\n", headerTilt.c_str(),
                tilt ? fmt::format("{:.2f} degrees between the slice normal and the slice steps", *tilt).c_str()
                     : "the geometry cannot tell (one slice or no positions)");
    if (const auto& p = s.slices.front().position) {
      std::printf("  first slice    %g %g %g (ImagePositionPatient of %s)\n", (*p)[0], (*p)[1], (*p)[2],
                  s.slices.front().path.c_str());
    }
    if (const auto box = patientExtent(s)) {
      const auto& b = *box;
      std::printf("  extent         x %g .. %g, y %g .. %g, z %g .. %g (LPS mm, corner pixel centres)\n", b[0], b[3],
                  b[1], b[4], b[2], b[5]);
    }
    std::printf("  transfer       %s (%s)\n", s.transferSyntax.c_str(), s.transferSyntaxUid.c_str());
    for (const std::string& w : s.warnings) std::printf("  warning        %s\n", w.c_str());
    for (const std::string& note : s.notes) std::printf("  note           %s\n", note.c_str());
    try {
      auto source = openDicomSeries(s, options.dicom);
      if (histogramBins > 0) {
        const ValueHistogram h =
            streamHistogram(*source, histogramBins, [&] { return openDicomSeries(s, options.dicom); });
        const auto range = h.valueRange.value_or(
            std::array<double, 2>{std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()});
        std::printf("  value range    %g .. %g (after rescale)\n", range[0], range[1]);
        printHistogram(h, "  ", 15);
      } else {
        const auto range = scanValueRange(*source);
        std::printf("  value range    %g .. %g (after rescale)\n", range[0], range[1]);
      }
    } catch (const Interrupted&) {
      throw;  // not an unreadable series: the run stops
    } catch (const Error& e) {
      std::printf("  unreadable     %s\n", e.what());
    }
  }
  return 0;
}

int runMetrics(const std::string& input, const std::string& sphereText, const std::string& reportPath) {
  MeshMetadata meta;
  IndexedMesh mesh = readMesh(input, &meta);
  // The volume's faces tell the surface's cut edges from holes; without them, that is unknown.
  if (meta.volumeFaces) mesh.boundary = volumeFaceFlags(mesh.positions, *meta.volumeFaces, meta.positionTolerance);
  MeshStatsSink stats;
  ComponentSink components;
  std::optional<SphereErrorSink> errors;
  std::vector<MeshSink*> sinks{&stats, &components};
  std::optional<Sphere> sphere;
  if (!sphereText.empty()) {
    sphere = parseSphere(sphereText);
    errors.emplace(*sphere);
    sinks.push_back(&*errors);
  }
  TeeSink tee(sinks);
  feedMesh(mesh, MeshHeader{}, tee);
  throwIfInterrupted();  // nothing is printed or written after a stop
  const MeshStats& s = stats.stats();
  nlohmann::ordered_json r;
  r["input"] = input;
  if (!meta.method.empty()) r["method"] = meta.method;
  if (meta.iso) r["iso"] = *meta.iso;
  if (!meta.space.empty()) r["space"] = meta.space;
  r["volume_bounds"] = meta.volumeBounds ? nlohmann::ordered_json(*meta.volumeBounds) : nlohmann::ordered_json();
  addStatsJson(r, s);
  if (!meta.volumeFaces) r["interior_boundary_edges"] = nullptr;
  r["components"] = componentsJson(components.components());
  if (sphere) r["sphere"] = sphereJson(sphereReport(*sphere, s, *errors));
  const std::string text = reportText(r, reportPath.empty() ? input : reportPath) + "\n";
  if (reportPath.empty()) {
    std::fputs(text.c_str(), stdout);
  } else {
    writeText(reportPath, text);
  }
  return 0;
}

int runDecode(const std::string& input, const std::string& output) {
  MeshMetadata meta;
  IndexedMesh mesh = readMesh(input, &meta);
  if (meta.volumeFaces) mesh.boundary = volumeFaceFlags(mesh.positions, *meta.volumeFaces, meta.positionTolerance);
  const MeshHeader header = headerForDecodedMesh(meta, mesh.positions, !mesh.normals.empty());
  WriterOptions writerOptions;
  writerOptions.voxelSize =
      1e-3 * std::max({header.volumeBounds[3] - header.volumeBounds[0], header.volumeBounds[4] - header.volumeBounds[1],
                       header.volumeBounds[5] - header.volumeBounds[2], 1e-30});
  // The output appears only when the run was not interrupted (the writer's commit is left to the
  // group; an interruption or an error removes its temporary file).
  CommitGroup outputs;
  auto writer = makeMeshWriter(output, writerOptions);
  feedMesh(mesh, header, *writer);
  throwIfInterrupted();
  outputs.commit();
  std::fprintf(stderr, "isoslab: %zu triangles, %zu vertices -> %s\n", mesh.triangles.size(), mesh.positions.size(),
               output.c_str());
  return 0;
}

int runPhantom(const std::string& spec, const std::string& output, bool compress) {
  if (!PhantomSource::isPhantom(spec))
    throw UsageError(fmt::format("{}: not a phantom spec (phantom:NAME?key=value&...)", spec));
  auto source = PhantomSource::open(spec);
  const VolumeInfo& info = source->info();
  VolumeWriteOptions write;
  write.type = info.type;
  write.compress = compress;
  const std::int64_t bytes = writeVolume(*source, output, write);
  if (isVolumeFormat(output)) {
    std::printf("%s: %lld bytes\n", output.c_str(), static_cast<long long>(bytes));
    return 0;
  }
  std::printf("%s: %lld bytes; read it back with --raw-dims %lld,%lld,%lld --raw-type %s --spacing %g,%g,%g\n",
              output.c_str(), static_cast<long long>(bytes), static_cast<long long>(info.dims[0]),
              static_cast<long long>(info.dims[1]), static_cast<long long>(info.dims[2]),
              std::string(voxelTypeName(info.type)).c_str(), info.spacing[0], info.spacing[1], info.spacing[2]);
  return 0;
}
}  // namespace isoslab::cli
