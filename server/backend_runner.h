#pragma once
// Jobs on an external backend (server/backend.h): a monitor thread submits queued jobs as shards
// (backend mode), follows every backend job through its work directory (also those a local-mode
// daemon adopted at start), merges the shards' partials when all are done and commits the result
// (server/job_results.h); cancelled or failed jobs' processes are stopped, killed after a grace.
// The Scheduler (server/scheduler.h) owns one and leaves backend jobs to it.
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "core/run/result.h"
#include "server/backend.h"
#include "server/disk_guard.h"
#include "server/job_results.h"
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

class BackendRunner {
 public:
  // `max_crashes`: a job whose merge was interrupted by the daemon's death this many times
  // fails (code "crashed"). `disk`: while it finds the data directory short, queued jobs wait.
  BackendRunner(Store& store, SiteRegistry& sites, JobResults& results, ResolvedBackend backend,
                int max_crashes, const DiskGuard* disk);
  ~BackendRunner();
  BackendRunner(const BackendRunner&) = delete;
  BackendRunner& operator=(const BackendRunner&) = delete;

  // At start, before Store::recover_interrupted: the running jobs an earlier daemon submitted to
  // a backend are followed again. Returns their ids.
  std::vector<std::string> adopt();
  // Starts the monitor thread at `job_nice` (inherited by the processes it starts).
  void start(int job_nice);
  void shutdown();
  // A job was queued (backend mode: the monitor submits it).
  void notify();
  // A running job was cancelled in the store: true when it is this runner's (followed, or being
  // submitted in backend mode); its processes are then stopped.
  bool cancel(const std::string& job_id);

  bool holds(const std::string& job_id) const;
  std::optional<LiveProgress> progress(const std::string& job_id) const;
  double histories_per_s() const;

  // A backend attempt's work directory (server/backend.h).
  std::filesystem::path workdir(const std::string& job_id, int attempt) const;

 private:
  struct Tracked;   // a backend job being followed
  struct Stopping;  // a cancelled or failed backend job whose processes may still be at work

  void monitor_loop();
  void submit_queued();
  void submit(JobRow row);
  void follow();
  void finish(Tracked& t);
  void stop(const BackendJob& job, bool remove_workdir);
  void sweep_stopping();
  // The job's scenario as a stand-alone file would hold it: a site_id replaced by the site.
  std::string stand_alone_scenario(const JobRow& job);

  Store& store_;
  SiteRegistry& sites_;
  JobResults& results_;
  const ResolvedBackend backend_;
  const int max_crashes_;
  StartGate gate_;

  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool pending_ = true;                                      // look at the queue before sleeping
  std::set<std::string> cancel_pending_;                     // cancelled while being submitted
  std::map<std::string, std::shared_ptr<Tracked>> tracked_;  // by job id
  std::vector<std::shared_ptr<Stopping>> stopping_jobs_;
  std::thread monitor_;
};

}  // namespace fragsim::server
