#include "mpi/mpi_run.h"

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstdlib>
#include <exception>
#include <future>
#include <iostream>
#include <memory>
#include <mutex>
#include <new>
#include <optional>
#include <thread>

#include "app/args.h"
#include "app/commands.h"
#include "app/progress.h"
#include "core/common/error.h"
#include "core/run/partial.h"
#include "formats/output_dir.h"
#include "formats/partial_file.h"

namespace fragsim::mpi {

namespace {

constexpr int kTagSize = 1, kTagBytes = 2;

// Rank 0 reads the scenario file; every rank gets its bytes (no shared file system needed for
// the input). The status is 0, or 2 when rank 0 could not read it (message printed there).
int broadcast_scenario(const app::Options& o, std::string& text, int rank, MPI_Comm comm) {
  int status = 0;
  if (rank == 0) {
    try {
      text = app::read_file(o.scenario);
    } catch (const InputError& e) {
      std::cerr << "error: " << e.what() << "\n";
      status = app::kExitInvalidInput;
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
std::optional<run::PartialRun> reduce_partials(run::PartialRun mine, const app::Options& o,
                                               const app::PreparedRun& p, int rank, int size,
                                               MPI_Comm comm) {
  const formats::PartialIdentity id = app::identity_of(o, p);
  const std::size_t bins = run::tally_bins(p.doc.scenario, *p.site).total;
  for (int step = 1; step < size; step *= 2) {
    if (rank % (2 * step) == step) {
      send_bytes(formats::encode_partial(mine, id), rank - step, comm);
      return std::nullopt;
    }
    if (rank % (2 * step) == 0 && rank + step < size) {
      formats::PartialIdentity theirs;
      run::PartialRun other = formats::decode_partial(
          receive_bytes(rank + step, comm), bins, theirs, "rank " + std::to_string(rank + step));
      if (!(theirs == id)) throw std::runtime_error("a rank ran another scenario");
      run::merge(mine, std::move(other));
    }
  }
  return mine;
}

// What the ranks tell each other at each tick: histories done and to do, how many ranks still
// run their shard, how many were told to stop (a signal, or a failure of theirs), and how many
// wait at a batch boundary of a divided settings.precision run with their batch's state.
struct Tick {
  std::int64_t done = 0, total = 0, running = 0, stopping = 0, posted = 0;
};
constexpr auto kTickInterval = std::chrono::milliseconds(250);

// A nonblocking MPI_Allreduce, polled every 0.5 ms: a rank that comes early (at a batch
// boundary) waits for the others' next tick without spinning a core in the collective.
Tick exchange(Tick mine, MPI_Comm comm) {
  std::int64_t v[5] = {mine.done, mine.total, mine.running, mine.stopping, mine.posted};
  MPI_Request request;
  MPI_Iallreduce(MPI_IN_PLACE, v, 5, MPI_INT64_T, MPI_SUM, comm, &request);
  for (int complete = 0;;) {
    MPI_Test(&request, &complete, MPI_STATUS_IGNORE);
    if (complete) break;
    std::this_thread::sleep_for(std::chrono::microseconds(500));
  }
  return {v[0], v[1], v[2], v[3], v[4]};
}

// Every rank's bytes on every rank, in rank order: the sizes by MPI_Allgather, then each rank's
// bytes by MPI_Bcast from it (in messages of <= kMessageBytes).
std::vector<std::string> all_gather_bytes(const std::string& mine, int rank, int size,
                                          MPI_Comm comm) {
  std::vector<std::uint64_t> sizes(static_cast<std::size_t>(size));
  std::uint64_t n = mine.size();
  MPI_Allgather(&n, 1, MPI_UINT64_T, sizes.data(), 1, MPI_UINT64_T, comm);
  std::vector<std::string> all(static_cast<std::size_t>(size));
  for (int r = 0; r < size; ++r) {
    std::string& b = all[static_cast<std::size_t>(r)];
    if (r == rank) {
      b = mine;
    } else {
      b.resize(sizes[static_cast<std::size_t>(r)]);
    }
    for (std::uint64_t at = 0; at < b.size(); at += kMessageBytes) {
      const auto k = static_cast<int>(std::min<std::uint64_t>(kMessageBytes, b.size() - at));
      MPI_Bcast(b.data() + at, k, MPI_BYTE, r, comm);
    }
  }
  return all;
}

// The batch boundaries of a divided settings.precision run (core/run/partial.h): the shard's
// thread posts its batch's encoded state and waits; the main thread, the only one that calls
// MPI, exchanges the states at a tick where every rank has posted and hands them back, or
// aborts the boundary when a rank is told to stop. The shard's thread decodes and merges them
// (in rank order; any order gives the same bits).
class MpiBatchExchange : public run::BatchSynchronizer {
 public:
  MpiBatchExchange(formats::PartialIdentity id, std::size_t bins)
      : id_(std::move(id)), bins_(bins) {}

  std::optional<run::BatchState> exchange(const run::BatchState& mine) override {
    const auto t0 = std::chrono::steady_clock::now();
    std::string bytes = formats::encode_batch(mine, id_);
    std::vector<std::string> all;
    const auto t1 = std::chrono::steady_clock::now();
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (aborted_) return std::nullopt;
      posted_ = std::move(bytes);
      has_posted_ = true;
      cv_.notify_all();
      cv_.wait(lock, [&] { return has_result_ || aborted_; });
      if (!has_result_) return std::nullopt;
      all = std::move(result_);
      has_result_ = false;
    }
    const auto t2 = std::chrono::steady_clock::now();
    run::BatchState merged;
    for (std::size_t r = 0; r < all.size(); ++r) {
      formats::PartialIdentity theirs;
      run::BatchState b =
          formats::decode_batch(all[r], bins_, theirs, "batch state of rank " + std::to_string(r));
      if (!(theirs == id_)) throw std::runtime_error("a rank ran another scenario");
      if (r == 0) {
        merged = std::move(b);
      } else {
        run::merge(merged, std::move(b));
      }
    }
    const auto t3 = std::chrono::steady_clock::now();
    codec_s_ += std::chrono::duration<double>((t1 - t0) + (t3 - t2)).count();
    wait_s_ += std::chrono::duration<double>(t2 - t1).count();
    return merged;
  }

  // The main thread's side. Waits until `deadline` or until the shard posts its state: true
  // when one is posted.
  bool wait_posted(std::chrono::steady_clock::time_point deadline) {
    std::unique_lock<std::mutex> lock(mutex_);
    return cv_.wait_until(lock, deadline, [&] { return has_posted_; });
  }
  std::string take_posted() {
    const std::lock_guard<std::mutex> lock(mutex_);
    has_posted_ = false;
    return std::move(posted_);
  }
  void deliver(std::vector<std::string> all) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      result_ = std::move(all);
      has_result_ = true;
    }
    cv_.notify_all();
  }
  // Every boundary from now on ends the run (the shard ends cancelled).
  void abort() {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      aborted_ = true;
      has_posted_ = false;
    }
    cv_.notify_all();
  }
  std::int64_t exchanges() const { return exchanges_; }
  // The shard's seconds encoding, decoding and merging states, and waiting for the exchange
  // (for the other ranks to reach the boundary, and the transfer).
  double codec_s() const { return codec_s_; }
  double wait_s() const { return wait_s_; }
  std::uint64_t bytes() const { return bytes_; }
  void count(std::uint64_t bytes) {
    ++exchanges_;
    bytes_ += bytes;
  }

