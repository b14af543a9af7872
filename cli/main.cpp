// The isoslab program: extract, info and phantom. Library errors (isoslab::Error) become one line
// on stderr, "isoslab: error: ...", and exit status 1; usage errors (CLI11's, and UsageError)
// exit with 2. Warnings ("isoslab: warning: ...") print even with --quiet, as compilers' do.
#include <fmt/format.h>
#include <sched.h>
#include <signal.h>
#include <time.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "cli/arguments.h"
#include "cli/batch.h"
#include "cli/compare.h"
#include "cli/mpi_group.h"
#include "cli/render.h"
#include "cli/view.h"
#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "encode/indexed_mesh.h"
#include "encode/mesh_metadata.h"
#include "encode/mesh_reader.h"
#include "encode/mesh_writer.h"
#include "encode/ply_writer.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "io/crop_source.h"
#include "io/dicom_series.h"
#include "io/image_writer.h"
#include "io/open_source.h"
#include "io/pad_source.h"
#include "io/phantom.h"
#include "io/volume_formats.h"
#include "io/volume_writer.h"
#include "metrics/component_filter.h"
#include "metrics/components.h"
#include "metrics/measure.h"
#include "metrics/mesh_stats.h"
#include "metrics/report.h"
#include "metrics/sphere_metrics.h"
#include "process/decimation.h"
#include "process/smoothing.h"
#include "stream/iso_choice.h"
#include "stream/pipeline.h"
#include "stream/progress.h"
#include "stream/rank_group.h"
#include "stream/value_histogram.h"

