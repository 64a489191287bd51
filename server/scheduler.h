#pragma once
// Runs queued jobs one at a time, highest priority then oldest, each on all of the daemon's
// Monte Carlo threads (core::run's pool; results do not depend on the thread count).
//
// A job's life: queued -> running (mark_running) -> run -> files staged and renamed into
// <data>/jobs/<job_id>/ -> one transaction marks it done with its figures. Cancelled meanwhile:
// the files are removed and the job stays cancelled. Daemon shutdown: the running job is stopped
// and queued again; being deterministic, its rerun gives the same result.
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>

#include "core/run/precision.h"
#include "server/site_registry.h"
#include "server/store.h"

namespace fragsim::server {

struct LiveProgress {
  std::string job_id;
  std::int64_t histories_done = 0;
  std::int64_t histories_total = 0;
  double elapsed_s = 0.0;
  double histories_per_s = 0.0;
  // settings.precision: the last batch boundary's check of the targets (null before it).
  std::shared_ptr<const run::PrecisionReport> precision;
};

class Scheduler {
 public:
  // `job_nice`: the nice value the job's threads run at (0 = the daemon's own), so that requests
  // are answered promptly while a job keeps the cores busy.
  Scheduler(Store& store, SiteRegistry& sites, std::filesystem::path jobs_dir, int threads,
            int job_nice = 0);
  ~Scheduler();
  Scheduler(const Scheduler&) = delete;
  Scheduler& operator=(const Scheduler&) = delete;

  void start();
  // Stops the running job (queued again) and the worker; returns when the worker has exited.
  void shutdown();
  // A job was queued.
  void notify();
  // queued|running -> cancelled; a running job is stopped and this returns once the worker has
  // let go of it (well within a second). nullopt: no such job; else the state before.
  std::optional<JobState> cancel(const std::string& job_id);

  std::optional<LiveProgress> running() const;
  // Histories of the jobs finished (done) since start: a counter, it never goes down.
  std::int64_t histories_completed() const;

  std::filesystem::path job_dir(const std::string& job_id) const { return jobs_dir_ / job_id; }

 private:
  void loop();
  void run_job(const JobRow& job);

  Store& store_;
  SiteRegistry& sites_;
  std::filesystem::path jobs_dir_;
  int threads_;
  int job_nice_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;      // worker: a job queued or shutdown
  std::condition_variable released_;  // cancel(): the worker left the running job
  bool stopping_ = false;
  bool pending_ = true;  // look at the queue before sleeping
  std::optional<LiveProgress> live_;
  std::atomic<bool> cancel_run_{false};
  std::set<std::string> cancel_pending_;  // cancelled between mark_running and run_job
  std::int64_t completed_ = 0;
  std::thread worker_;
};

}  // namespace fragsim::server
