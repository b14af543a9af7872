// A request to stop, set by a signal handler and polled at slice boundaries and in long loops.
#pragma once

#include <atomic>
#include <cstddef>
#include <string>

#include "core/error.h"

namespace isoslab {

/// The signal number that asked the run to stop, or 0. Lock-free, so a signal handler may store
/// to it (the only async-signal-safe thing the handler does).
inline std::atomic<int> gInterruptSignal{0};
static_assert(std::atomic<int>::is_always_lock_free);

/// Thrown where a loop notices gInterruptSignal; unwinding removes every temporary file through
/// its owner's destructor. Derives from Error so that layers that translate Error pass it on.
class Interrupted : public Error {
 public:
  explicit Interrupted(int signal) : Error("interrupted"), signal_(signal) {}
  int signal() const noexcept { return signal_; }

 private:
  int signal_;
};

/// Throws Interrupted when a stop was requested. Call between slices, chunks or stages, never
/// inside a kernel (kernels are noexcept) nor in a destructor.
inline void throwIfInterrupted() {
  if (const int s = gInterruptSignal.load(std::memory_order_relaxed); s != 0) throw Interrupted(s);
}

/// Items of a long loop (triangles, vertices, rows) between two polls: about a millisecond of the
/// slowest loop that polls (formatting OBJ text), so that every command stops within a second.
inline constexpr std::size_t kInterruptStride = std::size_t{1} << 14;

/// throwIfInterrupted() on every kInterruptStride-th item of a loop (`index` counts the items).
inline void throwIfInterruptedEvery(std::size_t index) {
  if (index % kInterruptStride == 0) throwIfInterrupted();
}

}  // namespace isoslab