namespace isoslab {
namespace {

using cli::alternatives;
using cli::editDistance;
using cli::finiteNumber;
using cli::integerIn;
using cli::isoValue;
using cli::numberList;
using cli::oneOf;
using cli::parseList;
using cli::UsageError;

constexpr const char* kVersion = ISOSLAB_VERSION;
/// --threads: more would fail to start (EAGAIN) long before it helped.
constexpr std::int64_t kMaxThreads = 256;
/// info --bins: 2^24 bins are 128 MiB of counts.
constexpr std::int64_t kMaxHistogramBins = std::int64_t{1} << 24;

struct RawArgs {
  std::string series;
  bool strict = false;
  bool skipBad = false;
  int channel = -1;
  std::string niftiXform;  // empty: the sform when sform_code > 0, else the qform
  std::string dims;
  std::string type = "u8";
  std::string endian = "little";
  std::int64_t offset = 0;
  std::string spacing;
};

void addRawOptions(CLI::App* cmd, RawArgs& raw) {
  cmd->add_option("--series", raw.series,
                  "DICOM: the series to read, by SeriesInstanceUID or index (default: the largest)")
      ->group("DICOM input");
  cmd->add_flag("--strict", raw.strict, "DICOM: treat series warnings (a slice may be missing, duplicates) as errors")
      ->group("DICOM input");
  cmd->add_flag("--skip-bad", raw.skipBad, "DICOM: skip corrupt or unreadable files with a warning")
      ->group("DICOM input");
  cmd->add_option("--channel", raw.channel,
                  "Colour or multi-component input (DICOM, image stacks, NRRD, MetaImage): the channel to use, from 0")
      ->check(integerIn(-1, std::numeric_limits<int>::max(), " (-1: none)"))
      ->group("DICOM input");
  cmd->add_option("--nifti-xform", raw.niftiXform,
                  "NIfTI: the world transform, sform or qform (default: the sform when sform_code > 0, else the "
                  "qform)")
      ->check(CLI::IsMember({"sform", "qform"}))
      ->group("DICOM input");
  cmd->add_option("--raw-dims", raw.dims, "Raw input: lattice points X,Y,Z (Z may be left out for per-slice files)")
      ->check(numberList([](const std::vector<double>& dims) -> std::string {
        if (dims.size() != 2 && dims.size() != 3) return "needs X,Y or X,Y,Z";
        for (double d : dims) {
          if (d != std::floor(d) || d < -9.0e18 || d > 9.0e18) return "must hold whole numbers";
        }
        return {};
      }))
      ->group("Raw input");
  cmd->add_option("--raw-type", raw.type, "Raw input: voxel type u8 i8 u16 i16 u32 i32 f32 f64")
      ->check(CLI::Validator(
          [](std::string& value) -> std::string {
            return parseVoxelType(value)
                       ? std::string()
                       : fmt::format("unknown voxel type '{}' (use u8 i8 u16 i16 u32 i32 f32 f64)", value);
          },
          ""))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-endian", raw.endian, "Raw input: byte order, little or big")
      ->transform(oneOf("byte order", {"little", "big"}))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-offset", raw.offset, "Raw input: header bytes to skip in each file")
      ->check(integerIn(0, std::numeric_limits<std::int64_t>::max()))
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--spacing", raw.spacing, "Voxel spacing sx,sy,sz (raw input and image stacks; default 1,1,1)")
      ->check(numberList([](const std::vector<double>& s) -> std::string {
        if (s.size() != 3) return "needs three values";
        return s[0] > 0 && s[1] > 0 && s[2] > 0 ? "" : "needs three positive values";
      }))
      ->group("Raw input");
}

// The options' values, which their validators (addRawOptions) have checked while parsing.
SourceOptions sourceOptions(const RawArgs& raw) {
  SourceOptions options;
  options.dicom.series = raw.series;
  options.dicom.strict = raw.strict;
  options.dicom.skipBad = raw.skipBad;
  options.dicom.channel = raw.channel;
  if (raw.niftiXform == "sform") options.niftiXform = NiftiXform::kSform;
  if (raw.niftiXform == "qform") options.niftiXform = NiftiXform::kQform;
  std::optional<std::array<double, 3>> spacing;
  if (!raw.spacing.empty()) {
    const auto s = parseList(raw.spacing, "--spacing");
    spacing = std::array<double, 3>{s.at(0), s.at(1), s.at(2)};
  }
  if (raw.dims.empty()) {
    options.spacing = spacing;
    return options;
  }
  RawOptions r;
  const auto dims = parseList(raw.dims, "--raw-dims");
  for (std::size_t a = 0; a < dims.size() && a < 3; ++a) r.dims[a] = static_cast<std::int64_t>(dims[a]);
  r.type = parseVoxelType(raw.type).value();
  r.byteOrder = raw.endian == "big" ? ByteOrder::kBig : ByteOrder::kLittle;
  r.headerBytes = raw.offset;
  if (spacing) r.spacing = *spacing;
  options.raw = r;
  return options;
}

nlohmann::json array3(const std::array<double, 3>& a) {
  return nlohmann::json::array({a[0], a[1], a[2]});
}

void writeText(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.write(text.data(), text.size());
  f.commit();
}

// --sphere cx,cy,cz,r, for extract and metrics.
CLI::Validator sphereList() {
  return numberList([](const std::vector<double>& v) -> std::string {
    return v.size() == 4 && v[3] > 0 ? "" : "needs cx,cy,cz,r with r > 0";
  });
}

Sphere parseSphere(const std::string& text) {
  const auto v = parseList(text, "--sphere");
  return Sphere{{v.at(0), v.at(1), v.at(2)}, v.at(3)};
}

struct ExtractArgs {
  std::vector<std::string> inputs;
  std::string space = "physical";
  std::string iso;  // a number, auto, bone or skin (checked by isoValue()); empty: the input's suggestion
  std::string method = "mc";
  std::string output;
  bool normals = false;
  bool closeBoundary = false;
  std::string report;
  bool quiet = false;
  std::string sphere;
  int threads = 0;
  int maxMemory = 256;                 // MiB
  std::int64_t sequentialVoxels = -1;  // the cost model's default
  int dracoLevel = 7;
  int quantBits = 0;
  std::int64_t chunkTriangles = 1 << 19;
  std::string draco = "on";
  std::string gltfFrame = "gltf";
  std::string preview;  // a PNG rendered as the triangles stream past
  cli::ImageArgs previewImage;
  RawArgs raw;
  std::string roi;  // i0,j0,k0,i1,j1,k1 or, with roiSpace "physical", x0,y0,z0,x1,y1,z1
  std::string roiSpace = "voxel";
  // Component filters (0 or empty: not given).
  std::uint64_t keepLargest = 0;
  std::string componentMeasure = "triangles";
  std::uint64_t minTriangles = 0;
  double minVolume = -1;
  std::string seed;  // x,y,z in output coordinates
  // Smoothing.
  int smooth = 0;
  std::string smoothMethod = "sinc";
  double passBand = 0.08;
  std::string smoothFaces = "slide";
  std::string smoothNormals = "smoothed";
  // Decimation (1 and 0: off).
  double decimate = 1.0;
  double maxError = 0;
};

// The component filters of a run (any() false when none is given).
ComponentRules componentRules(const ExtractArgs& args, const VolumeInfo& info) {
  ComponentRules rules;
  if (args.keepLargest > 0) rules.keepLargest = args.keepLargest;
  rules.measure = args.componentMeasure == "volume" ? ComponentMeasure::kVolume : ComponentMeasure::kTriangles;
  if (args.minTriangles > 0) rules.minTriangles = args.minTriangles;
  if (args.minVolume >= 0) rules.minVolume = args.minVolume;
  if (!args.seed.empty()) {
    const auto v = parseList(args.seed, "--seed");
    rules.seed = Vec3f{static_cast<float>(v.at(0)), static_cast<float>(v.at(1)), static_cast<float>(v.at(2))};
  }
  // A seed may miss a component's bounds by one voxel diagonal.
  const auto& sp = info.spacing;
  rules.seedReach = args.space == "voxel" ? std::sqrt(3.0) : std::sqrt(sp[0] * sp[0] + sp[1] * sp[1] + sp[2] * sp[2]);
  return rules;
}

// --roi as run: the box as given, the lattice points it selected (the input's indices, inclusive)
// and the input's dims.
struct RoiChoice {
  std::vector<double> requested;
  LatticeBox box;
  std::array<std::int64_t, 3> inputDims{};
  bool clipped = false;
};

// --roi: six numbers, each lower corner at most the upper one.
CLI::Validator roiList() {
  return numberList([](const std::vector<double>& v) -> std::string {
    if (v.size() != 6) return "needs six numbers, the box's lower and upper corners: i0,j0,k0,i1,j1,k1";
    for (std::size_t a = 0; a < 3; ++a) {
      if (v[a] > v[a + 3]) return fmt::format("is reversed: its upper corner is below its lower one on axis {}", a);
    }
    return {};
  });
}

// The source cut to --roi. A voxel box is clipped to the lattice (with a note); a physical box, in
// the output coordinates of --space, selects the lattice points that lie in it (LatticeFrame::
// latticeBox). A box that leaves fewer than 2 points on an axis is an error naming the input.
std::unique_ptr<SliceSource> cropToRoi(std::unique_ptr<SliceSource> source, const ExtractArgs& args, RoiChoice& roi) {
  const VolumeInfo& info = source->info();
  const std::string& input = args.inputs.front();
  roi.requested = parseList(args.roi, "--roi");
  roi.inputDims = info.dims;
  const auto& v = roi.requested;
  std::string note;
  if (args.roiSpace == "voxel") {
    LatticeBox asked;
    for (std::size_t a = 0; a < 6; ++a) {
      if (v[a] != std::floor(v[a]) || std::abs(v[a]) > 9.0e15) {
        throw UsageError(
            fmt::format("--roi '{}' needs whole numbers (lattice indices) with --roi-space voxel", args.roi));
      }
      (a < 3 ? asked.lo[a] : asked.hi[a - 3]) = static_cast<std::int64_t>(v[a]);
    }
    roi.box = clipLatticeBox(asked, info.dims, input, &roi.clipped);
    if (roi.clipped) {
      note = fmt::format("--roi {} reaches past the volume's {}x{}x{} lattice points: clipped to {}", args.roi,
                         info.dims[0], info.dims[1], info.dims[2], latticeBoxText(roi.box));
    }
  } else {
    const std::string box = fmt::format("--roi {} ({} coordinates)", args.roi, args.space);
    const LatticeFrame frame = LatticeFrame::forSpace(info, args.space);
    const auto found = frame.latticeBox({v[0], v[1], v[2], v[3], v[4], v[5]}, info.dims);
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
  if (!args.quiet && !note.empty()) std::fprintf(stderr, "isoslab: %s\n", note.c_str());
  return std::make_unique<CropSource>(std::move(source), roi.box);
}

std::array<double, 2> valueRange(SliceSource& source);

// A value of the float slices by its shortest decimal form (999.7, not 999.7000122070312).
double asFloat(double value) {
  return std::strtod(fmt::format("{}", static_cast<float>(value)).c_str(), nullptr);
}

// A missing --iso, with the input's value range (one pass through it) and, for CT (DICOM Modality
// CT, or values down to air's -1000 HU), typical Hounsfield values.
std::string missingIsoMessage(const std::string& input, SliceSource& source) {
  const VolumeInfo& info = source.info();
  const std::array<double, 2> range = info.valueRange ? *info.valueRange : valueRange(source);
  std::string text = fmt::format("{}: --iso is required for this input", input);
  if (!(range[0] <= range[1])) return text + " (it holds no values but NaN)";
  text += fmt::format(", whose values range from {} to {}", asFloat(range[0]), asFloat(range[1]));
  if (CLI::detail::to_lower(info.modality) == "ct" || range[0] <= -1000) {
    text += "; for CT in Hounsfield units try about 300..400 for bone, -500..-200 for skin or 40 for soft tissue";
  }
  return text + "; --iso auto takes Otsu's threshold";
}

// The iso value of a run: --iso's number, auto or name, else the input's suggestion. "auto" reads
// the source to its end (stream/iso_choice.h), so `source` is then opened again (and cut to the
// same --roi box: the histogram is the box's).
IsoChoice chooseIsoValue(const ExtractArgs& args, std::unique_ptr<SliceSource>& source, const RoiChoice* roi) {
  if (args.iso.empty()) {
    if (!source->info().suggestedIso) throw UsageError(missingIsoMessage(args.inputs.front(), *source));
    IsoChoice choice;
    choice.value = *source->info().suggestedIso;
    choice.source = "suggested by the input";
    return choice;
  }
  const auto request = parseIsoRequest(args.iso);
  if (!request) throw UsageError(fmt::format("--iso: '{}' is not a number, auto, bone or skin", args.iso));
  const SourceOptions options = sourceOptions(args.raw);
  const SourceOpener reopen = [&]() -> std::unique_ptr<SliceSource> {
    auto opened = openSource(args.inputs, options);
    if (roi != nullptr) return std::make_unique<CropSource>(std::move(opened), roi->box);
    return opened;
  };
  IsoChoice choice = chooseIso(*request, args.inputs.front(), *source, reopen);
  if (choice.sourceRead) source = reopen();
  return choice;
}

// Why a run wrote no triangles, which would otherwise pass for success (an empty mesh is
// "closed"): one warning naming the cause (`name` names the iso value), or none when there are
// triangles.
std::optional<std::string> emptySurfaceWarning(double iso, const std::string& name,
                                               const std::optional<std::array<double, 2>>& range,
                                               std::uint64_t triangles) {
  if (triangles > 0) return std::nullopt;
  if (!range) return "0 triangles: the input holds no values but NaN";
  const double lo = asFloat((*range)[0]);
  const double hi = asFloat((*range)[1]);
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

void printWarning(const std::string& warning) {
  std::fprintf(stderr, "isoslab: warning: %s\n", cli::terminalLine(cli::withFlags(warning)).c_str());
}

// Whether two output paths name one file: the same spelling after normalisation, or (when the file
// exists) the same file through links and other spellings.
bool sameFile(const std::string& a, const std::string& b) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (fs::equivalent(a, b, ec) && !ec) return true;
  // A link to a file that does not exist yet names that file.
  const auto resolve = [&](fs::path p) {
    for (int hops = 0; hops < 40 && fs::is_symlink(fs::symlink_status(p, ec)); ++hops) {
      const fs::path link = fs::read_symlink(p, ec);
      if (ec) break;
      p = link.is_absolute() ? link : p.parent_path() / link;
    }
    return fs::weakly_canonical(fs::absolute(p), ec).lexically_normal();
  };
  const fs::path ca = resolve(a);
  const fs::path cb = resolve(b);
  return ca == cb;
}

// --threads' default: the core count, at most 8; with ranks, divided among the ranks on this
// machine (Open MPI's OMPI_COMM_WORLD_LOCAL_SIZE), so that N ranks on one machine use its cores once.
int defaultThreads(bool ranked) {
  // The cores this process may run on (mpirun binds ranks to cores or sockets).
  const unsigned machine = std::clamp(std::thread::hardware_concurrency(), 1u, 1024u);
  unsigned cores = machine;
  cpu_set_t set;
  if (::sched_getaffinity(0, sizeof set, &set) == 0) {
    cores = std::clamp(static_cast<unsigned>(CPU_COUNT(&set)), 1u, machine);
  }
  if (ranked && cores == machine) {
    // Unbound ranks share the machine.
    const char* local = std::getenv("OMPI_COMM_WORLD_LOCAL_SIZE");
    if (local == nullptr) local = std::getenv("MPI_LOCALNRANKS");
    const long n = local != nullptr ? std::strtol(local, nullptr, 10) : 0;
    if (n > 0) cores = std::max(1u, cores / static_cast<unsigned>(n));
  }
  return static_cast<int>(std::min(cores, 8u));
}

// The ranks of an extraction under mpirun (cli/mpi_group.h), or nullptr.
RankGroup* gRanks = nullptr;

// Whether this process prints the error that ends it. Under mpirun one rank does: rank 0 when
// the failure was shared through the pipeline (it holds the failing rank's message), else the
// lowest rank that failed (the ranks agree on it here, as every rank ends in an agree()).
bool reportsFailure() {
  if (gRanks == nullptr || gRanks->size() < 2) return true;
  if (gRanks->failureShared()) return gRanks->rank() == 0;
  const int lowest = gRanks->agree(false);
  gRanks->setFailureShared();
  return lowest == gRanks->rank();
}

int runExtract(const ExtractArgs& args) {
  // Under mpirun every rank runs this function with the same arguments; rank 0 alone writes the
  // outputs and prints, and the others extract their slabs for it (runPipeline).
  const bool primary = gRanks == nullptr || gRanks->rank() == 0;
  const auto method = parseMethod(args.method);
  if (!method)
    throw UsageError(
        fmt::format("--method: unknown method '{}' (use {})", args.method, fmt::join(methodNames(), ", ")));
  if (!args.report.empty() && sameFile(args.report, args.output)) {
    throw UsageError(fmt::format("--report '{}' names the same file as -o '{}'", args.report, args.output));
  }
  if (!args.preview.empty() &&
      (sameFile(args.preview, args.output) || (!args.report.empty() && sameFile(args.preview, args.report)))) {
    throw UsageError(fmt::format("--preview '{}' names the same file as another output", args.preview));
  }
  std::vector<std::string> notes;
  auto source = openSource(args.inputs, sourceOptions(args.raw), &notes);
  // The mesh's coordinates are float32: a physical box they cannot hold is refused before the
  // first slice (voxel coordinates always fit).
  if (args.space != "voxel") {
    const VolumeInfo& opened = source->info();
    validateFloat32Geometry(opened, opened.source.empty() ? args.inputs.front() : opened.source);
  }
  std::optional<RoiChoice> roi;
  // Readers' notes that are warnings print even with --quiet and go to the report.
  std::vector<std::string> warnings;
  for (std::string& n : notes) {
    n = cli::withFlags(n);
    if (n.rfind("warning: ", 0) == 0) {
      warnings.push_back(n.substr(9));
      if (primary) printWarning(warnings.back());
    } else if (!args.quiet && primary) {
      std::fprintf(stderr, "isoslab: %s\n", n.c_str());
    }
  }
  if (!args.roi.empty()) source = cropToRoi(std::move(source), args, roi.emplace());
  const IsoChoice isoChoice = chooseIsoValue(args, source, roi ? &*roi : nullptr);
  if (!isoChoice.note.empty() && !args.quiet && primary)
    std::fprintf(stderr, "isoslab: %s\n", cli::withFlags(isoChoice.note).c_str());
  const VolumeInfo info = source->info();  // a copy: a component filter reopens the source
  const double iso = isoChoice.value;
  const bool isoNumber = isoChoice.source == "value";
  const std::string isoName = args.iso.empty() ? fmt::format("the suggested iso {}", iso)
                              : isoNumber      ? fmt::format("--iso {}", iso)
                                               : fmt::format("--iso {} ({})", args.iso, iso);

  const LatticeFrame frame = LatticeFrame::forSpace(info, args.space);
  // The default: the cores, at most 8; under mpirun, the cores shared among this machine's ranks.
  const int threads = args.threads > 0 ? args.threads : defaultThreads(gRanks != nullptr && gRanks->size() > 1);
  WriterOptions writerOptions;
  // With threads, the writer gathers chunks while others encode them: encoding then overlaps
  // everything else (it is the slowest stage). Each encoder holds about 200 bytes per triangle of
  // its chunk (docs/performance.md), so --max-memory allows half its budget to as many encoders
  // as fit, at most one per thread; when none fits, chunks encode in the emit stage, as with
  // one thread. The other half goes to slices in flight and the threads' caches.
  const auto budget = static_cast<std::size_t>(args.maxMemory) << 20;
  const auto encoderBytes = static_cast<std::size_t>(std::max<std::int64_t>(1, args.chunkTriangles)) * 200;
  writerOptions.encodeThreads =
      threads > 1 ? static_cast<int>(std::min<std::size_t>(budget / 2 / encoderBytes, threads)) : 0;
  writerOptions.dracoLevel = args.dracoLevel;
  writerOptions.quantBits = args.quantBits;
  writerOptions.chunkTriangles = args.chunkTriangles;
  writerOptions.draco = args.draco == "on";
  writerOptions.gltfFrame = args.gltfFrame == "gltf";
  writerOptions.voxelSize = args.space == "voxel" ? 1.0 : std::min({info.spacing[0], info.spacing[1], info.spacing[2]});
  // The mesh and the report appear together or not at all: both are completed under temporary
  // names, and renamed into place only once the report is written.
  CommitGroup outputs;
  std::unique_ptr<MeshFileSink> writer;
  if (primary) writer = makeMeshWriter(args.output, writerOptions);
  std::optional<Sphere> sphere = phantomSphere(info);
  if (!args.sphere.empty()) sphere = parseSphere(args.sphere);
  ExtractOptions options;
  options.method = *method;
  options.iso = iso;
  options.normals = args.normals;
  // The per-tetrahedron inside volume (volume_cells) costs a quarter of mt6's time: only for a
  // report or sphere measures.
  options.cellVolumes = !args.report.empty() || sphere.has_value();
  options.closeBoundary = args.closeBoundary;
  auto extractor = makeExtractor(options, info, frame);

  const MeshHeader header = extractionHeader(options, info, frame, *extractor);
  // The caps need the field beyond the faces: one NaN point around the volume (the header, frame
  // and value range stay the volume's own).
  if (args.closeBoundary) source = std::make_unique<PadSource>(std::move(source));
  PipelineOptions pipelineOptions;
  pipelineOptions.progress = !args.quiet && primary;
  pipelineOptions.ranks = gRanks;
  pipelineOptions.threads = threads;
  pipelineOptions.maxThreadBytes = budget / 2;
  if (args.sequentialVoxels >= 0) pipelineOptions.sequentialVoxels = args.sequentialVoxels;

  // Component filters: a first pass finds and measures the components, and chooses; the second
  // (the run below) extracts again from the input reopened, and keeps only the chosen ones.
  const ComponentRules rules = componentRules(args, info);
  std::optional<ComponentSink> components;
  std::vector<bool> keptComponents, keepPart;
  nlohmann::ordered_json componentReport, filterReport;
  std::optional<ComponentFilterSink> filter;
  double firstPassSeconds = 0;
  if (rules.any()) {
    ComponentSink& found = components.emplace();
    found.setSeed(rules.seed);
    firstPassSeconds = runPipeline(*source, *extractor, found, header, pipelineOptions).totalSeconds;
    throwIfInterrupted();
    // Under mpirun only rank 0 saw the mesh (and chooses); the other ranks' sinks see nothing.
    if (primary) {
      keptComponents = selectComponents(found.components(), rules);
      keepPart = keptParts(found, keptComponents);
      // The report's pieces now, so that the second pass holds a bit per part and no list.
      componentReport = componentsJson(found.components(), 10, &keptComponents);
      filterReport = componentFilterJson(rules, found.components(), keptComponents, found.parts());
    }
    components.reset();
    auto reopened = openSource(args.inputs, sourceOptions(args.raw));
    if (roi) reopened = std::make_unique<CropSource>(std::move(reopened), roi->box);
    if (args.closeBoundary) reopened = std::make_unique<PadSource>(std::move(reopened));
    source = std::move(reopened);
    extractor = makeExtractor(options, info, frame);
  }

  MeshStatsSink stats;
  std::optional<SphereErrorSink> sphereErrors;
  std::vector<MeshSink*> sinks{&stats};
  if (writer) sinks.insert(sinks.begin(), writer.get());
  // The report lists the connected components (memory: the live front and the components); with
  // filters, those of the first pass.
  if (!args.report.empty() && !rules.any()) sinks.push_back(&components.emplace());
  if (sphere) {
    sphereErrors.emplace(*sphere);
    sinks.push_back(&*sphereErrors);
  }
  // The preview keeps the image and two slabs' vertices, never the mesh.
  std::optional<render::RenderSink> preview;
  if (!args.preview.empty()) {
    const auto [width, height] = cli::sizeOf(args.previewImage);
    preview.emplace(cli::viewOf(args.previewImage), width, height, cli::styleOf(args.previewImage, args.normals));
    sinks.push_back(&*preview);
  }
  TeeSink tee(sinks);
  MeshSink* target = &tee;
  // Decimation, last before the writer and the measures: on the smoothed surface.
  std::optional<DecimationSink> decimation;
  if (args.decimate != 1.0 || args.maxError != 0) {
    DecimateOptions decimateOptions;
    decimateOptions.ratio = args.decimate;
    decimateOptions.maxError = args.maxError;
    // Every decimated triangle stays within --max-error of the surface, or half a voxel.
    decimateOptions.maxDistance = args.maxError > 0 ? args.maxError : 0.5;
    decimateOptions.voxelSize = writerOptions.voxelSize;
    if (const std::string e = checkDecimateOptions(decimateOptions); !e.empty()) throw UsageError(cli::withFlags(e));
    target = &decimation.emplace(*target, decimateOptions);
  }
  // Smoothing runs on what the filter keeps; its output feeds the writer and the measures.
  std::optional<SmoothingSink> smoothing;
  if (args.smooth > 0) {
    SmoothOptions smoothOptions;
    smoothOptions.iterations = args.smooth;
    smoothOptions.method = args.smoothMethod == "taubin" ? SmoothMethod::kTaubin : SmoothMethod::kSinc;
    smoothOptions.passBand = args.passBand;
    smoothOptions.faces = args.smoothFaces == "lock" ? FaceVertices::kLock : FaceVertices::kSlide;
    smoothOptions.recomputeNormals = args.smoothNormals == "smoothed";
    if (const std::string e = checkSmoothOptions(smoothOptions); !e.empty()) throw UsageError(cli::withFlags(e));
    target = &smoothing.emplace(*target, smoothOptions);
  }
  if (rules.any()) target = &filter.emplace(*target, std::move(keepPart));
  const PipelineResult run = runPipeline(*source, *extractor, *target, header, pipelineOptions);
  if (preview && primary) {
    const render::Image image = preview->image();
    writePng(args.preview, image.width, image.height, image.rgb);
  }
  const MeshStats& s = stats.stats();
  const std::size_t readerWarnings = warnings.size();
  for (std::string& w : source->warnings()) warnings.push_back(std::move(w));
  for (const std::string& w : run.rankWarnings) warnings.push_back(w);  // the other ranks' readers
  if (auto w = emptySurfaceWarning(iso, isoName, run.valueRange, s.triangles)) warnings.push_back(*w);
  if (primary) {
    for (std::size_t n = readerWarnings; n < warnings.size(); ++n) printWarning(warnings[n]);
  }

  if (!args.report.empty() && primary) {
    nlohmann::ordered_json r;
    r["generator"] = fmt::format("isoslab {}", kVersion);
    r["input"] =
        args.inputs.size() == 1 ? nlohmann::ordered_json(args.inputs.front()) : nlohmann::ordered_json(args.inputs);
    r["reader"] = info.reader;
    r["method"] = header.method;
    r["iso"] = iso;
    r["iso_source"] = isoChoice.source;
    if (!isoChoice.note.empty()) r["iso_note"] = cli::withFlags(isoChoice.note);
    if (isoChoice.histogram && isoChoice.split) {
      const ValueHistogram& h = *isoChoice.histogram;
      r["iso_histogram"] = {{"bins", h.bins()},
                            {"range", {h.lo, h.hi}},
                            {"range_from", h.rangeFromReader ? "reader" : "data"},
                            {"passes", h.passes},
                            {"first_inside_bin", isoChoice.split->firstUpperBin}};
    }
    r["dims"] = {info.dims[0], info.dims[1], info.dims[2]};
    if (roi) {
      r["roi"] = {
          {"box", {roi->box.lo[0], roi->box.lo[1], roi->box.lo[2], roi->box.hi[0], roi->box.hi[1], roi->box.hi[2]}},
          {"requested", roi->requested},
          {"space", args.roiSpace},
          {"clipped", roi->clipped},
          {"input_dims", {roi->inputDims[0], roi->inputDims[1], roi->inputDims[2]}}};
    }
    r["spacing"] = array3(info.spacing);
    r["volume_bounds"] = header.volumeBounds;
    r["voxel_type"] = std::string(voxelTypeName(info.type));
    r["space"] = header.space;
    r["normals"] = args.normals;
    r["value_range"] =
        run.valueRange ? nlohmann::ordered_json::array({asFloat((*run.valueRange)[0]), asFloat((*run.valueRange)[1])})
                       : nlohmann::ordered_json();
    r["warnings"] = warnings;
    addStatsJson(r, s);
    if (args.smooth > 0) {
      r["smoothing"] = {{"iterations", args.smooth},
                        {"method", args.smoothMethod},
                        {"pass_band", args.passBand},
                        {"faces", args.smoothFaces},
                        {"normals", args.normals ? args.smoothNormals : "none"},
                        {"peak_chunks", smoothing ? smoothing->peakChunks() : 0},
                        {"peak_vertices", smoothing ? smoothing->peakVertices() : 0}};
    }
    if (decimation) {
      const DecimationReport& d = decimation->report();
      r["decimation"] = {
          {"ratio", args.decimate},
          {"max_error", args.maxError},
          {"triangles_before", d.trianglesIn},
          {"triangles_after", d.trianglesOut},
          {"kept_fraction",
           d.trianglesIn > 0 ? static_cast<double>(d.trianglesOut) / static_cast<double>(d.trianglesIn) : 1.0},
          {"distance_bound_voxels", args.maxError > 0 ? args.maxError : 0.5},
          {"blocks", d.blocks},
          {"regions", d.regions},
          {"regions_repaired", d.repairedRegions},
          {"triangles_frozen", d.frozenTriangles},
          {"regions_kept_whole", d.keptRegions},
          {"simplify_calls", d.attempts},
          {"distance_mean", d.distanceMean},
          {"distance_max", d.distanceMax},
          {"distance_mean_voxels", d.distanceMean / writerOptions.voxelSize},
          {"distance_max_voxels", d.distanceMax / writerOptions.voxelSize},
          {"distance_samples", d.samples}};
    }
    if (rules.any()) {
      r["components"] = componentReport;
      r["component_filter"] = filterReport;
    } else {
      r["components"] = componentsJson(components->components());
    }
    if (sphere) r["sphere"] = sphereJson(sphereReport(*sphere, s, *sphereErrors));
    r["seconds"] = {{"read", run.readSeconds},
                    {"extract", run.extractSeconds},
                    {"write", run.writeSeconds},
                    {"total", run.totalSeconds + firstPassSeconds}};
    if (rules.any()) r["seconds"]["component_pass"] = firstPassSeconds;
    if (gRanks != nullptr && gRanks->size() > 1) r["ranks"] = gRanks->size();
    r["ring_bytes"] = run.ringBytes;
    r["peak_rss_mib"] = peakRssMib();
    nlohmann::ordered_json output = {{"path", args.output}, {"bytes", writer->bytes()}};
    if (s.triangles > 0)
      output["bits_per_triangle"] = 8.0 * static_cast<double>(writer->bytes()) / static_cast<double>(s.triangles);
    const std::int64_t plyBytes = PlyWriter::binaryBytes(s.vertices, s.triangles, header);
    output["ratio_to_binary_ply"] = static_cast<double>(writer->bytes()) / static_cast<double>(plyBytes);
    for (const auto& [key, value] : writer->details()) output[key] = value;
    r["output"] = output;
    writeText(args.report, reportText(r, args.report) + "\n");
  }
  throwIfInterrupted();
  outputs.commit();
  // Every rank ends here together: a rank that failed after the last extraction (rank 0 writing
  // the report) tells the others.
  if (gRanks != nullptr && gRanks->size() > 1) {
    if (const int failed = gRanks->agree(true); failed >= 0) {
      gRanks->setFailureShared();
      throw RankFailed(failed);
    }
  }
  if (!args.quiet && primary) {
    std::fprintf(stderr, "isoslab: %s at iso %g%s: %llu triangles, %llu vertices, %s, %.2f s -> %s\n",
                 header.method.c_str(), iso,
                 args.iso.empty() ? " (the input's suggestion)"
                 : isoNumber      ? ""
                                  : fmt::format(" (--iso {})", args.iso).c_str(),
                 static_cast<unsigned long long>(s.triangles), static_cast<unsigned long long>(s.vertices),
                 s.closed() ? "closed" : fmt::format("{} boundary edges", s.boundaryEdges).c_str(), run.totalSeconds,
                 args.output.c_str());
  }
  return 0;
}

std::array<double, 2> valueRange(SliceSource& source) {
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

int runInfo(const std::vector<std::string>& inputs, const RawArgs& raw, std::size_t histogramBins) {
  const SourceOptions options = sourceOptions(raw);
  const bool dicom = !options.raw && !PhantomSource::isPhantom(inputs.front()) &&
                     std::all_of(inputs.begin(), inputs.end(), [](const std::string& in) { return isDicomInput(in); });
  if (!dicom) {
    std::vector<std::string> notes;
    auto source = openSource(inputs, options, &notes);
    std::printf("input      %s\n", inputs.front().c_str());
    printGeometry(source->info());
    std::optional<ValueHistogram> histogram;
    if (histogramBins > 0)
      histogram = streamHistogram(*source, histogramBins, [&] { return openSource(inputs, options); });
    const auto range = !histogram              ? valueRange(*source)
                       : histogram->valueRange ? *histogram->valueRange
                                               : std::array<double, 2>{std::numeric_limits<double>::infinity(),
                                                                       -std::numeric_limits<double>::infinity()};
    std::printf("range      %g .. %g\n", range[0], range[1]);
    if (histogram) printHistogram(*histogram, "", 11);
    for (std::string& n : notes) {
      n = cli::withFlags(n);
      const bool warning = n.rfind("warning: ", 0) == 0;
      std::printf("%s%s\n", warning ? "warning    " : "note       ", n.c_str() + (warning ? 9 : 0));
    }
    for (const std::string& w : source->warnings()) std::printf("warning    %s\n", cli::withFlags(w).c_str());
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
        const auto range = valueRange(*source);
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

}  // namespace
}  // namespace isoslab

namespace {

// When the first stop signal came (CLOCK_MONOTONIC nanoseconds, 0 before it). The handler may run
// on two threads at once (a signal is blocked only on the thread that handles it), so the first
// is the one that sets this, before gInterruptSignal.
std::atomic<std::int64_t> gFirstStopNs{0};
static_assert(std::atomic<std::int64_t>::is_always_lock_free);

// A repeat this soon after the first signal is the same request delivered twice, not the user
// insisting: timeout(1) sends its signal to the process and then to the process group, a
// terminal's Ctrl-C reaches every process of the job, and wrappers forward signals they received
// too. Ending the process on such a repeat left the temporary files behind (issue 33).
constexpr std::int64_t kRepeatNs = 1'000'000'000;

// Asks the run to stop (the loops poll gInterruptSignal; it stops within a second). A signal that
// comes kRepeatNs or more after the first ends the process at once, by the signal's default
// action: a way out of a read that hangs, which leaves the temporary files.
extern "C" void onStopSignal(int signal) {
  const int savedErrno = errno;
  timespec now{};
  ::clock_gettime(CLOCK_MONOTONIC, &now);
  const std::int64_t ns = std::max<std::int64_t>(1, std::int64_t{now.tv_sec} * 1'000'000'000 + now.tv_nsec);
  std::int64_t first = 0;
  if (gFirstStopNs.compare_exchange_strong(first, ns)) {
    isoslab::gInterruptSignal.store(signal);
  } else if (ns - first >= kRepeatNs) {
    ::signal(signal, SIG_DFL);
    ::raise(signal);
  }
  errno = savedErrno;
}

}  // namespace

// Prints "isoslab: error: MESSAGE" on one line, with control characters in the message (from a
// file name or a header value) escaped: a newline, tab or ESC must not make a second line or
// drive the terminal.
static void printError(const std::string& message) {
  std::fprintf(stderr, "isoslab: error: %s\n", isoslab::cli::terminalLine(isoslab::cli::withFlags(message)).c_str());
}

int main(int argc, char** argv) {
  using namespace isoslab;
#if defined(__GLIBC__)
  // Buffers of a slab, a chunk or a meshoptimizer batch come and go with the stream. glibc raises
  // its mmap threshold to the largest buffer freed, after which such buffers come from the heap,
  // whose freed space stays in the process: on the 36-million-triangle foam that added a third to
  // the peak (docs/performance.md). A fixed threshold maps each large buffer and unmaps it when
  // freed.
  ::mallopt(M_MMAP_THRESHOLD, 256 * 1024);
#endif
  // A file-size limit then fails the write with EFBIG, reported like any write error.
  ::signal(SIGXFSZ, SIG_IGN);
  for (const int stop : {SIGINT, SIGTERM, SIGHUP}) {
    struct sigaction action {};
    action.sa_handler = onStopSignal;
    sigemptyset(&action.sa_mask);
    action.sa_flags = SA_RESTART;
    ::sigaction(stop, &action, nullptr);
  }
  CLI::App app{"isoslab: streaming iso-surface extraction from volumetric scanner data", "isoslab"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kVersion);
  app.footer(
      "Exit codes: 0 success; 1 input or output error; 2 usage error; 129, 130, 143 interrupted by SIGHUP, "
      "SIGINT, SIGTERM (no output or temporary file is left).");

  ExtractArgs ex;
  auto* extract = app.add_subcommand("extract", "Extract an iso-surface mesh from a volume");
  extract
      ->add_option(
          "INPUT", ex.inputs,
          "Volume: DICOM folders, DICOMDIRs or files; a raw file, pattern or folder; or phantom:NAME?key=value&...")
      ->required();
  extract
      ->add_option("--space", ex.space,
                   "Output coordinates: physical (the input's frame; LPS for DICOM), lps, ras or voxel")
      ->transform(oneOf("space", {"physical", "lps", "ras", "voxel"}))
      ->capture_default_str();
  extract
      ->add_option("--iso", ex.iso,
                   "Iso value; voxels with value >= iso are inside. A number; auto (Otsu's threshold on the input's "
                   "histogram, one or two extra passes over it); or for CT bone (300 HU) or skin (-400 HU). Default: "
                   "the input's suggestion, for phantoms")
      ->transform(isoValue());
  extract->add_option("--method", ex.method, fmt::format("{}", fmt::join(methodNames(), ", ")))
      ->transform(oneOf("method", methodNames()))
      ->capture_default_str();
  extract
      ->add_option("-o,--output", ex.output,
                   "Output mesh: .ply (binary), .stl (binary), .obj, .glb (glTF 2.0, Draco-compressed chunks) or "
                   ".drc (one Draco mesh)")
      ->required();
  extract->add_flag("--close-boundary", ex.closeBoundary,
                    "Take the field as outside beyond the volume's faces, so that the surface is capped there "
                    "and closed");
  extract->add_flag("--normals", ex.normals,
                    "Write vertex normals from the field's gradient (PLY, OBJ and Draco; STL has facet normals)");
  extract->add_option("--report", ex.report, "Write a JSON report of the run");
  extract->add_flag("-q,--quiet", ex.quiet, "No progress line, notes or summary on stderr (warnings still print)");
  extract
      ->add_option("--threads", ex.threads,
                   "Threads (default: the core count, at most 8, shared among the ranks on a machine under mpirun): N "
                   "threads share reading, extracting and "
                   "writing, and .glb chunks encode on up to N more, as --max-memory allows; volumes under "
                   "2^24 voxels take 1. The output is the same for every count")
      ->check(integerIn(1, kMaxThreads));
  extract
      ->add_option("--max-memory", ex.maxMemory,
                   "MiB for what grows with --threads: half for slices in flight and each thread's caches "
                   "(shorter runs, then fewer extraction threads, when it runs short), half for .glb encoders on "
                   "threads of their own (about 100 MiB "
                   "each at the default --chunk-triangles; none fits under 200, and chunks then encode in turn)")
      ->check(integerIn(16, 1 << 20))
      ->capture_default_str();
  // The cost model's smallest volume for threads; a hidden hook for the tests, which check the
  // threaded paths on small volumes.
  extract->add_option("--sequential-voxels", ex.sequentialVoxels)->group("");
  extract->add_option("--draco-level", ex.dracoLevel, "Draco (.glb, .drc): 0 fastest .. 10 smallest")
      ->check(integerIn(0, 10))
      ->capture_default_str()
      ->group("Draco output");
  extract
      ->add_option("--quant-bits", ex.quantBits,
                   "Draco: bits per position component (default: the fewest whose step is at most 1/64 voxel)")
      ->check(integerIn(1, 30))
      ->group("Draco output");
  extract
      ->add_option("--chunk-triangles", ex.chunkTriangles,
                   "Draco .glb: triangles per chunk, closed at the next slab boundary. .drc holds the whole mesh "
                   "in memory (about 28 bytes per triangle) to encode it at the end")
      ->check(integerIn(1, std::numeric_limits<std::int64_t>::max()))
      ->capture_default_str()
      ->group("Draco output");
  extract
      ->add_option("--draco", ex.draco,
                   ".glb: on (Draco-compressed chunks) or off (plain accessors, for readers without Draco)")
      ->check(CLI::IsMember({"on", "off"}))
      ->capture_default_str()
      ->group("glTF output");
  extract
      ->add_option("--gltf-frame", ex.gltfFrame,
                   ".glb: gltf (a root node maps the output space to glTF's Y-up frame in metres) or raw (no "
                   "node transform; positions in the output space's units)")
      ->check(CLI::IsMember({"gltf", "raw"}))
      ->capture_default_str()
      ->group("glTF output");

  extract
      ->add_option("--sphere", ex.sphere,
                   "Measure the mesh against the sphere cx,cy,cz,r (output coordinates); phantom spheres are measured "
                   "by themselves")
      ->check(sphereList());

  auto* roiOption = extract
                        ->add_option("--roi", ex.roi,
                                     "Extract only the box i0,j0,k0,i1,j1,k1 of lattice points (inclusive; clipped to "
                                     "the volume), or x0,y0,z0,x1,y1,z1 with --roi-space physical")
                        ->check(roiList())
                        ->group("Region of interest");
  extract
      ->add_option("--roi-space", ex.roiSpace,
                   "--roi in voxel (lattice indices) or physical (the output coordinates of --space)")
      ->transform(oneOf("ROI space", {"voxel", "physical"}))
      ->capture_default_str()
      ->needs(roiOption)
      ->group("Region of interest");

  const std::string componentsGroup = "Connected components (a second pass over the input)";
  extract->add_option("--keep-largest", ex.keepLargest, "Keep only the N largest components (by --component-measure)")
      ->check(CLI::Range(std::uint64_t{1}, std::numeric_limits<std::uint64_t>::max()))
      ->group(componentsGroup);
  extract
      ->add_option("--component-measure", ex.componentMeasure,
                   "--keep-largest by triangles or by volume (|enclosed volume|; use --close-boundary for objects "
                   "that the faces cut)")
      ->transform(oneOf("component measure", {"triangles", "volume"}))
      ->capture_default_str()
      ->group(componentsGroup);
  extract->add_option("--min-triangles", ex.minTriangles, "Drop components of fewer triangles")
      ->check(CLI::Range(std::uint64_t{1}, std::numeric_limits<std::uint64_t>::max()))
      ->group(componentsGroup);
  extract
      ->add_option("--min-volume", ex.minVolume,
                   "Drop components enclosing less volume (output units cubed, |enclosed volume|)")
      ->check(CLI::NonNegativeNumber)
      ->group(componentsGroup);
  extract
      ->add_option("--seed", ex.seed,
                   "Keep the component nearest to the point x,y,z (output coordinates), as a pick in Slicer; it must "
                   "lie within a voxel of some component's bounds")
      ->check(numberList([](const std::vector<double>& v) { return v.size() == 3 ? "" : "needs x,y,z"; }))
      ->group(componentsGroup);

  const std::string smoothGroup = "Smoothing";
  extract
      ->add_option("--smooth", ex.smooth,
                   fmt::format("Smooth the surface with N iterations of a non-shrinking filter, in the stream "
                               "(0 to {}; 20 is a common choice)",
                               kMaxSmoothIterations))
      ->check(integerIn(0, kMaxSmoothIterations))
      ->group(smoothGroup);
  extract
      ->add_option("--smooth-method", ex.smoothMethod,
                   "sinc (windowed sinc, as VTK's vtkWindowedSincPolyDataFilter and 3D Slicer) or taubin (lambda|mu)")
      ->transform(oneOf("smoothing method", {"sinc", "taubin"}))
      ->capture_default_str()
      ->group(smoothGroup);
  extract
      ->add_option("--pass-band", ex.passBand,
                   "The filter's pass band in (0, 2): lower smooths more (sinc's cut-off; Taubin's 1/lambda + 1/mu)")
      ->capture_default_str()
      ->group(smoothGroup);
  extract
      ->add_option("--smooth-faces", ex.smoothFaces,
                   "Vertices on the volume's faces: slide (stay within their faces) or lock (stay put)")
      ->transform(oneOf("face vertices", {"slide", "lock"}))
      ->capture_default_str()
      ->group(smoothGroup);
  extract
      ->add_option("--smooth-normals", ex.smoothNormals,
                   "With --normals: smoothed (from the smoothed mesh) or field (the field's gradient, as extracted)")
      ->transform(oneOf("smoothing normals", {"smoothed", "field"}))
      ->capture_default_str()
      ->group(smoothGroup);

  const std::string decimateGroup = "Decimation";
  extract
      ->add_option("--decimate", ex.decimate,
                   "Keep this fraction of the triangles, in (0, 1], by quadric-error edge collapses (meshoptimizer), "
                   "in the stream; the mesh stays closed and the chunks join")
      ->group(decimateGroup);
  extract
      ->add_option("--max-error", ex.maxError,
                   "Decimate as far as an error of E voxels allows (alone, or as a bound with --decimate)")
      ->group(decimateGroup);

  extract->add_option("--preview", ex.preview, "Also render the mesh to this PNG as it streams (memory: the image)")
      ->group("Preview");
  cli::addImageOptions(extract, ex.previewImage, "preview-", "Preview");

  std::string metricsInput;
  std::string metricsSphere;
  std::string metricsReport;
  auto* metrics =
      app.add_subcommand("metrics", "Measure a mesh file (.ply, .stl, .obj, .glb, .drc), optionally against a sphere");
  metrics->add_option("MESH", metricsInput, "Mesh file")->required();
  metrics->add_option("--sphere", metricsSphere, "cx,cy,cz,r: add the paper's radius, area and volume errors")
      ->check(sphereList());
  metrics->add_option("--report", metricsReport, "Write the JSON here instead of stdout");

  CompareArgs cmp;
  auto* compare = app.add_subcommand(
      "compare", "Run the paper's experiments: spheres51, paper (Tables 2 and 3), cubes or figures (its images)");
  compare->add_option("--suite", cmp.suite, "spheres51, paper, cubes or figures")
      ->transform(oneOf("suite", {"spheres51", "paper", "cubes", "figures"}))
      ->capture_default_str();
  compare->add_option("--out", cmp.out, "Output folder")->capture_default_str();
  compare->add_option("--radii", cmp.radii, "spheres51: radii to run, e.g. 5,10,20 (default: the 51 radii 0.1 .. 50.1)")
      ->check(numberList([](const std::vector<double>& radii) -> std::string {
        return std::all_of(radii.begin(), radii.end(), [](double r) { return r > 0; }) ? "" : "needs radii above 0";
      }));
  compare->add_option("--centre", cmp.centre, "spheres51: centre offset from a grid point (default 0.5,0.5,0.5)")
      ->check(numberList([](const std::vector<double>& c) { return c.size() == 3 ? "" : "needs three values"; }));
  compare->add_option("--methods", cmp.methods, "Methods to compare")
      ->transform(cli::listOf("method", methodNames()))
      ->capture_default_str();
  compare->add_option("--engine", cmp.engine, "paper: the engine CT (raw 256x256x128 u8, gzip allowed)");
  compare->add_option("--cthead", cmp.cthead, "paper and figures: the CThead slices folder (u16 big-endian)");
  compare
      ->add_option("--smooth", cmp.smooth,
                   "spheres51: also run each method with extract's --smooth N (rows named method+sincN or +taubinN)")
      ->check(integerIn(0, kMaxSmoothIterations));
  compare->add_option("--smooth-method", cmp.smoothMethod, "spheres51: sinc or taubin, for --smooth")
      ->transform(oneOf("smoothing method", {"sinc", "taubin"}))
      ->capture_default_str();
  compare->add_flag("!--no-charts", cmp.charts, "spheres51: skip the PNG charts");
  compare->add_flag("-q,--quiet", cmp.quiet, "No notes on stderr");

  std::string decodeInput;
  std::string decodeOutput;
  auto* decode = app.add_subcommand("decode", "Decode a .glb or .drc mesh (welding chunk seams) to .ply, .stl or .obj");
  decode->add_option("INPUT", decodeInput, "A .glb written by isoslab (Draco chunks) or a .drc")->required();
  decode->add_option("-o,--output", decodeOutput, "Output mesh: .ply, .stl or .obj")->required();
  std::string renderInput;
  std::string renderOutput;
  cli::ImageArgs renderImage;
  auto* renderCmd = app.add_subcommand("render", "Render a mesh file (.ply, .stl, .obj, .glb, .drc) to a PNG image");
  renderCmd->add_option("MESH", renderInput, "Mesh file")->required();
  renderCmd->add_option("-o,--output", renderOutput, "Output image (.png)")->required();
  cli::addImageOptions(renderCmd, renderImage, "", "Image");
  renderCmd->add_flag("--chunk-colours", renderImage.chunkColours, ".glb: a colour per chunk, to show the seams")
      ->group("Image");

  std::string viewInput;
  std::string viewReport;
  std::string viewPage;
  auto* viewCmd =
      app.add_subcommand("view", "Write a self-contained HTML viewer page for a .glb (three.js, works from file://)");
  viewCmd->add_option("GLB", viewInput, "A .glb written by isoslab")->required();
  viewCmd->add_option("--report", viewReport, "The extraction's JSON report, whose numbers the page shows");
  viewCmd->add_option("-o,--output", viewPage, "The page (default: the .glb's path with .html)");

  addRawOptions(extract, ex.raw);

  cli::BatchArgs bx;
  auto* batch = app.add_subcommand(
      "batch",
      "Extract many inputs, one per line of LIST, each to OUT/NAME.FORMAT with OUT/NAME.json (also under mpirun)");
  batch
      ->add_option("LIST", bx.list,
                   "A text file: one input per line; blank lines and lines starting with # are skipped")
      ->required();
  batch->add_option("EXTRACT_OPTIONS", bx.extract,
                    "After --: options for every isoslab extract, e.g. -- --iso 300 --method mt6");
  batch->add_option("--out", bx.out, "Folder for the meshes, their reports and batch.json (created)")->required();
  batch->add_option("--format", bx.format, "The meshes' format: glb, drc, ply, stl or obj")
      ->transform(oneOf("format", {"glb", "drc", "ply", "stl", "obj"}))
      ->capture_default_str();
  batch->add_option("--jobs", bx.jobs, "Extractions at once (per rank under mpirun)")
      ->check(integerIn(1, 256))
      ->capture_default_str();
  batch->add_flag("-q,--quiet", bx.quiet, "No summary table on stdout");

  std::vector<std::string> infoInputs;
  RawArgs infoRaw;
  auto* info = app.add_subcommand("info", "Print a volume's geometry and value range; list DICOM series");
  info->add_option("INPUT", infoInputs, "Volume")->required();
  bool infoHistogram = false;
  std::size_t infoBins = kAutoIsoBins;
  auto* histogramFlag = info->add_flag(
      "--histogram", infoHistogram,
      "Also count the values in equal bins over their range (streamed; NaN and infinities apart) and print "
      "Otsu's threshold");
  info->add_option("--bins", infoBins, "--histogram: the number of bins")
      ->check(integerIn(1, kMaxHistogramBins))
      ->needs(histogramFlag)
      ->capture_default_str();
  addRawOptions(info, infoRaw);

  std::string phantomSpec;
  std::string phantomOut;
  auto* phantom = app.add_subcommand(
      "phantom", "Write a phantom to a volume file: .nii, .nii.gz, .nrrd, .mha, or raw voxels for any other name");
  phantom->add_option("SPEC", phantomSpec, "phantom:NAME?key=value&...")->required();
  bool phantomCompress = false;
  phantom
      ->add_option("-o,--output", phantomOut,
                   "Output volume: .nii, .nii.gz, .nrrd, .mha, or raw voxels for any other name")
      ->required();
  phantom->add_flag("--compress", phantomCompress, "NRRD and MetaImage: deflate the data");

  // No command: the usage, on stderr as for any usage error.
  if (argc < 2) {
    std::fputs(app.help().c_str(), stderr);
    return 2;
  }
  // The command is the first argument (isoslab itself has only --help and --version).
  const std::vector<CLI::App*> commands = app.get_subcommands([](CLI::App*) { return true; });
  if (argv[1][0] != '-' &&
      std::none_of(commands.begin(), commands.end(), [&](CLI::App* c) { return c->check_name(argv[1]); })) {
    const std::string typed = argv[1];
    std::string nearest;
    std::size_t distance = std::numeric_limits<std::size_t>::max();
    std::vector<std::string> names;
    for (const CLI::App* sub : commands) {
      names.push_back(sub->get_name());
      const std::size_t d = editDistance(typed, sub->get_name());
      if (d < distance) {
        distance = d;
        nearest = sub->get_name();
      }
    }
    if (distance <= std::max<std::size_t>(2, typed.size() / 3)) {
      std::fprintf(stderr, "isoslab: error: unknown command '%s'; did you mean '%s'?\n", typed.c_str(),
                   nearest.c_str());
    } else {
      std::fprintf(stderr, "isoslab: error: unknown command '%s' (use %s)\n", typed.c_str(),
                   alternatives(names).c_str());
    }
    return 2;
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ValidationError& e) {
    printError(e.what());  // the message lists the choices
    return 2;
  } catch (const CLI::ParseError& e) {
    const auto parsed = app.get_subcommands();
    const std::string help = parsed.empty() ? "isoslab --help" : "isoslab " + parsed.back()->get_name() + " --help";
    printError(fmt::format("{} (see {})", e.what(), help));
    return 2;
  }

  // Under mpirun, extract joins the other ranks (MPI is finalised when `ranks` goes).
  std::unique_ptr<RankGroup> ranks;
  try {
    if (*extract || *batch) {
      ranks = cli::joinRanks();
      gRanks = ranks.get();
    }
    if (*extract) return runExtract(ex);
    if (*batch) return cli::runBatch(bx, gRanks != nullptr && gRanks->size() > 1 ? gRanks : nullptr);
    if (*info) return runInfo(infoInputs, infoRaw, infoHistogram ? infoBins : 0);
    if (*phantom) return runPhantom(phantomSpec, phantomOut, phantomCompress);
    if (*decode) return runDecode(decodeInput, decodeOutput);
    if (*renderCmd) return cli::runRender(renderInput, renderOutput, renderImage);
    if (*viewCmd) return cli::runView(viewInput, viewReport, viewPage);
    if (*metrics) return runMetrics(metricsInput, metricsSphere, metricsReport);
    if (*compare) return runCompare(cmp);
  } catch (const RankFailed&) {
    return 1;  // the rank that failed, or rank 0, printed why
  } catch (const UsageError& e) {
    if (reportsFailure()) printError(e.what());
    return 2;
  } catch (const Interrupted& e) {
    // Under mpirun the other ranks may be waiting for this one: stop them all.
    if (gRanks != nullptr && gRanks->size() > 1 && !gRanks->failureShared()) {
      if (gRanks->rank() == 0) {
        std::fprintf(stderr, "%sisoslab: interrupted by SIG%s\n", progressLineShown() ? "\n" : "",
                     sigabbrev_np(e.signal()));
      }
      gRanks->abort(128 + e.signal());
    }
    // Unwinding has joined the threads and removed every temporary file.
    // One line, after the progress line if one is still on the terminal (unwinding clears it).
    std::fprintf(stderr, "%sisoslab: interrupted by SIG%s\n", progressLineShown() ? "\n" : "",
                 sigabbrev_np(e.signal()));
    return 128 + e.signal();
  } catch (const Error& e) {
    if (reportsFailure()) printError(e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    if (reportsFailure()) std::fprintf(stderr, "isoslab: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    if (reportsFailure()) printError(e.what());
    return 1;
  }
  return 0;
}
