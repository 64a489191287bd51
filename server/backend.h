#pragma once
// fragsimd's external backends (docs/http-api.md, "fragsimd backends"): a job runs as N shards
// (`fragsim run --shard I/N`) started by commands (mpirun, sbatch, any script), and the daemon
// follows it only through files in the job's work directory, so that it works the same for every
// engine and a restarted daemon picks it up where it was:
//
//   W = <data>/jobs/<job_id>/backend-<attempt>/
//     scenario.json          the job's scenario with its site inline: what every shard runs
//     shard.sh               runs shard I (its argument, or the rank a launcher gives it:
//                            SLURM_ARRAY_TASK_ID, OMPI_COMM_WORLD_RANK, PMI_RANK, PMIX_RANK),
//                            output to shard-I.log, then records its exit status in shard-I.exit
//     manifest.json          what was submitted: process groups or queue ids, and the expanded
//                            status and cancel commands (written "submitting", then "submitted")
//     submit-K.pid|.out|.log the K-th submit command: its process (pid and start time), stdout,
//                            stderr
//     shard-I/partial.fsp    shard I's exact tallies (run::PartialRun)
//     shard-I.progress.json  its progress, rewritten about every 0.5 s
//     shard-I.exit           its exit status, written by shard.sh when the shard ends
//     shard-I.log            its output
//
// A settings.precision job is one shard (precision_backend()); on the mpi preset its shard.sh,
// started once, runs `mpirun -np N fragsim-mpi ... --shard 0/1`, whose ranks exchange every batch
// and whose rank 0 writes shard-0/partial.fsp and shard-0.progress.json.
//
// A job is done when every shard-I.exit holds 0 and every partial.fsp is there; it has failed
// when a shard exited non-zero, or when its processes are gone (process group, or the queue's
// status) without a shard-I.exit.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "server/config.h"

namespace fragsim::server {

enum class BackendTrack {
  kProcess,  // the submit command's process group lives as long as the job (mpirun, a script)
  kQueue     // the submit command prints the queue's ids and returns (sbatch --parsable)
};

// A BackendConfig with its preset applied, its defaults filled and its templates checked.
struct ResolvedBackend {
  bool local = true;
  std::string kind = "local";
  int shards = 1;
  int max_jobs = 1;
  int threads = 0;
  std::string fragsim;
  std::vector<std::string> run;
  std::vector<std::string> submit;
  bool submit_per_shard = false;  // the submit template holds {shard}: run once per shard
  BackendTrack track = BackendTrack::kProcess;
  std::vector<std::string> status;
  std::vector<std::string> cancel;
  std::vector<std::pair<std::string, std::string>> env;
  double poll_interval_s = 0.5;
  double status_interval_s = 30.0;
  double lost_after_s = 600.0;
  double submit_timeout_s = 120.0;
  bool keep_workdir = false;
  // mpi: the command of a settings.precision job's one shard: fragsim-mpi on `shards` ranks
  // under the preset's mpirun, writing the whole run's partial (`--shard 0/1`). Empty: such a job
  // runs as one process (`run` as shard 0/1); `precision_note` then says why.
  std::vector<std::string> precision_run;
  std::string precision_note;
};

// Throws InputError naming the config key ("backend.submit[2]: unknown placeholder {shrad}").
ResolvedBackend resolve_backend(const BackendConfig& config);
// resolve_backend() as a check of the daemon's configuration at start: ConfigError naming the
// key (server/config.h's check_config() checks the rest).
void check_backend_config(const BackendConfig& config);

// The backend a settings.precision job is submitted to: one shard (its stop rule needs every
// history of a batch; independent shards cannot exchange them). With `precision_run` (mpi),
// that shard is shard.sh started once (`{shard_script} 0`, its process group followed as any
// other), running mpirun -np N fragsim-mpi, whose ranks exchange every batch and whose rank 0
// writes shard-0/partial.fsp.
ResolvedBackend precision_backend(const ResolvedBackend& backend);

// The fragsim program beside the running fragsimd (the install layout), or in the build tree
// (build/server/fragsimd -> build/cli/fragsim); else "fragsim" from PATH.
std::string default_fragsim_program();
// fragsim-mpi where this machine can see it: beside `fragsim` or `self` (fragsimd), in their
// build tree (build/cli/fragsim, build/server/fragsimd -> build/mpi/fragsim-mpi), else on PATH;
// "" when none (it is built only where CMake finds an MPI).
std::string find_fragsim_mpi(const std::filesystem::path& fragsim,
                             const std::filesystem::path& self);

// Runs `argv` and waits at most `timeout_s`; stdout and stderr go to the files given ("" :
// /dev/null). Returns the exit status, 128 + signal when killed, or -1 (could not start, or timed
// out: its process group is then killed).
int run_command(const std::vector<std::string>& argv, const std::filesystem::path& out,
                const std::filesystem::path& err, double timeout_s);

// The shard-I files of a work directory.
struct ShardFiles {
  std::filesystem::path dir, progress, exit, log;
  static ShardFiles of(const std::filesystem::path& workdir, int shard);
};

struct ShardProgress {
  std::int64_t histories_done = 0;
  std::int64_t histories_total = 0;
  double elapsed_s = 0.0;
  std::string state;               // "running" | "done" | "failed" | "cancelled" | "" (none)
  std::optional<int> exit_status;  // shard-I.exit
};

// One attempt of one job on a backend: its work directory and what was submitted.
class BackendJob {
 public:
  using Clock = std::chrono::steady_clock;

