// fragsim-mpi: `fragsim run` with the histories divided among MPI ranks (docs/cluster.md):
//   mpirun -np 4 fragsim-mpi run SCENARIO.json --out DIR [--threads N] [--samples-scale X]
// Rank 0 writes DIR/summary.json, DIR/results.h5, ... bit-identical to `fragsim run`; with
// --shard 0/1, the whole run's DIR/partial.fsp instead (fragsimd's mpi backend).
#include <string>
#include <vector>

#include "app/signals.h"
#include "mpi/mpi_run.h"

int main(int argc, char** argv) {
  // Only the main thread calls MPI; the run's threads (and the shard's) never do.
  int provided = 0;
  MPI_Init_thread(&argc, &argv, MPI_THREAD_FUNNELED, &provided);
  // mpirun forwards SIGINT/SIGTERM to the ranks: the run stops at the next history, every rank
  // agrees on it and nothing is written.
  fragsim::app::install_cancel_handlers();
  const std::vector<std::string> args(argv + 1, argv + argc);
  const int code = fragsim::mpi::run_mpi(args, MPI_COMM_WORLD, fragsim::app::cancel_flag());
  MPI_Finalize();
  return code;
}
