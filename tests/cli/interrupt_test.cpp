// Interrupts in every command (issue 33): each command that can run for more than a moment, sent
// SIGINT, SIGTERM or SIGHUP during a long run, exits with 128 + the signal within a second (the
// tests allow 3 s: the machine's speed drifts), prints exactly one line on stderr,
// "isoslab: interrupted by SIG...", and leaves nothing in its output folder. stderr is a file here,
// never a terminal, so extract draws no progress line and the message is the whole of stderr.
//
// The signal goes as timeout(1) sends it: to the process, then to its process group (the program
// runs in a group of its own), so that one interrupt often arrives twice, as it does from a
// terminal's Ctrl-C to a job. Before the fix, the second delivery ended the process at once: no
// message, status "killed by SIGINT", and the output's temporary file left behind.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "test_support.h"

namespace isoslab::testing {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitized = true;
#else
constexpr bool kSanitized = false;
#endif

// The bound on the time from the signal to the exit (the goal is 1 s).
constexpr double kExitBound = 3.0;

double since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The isoslab program running in the background, in a process group of its own, with stdout and
// stderr in files of `logs` (a folder apart from the outputs').
struct Child {
  pid_t pid = -1;
  std::string logs;
  Clock::time_point started;
};

Child start(const std::vector<std::string>& args, std::vector<std::string> env = {}) {
  Child run;
  run.logs = tempDir();
  run.started = Clock::now();
  const std::string out = run.logs + "/stdout";
  const std::string err = run.logs + "/stderr";
  std::fflush(nullptr);  // or the child would write this process's buffered output again
  run.pid = ::fork();
  if (run.pid == 0) {
    ::setpgid(0, 0);
    std::vector<std::string> argv{ISOSLAB_CLI_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    std::vector<char*> cargv;
    for (std::string& a : argv) cargv.push_back(a.data());
    cargv.push_back(nullptr);
    for (std::string& e : env) ::putenv(e.data());
    if (!std::freopen("/dev/null", "r", stdin) || !std::freopen(out.c_str(), "w", stdout) ||
        !std::freopen(err.c_str(), "w", stderr)) {
      ::_exit(126);
    }
    ::execv(cargv[0], cargv.data());
    ::_exit(127);
  }
  ::setpgid(run.pid, run.pid);  // also here, so that the group exists before any signal to it
  return run;
}

// Whether the process has a handler of its own for `signal` (SigCgt in /proc/PID/status): the
// program installs its stop handlers first thing in main(), which under the sanitizers can come
// well after a tenth of a second of CPU spent loading.
bool catches(pid_t pid, int signal) {
  std::ifstream f(fmt::format("/proc/{}/status", pid));
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("SigCgt:", 0) == 0) {
      const unsigned long long mask = std::stoull(line.substr(7), nullptr, 16);
      return (mask >> (signal - 1) & 1) != 0;
    }
  }
  return false;
}

