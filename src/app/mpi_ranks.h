#pragma once
// MPI for `mpirun -np N fogmap render ...` (docs/distributed.md): initialised only
// when the process was started by mpirun (Open MPI's environment), so a plain `fogmap` runs
// exactly as without MPI. MPI's headers stay in mpi_ranks.cpp.

#include "core/ranks.h"

#include <memory>

namespace fogmap {

/// The MPI ranks of this job, or null when the process was not started by mpirun. Initialises MPI
/// (MPI_THREAD_FUNNELED: TBB's workers never call MPI); the returned object finalises it.
std::unique_ptr<Ranks> start_mpi(int* argc, char*** argv);

/// Ends every rank of the job with `code` (a failure after the ranks have parted ways).
[[noreturn]] void abort_mpi(int code);

}  // namespace fogmap
