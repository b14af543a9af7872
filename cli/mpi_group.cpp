#include "cli/mpi_group.h"

#include <cstdlib>

#include "core/modules.h"

namespace isoslab::cli {

bool haveMpi() noexcept {
#if defined(ISOSLAB_HAVE_MPI)
  return true;
#else
  return false;
#endif
}

std::unique_ptr<RankGroup> joinRanks() {
  if (!haveMpi() || (std::getenv("OMPI_COMM_WORLD_SIZE") == nullptr && std::getenv("PMI_SIZE") == nullptr &&
                     std::getenv("PMIX_RANK") == nullptr)) {
    return nullptr;
  }
  using Join = RankGroup* (*)();
  const auto join = reinterpret_cast<Join>(moduleSymbol(LoadableModule::kMpi, "isoslab_mpi_join", "mpirun runs"));
  return std::unique_ptr<RankGroup>(join());
}

}  // namespace isoslab::cli
