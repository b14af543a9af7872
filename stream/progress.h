// A one-line progress display on stderr, and process resource readings.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace isoslab {

/// Shows "label  NN% (done/total)  elapsed" on stderr, redrawn in place, once the run has taken
/// more than a second, and only when enabled and stderr is a terminal. Cleared by finish().
class Progress {
 public:
  Progress(std::string label, std::int64_t total, bool enabled);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void update(std::int64_t done);
  void finish();

 private:
  std::string label_;
  std::int64_t total_;
  bool enabled_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_;
  std::chrono::steady_clock::time_point lastDraw_;
};

/// Whether a Progress line is on stderr now (drawn and not yet cleared): a message printed then
/// starts on a new line. Progress clears its line when it finishes or is destroyed (unwinding).
bool progressLineShown() noexcept;

/// Peak resident set size of this process so far, in MiB (VmHWM), or 0 where unknown.
double peakRssMib() noexcept;

}  // namespace isoslab