// The CPU time the process has used, in seconds (0 once it has gone).
double cpuSeconds(pid_t pid) {
  std::ifstream f(fmt::format("/proc/{}/stat", pid));
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  const std::size_t close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  long long utime = 0, stime = 0;
  for (int k = 3; k <= 15 && fields >> field; ++k) {
    if (k == 14) utime = std::stoll(field);
    if (k == 15) stime = std::stoll(field);
  }
  return static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

// The bytes the process has read (rchar), or -1 once it has gone.
std::int64_t bytesRead(pid_t pid) {
  std::ifstream f(fmt::format("/proc/{}/io", pid));
  std::string key;
  std::int64_t value = 0;
  while (f >> key >> value) {
    if (key == "rchar:") return value;
  }
  return -1;
}

bool exited(pid_t pid) {
  int status = 0;
  return ::waitpid(pid, &status, WNOHANG | WNOWAIT) == pid;
}

// Waits (at most 20 s) until `ready` holds, polling every 5 ms; false if the run ended first.
bool waitFor(const Child& run, const std::function<bool()>& ready) {
  const auto end = Clock::now() + std::chrono::seconds(20);
  while (Clock::now() < end) {
    siginfo_t info{};
    if (::waitid(P_PID, static_cast<id_t>(run.pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == run.pid)
      return false;
    if (ready()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return false;
}

// Entries of a folder (hidden ones too), or none when it does not exist.
std::vector<std::string> entries(const std::string& folder) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec))
    names.push_back(it->path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

bool holdsTemporary(const std::string& folder) {
  for (const std::string& name : entries(folder)) {
    if (name.find(".tmp.") != std::string::npos) return true;
  }
  return false;
}

struct Stopped {
  int status = -1;  // the exit status, or 1000 + the signal that ended the process
  double seconds = 0;
  std::string out;
  std::string err;
};

// Sends `signal` as timeout(1) does (to the process, then to its group; `gap` between the two, as
// from a wrapper that passes on a signal its group received too) and waits for the exit, at most
// 20 s (then SIGKILL).
Stopped stop(const Child& run, int signal, std::chrono::microseconds gap = {}) {
  const auto sent = Clock::now();
  ::kill(run.pid, signal);
  if (gap.count() > 0) std::this_thread::sleep_for(gap);
  ::kill(-run.pid, signal);
  Stopped s;
  int status = 0;
  while (::waitpid(run.pid, &status, WNOHANG) == 0) {
    if (since(sent) > 20) {
      ::kill(-run.pid, SIGKILL);
      ::waitpid(run.pid, &status, 0);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  s.seconds = since(sent);
  s.status = WIFEXITED(status) ? WEXITSTATUS(status) : 1000 + WTERMSIG(status);
  s.out = slurp(run.logs + "/stdout");
  s.err = slurp(run.logs + "/stderr");
  fs::remove_all(run.logs);
  return s;
}

std::string interruptedLine(int signal) {
  return fmt::format("isoslab: interrupted by SIG{}\n", sigabbrev_np(signal));
}

// Under the sanitizers, LeakSanitizer's check at exit stops every thread from a tracer thread, and
// that tracer itself sometimes crashes on a loaded machine ("Tracer caught signal 11", seen once in
// CI in about 500 interrupted runs; never reproduced alone). The run had already stopped cleanly and
// printed its one line: that failure is the checker's, not isoslab's, so it is accepted here with a
// note, and only in this exact form (the status of the SIGSEGV and LSan's own fatal-error lines).
Stopped withoutTracerCrash(Stopped s, int signal) {
  if (!kSanitized || s.status != 1000 + SIGABRT) return s;  // LSan's Die() aborts
  const std::string line = interruptedLine(signal);
  if (s.err.rfind(line + "Tracer caught signal 11:", 0) != 0) return s;
  if (s.err.find("==LeakSanitizer has encountered a fatal error.\n") == std::string::npos) return s;
  std::printf("note: LeakSanitizer's tracer crashed after the run stopped; accepted as its own fault\n");
  s.status = 128 + signal;
  s.err = line;
  return s;
}

// The checks every test makes: the status, the one line, the time, and `folder` as it was.
void expectStopped(const Stopped& stopped, int signal, const std::string& folder,
                   const std::vector<std::string>& before) {
  const Stopped s = withoutTracerCrash(stopped, signal);
  EXPECT_EQ(s.status, 128 + signal) << "1000 + n: ended by signal n, not by the program's own exit";
  EXPECT_EQ(s.err, interruptedLine(signal));
  EXPECT_LT(s.seconds, kExitBound) << "from the signal to the exit";
  EXPECT_EQ(entries(folder), before) << "an output or temporary file was left in " << folder;
}

// A mesh large enough that reading it takes seconds: a plain (uncompressed) .glb of a wavy height
// field of 2 x 1000 x 1000 triangles, written once per test program.
const std::string& bigGlb() {
  static const std::string path = [] {
    const int n = kSanitized ? 600 : 1000;  // points per side
    std::string bin;
    std::vector<float> positions;
    positions.reserve(static_cast<std::size_t>(3 * n * n));
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        positions.insert(positions.end(),
                         {static_cast<float>(i), static_cast<float>(j),
                          5.0f * std::sin(0.05f * static_cast<float>(i)) * std::cos(0.07f * static_cast<float>(j))});
      }
    }
    std::vector<std::uint32_t> indices;
    indices.reserve(static_cast<std::size_t>(6 * (n - 1) * (n - 1)));
    for (int j = 0; j + 1 < n; ++j) {
      for (int i = 0; i + 1 < n; ++i) {
        const auto v = static_cast<std::uint32_t>(j * n + i);
        const auto w = static_cast<std::uint32_t>(n);
        indices.insert(indices.end(), {v, v + 1, v + w + 1, v, v + w + 1, v + w});
      }
    }
    const std::size_t positionBytes = positions.size() * sizeof(float);
    const std::size_t indexBytes = indices.size() * sizeof(std::uint32_t);
    bin.resize(positionBytes + indexBytes);
    std::memcpy(bin.data(), positions.data(), positionBytes);
    std::memcpy(bin.data() + positionBytes, indices.data(), indexBytes);
    std::string json = fmt::format(
        R"({{"asset":{{"version":"2.0"}},"buffers":[{{"byteLength":{0}}}],)"
        R"("bufferViews":[{{"buffer":0,"byteLength":{1}}},{{"buffer":0,"byteOffset":{1},"byteLength":{2}}}],)"
        R"("accessors":[{{"bufferView":0,"componentType":5126,"count":{3},"type":"VEC3",)"
        R"("min":[0,0,-5],"max":[{4},{4},5]}},{{"bufferView":1,"componentType":5125,"count":{5},"type":"SCALAR"}}],)"
        R"("meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"mode":4}}]}}]}})",
        bin.size(), positionBytes, indexBytes, n * n, n - 1, indices.size());
    while (json.size() % 4 != 0) json += ' ';
    auto u32 = [](std::size_t v) {
      const auto u = static_cast<std::uint32_t>(v);
      return std::string(reinterpret_cast<const char*>(&u), 4);
    };
    const fs::path folder = fs::temp_directory_path() / ("isoslab-interrupt-" + std::to_string(::getpid()));
    fs::create_directories(folder);
    const std::string file = (folder / "big.glb").string();
    std::ofstream f(file, std::ios::binary);
    f << "glTF" << u32(2) << u32(12 + 8 + json.size() + 8 + bin.size()) << u32(json.size()) << u32(0x4E4F534A) << json
      << u32(bin.size()) << u32(0x004E4942) << bin;
    return file;
  }();
  return path;
}

