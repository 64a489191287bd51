#pragma once
// Removing finished jobs (docs/operations.md, "Retention"): on request
// (DELETE /v1/jobs/{id}?purge=true) and by the retention policy (--retain-days, --retain-bytes),
// the earliest finished first.
//
// A purge deletes the job's rows in one transaction, then its directory (renamed first, so that
// a half-removed directory never looks like a job's). A daemon killed between the two leaves a
// directory without a row; the next start removes it (sweep_orphans), so the store and the data
// directory agree again. Never purged: a queued or running job, one the scheduler still holds
// (cancelled and letting go), the base of a queued or running comparison.
#include <array>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "server/store.h"

namespace fragsim::server {

class Scheduler;

struct RetentionPolicy {
  double max_age_days = 0.0;   // finished longer ago than this: purged (0: no age limit)
  std::int64_t max_bytes = 0;  // the jobs directory above this: purged until below (0: none)
  double interval_s = 600.0;   // applied this often, and at start
  bool active() const { return max_age_days > 0.0 || max_bytes > 0; }
};

enum class PurgeReason { kRequest, kAge, kBytes };
inline constexpr int kPurgeReasonCount = 3;
const char* purge_reason_name(PurgeReason r);

struct PurgeResult {
  enum class Outcome {
    kPurged,
    kNoSuchJob,
    kNotFinished,     // queued or running
    kStillStopping,   // cancelled, but the scheduler still holds its files
    kComparisonBase,  // a queued or running comparison pairs with it
  } outcome = Outcome::kNoSuchJob;
  JobState state = JobState::kFailed;  // the job's state when found
  std::int64_t comparisons = 0;        // kComparisonBase: how many
  std::uint64_t bytes_freed = 0;       // kPurged: the directory's size
};

// The time of an ISO 8601 UTC stamp as the store writes it ("2026-11-29T11:40:05.123Z"), in
// seconds since the epoch; nullopt when it is not one.
std::optional<double> parse_utc(const std::string& stamp);

class JobPurger {
 public:
  // `catalogue`: held while the rows go, as job submission holds it while it checks that a
  // comparison's base job exists and queues the comparison (server/service.h).
  JobPurger(Store& store, Scheduler& scheduler, std::filesystem::path jobs_dir,
            std::mutex& catalogue);

  // `by`: who asked (a token's owner name, "retention"), for the log.
  PurgeResult purge(const std::string& job_id, PurgeReason why, const std::string& by);
  // At start, with the data directory's lock held: directories of purged jobs (a daemon killed
  // mid-purge) and half-removed ones go. Returns how many.
  std::size_t sweep_orphans();
  // The policy once, at `now_unix` (seconds since the epoch). Returns the jobs purged.
  std::size_t apply(const RetentionPolicy& policy, double now_unix);

  struct Counters {
    std::array<std::uint64_t, kPurgeReasonCount> jobs{};   // PurgeReason order
    std::array<std::uint64_t, kPurgeReasonCount> bytes{};  // bytes freed
  };
  Counters counters() const;

 private:
  std::uint64_t remove_directory(const std::string& job_id);

  Store& store_;
  Scheduler& scheduler_;
  std::filesystem::path jobs_dir_;
  std::mutex& catalogue_;
  std::mutex purge_mutex_;  // one purge at a time (a request and the timer)
  mutable std::mutex counters_mutex_;
  Counters counters_;
};

// Applies the policy at start and every interval_s on a thread of its own, until stopped.
class RetentionTimer {
 public:
  RetentionTimer(JobPurger& purger, RetentionPolicy policy);
  ~RetentionTimer();
  RetentionTimer(const RetentionTimer&) = delete;
  RetentionTimer& operator=(const RetentionTimer&) = delete;
  void stop();

 private:
  void loop();
  JobPurger& purger_;
  RetentionPolicy policy_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace fragsim::server