 private:
  const formats::PartialIdentity id_;
  const std::size_t bins_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::string posted_;
  std::vector<std::string> result_;
  bool has_posted_ = false, has_result_ = false, aborted_ = false;
  double codec_s_ = 0.0, wait_s_ = 0.0;  // shard thread only (read after it ends)
  std::int64_t exchanges_ = 0;           // main thread only
  std::uint64_t bytes_ = 0;              // this rank's states sent
};

// Histories of the whole run when it is not a settings.precision run (whose shards report their
// totals: every batch it may run): the shards partition each group's samples.
std::int64_t whole_samples(const app::PreparedRun& p) {
  std::int64_t n = 0;
  for (const auto& g : p.doc.scenario.groups) n += g.samples;
  return n;
}

// This rank's shard runs on a thread of its own while the main thread, the only one that calls
// MPI, exchanges a Tick with the other ranks every kTickInterval: rank 0 keeps --progress-file
// up to date for the whole run, and a signal or a failure on any rank stops every rank's shard
// within a tick. The ticks are collective, so every rank makes the same number of them: they
// end together when no rank runs any more. The exception of a failed shard is rethrown.
//
// A divided settings.precision run adds its batch boundaries to the ticks: a rank whose shard has
// posted its batch's state does not wait for the interval, and when a tick finds every rank
// posted (and none stopping), the ranks exchange their states at once (all_gather_bytes). A stop
// aborts the boundary on every rank alike: they all end at the same one.
run::PartialRun run_shard(const app::Options& o, const app::PreparedRun& p, int rank, int size,
                          MPI_Comm comm, const std::atomic<bool>& cancel,
                          app::ProgressFile& progress, bool& stopped) {
  std::atomic<bool> stop{false};
  std::atomic<std::int64_t> done{0}, total{0};
  const bool divided = p.doc.scenario.settings.precision && size > 1;
  MpiBatchExchange batches(app::identity_of(o, p), run::tally_bins(p.doc.scenario, *p.site).total);
  run::RunControl control;
  control.cancel = &stop;
  if (divided) control.synchronizer = &batches;
  control.on_progress = [&](const run::Progress& pr) {
    done.store(pr.histories_done);
    total.store(pr.histories_total);
  };
  std::exception_ptr error;
  std::atomic<bool> failed{false};
  const auto t0 = std::chrono::steady_clock::now();
  std::future<std::optional<run::PartialRun>> shard = std::async(std::launch::async, [&] {
    try {
      return std::optional(run::run_partial(p.doc.scenario, p.site, {rank, size}, control));
    } catch (...) {
      error = std::current_exception();
      failed.store(true);
      return std::optional<run::PartialRun>();
    }
  });
  const std::int64_t fallback_total = whole_samples(p);
  for (;;) {
    // After an exchange every rank waits one interval: they reach the next one together, so
    // little time is spent spinning in MPI_Allreduce on a shared node.
    const auto next = std::chrono::steady_clock::now() + kTickInterval;
    const bool posted = divided && batches.wait_posted(next);
    const bool running = shard.wait_until(posted ? std::chrono::steady_clock::now() : next) !=
                         std::future_status::ready;
    if (!running && !posted) std::this_thread::sleep_until(next);
    const Tick mine{done.load(), total.load(), running ? 1 : 0,
                    cancel.load() || failed.load() ? 1 : 0, posted ? 1 : 0};
    const Tick all = exchange(mine, comm);
    if (all.stopping > 0) {
      stop.store(true);
      stopped = true;
      batches.abort();
    } else if (divided && all.posted == size) {
      const std::string state = batches.take_posted();
      batches.count(state.size());
      batches.deliver(all_gather_bytes(state, rank, size, comm));
    }
    if (rank == 0) {
      run::Progress pr;
      pr.histories_done = all.done;
      pr.histories_total = (size == 1 || divided) && all.total > 0 ? all.total : fallback_total;
      pr.elapsed_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      progress.update(pr);
    }
    if (all.running == 0) break;
  }
  std::optional<run::PartialRun> part = shard.get();
  if (error) std::rethrow_exception(error);
  if (divided && rank == 0 && std::getenv("FRAGSIM_MPI_EXCHANGE_STATS") != nullptr)
    std::cerr << "batch exchanges: " << batches.exchanges() << ", rank 0 sent " << batches.bytes()
              << " bytes; encode/decode/merge " << batches.codec_s() << " s, waited "
              << batches.wait_s() << " s\n";
  return std::move(*part);
}

// The merge of every rank's shard r/P is the whole run: every stratum the ranks cut is closed
// again, so it is the partial of shard 0 of 1, as `fragsim run --shard 0/1` writes it (its
// figures to the bit; timings and thread counts are the ranks').
run::PartialRun as_one_shard(run::PartialRun whole) {
  whole.shard_count = 1;
  whole.shards = {0};
  return whole;
}

int run_ranks(const app::Options& o, const app::PreparedRun& p, int rank, int size, MPI_Comm comm,
              const std::atomic<bool>& cancel, formats::OutputDir* out) {
  app::ProgressFile progress(rank == 0 ? o.progress_file : std::string());
  bool stopped = false;
  run::PartialRun part = run_shard(o, p, rank, size, comm, cancel, progress, stopped);
  if (stopped || part.cancelled) {
    progress.finish("cancelled");
    if (rank == 0) std::cerr << "cancelled: no output written\n";
    return app::kExitCancelled;
  }
  std::optional<run::PartialRun> whole = reduce_partials(std::move(part), o, p, rank, size, comm);
  if (!whole) return app::kExitOk;
  if (o.shard) {  // --shard 0/1: the whole run's partial, for fragsimd or `fragsim merge`
    const int code = app::write_partial(o, p, as_one_shard(std::move(*whole)), *out);
    progress.finish(code == app::kExitOk ? "done" : "cancelled");
    return code;
  }
  run::RunResult result = run::finish(p.doc.scenario, *p.site, std::move(*whole));
  const int code = app::write_outputs(o, p, result, cancel, *out);
  progress.finish(code == app::kExitOk ? "done" : "cancelled");
  return code;
}

// Rank 0 makes --out before the run, so that one that cannot be made fails now, not after it
// (removed again unless the outputs are committed). Every rank returns the same status.
int open_out(const app::Options& o, int rank, MPI_Comm comm,
             std::unique_ptr<formats::OutputDir>& out) {
  int status = 0;
  if (rank == 0) {
    try {
      out = app::open_out(o);
    } catch (const InputError& e) {
      std::cerr << "error: " << e.what() << "\n";
      status = app::kExitInvalidInput;
    }
  }
  MPI_Bcast(&status, 1, MPI_INT, 0, comm);
  return status;
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
  app::Options o;
  std::string text;
  try {
    o = app::parse_args(args);
    if (o.command != app::Command::kRun)
      throw app::UsageError("fragsim-mpi runs one command: run SCENARIO.json --out DIR ...");
    if (o.shard && o.shard->count != 1)
      throw app::UsageError(
          "--shard: fragsim-mpi divides the histories among its ranks itself (only --shard 0/1 "
          "is taken: the whole run's DIR/partial.fsp instead of the outputs)");
  } catch (const app::UsageError& e) {
    if (rank == 0) std::cerr << "error: " << e.what() << "\n";
    return app::kExitInvalidInput;
  }
  if (const int status = broadcast_scenario(o, text, rank, comm); status != 0) return status;
  std::optional<app::PreparedRun> p;
  try {
    p = app::prepare_text(o, std::move(text));
  } catch (const InputError& e) {
    if (rank == 0) std::cerr << "error: " << e.what() << "\n";
    return app::kExitInvalidInput;
  }
  if (rank == 0 && !o.quiet) std::cerr << app::input_notes(*p);
  std::unique_ptr<formats::OutputDir> out;
  if (const int status = open_out(o, rank, comm, out); status != 0) return status;
  try {
    return run_ranks(o, *p, rank, size, comm, cancel, out.get());
  } catch (const std::exception& e) {
    std::cerr << "error (rank " << rank << "): " << e.what() << "\n";
  } catch (...) {
    std::cerr << "error (rank " << rank << "): unknown\n";
  }
  MPI_Abort(comm, app::kExitInternal);
  return app::kExitInternal;
}

}  // namespace fragsim::mpi