// Removes bigGlb()'s folder when the test program ends.
class BigGlbFolder final : public ::testing::Environment {
 public:
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(fs::temp_directory_path() / ("isoslab-interrupt-" + std::to_string(::getpid())), ec);
  }
};
[[maybe_unused]] ::testing::Environment* const kBigGlbFolder = ::testing::AddGlobalTestEnvironment(new BigGlbFolder);

// Runs `args` on bigGlb() and interrupts it once the whole file is read (its decoding has begun).
void interruptMeshCommand(const std::vector<std::string>& args, int signal, const std::string& folder) {
  const std::string& input = bigGlb();
  const auto size = static_cast<std::int64_t>(fs::file_size(input));
  const auto before = entries(folder);
  const Child run = start(args);
  ASSERT_TRUE(waitFor(run, [&] { return bytesRead(run.pid) >= size; })) << "the run ended before reading its input";
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // into the decoding
  ASSERT_FALSE(exited(run.pid)) << "the input is too small: the run ended before the signal";
  const Stopped s = stop(run, signal);
  expectStopped(s, signal, folder, before);
  EXPECT_EQ(s.out, "");
}

}  // namespace

TEST(Interrupt, ExtractStopsOnEachSignalWithOneLine) {
  for (const auto& [signal, output] : {std::pair{SIGINT, "m.ply"}, {SIGTERM, "m.obj"}, {SIGHUP, "m.drc"}}) {
    SCOPED_TRACE(fmt::format("SIG{} -o {}", sigabbrev_np(signal), output));
    const std::string dir = tempDir();
    // Without -q: the message must not follow a blank line (no progress line is drawn on a file).
    const Child run = start({"extract", "phantom:head?n=400", "--threads", "2", "-o", dir + "/" + output});
    ASSERT_TRUE(waitFor(run, [&] { return holdsTemporary(dir); }));
    const Stopped s = stop(run, signal);
    expectStopped(s, signal, dir, {});
  }
}

