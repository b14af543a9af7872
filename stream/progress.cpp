#include "stream/progress.h"

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <fstream>
#include <string>

namespace isoslab {
namespace {

// Progress lines on stderr now (one at a time in practice).
std::atomic<int> gLinesShown{0};

}  // namespace

bool progressLineShown() noexcept {
  return gLinesShown.load() > 0;
}

Progress::Progress(std::string label, std::int64_t total, bool enabled)
    : label_(std::move(label)),
      total_(total),
      enabled_(enabled && ::isatty(STDERR_FILENO) == 1),
      start_(std::chrono::steady_clock::now()),
      lastDraw_(start_) {}

Progress::~Progress() {
  finish();
}

void Progress::update(std::int64_t done) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - start_ < std::chrono::seconds(1) || now - lastDraw_ < std::chrono::milliseconds(100)) return;
  lastDraw_ = now;
  if (!shown_) gLinesShown.fetch_add(1);
  shown_ = true;
  const double seconds = std::chrono::duration<double>(now - start_).count();
  const double pct = total_ > 0 ? 100.0 * static_cast<double>(done) / static_cast<double>(total_) : 100.0;
  std::fputs(fmt::format("\r{} {:3.0f}% ({}/{}) {:.1f} s\x1b[K", label_, pct, done, total_, seconds).c_str(), stderr);
  std::fflush(stderr);
}

void Progress::finish() {
  if (shown_) {
    std::fputs("\r\x1b[K", stderr);
    std::fflush(stderr);
    shown_ = false;
    gLinesShown.fetch_sub(1);
  }
}

double peakRssMib() noexcept {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) {
      try {
        return std::stod(line.substr(6)) / 1024.0;  // kB
      } catch (...) {
        return 0;
      }
    }
  }
  return 0;
}

}  // namespace isoslab
