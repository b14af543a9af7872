// The isoslab program: extract, info and phantom. Library errors (isoslab::Error) become one line
// on stderr, "isoslab: error: ...", and exit status 1; usage errors (CLI11's, and UsageError)
// exit with 2. Warnings ("isoslab: warning: ...") print even with --quiet, as compilers' do.
// The program parses its options and calls the library: extract runs the job of job/extract_job.h.
#include <fmt/format.h>
#include <signal.h>
#include <sys/resource.h>
#include <time.h>
#if defined(__GLIBC__)
#include <malloc.h>
#endif
#include <CLI/CLI.hpp>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "cli/arguments.h"
#include "cli/batch.h"
#include "cli/commands.h"
#include "cli/compare.h"
#include "cli/extract_command.h"
#include "cli/mpi_group.h"
#include "cli/render.h"
#include "cli/source_options.h"
#include "cli/view.h"
#include "core/error.h"
#include "core/interrupt.h"
#include "extract/extractor.h"
#include "process/smoothing.h"
#include "stream/progress.h"
#include "stream/rank_group.h"
#include "stream/value_histogram.h"

namespace isoslab {
namespace {

using cli::alternatives;
using cli::integerIn;
using cli::numberList;
using cli::oneOf;
using cli::UsageError;
using isoslab::editDistance;

constexpr const char* kVersion = ISOSLAB_VERSION;
/// info --bins: 2^24 bins are 128 MiB of counts.
constexpr std::int64_t kMaxHistogramBins = std::int64_t{1} << 24;

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
  // Buffers of a slab, a chunk or a decimation batch come and go with the stream. glibc raises
  // its mmap threshold to the largest buffer freed, after which such buffers come from the heap,
  // whose freed space stays in the process: on the 36-million-triangle foam that added a third to
  // the peak (docs/performance.md). A fixed threshold maps each large buffer and unmaps it when
  // freed.
  ::mallopt(M_MMAP_THRESHOLD, 256 * 1024);
#endif
  // A file-size limit then fails the write with EFBIG, reported like any write error.
  ::signal(SIGXFSZ, SIG_IGN);
  // A pattern output of label surfaces keeps two descriptors a label open until the run commits
  // (the file and its spool): an atlas of 1000 labels passes the usual soft limit of 1024, so the
  // soft limit goes up to the hard one, as far as the system allows.
  if (struct rlimit files{}; ::getrlimit(RLIMIT_NOFILE, &files) == 0 && files.rlim_cur < files.rlim_max) {
    files.rlim_cur = files.rlim_max;
    ::setrlimit(RLIMIT_NOFILE, &files);
  }
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

  cli::ExtractArgs ex;
  CLI::App* extract = cli::addExtractCommand(app, ex);

  std::string metricsInput;
  std::string metricsSphere;
  std::string metricsReport;
  auto* metrics =
      app.add_subcommand("metrics", "Measure a mesh file (.ply, .stl, .obj, .glb, .drc), optionally against a sphere");
  metrics->add_option("MESH", metricsInput, "Mesh file")->required();
  metrics->add_option("--sphere", metricsSphere, "cx,cy,cz,r: add the paper's radius, area and volume errors")
      ->check(cli::sphereList());
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
  cli::RawArgs infoRaw;
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
  cli::addRawOptions(info, infoRaw);

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

  // Where a usage error points: the help of the command parsed last.
  const auto helpCommand = [&app] {
    const auto parsed = app.get_subcommands();
    return parsed.empty() ? std::string("isoslab --help") : "isoslab " + parsed.back()->get_name() + " --help";
  };
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ValidationError& e) {
    // The message lists the choices, unless the value was the next option (`--threads --quiet`).
    const std::string taken = cli::optionTakenAsValue(app);
    printError(taken.empty() ? std::string(e.what()) : taken);
    return 2;
  } catch (const CLI::ParseError& e) {
    // An option that took the next option as its value is the cause of what follows from it
    // (`--report --sphere 1,1,1,1`: "1,1,1,1 was not expected").
    const std::string taken = cli::optionTakenAsValue(app);
    printError(fmt::format("{} (see {})", taken.empty() ? std::string(e.what()) : taken, helpCommand()));
    return 2;
  }
  if (const std::string taken = cli::optionTakenAsValue(app); !taken.empty()) {
    printError(fmt::format("{} (see {})", taken, helpCommand()));
    return 2;
  }

  // Under mpirun, extract joins the other ranks (MPI is finalised when `ranks` goes).
  std::unique_ptr<RankGroup> ranks;
  try {
    if (*extract || *batch) {
      ranks = cli::joinRanks();
      gRanks = ranks.get();
    }
    if (*extract) return cli::runExtractCommand(ex, gRanks);
    if (*batch) return cli::runBatch(bx, gRanks != nullptr && gRanks->size() > 1 ? gRanks : nullptr);
    if (*info) return cli::runInfo(infoInputs, infoRaw, infoHistogram ? infoBins : 0);
    if (*phantom) return cli::runPhantom(phantomSpec, phantomOut, phantomCompress);
    if (*decode) return cli::runDecode(decodeInput, decodeOutput);
    if (*renderCmd) return cli::runRender(renderInput, renderOutput, renderImage);
    if (*viewCmd) return cli::runView(viewInput, viewReport, viewPage);
    if (*metrics) return cli::runMetrics(metricsInput, metricsSphere, metricsReport);
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
  } catch (const SettingError& e) {
    if (reportsFailure()) printError(e.what());
    return 2;
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
