#include "server/purge.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <system_error>
#include <vector>

#include "api/job_request.h"
#include "server/log.h"
#include "server/scheduler.h"

namespace fragsim::server {

namespace fs = std::filesystem;

namespace {

// A directory being removed: renamed to this first, so that a daemon killed halfway leaves
// something sweep_orphans knows to finish.
constexpr const char* kPurgingPrefix = ".purging-";

std::uint64_t directory_bytes(const fs::path& dir) {
  std::uint64_t n = 0;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, fs::directory_options::skip_permission_denied, ec),
       end;
       !ec && it != end; it.increment(ec)) {
    std::error_code e;
    if (it->is_regular_file(e)) n += it->file_size(e);
  }
  return n;
}

std::size_t reason_index(PurgeReason r) {
  return static_cast<std::size_t>(r);
}

}  // namespace

const char* purge_reason_name(PurgeReason r) {
  switch (r) {
    case PurgeReason::kRequest: return "request";
    case PurgeReason::kAge: return "age";
    case PurgeReason::kBytes: return "bytes";
  }
  return "request";
}

std::optional<double> parse_utc(const std::string& stamp) {
  std::tm tm{};
  int ms = 0;
  char z = 0;
  // 2026-11-29T11:40:05.123Z (the store's stamps: server/log.h, utc_now)
  if (std::sscanf(stamp.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d.%3d%c", &tm.tm_year, &tm.tm_mon,
                  &tm.tm_mday, &tm.tm_hour, &tm.tm_min, &tm.tm_sec, &ms, &z) != 8 ||
      z != 'Z')
    return std::nullopt;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  return static_cast<double>(timegm(&tm)) + ms / 1000.0;
}

JobPurger::JobPurger(Store& store, Scheduler& scheduler, fs::path jobs_dir, std::mutex& catalogue)
    : store_(store), scheduler_(scheduler), jobs_dir_(std::move(jobs_dir)), catalogue_(catalogue) {}

PurgeResult JobPurger::purge(const std::string& job_id, PurgeReason why, const std::string& by) {
  const std::lock_guard<std::mutex> lock(purge_mutex_);
  PurgeResult r;
  // A running job is held too; it is named as running, not as "letting go".
  if (const auto row = store_.job(job_id);
      row && is_final(row->state) && scheduler_.holds(job_id)) {
    r.outcome = PurgeResult::Outcome::kStillStopping;
    r.state = row->state;
    return r;
  }
  Store::Removal removal;
  {
    const std::lock_guard<std::mutex> catalogue(catalogue_);
    removal = store_.remove_finished_job(job_id);
  }
  r.state = removal.state;
  r.comparisons = removal.comparisons;
  switch (removal.outcome) {
    case Store::Removal::Outcome::kNoSuchJob:
      r.outcome = PurgeResult::Outcome::kNoSuchJob;
      return r;
    case Store::Removal::Outcome::kNotFinished:
      r.outcome = PurgeResult::Outcome::kNotFinished;
      return r;
    case Store::Removal::Outcome::kComparisonBase:
      r.outcome = PurgeResult::Outcome::kComparisonBase;
      return r;
    case Store::Removal::Outcome::kRemoved: break;
  }
  // The rows are gone: from here on the job does not exist for any request.
  r.outcome = PurgeResult::Outcome::kPurged;
  r.bytes_freed = remove_directory(job_id);
  {
    const std::lock_guard<std::mutex> c(counters_mutex_);
    counters_.jobs[reason_index(why)] += 1;
    counters_.bytes[reason_index(why)] += r.bytes_freed;
  }
  log(LogLevel::kInfo, "job purged",
      {{"job_id", job_id},
       {"was", job_state_name(r.state)},
       {"reason", purge_reason_name(why)},
       {"by", by},
       {"bytes_freed", std::to_string(r.bytes_freed)}});
  return r;
}

