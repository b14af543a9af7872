// The precision and speed study of V. Skala and A. Brus, "Two methods for iso-surface extraction
// from volumetric data and their comparison": their 51-sphere suite, their Tables 2 and 3, and
// their appendix cubes.
#include "cli/compare.h"

#include "cli/arguments.h"

#include <fmt/format.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <numbers>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "extract/extractor.h"
#include "io/open_source.h"
#include "io/phantom.h"
#include "metrics/measure.h"
#include "process/smoothing.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

std::vector<Method> methodsOf(const std::string& text) {
  std::vector<Method> methods;
  std::stringstream s(text);
  std::string item;
  while (std::getline(s, item, ',')) {
    const auto m = parseMethod(item);
    if (!m) throw Error(fmt::format("--methods: unknown method '{}' (use {})", item, fmt::join(methodNames(), ", ")));
    methods.push_back(*m);
  }
  return methods;
}

void writeFile(const std::string& path, const std::string& text) {
  AtomicFile f(path);
  f.write(text.data(), text.size());
  f.commit();
}

std::string num(double v) {
  return std::isfinite(v) ? fmt::format("{:.9g}", v) : "nan";
}

// --- spheres51 ---------------------------------------------------------------------------------

int runSpheres(const CompareArgs& args) {
  std::vector<double> radii;
  if (args.radii.empty()) {
    for (int k = 0; k <= 50; ++k) radii.push_back((1.0 + 10.0 * k) / 10.0);
  } else {
    radii = cli::parseList(args.radii, "--radii");
  }
  std::array<double, 3> offset{0.5, 0.5, 0.5};
  if (!args.centre.empty()) {
    const auto c = cli::parseList(args.centre, "--centre");
    if (c.size() != 3) throw Error(fmt::format("--centre: '{}' needs three values", args.centre));
    offset = {c[0], c[1], c[2]};
  }
  const auto methods = methodsOf(args.methods);
  // Each method, and with --smooth each method smoothed too.
  std::vector<std::pair<Method, bool>> runs;
  for (Method m : methods) {
    runs.emplace_back(m, false);
    if (args.smooth > 0) runs.emplace_back(m, true);
  }
  SmoothOptions smoothOptions;
  smoothOptions.iterations = args.smooth;
  smoothOptions.method = args.smoothMethod == "taubin" ? SmoothMethod::kTaubin : SmoothMethod::kSinc;
  std::string csv =
      "method,field,radius,n,iso,triangles,vertices,seconds,"
      "vertex_error_sum,vertex_error_sum_per_triangle,vertex_error_mean,vertex_error_mean_abs,vertex_error_rms,"
      "vertex_error_max_abs,centroid_error_sum,centroid_error_sum_per_triangle,centroid_error_mean,"
      "centroid_error_mean_abs,centroid_error_rms,centroid_error_max_abs,area_error,volume_error,volume_cells_error,"
      "closed,euler\n";
  struct Totals {
    double area = 0, volume = 0, vertex = 0, centroid = 0, seconds = 0;
    std::uint64_t triangles = 0;
    int runs = 0;
  };
  std::map<std::pair<std::string, std::string>, Totals> totals;  // (field, method)
  const auto start = std::chrono::steady_clock::now();
  for (const char* field : {"binary", "distance"}) {
    for (double r : radii) {
      // The smallest grid with at least two voxels between the sphere and the border.
      const auto n = static_cast<std::int64_t>(2 * std::ceil(r) + 7);
      const double c0 = static_cast<double>(n / 2);
      const std::string spec = fmt::format("phantom:sphere?n={}&r={}&c={},{},{}&field={}", n, r, c0 + offset[0],
                                           c0 + offset[1], c0 + offset[2], field);
      const double iso = std::string(field) == "binary" ? 50.0 : 1000.0 - 10.0 * r;
      for (const auto& [m, smooth] : runs) {
        auto source = PhantomSource::open(spec);
        ExtractOptions o;
        o.method = m;
        o.iso = iso;
        std::optional<SmoothingSink> smoothing;
        SinkWrapper through;
        if (smooth) {
          through = [&](MeshSink& into) -> MeshSink& { return smoothing.emplace(into, smoothOptions); };
        }
        const Measurement x = measureExtraction(*source, o, phantomSphere(source->info()), {}, through);
        const std::string label =
            smooth ? fmt::format("{}+{}{}", methodName(m), args.smoothMethod, args.smooth) : std::string(methodName(m));
        const SphereReport& s = *x.sphere;
        const double t = static_cast<double>(s.triangles);
        const auto& v = s.vertex;
        const auto& g = s.centroid;
        const bool empty = s.triangles == 0;
        auto val = [empty](double d) { return empty ? std::nan("") : d; };
        csv += fmt::format("{},{},{},{},{},{},{},{},", label, field, r, n, iso, s.triangles, s.vertices,
                           num(x.run.totalSeconds));
        csv += fmt::format("{},{},{},{},{},{},", num(val(v.sum)), num(val(v.sum / t)), num(val(v.mean())),
                           num(val(v.meanAbs())), num(val(v.rms())), num(val(v.maxAbs)));
        csv += fmt::format("{},{},{},{},{},{},", num(val(g.sum)), num(val(g.sum / t)), num(val(g.mean())),
                           num(val(g.meanAbs())), num(val(g.rms())), num(val(g.maxAbs)));
        csv += fmt::format("{},{},{},{},{}\n", num(val(s.areaError)), num(val(s.volumeError)),
                           s.volumeCellsError ? num(val(*s.volumeCellsError)) : "", x.stats.closed() ? 1 : 0,
                           x.stats.euler);
        if (!empty && r >= 5) {
          Totals& tot = totals[{field, label}];
          tot.area += std::abs(s.areaError);
          tot.volume += std::abs(s.volumeError);
          tot.vertex += v.meanAbs();
          tot.centroid += g.meanAbs();
          tot.seconds += x.run.totalSeconds;
          tot.triangles += s.triangles;
          ++tot.runs;
        }
      }
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  throwIfInterrupted();  // the runs polled; nothing is written after a stop
  makeOutputFolder(args.out);
  const std::string csvPath = args.out + "/results.csv";
  writeFile(csvPath, csv);

  std::string md = "# spheres51: precision of the methods on analytic spheres\n\n";
  md += fmt::format(
      "{} radii ({} .. {} voxels), centres offset by ({}, {}, {}) from a grid point, grids with at least 2 "
      "voxels of margin; fields `binary` (100 inside, 0 outside, iso 50) and `distance` (1000 - 10 |p - c|, "
      "iso 1000 - 10 r). Run time {:.1f} s. Every measure is relative: (measured - true) / true.\n\n",
      radii.size(), radii.front(), radii.back(), offset[0], offset[1], offset[2], seconds);
  md += "Means over the radii of at least 5 voxels:\n\n";
  md +=
      "| field | method | triangles | mean \\|vertex radius error\\| | mean \\|centroid radius error\\| | mean \\|area "
      "error\\| | "
      "mean \\|volume error\\| | seconds |\n|---|---|---|---|---|---|---|---|\n";
  for (const auto& [key, t] : totals) {
    if (t.runs == 0) continue;
    md +=
        fmt::format("| {} | {} | {} | {:.3e} | {:.3e} | {:.3e} | {:.3e} | {:.2f} |\n", key.first, key.second,
                    t.triangles, t.vertex / t.runs, t.centroid / t.runs, t.area / t.runs, t.volume / t.runs, t.seconds);
  }
  md +=
      "\nCharts (`chart1_triangles.png` .. `chart7_volume_error.png`) mirror the paper's Charts 1-7; "
      "`results.csv` holds every metric of every run.\n";
  writeFile(args.out + "/summary.md", md);
  if (!args.quiet)
    std::fprintf(stderr, "isoslab: spheres51: %zu rows in %.1f s -> %s\n", radii.size() * 2 * methods.size(), seconds,
                 csvPath.c_str());
  if (args.charts) {
    try {
      drawCharts(csvPath, args.out, args.quiet);
    } catch (const Interrupted&) {
      // Stopped while drawing: the results go too, so that nothing of the run is left.
      std::error_code ec;
      fs::remove(csvPath, ec);
      fs::remove(args.out + "/summary.md", ec);
      throw;
    }
  }
  return 0;
}

// --- paper: Tables 2 and 3 ---------------------------------------------------------------------

struct Dataset {
  std::string name;
  std::string input;
  SourceOptions options;
  double iso = 0;
  std::string note;
};

Dataset dataset(std::string name, std::string input, double iso, std::string note) {
  Dataset d;
  d.name = std::move(name);
  d.input = std::move(input);
  d.iso = iso;
  d.note = std::move(note);
  return d;
}

double readSeconds(const Dataset& d) {
  auto source = openSource(d.input, d.options);
  std::vector<float> slice;
  const auto start = std::chrono::steady_clock::now();
  while (readSliceInto(*source, slice)) {
  }
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int runPaper(const CompareArgs& args) {
  std::vector<Dataset> sets;
  sets.push_back(dataset("Syn 64", "phantom:head?n=64&seed=64", -400,
                         "64^3 head phantom (air, skin, skull, brain, noise 20), iso -400"));
  if (!args.engine.empty()) {
    Dataset d = dataset("Engine", args.engine, 90, "engine CT, 256x256x128 u8, iso 90");
    d.options.raw = RawOptions{};
    d.options.raw->dims = {256, 256, 128};
    sets.push_back(d);
  } else {
    sets.push_back(dataset("Engine (phantom)", "phantom:torus?n=256,256,110&R=80&r=30&field=binary", 50,
                           "no --engine given: binary torus in 256x256x110, iso 50"));
  }
  if (!args.cthead.empty()) {
    Dataset d = dataset("CThead", args.cthead, 600, "UNC CT head, 256x256x113 u16 big-endian, iso 600");
    d.options.raw = RawOptions{};
    d.options.raw->dims = {256, 256, 0};
    d.options.raw->type = VoxelType::kU16;
    d.options.raw->byteOrder = ByteOrder::kBig;
    d.options.raw->spacing = {1, 1, 2};
    sets.push_back(d);
  } else {
    sets.push_back(dataset("3dhead (phantom)", "phantom:head?n=256,256,109", -400,
                           "no --cthead given: head phantom 256x256x109, iso -400"));
  }
  const auto methods = methodsOf(args.methods);
  std::string csv =
      "dataset,method,triangles,seconds,constant_seconds,read_seconds,triangle_ratio_to_mt6,time_ratio_to_mt6\n";
  std::string md = "# paper: the counterparts of the paper's Tables 2 and 3\n\n";
  for (const Dataset& d : sets) md += fmt::format("- **{}**: {} (`{}`)\n", d.name, d.note, d.input);
  md +=
      "- **51Sphere**: see `isoslab compare --suite spheres51`.\n\nTimes are extraction runs, single-threaded, "
      "including reading; the constant time is the same run with an iso above every value, so no cell is handled.\n\n"
      "| data | method | triangles | seconds | constant s | read s | triangles / mt6 | time / mt6 |\n"
      "|---|---|---|---|---|---|---|---|\n";
  for (const Dataset& d : sets) {
    struct Row {
      Method m;
      std::uint64_t triangles;
      double seconds, constant;
    };
    std::vector<Row> rows;
    for (Method m : methods) {
      ExtractOptions o;
      o.method = m;
      o.iso = d.iso;
      auto source = openSource(d.input, d.options);
      const Measurement x = measureExtraction(*source, o, std::nullopt);
      o.iso = 1e30;
      auto again = openSource(d.input, d.options);
      const Measurement none = measureExtraction(*again, o, std::nullopt);
      rows.push_back({m, x.stats.triangles, x.run.totalSeconds, none.run.totalSeconds});
    }
    const double read = readSeconds(d);
    const Row* mt6 = nullptr;
    for (const Row& r : rows) {
      if (r.m == Method::kTetra6) mt6 = &r;
    }
    for (const Row& r : rows) {
      const double tr = mt6 ? static_cast<double>(r.triangles) / static_cast<double>(mt6->triangles) : std::nan("");
      const double sr = mt6 ? r.seconds / mt6->seconds : std::nan("");
      csv += fmt::format("{},{},{},{},{},{},{},{}\n", d.name, methodName(r.m), r.triangles, num(r.seconds),
                         num(r.constant), num(read), num(tr), num(sr));
      md += fmt::format("| {} | {} | {} | {:.3f} | {:.3f} | {:.3f} | {:.2f} | {:.2f} |\n", d.name, methodName(r.m),
                        r.triangles, r.seconds, r.constant, read, tr, sr);
    }
  }
  throwIfInterrupted();  // the runs polled; nothing is written after a stop
  makeOutputFolder(args.out);
  writeFile(args.out + "/paper.csv", csv);
  writeFile(args.out + "/paper.md", md);
  if (!args.quiet) std::fprintf(stderr, "isoslab: paper: -> %s/paper.md\n", args.out.c_str());
  return 0;
}

// --- cubes: the appendix ------------------------------------------------------------------------

int runCubes(const CompareArgs& args) {
  const auto methods = methodsOf(args.methods);
  std::string csv = "edge,iso,method,triangles,true_edge,area_error,volume_error,closed\n";
  std::string md =
      "# cubes: the paper's appendix cubes\n\nBinary cubes of L inside lattice points per edge (100 inside, 0 "
      "outside). "
      "The true surface is the cube of edge L (from -0.5 to L-0.5) at iso 50, and of edge L-1 (through the outermost "
      "inside points) at iso 100.\n\n| edge | iso | method | triangles | area error | volume error "
      "|\n|---|---|---|---|---|---|\n";
  for (int edge : {2, 6, 80}) {
    for (double iso : {100.0, 50.0}) {
      const int n = edge + 6;
      const std::string spec = fmt::format("phantom:box?n={}&lo=3,3,3&hi={},{},{}", n, edge + 2, edge + 2, edge + 2);
      const double trueEdge = iso == 50.0 ? edge : edge - 1;
      for (Method m : methods) {
        auto source = PhantomSource::open(spec);
        ExtractOptions o;
        o.method = m;
        o.iso = iso;
        const Measurement x = measureExtraction(*source, o, std::nullopt);
        const double area = 6 * trueEdge * trueEdge;
        const double volume = trueEdge * trueEdge * trueEdge;
        const double ae = (x.stats.area - area) / area;
        const double ve = (x.stats.volume - volume) / volume;
        csv += fmt::format("{},{},{},{},{},{},{},{}\n", edge, iso, methodName(m), x.stats.triangles, trueEdge, num(ae),
                           num(ve), x.stats.closed() ? 1 : 0);
        md += fmt::format("| {} | {} | {} | {} | {:+.4f} | {:+.4f} |\n", edge, iso, methodName(m), x.stats.triangles,
                          ae, ve);
      }
    }
  }
  throwIfInterrupted();  // the runs polled; nothing is written after a stop
  makeOutputFolder(args.out);
  writeFile(args.out + "/cubes.csv", csv);
  writeFile(args.out + "/cubes.md", md);
  if (!args.quiet) std::fprintf(stderr, "isoslab: cubes: -> %s/cubes.md\n", args.out.c_str());
  return 0;
}

}  // namespace

int runCompare(const CompareArgs& args) {
  if (args.suite != "spheres51" && args.suite != "paper" && args.suite != "cubes" && args.suite != "figures") {
    throw Error(fmt::format("--suite: unknown suite '{}' (use spheres51, paper, cubes or figures)", args.suite));
  }
  std::error_code ec;
  const bool outExisted = fs::exists(args.out, ec);
  makeOutputFolder(args.out);  // before the runs, which take minutes
  try {
    if (args.suite == "spheres51") return runSpheres(args);
    if (args.suite == "paper") return runPaper(args);
    if (args.suite == "cubes") return runCubes(args);
    return runFigures(args, methodsOf(args.methods));
  } catch (...) {
    // Interrupted or failed: the suites write their files at the end (figures through a
    // CommitGroup), and a folder this run made goes too, when nothing is in it.
    if (!outExisted) fs::remove(args.out, ec);
    throw;
  }
}

}  // namespace isoslab
