#include "mpi/mpi_run.h"

#include <algorithm>
#include <cstdint>
#include <exception>
#include <iostream>
#include <new>
#include <optional>

#include "api/partial_file.h"
#include "cli/args.h"
#include "cli/commands.h"
#include "cli/progress.h"
#include "core/common/error.h"
#include "core/run/partial.h"

namespace fragsim::mpi {

namespace {

constexpr int kTagSize = 1, kTagBytes = 2;

// Rank 0 reads the scenario file; every rank gets its bytes (no shared file system needed for
// the input). The status is 0, or 2 when rank 0 could not read it (message printed there).
int broadcast_scenario(const cli::Options& o, std::string& text, int rank, MPI_Comm comm) {
  int status = 0;
  if (rank == 0) {
    try {
      text = cli::read_file(o.scenario);
    } catch (const InputError& e) {
      std::cerr << "error: " << e.what() << "\n";
      status = cli::kExitInvalidInput;
    }
  }
  MPI_Bcast(&status, 1, MPI_INT, 0, comm);
  if (status != 0) return status;
  std::uint64_t size = text.size();
  MPI_Bcast(&size, 1, MPI_UINT64_T, 0, comm);
  text.resize(size);
  for (std::uint64_t at = 0; at < size; at += kMessageBytes) {
    const auto n = static_cast<int>(std::min<std::uint64_t>(kMessageBytes, size - at));
    MPI_Bcast(text.data() + at, n, MPI_BYTE, 0, comm);
  }
  return 0;
}

// Merges the ranks' partials up a binary tree: at step s, rank r with r mod 2s == s sends its
// partial to r - s. Exact sums make the tree's shape irrelevant to the result. Rank 0 returns
// the whole run's partial; the others return nothing.
std::optional<run::PartialRun> reduce_partials(run::PartialRun mine, const cli::Options& o,
                                               const cli::PreparedRun& p, int rank, int size,
                                               MPI_Comm comm) {
  const api::PartialIdentity id = cli::identity_of(o, p);
  const std::size_t bins = run::tally_bins(*p.site).total;
  for (int step = 1; step < size; step *= 2) {
    if (rank % (2 * step) == step) {
      send_bytes(api::encode_partial(mine, id), rank - step, comm);
      return std::nullopt;
    }
    if (rank % (2 * step) == 0 && rank + step < size) {
      api::PartialIdentity theirs;
      run::PartialRun other = api::decode_partial(receive_bytes(rank + step, comm), bins, theirs,
                                                  "rank " + std::to_string(rank + step));
      if (!(theirs == id)) throw std::runtime_error("a rank ran another scenario");
      run::merge(mine, std::move(other));
    }
  }
  return mine;
}

std::string rank_progress_file(const cli::Options& o, int rank, int size) {
  if (o.progress_file.empty() || size == 1) return o.progress_file;
  return o.progress_file + "." + std::to_string(rank);
}

int run_ranks(const cli::Options& o, const cli::PreparedRun& p, int rank, int size, MPI_Comm comm,
              const std::atomic<bool>& cancel) {
  cli::ProgressFile progress(rank_progress_file(o, rank, size));
  run::RunControl control;
  control.cancel = &cancel;
  control.on_progress = [&](const run::Progress& pr) { progress.update(pr); };
  run::PartialRun part = run::run_partial(p.doc.scenario, p.site, {rank, size}, control);
  int cancelled = part.cancelled || cancel.load() ? 1 : 0;
  MPI_Allreduce(MPI_IN_PLACE, &cancelled, 1, MPI_INT, MPI_MAX, comm);
  if (cancelled != 0) {
    progress.finish("cancelled");
    if (rank == 0) std::cerr << "cancelled: no output written\n";
    return cli::kExitCancelled;
  }
  progress.finish("done");
  std::optional<run::PartialRun> whole = reduce_partials(std::move(part), o, p, rank, size, comm);
  if (!whole) return cli::kExitOk;
  run::RunResult result = run::finish(p.doc.scenario, *p.site, std::move(*whole));
  const int code = cli::write_outputs(o, p, result, cancel);
  if (size > 1 && !o.progress_file.empty()) {
    cli::ProgressFile all(o.progress_file);  // the whole run's, once, at the end
    run::Progress pr;
    pr.histories_done = pr.histories_total = result.histories_done;
    pr.elapsed_s = result.timing.wall_s;
    all.update(pr);
    all.finish(code == cli::kExitOk ? "done" : "failed");
  }
  return code;
}

}  // namespace

void send_bytes(const std::string& bytes, int to, MPI_Comm comm) {
  std::uint64_t size = bytes.size();
  MPI_Send(&size, 1, MPI_UINT64_T, to, kTagSize, comm);
  for (std::uint64_t at = 0; at < size; at += kMessageBytes) {
    const auto n = static_cast<int>(std::min<std::uint64_t>(kMessageBytes, size - at));
    MPI_Send(bytes.data() + at, n, MPI_BYTE, to, kTagBytes, comm);
  }
}

std::string receive_bytes(int from, MPI_Comm comm) {
  std::uint64_t size = 0;
  MPI_Recv(&size, 1, MPI_UINT64_T, from, kTagSize, comm, MPI_STATUS_IGNORE);
  std::string bytes(size, '\0');
  for (std::uint64_t at = 0; at < size; at += kMessageBytes) {
    const auto n = static_cast<int>(std::min<std::uint64_t>(kMessageBytes, size - at));
    MPI_Recv(bytes.data() + at, n, MPI_BYTE, from, kTagBytes, comm, MPI_STATUS_IGNORE);
  }
  return bytes;
}

int run_mpi(const std::vector<std::string>& args, MPI_Comm comm, const std::atomic<bool>& cancel) {
  int rank = 0, size = 1;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  // Input errors are found alike on every rank (same arguments, same bytes): each returns 2
  // and only rank 0 speaks. Anything else on one rank would leave the others waiting: abort.
  cli::Options o;
  std::string text;
  try {
    o = cli::parse_args(args);
    if (o.command != cli::Command::kRun)
      throw cli::UsageError("fragsim-mpi runs one command: run SCENARIO.json --out DIR ...");
    if (o.shard)
      throw cli::UsageError("--shard: fragsim-mpi divides the histories among its ranks itself");
  } catch (const cli::UsageError& e) {
    if (rank == 0) std::cerr << "error: " << e.what() << "\n";
    return cli::kExitInvalidInput;
  }
  if (const int status = broadcast_scenario(o, text, rank, comm); status != 0) return status;
  std::optional<cli::PreparedRun> p;
  try {
    p = cli::prepare_text(o, std::move(text));
    if (size > 1 && p->doc.scenario.settings.precision)
      throw InputError("settings.precision",
                       "cannot be divided among MPI ranks: its checks at batch boundaries need "
                       "every history of a batch in one process (run it with one rank)");
  } catch (const InputError& e) {
    if (rank == 0) std::cerr << "error: " << e.what() << "\n";
    return cli::kExitInvalidInput;
  }
  try {
    return run_ranks(o, *p, rank, size, comm, cancel);
  } catch (const std::exception& e) {
    std::cerr << "error (rank " << rank << "): " << e.what() << "\n";
  } catch (...) {
    std::cerr << "error (rank " << rank << "): unknown\n";
  }
  MPI_Abort(comm, cli::kExitInternal);
  return cli::kExitInternal;
}

}  // namespace fragsim::mpi