std::uint64_t JobPurger::remove_directory(const std::string& job_id) {
  const fs::path dir = jobs_dir_ / job_id;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return 0;  // never started, or removed by an earlier attempt
  const std::uint64_t bytes = directory_bytes(dir);
  const fs::path doomed = jobs_dir_ / (kPurgingPrefix + job_id);
  fs::rename(dir, doomed, ec);
  const fs::path& target = ec ? dir : doomed;
  fs::remove_all(target, ec);
  if (ec)
    log(LogLevel::kWarn, "purged job's directory not removed; the next start tries again",
        {{"job_id", job_id}, {"path", target.string()}, {"error", ec.message()}});
  return bytes;
}

std::size_t JobPurger::sweep_orphans() {
  std::size_t n = 0;
  std::error_code ec;
  std::vector<fs::path> doomed;
  for (fs::directory_iterator it(jobs_dir_, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.starts_with(kPurgingPrefix) ||
        (api::is_job_id(name) && it->is_directory(ec) && !store_.has_job(name)))
      doomed.push_back(it->path());
  }
  for (const auto& p : doomed) {
    std::error_code e;
    fs::remove_all(p, e);
    if (e) {
      log(LogLevel::kWarn, "directory of a purged job not removed",
          {{"path", p.string()}, {"error", e.message()}});
    } else {
      ++n;
    }
  }
  return n;
}

std::size_t JobPurger::apply(const RetentionPolicy& policy, double now_unix) {
  if (!policy.active()) return 0;
  std::size_t purged = 0;
  const auto finished = store_.finished_jobs();  // earliest finished first
  std::vector<bool> gone(finished.size(), false);
  if (policy.max_age_days > 0.0) {
    const double cutoff = now_unix - policy.max_age_days * 86400.0;
    for (std::size_t k = 0; k < finished.size(); ++k) {
      const auto t = parse_utc(finished[k].finished_utc);
      if (!t || *t >= cutoff) break;  // the rest finished later
      if (purge(finished[k].job_id, PurgeReason::kAge, "retention").outcome ==
          PurgeResult::Outcome::kPurged) {
        gone[k] = true;
        ++purged;
      }
    }
  }
  if (policy.max_bytes > 0) {
    std::uint64_t total = directory_bytes(jobs_dir_);
    const auto limit = static_cast<std::uint64_t>(policy.max_bytes);
    for (std::size_t k = 0; k < finished.size() && total > limit; ++k) {
      if (gone[k]) continue;
      const PurgeResult r = purge(finished[k].job_id, PurgeReason::kBytes, "retention");
      if (r.outcome != PurgeResult::Outcome::kPurged) continue;
      total -= std::min(total, r.bytes_freed);
      ++purged;
    }
    if (total > limit)
      log(LogLevel::kWarn, "jobs directory above --retain-bytes with no finished job left to purge",
          {{"bytes", std::to_string(total)}, {"limit", std::to_string(limit)}});
  }
  return purged;
}

JobPurger::Counters JobPurger::counters() const {
  const std::lock_guard<std::mutex> lock(counters_mutex_);
  return counters_;
}

RetentionTimer::RetentionTimer(JobPurger& purger, RetentionPolicy policy)
    : purger_(purger), policy_(policy) {
  if (policy_.active()) thread_ = std::thread([this] { loop(); });
}

RetentionTimer::~RetentionTimer() {
  stop();
}

void RetentionTimer::stop() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

void RetentionTimer::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    lock.unlock();
    try {
      const double now =
          std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
              .count();
      purger_.apply(policy_, now);
    } catch (const std::exception& e) {
      // A database fault: logged, and tried again at the next interval.
      log(LogLevel::kError, "retention failed", {{"error", e.what()}});
    }
    lock.lock();
    wake_.wait_for(lock, std::chrono::duration<double>(policy_.interval_s),
                   [&] { return stopping_; });
  }
}

}  // namespace fragsim::server
