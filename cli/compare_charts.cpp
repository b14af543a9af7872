// `isoslab compare`'s charts: bench/plot_precision.py run as a child process that a stop signal ends.
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <stdlib.h>
#include <sys/wait.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "cli/compare.h"
#include "core/error.h"
#include "core/interrupt.h"

namespace fs = std::filesystem;

namespace isoslab {
namespace {

extern "C" char** environ;

// Runs `argv` (argv[0] found on PATH) and returns its exit status, or -1 when it cannot start or
// ends by a signal. Unlike std::system(), which ignores SIGINT while it waits, a stop signal ends
// the child (SIGTERM) and throws Interrupted once it has gone.
int runProgram(std::vector<std::string> argv) {
  std::vector<char*> cargv;
  for (std::string& a : argv) cargv.push_back(a.data());
  cargv.push_back(nullptr);
  // In a process group of its own, so that a terminal's Ctrl-C reaches only isoslab, which ends
  // the child itself (no KeyboardInterrupt traceback from Python on the shared stderr).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, cargv[0], nullptr, &attributes, cargv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  if (spawned != 0) return -1;
  int status = 0;
  bool stopped = false;
  for (;;) {
    const pid_t done = ::waitpid(pid, &status, WNOHANG);
    if (done == pid || (done < 0 && errno != EINTR)) break;
    if (gInterruptSignal.load() != 0 && !stopped) {
      ::kill(pid, SIGTERM);
      stopped = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  throwIfInterrupted();
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

// Runs the chart script (bench/plot_precision.py) with Debian's python3, which has matplotlib. It
// draws into a temporary folder beside the results, whose charts are moved into `out` when it
// succeeds: an interruption or a failure leaves none.
void drawCharts(const std::string& csv, const std::string& out, bool quiet) {
  const std::string script = std::string(ISOSLAB_SOURCE_DIR) + "/bench/plot_precision.py";
  const std::string python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  if (!fs::exists(script)) {
    std::fprintf(stderr, "isoslab: charts skipped: %s is missing\n", script.c_str());
    return;
  }
  std::string scratch = out + "/.charts.tmp.XXXXXX";
  if (::mkdtemp(scratch.data()) == nullptr) {
    throw Error(fmt::format("{}: cannot create a folder for the charts: {}", out, std::strerror(errno)));
  }
  struct Scratch {
    std::string path;
    ~Scratch() {
      std::error_code ec;
      fs::remove_all(path, ec);
    }
  } owner{scratch};
  if (runProgram({python, script, csv, scratch}) != 0) {
    std::fprintf(stderr, "isoslab: charts skipped: %s failed (is python3-matplotlib installed?)\n", script.c_str());
    return;
  }
  std::error_code ec;
  for (auto chart = fs::directory_iterator(scratch, ec); !ec && chart != fs::directory_iterator();
       chart.increment(ec)) {
    fs::rename(chart->path(), fs::path(out) / chart->path().filename(), ec);
    if (ec) break;
  }
  if (ec) throw Error(fmt::format("{}: cannot move the charts into place: {}", out, ec.message()));
  if (!quiet) std::fprintf(stderr, "isoslab: charts written to %s\n", out.c_str());
}

}  // namespace isoslab