// Many interrupts at random moments, every format, 1 and 2 threads: the race of issue 33.
TEST(Interrupt, ExtractStopsCleanlyAtAnyMoment) {
  const char* given = std::getenv("ISOSLAB_INTERRUPT_SEED");
  const auto seed = given != nullptr ? static_cast<unsigned>(std::strtoul(given, nullptr, 10))
                                     : static_cast<unsigned>(std::random_device{}());
  std::printf("[ seed     ] %u (ISOSLAB_INTERRUPT_SEED=%u repeats these moments)\n", seed, seed);
  std::mt19937 random(seed);
  const int rounds = kSanitized ? 1 : 2;
  const char* formats[] = {"ply", "stl", "obj", "glb", "drc"};
  for (int round = 0; round < rounds; ++round) {
    for (const char* format : formats) {
      for (const char* threads : {"1", "2"}) {
        const double delay = std::uniform_real_distribution<double>(0.0, 0.8)(random);
        const std::chrono::microseconds gap(std::uniform_int_distribution<int>(0, 3000)(random));
        SCOPED_TRACE(fmt::format(".{} --threads {}, {:.3f} s after the run began, delivered twice {} us apart", format,
                                 threads, delay, gap.count()));
        const std::string dir = tempDir();
        // n=448: several seconds of work on a fast machine, so the signal always comes first.
        const Child run = start({"extract", "phantom:head?n=448", "--threads", threads, "-o", dir + "/m." + format});
        // From the moment the program runs with its handlers in place.
        ASSERT_TRUE(waitFor(run, [&] { return catches(run.pid, SIGINT) && catches(run.pid, SIGHUP); }));
        std::this_thread::sleep_for(std::chrono::duration<double>(delay));
        ASSERT_FALSE(exited(run.pid)) << "the run ended before the signal";
        const Stopped s = stop(run, SIGINT, gap);
        expectStopped(s, SIGINT, dir, {});
      }
    }
  }
}

TEST(Interrupt, PhantomStopsWithOneLineAndNoBlankLine) {
  const std::string dir = tempDir();
  const Child run = start({"phantom", "phantom:head?n=512", "-o", dir + "/v.nii"});
  ASSERT_TRUE(waitFor(run, [&] { return holdsTemporary(dir); }));
  const Stopped s = stop(run, SIGINT);
  expectStopped(s, SIGINT, dir, {});
  EXPECT_EQ(s.out, "");
}

TEST(Interrupt, DecodeOfALargeGlbStops) {
  const std::string dir = tempDir();
  interruptMeshCommand({"decode", bigGlb(), "-o", dir + "/m.ply"}, SIGINT, dir);
  interruptMeshCommand({"decode", bigGlb(), "-o", dir + "/m.obj"}, SIGTERM, dir);
}

TEST(Interrupt, MetricsStops) {
  const std::string dir = tempDir();
  interruptMeshCommand({"metrics", bigGlb(), "--report", dir + "/r.json"}, SIGINT, dir);
  interruptMeshCommand({"metrics", bigGlb()}, SIGHUP, dir);
}

