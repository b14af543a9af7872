// The isoslab program: extract, info and phantom. Library errors (isoslab::Error) become one line
// on stderr, "isoslab: error: ...", and exit status 1; usage errors exit with 2.
#include <fmt/format.h>
#include <signal.h>
#include <CLI/CLI.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "encode/mesh_writer.h"
#include "extract/extractor.h"
#include "extract/frame.h"
#include "extract/mesh_stats.h"
#include "io/atomic_file.h"
#include "io/error.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "stream/pipeline.h"
#include "stream/progress.h"

namespace isoslab {
namespace {

constexpr const char* kVersion = "0.1.0";

struct RawArgs {
  std::string dims;
  std::string type = "u8";
  std::string endian = "little";
  std::int64_t offset = 0;
  std::string spacing;
};

void addRawOptions(CLI::App* cmd, RawArgs& raw) {
  cmd->add_option("--raw-dims", raw.dims, "Raw input: lattice points X,Y,Z (Z may be left out for per-slice files)")
      ->group("Raw input");
  cmd->add_option("--raw-type", raw.type, "Raw input: voxel type u8 i8 u16 i16 u32 i32 f32 f64")
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-endian", raw.endian, "Raw input: byte order, little or big")
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--raw-offset", raw.offset, "Raw input: header bytes to skip in each file")
      ->group("Raw input")
      ->capture_default_str();
  cmd->add_option("--spacing", raw.spacing, "Voxel spacing sx,sy,sz (raw input; default 1,1,1)")->group("Raw input");
}

std::vector<double> parseList(const std::string& text, const std::string& option) {
  std::vector<double> values;
  std::size_t start = 0;
  while (start <= text.size()) {
    const std::size_t comma = text.find(',', start);
    const std::string item = text.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || end != item.c_str() + item.size() || !std::isfinite(v)) {
      throw Error(fmt::format("{}: '{}' is not a comma-separated list of numbers", option, text));
    }
    values.push_back(v);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return values;
}

SourceOptions sourceOptions(const RawArgs& raw) {
  SourceOptions options;
  if (raw.dims.empty()) {
    if (!raw.spacing.empty()) throw Error("--spacing: only raw input takes a spacing here; give --raw-dims too");
    return options;
  }
  RawOptions r;
  const auto dims = parseList(raw.dims, "--raw-dims");
  if (dims.size() != 2 && dims.size() != 3) throw Error(fmt::format("--raw-dims: '{}' needs X,Y or X,Y,Z", raw.dims));
  for (std::size_t a = 0; a < dims.size(); ++a) {
    if (dims[a] != std::floor(dims[a]) || dims[a] < -9.0e18 || dims[a] > 9.0e18) {
      throw Error(fmt::format("--raw-dims: '{}' must hold whole numbers", raw.dims));
    }
    r.dims[a] = static_cast<std::int64_t>(dims[a]);
  }
  const auto type = parseVoxelType(raw.type);
  if (!type)
    throw Error(fmt::format("--raw-type: unknown voxel type '{}' (use u8 i8 u16 i16 u32 i32 f32 f64)", raw.type));
  r.type = *type;
  if (raw.endian == "little") {
    r.byteOrder = ByteOrder::kLittle;
  } else if (raw.endian == "big") {
    r.byteOrder = ByteOrder::kBig;
  } else {
    throw Error(fmt::format("--raw-endian: '{}' must be 'little' or 'big'", raw.endian));
  }
  r.headerBytes = raw.offset;
  if (!raw.spacing.empty()) {
    const auto s = parseList(raw.spacing, "--spacing");
    if (s.size() != 3) throw Error(fmt::format("--spacing: '{}' needs three values", raw.spacing));
    r.spacing = {s[0], s[1], s[2]};
  }
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

struct ExtractArgs {
  std::string input;
  std::optional<double> iso;
  std::string method = "mc";
  std::string output;
  bool normals = false;
  std::string report;
  bool quiet = false;
  RawArgs raw;
};

int runExtract(const ExtractArgs& args) {
  const auto method = parseMethod(args.method);
  if (!method) throw Error(fmt::format("--method: unknown method '{}' (use mc, mt5, mt6 or bcc12)", args.method));
  auto writer = makeMeshWriter(args.output);
  auto source = openSource(args.input, sourceOptions(args.raw));
  const VolumeInfo& info = source->info();
  double iso = 0;
  if (args.iso) {
    iso = *args.iso;
  } else if (info.suggestedIso) {
    iso = *info.suggestedIso;
  } else {
    throw Error(fmt::format("{}: --iso is required for this input", args.input));
  }

  const LatticeFrame frame = LatticeFrame::physical(info);
  ExtractOptions options;
  options.method = *method;
  options.iso = iso;
  options.normals = args.normals;
  auto extractor = makeExtractor(options, info, frame);

  MeshHeader header;
  header.normals = args.normals;
  header.method = std::string(methodName(*method));
  header.iso = iso;
  header.space = frame.name();
  header.cellVolumes = extractor->cellVolumes();
  {
    const auto lo = frame.map(0, 0, 0);
    const auto hi = frame.map(static_cast<double>(info.dims[0] - 1), static_cast<double>(info.dims[1] - 1),
                              static_cast<double>(info.dims[2] - 1));
    for (int a = 0; a < 3; ++a) {
      header.volumeBounds[static_cast<std::size_t>(a)] =
          std::min(lo[static_cast<std::size_t>(a)], hi[static_cast<std::size_t>(a)]);
      header.volumeBounds[static_cast<std::size_t>(a + 3)] =
          std::max(lo[static_cast<std::size_t>(a)], hi[static_cast<std::size_t>(a)]);
    }
  }

  MeshStatsSink stats;
  TeeSink tee({writer.get(), &stats});
  PipelineOptions pipelineOptions;
  pipelineOptions.progress = !args.quiet;
  const PipelineResult run = runPipeline(*source, *extractor, tee, header, pipelineOptions);
  const MeshStats& s = stats.stats();

  if (!args.report.empty()) {
    nlohmann::ordered_json r;
    r["generator"] = fmt::format("isoslab {}", kVersion);
    r["input"] = args.input;
    r["reader"] = info.reader;
    r["method"] = header.method;
    r["iso"] = iso;
    r["dims"] = {info.dims[0], info.dims[1], info.dims[2]};
    r["spacing"] = array3(info.spacing);
    r["voxel_type"] = std::string(voxelTypeName(info.type));
    r["space"] = header.space;
    r["normals"] = args.normals;
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
    r["seconds"] = {{"read", run.readSeconds},
                    {"extract", run.extractSeconds},
                    {"write", run.writeSeconds},
                    {"total", run.totalSeconds}};
    r["ring_bytes"] = run.ringBytes;
    r["peak_rss_mib"] = peakRssMib();
    r["output"] = {{"path", args.output}, {"bytes", writer->bytes()}};
    writeText(args.report, r.dump(2) + "\n");
  }
  if (!args.quiet) {
    std::fprintf(stderr, "isoslab: %s at iso %g%s: %llu triangles, %llu vertices, %s, %.2f s -> %s\n",
                 header.method.c_str(), iso, args.iso ? "" : " (the input's suggestion)",
                 static_cast<unsigned long long>(s.triangles), static_cast<unsigned long long>(s.vertices),
                 s.closed() ? "closed" : fmt::format("{} boundary edges", s.boundaryEdges).c_str(), run.totalSeconds,
                 args.output.c_str());
  }
  return 0;
}

int runInfo(const std::string& input, const RawArgs& raw) {
  auto source = openSource(input, sourceOptions(raw));
  const VolumeInfo& info = source->info();
  std::vector<float> slice(static_cast<std::size_t>(info.sliceVoxels()));
  double lo = std::numeric_limits<double>::infinity();
  double hi = -lo;
  std::int64_t slices = 0;
  while (source->readSlice(slice)) {
    for (float v : slice) {
      lo = std::min(lo, static_cast<double>(v));
      hi = std::max(hi, static_cast<double>(v));
    }
    ++slices;
  }
  const auto& d = info.direction;
  std::printf("input      %s\n", input.c_str());
  std::printf("reader     %s\n", info.reader.c_str());
  std::printf("dims       %lld x %lld x %lld\n", static_cast<long long>(info.dims[0]),
              static_cast<long long>(info.dims[1]), static_cast<long long>(info.dims[2]));
  std::printf("type       %s\n", std::string(voxelTypeName(info.type)).c_str());
  std::printf("spacing    %g %g %g\n", info.spacing[0], info.spacing[1], info.spacing[2]);
  std::printf("origin     %g %g %g\n", info.origin[0], info.origin[1], info.origin[2]);
  std::printf("direction  %g %g %g  %g %g %g  %g %g %g\n", d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8]);
  std::printf("range      %g .. %g\n", lo, hi);
  if (info.suggestedIso) std::printf("iso        %g (suggested)\n", *info.suggestedIso);
  (void)slices;
  return 0;
}

int runPhantom(const std::string& spec, const std::string& output) {
  if (!PhantomSource::isPhantom(spec))
    throw Error(fmt::format("{}: not a phantom spec (phantom:NAME?key=value&...)", spec));
  auto source = PhantomSource::open(spec);
  const VolumeInfo& info = source->info();
  const std::int64_t bytes = writeRaw(*source, output, info.type);
  std::printf("%s: %lld bytes; read it back with --raw-dims %lld,%lld,%lld --raw-type %s --spacing %g,%g,%g\n",
              output.c_str(), static_cast<long long>(bytes), static_cast<long long>(info.dims[0]),
              static_cast<long long>(info.dims[1]), static_cast<long long>(info.dims[2]),
              std::string(voxelTypeName(info.type)).c_str(), info.spacing[0], info.spacing[1], info.spacing[2]);
  return 0;
}

}  // namespace
}  // namespace isoslab

