// fragsim-mpi: `fragsim run` with the histories divided among MPI ranks (docs/cluster.md):
//   mpirun -np 4 fragsim-mpi run SCENARIO.json --out DIR [--threads N] [--samples-scale X]
// Rank 0 writes DIR/summary.json, DIR/results.h5, ... bit-identical to `fragsim run`.
#include <csignal>
#include <cstring>
#include <string>
#include <vector>

#include "mpi/mpi_run.h"

namespace {

std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

// mpirun forwards SIGINT/SIGTERM to the ranks: the run stops at the next history, every rank
// agrees on it and nothing is written. A second signal terminates at once.
extern "C" void on_signal(int sig) {
  if (g_cancel.exchange(true)) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
  const std::vector<std::string> args(argv + 1, argv + argc);
  const int code = fragsim::mpi::run_mpi(args, MPI_COMM_WORLD, g_cancel);
  MPI_Finalize();
  return code;
}
