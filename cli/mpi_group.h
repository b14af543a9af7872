// The ranks of `isoslab extract` under mpirun (issue 20): a RankGroup over MPI's world
// communicator, from the MPI module (cli/mpi_module.cpp, loaded only under mpirun). Built when
// CMake finds MPI (ISOSLAB_MPI); otherwise joinRanks() gives nothing.
#pragma once

#include <memory>

#include "stream/rank_group.h"

namespace isoslab::cli {

/// The MPI world when the program was started by mpirun (Open MPI's OMPI_COMM_WORLD_SIZE, or
/// PMI_SIZE, is set), initialised on first call; nullptr otherwise, or when built without MPI.
/// The group finalises MPI when destroyed.
std::unique_ptr<RankGroup> joinRanks();

/// Whether this build can run under mpirun.
bool haveMpi() noexcept;

}  // namespace isoslab::cli