int main(int argc, char** argv) {
  using namespace isoslab;
  // A file-size limit then fails the write with EFBIG, reported like any write error.
  ::signal(SIGXFSZ, SIG_IGN);
  CLI::App app{"isoslab: streaming iso-surface extraction from volumetric scanner data"};
  app.require_subcommand(1);
  app.set_version_flag("--version", kVersion);

  ExtractArgs ex;
  auto* extract = app.add_subcommand("extract", "Extract an iso-surface mesh from a volume");
  extract->add_option("INPUT", ex.input, "Volume: a raw file, pattern or folder, or phantom:NAME?key=value&...")
      ->required();
  extract->add_option("--iso", ex.iso,
                      "Iso value; voxels with value >= iso are inside (default: the input's suggestion, for phantoms)");
  extract->add_option("--method", ex.method, "mc, mt5, mt6 or bcc12")->capture_default_str();
  extract->add_option("-o,--output", ex.output, "Output mesh: .ply (binary) or .stl (binary)")->required();
  extract->add_flag("--normals", ex.normals, "Write vertex normals from the field's gradient (PLY)");
  extract->add_option("--report", ex.report, "Write a JSON report of the run");
  extract->add_flag("-q,--quiet", ex.quiet, "No progress line and no summary on stderr");
  addRawOptions(extract, ex.raw);

  std::string infoInput;
  RawArgs infoRaw;
  auto* info = app.add_subcommand("info", "Print a volume's geometry and value range");
  info->add_option("INPUT", infoInput, "Volume")->required();
  addRawOptions(info, infoRaw);

  std::string phantomSpec;
  std::string phantomOut;
  auto* phantom = app.add_subcommand("phantom", "Write a phantom to a raw file");
  phantom->add_option("SPEC", phantomSpec, "phantom:NAME?key=value&...")->required();
  phantom->add_option("-o,--output", phantomOut, "Raw output file")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::fprintf(stderr, "isoslab: error: %s (see isoslab --help)\n", e.what());
    return 2;
  }

  try {
    if (*extract) return runExtract(ex);
    if (*info) return runInfo(infoInput, infoRaw);
    if (*phantom) return runPhantom(phantomSpec, phantomOut);
  } catch (const Error& e) {
    std::fprintf(stderr, "isoslab: error: %s\n", e.what());
    return 1;
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "isoslab: error: out of memory\n");
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "isoslab: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
