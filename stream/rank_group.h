// Processes that share one extraction (issue 20): each rank extracts its own range of slabs, and
// rank 0 stitches every range into the one mesh, as the threads' stitcher joins their runs. The
// transport is an interface, so that the pipeline does not depend on MPI: cli/mpi_group.cpp
// implements it over MPI, and the tests over threads (ThreadRanks in tests/stream/pipeline_test.cpp).
//
// The protocol of one runPipeline() call with a group of N > 1 ranks (stream/pipeline.cpp):
//   1. every rank: agree(true) (a rank that failed earlier takes part with agree(false) from its
//      error handler, and then every rank stops: see RankFailed);
//   2. rank r > 0: extracts slabs [N_r, N_r+1) into runs, spooled to a temporary file, then sends
//      them to rank 0 in slab order, then "end" with its value range, or "failed" with its error's
//      one line;
//   3. rank 0: extracts its own range and emits it, then receives the ranks' runs in rank order,
//      stitches and emits them, and finishes the sink;
//   4. rank 0 sends every rank the outcome; a rank told of a failure throws RankFailed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "core/error.h"

namespace isoslab {

class RankGroup {
 public:
  virtual ~RankGroup() = default;
  virtual int rank() const noexcept = 0;
  virtual int size() const noexcept = 0;
  /// Sends one message to rank `to`; messages between two ranks arrive in the order sent.
  virtual void send(int to, std::span<const std::byte> message) = 0;
  /// The next message from rank `from` (blocks until it comes).
  virtual std::vector<std::byte> receive(int from) = 0;
  /// Every rank calls it at the same points; returns the lowest rank that passed ok = false, or -1
  /// when all passed true.
  virtual int agree(bool ok) = 0;
  /// Ends every rank at once with `code` (MPI_Abort): for what the protocol cannot carry (an
  /// interrupt, a broken transport). Does not return.
  [[noreturn]] virtual void abort(int code) = 0;

  /// Whether every rank knows of a failure (an agree() found one, or rank 0 sent a run's
  /// outcome): no rank calls agree() again, and rank 0 holds the error to report.
  bool failureShared() const noexcept { return failureShared_; }
  void setFailureShared() noexcept { failureShared_ = true; }

 private:
  bool failureShared_ = false;
};

/// Thrown on a rank whose run failed because another rank failed: that rank's error was reported
/// (by rank 0), so this one exits non-zero without a message of its own.
class RankFailed : public Error {
 public:
  explicit RankFailed(int failedRank)
      : Error("rank " + std::to_string(failedRank) + " failed"), failedRank_(failedRank) {}
  int failedRank() const noexcept { return failedRank_; }

 private:
  int failedRank_;
};

/// The slabs [first, end) of rank `rank` of `ranks`, for a volume of `slabs` slabs: balanced by
/// count, rank 0 first.
struct SlabRange {
  std::int64_t first = 0;
  std::int64_t end = 0;
};
SlabRange rankSlabs(std::int64_t slabs, int rank, int ranks) noexcept;

}  // namespace isoslab