  // Writes scenario.json, shard.sh and the manifest, then runs the submit command(s). Throws
  // std::runtime_error (naming the command and its log) when a submission fails; whatever was
  // started is cancelled first.
  // `shards`: 0 for the backend's own count (a settings.precision job: precision_backend()).
  static BackendJob submit(const ResolvedBackend& backend, const std::string& job_id, int attempt,
                           const std::filesystem::path& workdir, const std::string& scenario_text,
                           int shards = 0);

  // A job submitted by an earlier daemon: nullopt when W has no manifest in state "submitted".
  static std::optional<BackendJob> attach(const std::filesystem::path& workdir);
  // An attempt a dead daemon left half submitted: stops what it may have started (best effort).
  static void abandon(const std::filesystem::path& workdir);

  struct Poll {
    enum class State { kRunning, kDone, kFailed } state = State::kRunning;
    std::vector<ShardProgress> shards;
    std::string error;  // kFailed: which shard, why, and its log file
  };
  // Reads the shard files; checks the processes (process groups: every call; queue: the status
  // command, every status_interval_s).
  Poll poll();

  // Stops the job: SIGTERM to its process groups (and the cancel command, if any); with `force`,
  // SIGKILL. Queue: the cancel command.
  void cancel(bool force);
  // Process track: no process of the job is left. Queue: true.
  bool processes_gone();

  const std::filesystem::path& workdir() const { return workdir_; }
  int shards() const { return shards_; }
  BackendTrack track() const { return track_; }
  std::filesystem::path partial_file(int shard) const;
  std::filesystem::path scenario_file() const;
  std::string describe() const;  // "process groups 1234" | "queue ids 5678"

 private:
  struct Group {
    pid_t pgid = 0;
    std::uint64_t start_time = 0;  // /proc/<pid>/stat starttime of its leader
  };
  void write_manifest(const std::string& state) const;
  // Runs submission k (`argv`, in workdir_, output to submit-k.out and .log): a process group
  // to follow, or a queue submission waited for and its job ids read from its output.
  void run_submission(const ResolvedBackend& b, int k, const std::vector<std::string>& argv);
  static std::optional<BackendJob> read_manifest(const std::filesystem::path& workdir,
                                                 std::string* state);
  bool groups_alive();
  // Queue: true when the status command says the job left the queue (or is unknown too long).
  bool queue_gone();
  std::vector<std::string> expand_ids(const std::vector<std::string>& tmpl) const;

  std::filesystem::path workdir_;
  std::string job_id_;
  int attempt_ = 0;
  int shards_ = 1;
  BackendTrack track_ = BackendTrack::kProcess;
  std::vector<Group> groups_;
  std::vector<std::string> ids_;
  std::vector<std::string> status_, cancel_;  // templates: {ids} still to expand
  double status_interval_s_ = 30.0;
  double lost_after_s_ = 600.0;
  std::string submitted_utc_;
  // Queue status bookkeeping: not persisted, and not copied. The scheduler copies a job to stop
  // it (Scheduler::cancel) while its monitor thread may be in poll() on the original, writing
  // these (a data race TSan reported in FakeSlurm.CancelRunsScancel, 2026-11-29); a copy starts
  // with none, which is all a copy needs (cancel and processes_gone do not read them).
  struct QueueWatch {
    Clock::time_point last_status{};
    bool status_checked = false;
    int gone_count = 0;
    std::optional<Clock::time_point> unknown_since;
    QueueWatch() = default;
    QueueWatch(const QueueWatch&) {}
    QueueWatch& operator=(const QueueWatch&) { return *this; }
    ~QueueWatch() = default;
  };
  QueueWatch watch_;
};

}  // namespace fragsim::server
