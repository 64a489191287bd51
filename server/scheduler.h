#pragma once
// Runs queued jobs, highest priority then oldest: with the local backend one at a time on all of
// the daemon's Monte Carlo threads (core::run's pool; results do not depend on the thread count);
// with an external backend (server/backend.h) up to backend.max_jobs at once, each submitted as
// shards, followed and merged by the BackendRunner (server/backend_runner.h). Either way the
// results are committed, or the failure recorded, by JobResults (server/job_results.h).
//
// A job's life: queued -> running (mark_running) -> run (local), or submit, follow, merge the
// shards' partials (backend) -> files staged and renamed into <data>/jobs/<job_id>/ -> one
// transaction marks it done with its figures. Cancelled meanwhile: the files are removed and the
// job stays cancelled. Daemon shutdown: a local job is stopped and queued again (being
// deterministic, its rerun gives the same result); a backend job goes on running where it was
// submitted, and the next daemon re-attaches to it (adopt_backend_jobs).
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "api/scenario_json.h"
#include "core/run/precision.h"
#include "core/run/result.h"
#include "core/run/run.h"
#include "formats/output_dir.h"
#include "server/backend.h"
#include "server/backend_runner.h"
#include "server/disk_guard.h"
#include "server/job_results.h"
#include "server/site_registry.h"
#include "server/store.h"

namespace fragsim::server {

class Scheduler {
 public:
  // `job_nice`: the nice value the job's threads run at (0 = the daemon's own), so that requests
  // are answered promptly while a job keeps the cores busy.
  // `backend`: where jobs run (local: this process); `max_crashes`: a backend job whose merge
  // was interrupted by the daemon's death this many times fails (code "crashed").
  // `disk`: while it finds the data directory short of space, queued jobs wait (null: never).
  Scheduler(Store& store, SiteRegistry& sites, std::filesystem::path jobs_dir, int threads,
            int job_nice = 0, ResolvedBackend backend = {}, int max_crashes = 3,
            const DiskGuard* disk = nullptr);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  // At start, before Store::recover_interrupted: the running jobs an earlier daemon submitted to a
  // backend are followed again (whatever backend is configured now). Returns their ids; the
  // others (a local run, a submission the daemon died in) are for recover_interrupted.
  std::vector<std::string> adopt_backend_jobs();

  void start();
  // Stops the running job (queued again) and the worker; returns when the worker has exited.
  void shutdown();
  // A job was queued.
  void notify();
  // queued|running -> cancelled; a running job is stopped and this returns once the worker has
  // let go of it (well within a second). nullopt: no such job; else the state before.
  std::optional<JobState> cancel(const std::string& job_id);

  // True while the scheduler still has a hand in the job's files: its local run (also one
  // cancelled and still letting go), a backend job it follows or one whose processes it is
  // stopping. A purge waits until it lets go (server/purge.h).
  bool holds(const std::string& job_id) const;
  // The live progress of a running job (nullopt: not running here, or not started yet).
  std::optional<LiveProgress> progress(const std::string& job_id) const;
  // The speed of every running job, summed (histories per second).
  double histories_per_s() const;
  // Histories of the jobs finished (done) since start: a counter, it never goes down.
  std::int64_t histories_completed() const { return results_.histories_completed(); }

  std::filesystem::path job_dir(const std::string& job_id) const {
    return results_.job_dir(job_id);
  }
  // A backend attempt's work directory (server/backend.h).
  std::filesystem::path backend_dir(const std::string& job_id, int attempt) const {
    return backends_.workdir(job_id, attempt);
  }

 private:
  void loop();
  void run_job(const JobRow& job);
  // The run's progress (from its worker threads): the live figures GET /jobs/{id} shows, and
  // the stored count at most once a second (`last_flush`, guarded by mutex_).
  void record_progress(const std::string& id, const run::Progress& p,
                       std::chrono::steady_clock::time_point& last_flush);
  // A run that stopped early: queued again when the daemon is stopping, else a client's cancel.
  void end_interrupted(const std::string& id);
  // A stored job's scenario and site (Scheduler::load).
  struct LoadedJob {
    api::ScenarioDocument doc;
    std::shared_ptr<const SiteEntry> entry;  // the stored site it names, kept alive
    std::shared_ptr<const scene::Site> site;
    std::optional<std::string> compare_with;
    double parse_s = 0.0, build_s = 0.0;
  };
  LoadedJob load(const JobRow& job);
  void run_comparison(const JobRow& job, const LoadedJob& variant, const run::RunControl& control,
                      std::chrono::steady_clock::time_point started);
  Store& store_;
  SiteRegistry& sites_;
  int threads_;
  int job_nice_;
  bool local_;  // the local backend: queued jobs run here
  JobResults results_;
  BackendRunner backends_;
  StartGate gate_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;      // worker: a job queued or shutdown
  std::condition_variable released_;  // cancel(): the worker left the running job
  bool stopping_ = false;
  bool pending_ = true;  // look at the queue before sleeping
  std::optional<LiveProgress> live_;
  std::atomic<bool> cancel_run_{false};
  std::set<std::string> cancel_pending_;  // cancelled between mark_running and run_job
  std::thread worker_;
};

}  // namespace fragsim::server