TEST(Interrupt, RenderStops) {
  const std::string dir = tempDir();
  interruptMeshCommand({"render", bigGlb(), "-o", dir + "/r.png"}, SIGINT, dir);
}

TEST(Interrupt, ViewStops) {
  // The signal comes while the .glb is decoded, before the page needs three.js.
  const std::string dir = tempDir();
  interruptMeshCommand({"view", bigGlb(), "-o", dir + "/v.html"}, SIGINT, dir);
}

// info reads every slice for the value range: a phantom for the range loop, and a DICOM series,
// whose reading error handler once took the interruption for an unreadable series and went on.
TEST(Interrupt, InfoStops) {
  const std::string dir = tempDir();
  Child run = start({"info", "phantom:head?n=400"});
  ASSERT_TRUE(waitFor(run, [&] { return catches(run.pid, SIGINT) && cpuSeconds(run.pid) >= 0.3; }));
  ASSERT_FALSE(exited(run.pid));
  expectStopped(stop(run, SIGINT), SIGINT, dir, {});
  const std::string data = sharedData("ct-philips-head");
  if (data.empty()) return;  // the phantom half stands alone
  // The series takes about 0.3 s of CPU here, less once it is in the page cache: the signal comes
  // after 0.1 s, and a run that ends first (read whole before the signal) leaves nothing to judge.
  run = start({"info", data});
  if (!waitFor(run, [&] { return catches(run.pid, SIGINT) && cpuSeconds(run.pid) >= 0.1; })) {
    ASSERT_TRUE(exited(run.pid)) << "info neither caught SIGINT nor ended in 20 s";
    return;
  }
  if (exited(run.pid)) return;
  expectStopped(stop(run, SIGTERM), SIGTERM, dir, {});
}

TEST(Interrupt, CompareStopsAndCreatesNoFolder) {
  const std::string dir = tempDir();
  for (const std::string& suite : {std::string("spheres51"), std::string("figures")}) {
    SCOPED_TRACE(suite);
    const std::string out = dir + "/" + suite;  // not there: compare would create it
    const Child run = start({"compare", "--suite", suite, "--out", out, "-q"});
    ASSERT_TRUE(waitFor(run, [&] { return catches(run.pid, SIGINT) && cpuSeconds(run.pid) >= 0.4; }));
    ASSERT_FALSE(exited(run.pid));
    const Stopped s = stop(run, SIGINT);
    expectStopped(s, SIGINT, dir, {});
  }
}

TEST(Interrupt, BatchStopsItsExtractionsAndLeavesNothing) {
  const std::string dir = tempDir();
  const std::string list = dir + "/list.txt";
  std::ofstream(list) << "phantom:head?n=400\nphantom:head?n=401\nphantom:head?n=402\n";
  const std::string out = dir + "/out";
  const Child run = start({"batch", list, "--out", out, "--jobs", "2", "--format", "ply", "--", "--threads", "1"});
  // Both extractions are writing their meshes.
  ASSERT_TRUE(waitFor(run, [&] {
    int temporaries = 0;
    for (const std::string& name : entries(out)) temporaries += name.find(".tmp.") != std::string::npos ? 1 : 0;
    return temporaries >= 2;
  }));
  const Stopped s = stop(run, SIGINT);
  expectStopped(s, SIGINT, dir, {"list.txt"});
  EXPECT_EQ(s.out, "");
  // No extraction outlives the batch.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_FALSE(fs::exists(out));
  for (const auto& p : fs::directory_iterator("/proc")) {
    const std::string cmdline = slurp((p.path() / "cmdline").string());
    EXPECT_EQ(cmdline.find(out + "/"), std::string::npos) << "a child is still running: pid " << p.path().filename();
  }
}

}  // namespace isoslab::testing
