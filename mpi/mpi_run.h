#pragma once
// `fragsim run` over MPI: rank r of P runs shard r/P (core/run/partial.h) with its own threads;
// the partials are merged exactly up a binary tree to rank 0, which writes the outputs
// `fragsim run` writes, bit-identical to a one-process run (docs/cluster.md, "MPI"). A
// settings.precision run's ranks run each batch together and exchange it at every batch boundary
// (docs/cluster.md, "Precision runs divided").
#include <mpi.h>

#include <atomic>
#include <string>
#include <vector>

namespace fragsim::mpi {

// `args` without argv[0]: "run SCENARIO.json --out DIR [options of fragsim run]"; --shard only
// as 0/1: rank 0 then writes the whole run's DIR/partial.fsp (what `fragsim run --shard 0/1`
// writes, which fragsimd's mpi backend collects) instead of the outputs.
// Returns the process exit code (0, 1 internal, 2 invalid input, 130 cancelled), the same on
// every rank but for errors of one rank (which abort the job: MPI_Abort).
int run_mpi(const std::vector<std::string>& args, MPI_Comm comm, const std::atomic<bool>& cancel);

// The size of the messages big buffers are sent in (MPI counts are int).
inline constexpr std::size_t kMessageBytes = std::size_t{1} << 30;
void send_bytes(const std::string& bytes, int to, MPI_Comm comm);
std::string receive_bytes(int from, MPI_Comm comm);

}  // namespace fragsim::mpi
