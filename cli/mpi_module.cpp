// The MPI module (libisoslab_mpi.so, core/modules.h): the ranks of `isoslab extract` under mpirun
// over MPI's world communicator. A module, loaded only by a program that mpirun started, so that
// every other run pays nothing for binding Open MPI's libraries at start-up (cli/mpi_group.h).
#include <mpi.h>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <vector>

#include "stream/rank_group.h"

namespace isoslab::cli {
namespace {

// Messages go as their size, then pieces of at most 1 GiB (MPI counts are ints).
constexpr int kTag = 20;
constexpr std::size_t kPiece = std::size_t{1} << 30;

class MpiGroup final : public RankGroup {
 public:
  MpiGroup() {
    int provided = 0;
    // Only the thread that called runPipeline() talks to the other ranks.
    MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
    MPI_Comm_rank(MPI_COMM_WORLD, &rank_);
    MPI_Comm_size(MPI_COMM_WORLD, &size_);
  }
  MpiGroup(const MpiGroup&) = delete;
  MpiGroup& operator=(const MpiGroup&) = delete;
  ~MpiGroup() override { MPI_Finalize(); }

  int rank() const noexcept override { return rank_; }
  int size() const noexcept override { return size_; }

  void send(int to, std::span<const std::byte> message) override {
    auto n = static_cast<std::uint64_t>(message.size());
    MPI_Send(&n, 1, MPI_UINT64_T, to, kTag, MPI_COMM_WORLD);
    for (std::size_t at = 0; at < message.size(); at += kPiece) {
      const auto piece = static_cast<int>(std::min(kPiece, message.size() - at));
      MPI_Send(message.data() + at, piece, MPI_BYTE, to, kTag, MPI_COMM_WORLD);
    }
  }

  std::vector<std::byte> receive(int from) override {
    std::uint64_t n = 0;
    MPI_Recv(&n, 1, MPI_UINT64_T, from, kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    std::vector<std::byte> message(static_cast<std::size_t>(n));
    for (std::size_t at = 0; at < message.size(); at += kPiece) {
      const auto piece = static_cast<int>(std::min(kPiece, message.size() - at));
      MPI_Recv(message.data() + at, piece, MPI_BYTE, from, kTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    }
    return message;
  }

  [[noreturn]] void abort(int code) override {
    std::fflush(stderr);
    MPI_Abort(MPI_COMM_WORLD, code);
    std::_Exit(code);
  }

  int agree(bool ok) override {
    int mine = ok ? INT_MAX : rank_;
    int lowest = INT_MAX;
    MPI_Allreduce(&mine, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    return lowest == INT_MAX ? -1 : lowest;
  }

 private:
  int rank_ = 0;
  int size_ = 1;
};

}  // namespace
}  // namespace isoslab::cli

/// A new group of the ranks (MPI initialised); its destructor finalises MPI.
extern "C" __attribute__((visibility("default"))) isoslab::RankGroup* isoslab_mpi_join() {
  return new isoslab::cli::MpiGroup();
}
