#include "server/backend_runner.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <system_error>
#include <utility>

#include "api/job_request.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "core/common/error.h"
#include "core/run/partial.h"
#include "formats/partial_file.h"
#include "server/log.h"
#include "server/thread_nice.h"

namespace fragsim::server {

namespace {

using Clock = std::chrono::steady_clock;

std::string read_text_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + p.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

// The shards' partial tallies merged and finished: the result run::run gives for the whole run,
// bit for bit, whatever the split (core/run/partial.h). Every partial must carry the identity of
// the scenario file the daemon wrote (formats/partial_file.h).
run::RunResult merge_partials(const run::Scenario& scenario, const scene::Site& site,
                              const BackendJob& job) {
  formats::PartialIdentity expected;
  expected.scenario_sha256 = api::sha256_hex(read_text_file(job.scenario_file()));
  const std::size_t bins = run::tally_bins(scenario, site).total;
  std::optional<run::PartialRun> merged;
  for (int k = 0; k < job.shards(); ++k) {
    const auto file = job.partial_file(k);
    formats::PartialIdentity identity;
    run::PartialRun part = formats::read_partial_file(file, bins, identity);
    if (part.cancelled)  // a worker writes nothing when cancelled
      throw std::runtime_error("shard " + std::to_string(k) + ": " + file.string() +
                               " is the partial of a cancelled shard: nothing to merge");
    if (!(identity == expected))
      throw std::runtime_error("shard " + std::to_string(k) + ": " + file.string() +
                               " is the partial of another scenario (its digest " +
                               identity.scenario_sha256 + ", this job's " +
                               expected.scenario_sha256 + ")");
    if (!merged)
      merged = std::move(part);
    else
      run::merge(*merged, std::move(part));
  }
  if (!merged) throw std::runtime_error("no shard to merge");
  return run::finish(scenario, site, std::move(*merged));
}

// How often the daemon began merging this attempt's shards (a counter file in its directory):
// a merge that kills the daemon must not be retried for ever.
int count_finish_attempt(const std::filesystem::path& workdir) {
  const auto file = workdir / "finish-attempts";
  int n = 0;
  {
    std::ifstream in(file);
    in >> n;
  }
  ++n;
  {
    std::ofstream out(file, std::ios::trunc);
    out << n << "\n";
  }
  formats::fsync_path(file);
  return n;
}

}  // namespace

struct BackendRunner::Tracked {
  JobRow row;  // with its scenario
  BackendJob job;
  LiveProgress live;
  Clock::time_point started;
  Clock::time_point last_flush{};
};

struct BackendRunner::Stopping {
  BackendJob job;
  Clock::time_point since;
  bool killed = false;
  bool remove_workdir = false;
};

BackendRunner::BackendRunner(Store& store, SiteRegistry& sites, JobResults& results,
                             ResolvedBackend backend, int max_crashes, const DiskGuard* disk)
    : store_(store),
      sites_(sites),
      results_(results),
      backend_(std::move(backend)),
      max_crashes_(max_crashes),
      gate_(disk) {}

BackendRunner::~BackendRunner() {
  shutdown();
}

std::filesystem::path BackendRunner::workdir(const std::string& job_id, int attempt) const {
  return results_.job_dir(job_id) / ("backend-" + std::to_string(attempt));
}

void BackendRunner::start(int job_nice) {
  if (backend_.kind == "mpi" && !backend_.precision_run.empty())
    log(LogLevel::kInfo, "mpi backend: settings.precision jobs divided among fragsim-mpi ranks",
        {{"ranks", std::to_string(backend_.shards)},
         {"command", join_words(backend_.precision_run)}});
  else if (backend_.kind == "mpi")
    log(LogLevel::kWarn, "mpi backend: settings.precision jobs run as one process",
        {{"reason", backend_.precision_note}});
  // Backend jobs: submitted (backend mode) and followed (also those adopted in local mode).
  monitor_ = std::thread([this, job_nice] {
    lower_thread_priority(job_nice);  // and by the processes it starts (a local mpirun)
    monitor_loop();
  });
}

void BackendRunner::shutdown() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (monitor_.joinable()) monitor_.join();
}

void BackendRunner::notify() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pending_ = true;
  }
  wake_.notify_all();
}

bool BackendRunner::cancel(const std::string& job_id) {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto it = tracked_.find(job_id);
  if (it == tracked_.end()) {
    if (backend_.local) return false;  // a local run (the scheduler's)
    // Marked running but not submitted yet: submit() sees this and stops what it started.
    cancel_pending_.insert(job_id);
    return true;
  }
  // Its cancel action runs now, on a copy (the monitor may be reading its files); the monitor
  // kills what is left after a grace and clears its work directory.
  const BackendJob job = it->second->job;
  tracked_.erase(it);
  lock.unlock();
  stop(job, !backend_.keep_workdir);
  log(LogLevel::kInfo, "backend job cancelled", {{"job_id", job_id}, {"backend", job.describe()}});
  return true;
}

bool BackendRunner::holds(const std::string& job_id) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (cancel_pending_.contains(job_id) || tracked_.contains(job_id)) return true;
  const auto dir = results_.job_dir(job_id);
  return std::any_of(stopping_jobs_.begin(), stopping_jobs_.end(),
                     [&](const auto& s) { return s->job.workdir().parent_path() == dir; });
}

std::optional<LiveProgress> BackendRunner::progress(const std::string& job_id) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (const auto it = tracked_.find(job_id); it != tracked_.end()) return it->second->live;
  return std::nullopt;
}

double BackendRunner::histories_per_s() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  double rate = 0.0;
  for (const auto& [id, t] : tracked_) rate += t->live.histories_per_s;
  return rate;
}

std::string BackendRunner::stand_alone_scenario(const JobRow& job) {
  nlohmann::json j = api::split_stored_request(api::parse_json_text(job.scenario_json)).scenario;
  if (const auto it = j.find("site_id"); it != j.end() && it->is_string()) {
    const std::string site_id = it->get<std::string>();
    const auto entry = sites_.find(site_id);
    if (!entry) throw InputError("site_id", "unknown site \"" + site_id + "\"");
    j.erase("site_id");
    j["site"] = entry->normalised;
  }
  return j.dump();
}

std::vector<std::string> BackendRunner::adopt() {
  std::vector<std::string> adopted;
  for (auto& row : store_.running_jobs()) {
    const auto dir = workdir(row.job_id, row.attempts);
    std::error_code ec;
    if (!std::filesystem::exists(dir, ec)) continue;  // a local run
    auto job = BackendJob::attach(dir);
    if (!job) {
      // The daemon died while submitting it: stop whatever it may have started; it is queued
      // again by recover_interrupted.
      BackendJob::abandon(dir);
      log(LogLevel::kWarn, "backend submission interrupted; stopped what it had started",
          {{"job_id", row.job_id}, {"workdir", dir.string()}});
      continue;
    }
    auto t = std::make_shared<Tracked>(Tracked{row, std::move(*job), {}, Clock::now(), {}});
    t->live = LiveProgress{row.job_id, row.histories_done, row.histories_total, 0.0, 0.0, nullptr};
    log(LogLevel::kInfo, "backend job re-attached",
        {{"job_id", row.job_id}, {"backend", t->job.describe()}, {"workdir", dir.string()}});
    adopted.push_back(row.job_id);
    const std::lock_guard<std::mutex> lock(mutex_);
    tracked_[row.job_id] = std::move(t);
  }
  return adopted;
}

void BackendRunner::monitor_loop() {
  const auto interval = std::chrono::duration<double>(backend_.poll_interval_s);
  while (true) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      wake_.wait_for(lock, interval, [&] { return stopping_ || pending_; });
      if (stopping_) return;
      pending_ = false;
    }
    try {
      follow();
      sweep_stopping();
      if (!backend_.local) submit_queued();
    } catch (const std::exception& e) {
      log(LogLevel::kError, "scheduler error", {{"error", e.what()}});
    }
  }
}

// Backend mode: queued jobs submitted while fewer than backend.max_jobs are followed.
void BackendRunner::submit_queued() {
  while (true) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_ || static_cast<int>(tracked_.size()) >= backend_.max_jobs) return;
    }
    if (!gate_.room()) return;
    const auto job = store_.next_queued();
    if (!job) return;
    if (!store_.mark_running(job->job_id, utc_now())) continue;  // cancelled meanwhile
    JobRow row = *job;
    row.attempts += 1;  // mark_running counted this start
    try {
      submit(std::move(row));
    } catch (...) {
      results_.fail_with_current_exception(job->job_id, "backend", "submitting the job");
    }
  }
}

// Submits a job marked running as its shards (or as one, a settings.precision job) and follows
// it; a job cancelled meanwhile is stopped again.
void BackendRunner::submit(JobRow row) {
  const std::string id = row.job_id;
  // Parsed here so that a scenario the run would refuse fails as it would locally.
  const std::string scenario = stand_alone_scenario(row);
  const auto doc = api::parse_scenario_document_text(scenario);
  // A settings.precision run decides at each batch boundary from all the batch's histories:
  // it runs as one shard (on the mpi preset, fragsim-mpi's ranks exchanging every batch).
  const bool precision = doc.scenario.settings.precision.has_value();
  const ResolvedBackend b = precision ? precision_backend(backend_) : backend_;
  auto submitted = BackendJob::submit(b, id, row.attempts, workdir(id, row.attempts), scenario);
  auto t = std::make_shared<Tracked>(Tracked{row, std::move(submitted), {}, Clock::now(), {}});
  t->live = LiveProgress{id, 0, row.histories_total, 0.0, 0.0, nullptr};
  if (precision && !backend_.precision_run.empty())
    log(LogLevel::kInfo, "job submitted to backend",
        {{"job_id", id},
         {"backend", backend_.kind},
         {"shards", "1"},
         {"ranks", std::to_string(backend_.shards)},
         {"submitted", t->job.describe()},
         {"histories", std::to_string(row.histories_total)}});
  else
    log(LogLevel::kInfo, "job submitted to backend",
        {{"job_id", id},
         {"backend", backend_.kind},
         {"shards", std::to_string(b.shards)},
         {"submitted", t->job.describe()},
         {"histories", std::to_string(row.histories_total)}});
  bool cancelled = false;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    cancelled = cancel_pending_.erase(id) > 0;
    if (!cancelled) tracked_[id] = t;
  }
  if (cancelled) stop(t->job, !backend_.keep_workdir);
}

void BackendRunner::follow() {
  std::vector<std::shared_ptr<Tracked>> jobs;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    for (const auto& [id, t] : tracked_) jobs.push_back(t);
  }
  for (const auto& t : jobs) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_) return;
      if (tracked_.count(t->row.job_id) == 0) continue;  // cancelled meanwhile
    }
    const std::string& id = t->row.job_id;
    const BackendJob::Poll p = t->job.poll();
    // Progress as a local run shows it: histories done, and the speed of the shards at work.
    std::int64_t done = 0;
    double rate = 0.0, elapsed = 0.0;
    for (const auto& s : p.shards) {
      done += s.histories_done;
      elapsed = std::max(elapsed, s.elapsed_s);
      if (!s.exit_status && s.elapsed_s > 0 && s.histories_done > 0)
        rate += static_cast<double>(s.histories_done) / s.elapsed_s;
    }
    done = std::min(done, t->row.histories_total);
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      t->live.histories_done = std::max(done, t->live.histories_done);
      t->live.elapsed_s = elapsed;
      t->live.histories_per_s = rate;
    }
    const auto now = Clock::now();
    if (now - t->last_flush >= std::chrono::seconds(1)) {
      t->last_flush = now;
      store_.update_progress(id, t->live.histories_done);
    }
    if (p.state == BackendJob::Poll::State::kRunning) continue;
    if (p.state == BackendJob::Poll::State::kFailed) {
      {
        const std::lock_guard<std::mutex> lock(mutex_);
        tracked_.erase(id);
      }
      store_.mark_failed(id, utc_now(), "backend", p.error);
      log(LogLevel::kWarn, "job failed", {{"job_id", id}, {"error", p.error}});
      stop(t->job, false);  // the other shards; the directory is kept for its logs
      continue;
    }
    finish(*t);
    const std::lock_guard<std::mutex> lock(mutex_);
    tracked_.erase(id);
  }
}

void BackendRunner::finish(Tracked& t) {
  const JobRow& job = t.row;
  const std::string& id = job.job_id;
  const auto started = Clock::now();
  try {
    if (const int n = count_finish_attempt(t.job.workdir()); n > max_crashes_) {
      results_.fail(id, "crashed",
                    "the daemon stopped abnormally " + std::to_string(n - 1) +
                        " times while merging this job's shards");
      return;
    }
    std::shared_ptr<const SiteEntry> entry;
    const api::SiteResolver resolve = sites_.resolver(entry);
    api::ScenarioDocument doc = api::parse_scenario_document(
        api::split_stored_request(api::parse_json_text(job.scenario_json)).scenario, &resolve);
    const std::shared_ptr<const scene::Site> site =
        entry ? entry->site : api::validate_scenario(doc.scenario);
    run::RunResult result = merge_partials(doc.scenario, *site, t.job);
    if (!results_.commit(job, doc, *site, result, started)) return;
    if (!backend_.keep_workdir) {
      std::error_code ec;
      std::filesystem::remove_all(t.job.workdir(), ec);
    }
  } catch (...) {
    results_.fail_with_current_exception(id, "backend", "merging the shards");
  }
}

void BackendRunner::stop(const BackendJob& job, bool remove_workdir) {
  BackendJob copy = job;
  copy.cancel(false);
  const std::lock_guard<std::mutex> lock(mutex_);
  stopping_jobs_.push_back(
      std::make_shared<Stopping>(Stopping{std::move(copy), Clock::now(), false, remove_workdir}));
}

// Cancelled or failed backend jobs: SIGKILL for what is still at work after 10 s; the work
// directory of a cancelled one goes once nothing writes to it any more.
void BackendRunner::sweep_stopping() {
  std::vector<std::shared_ptr<Stopping>> list;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    list = stopping_jobs_;
  }
  std::vector<std::shared_ptr<Stopping>> done;
  const auto now = Clock::now();
  for (const auto& s : list) {
    const bool gone = s->job.processes_gone();
    const bool grace_over = now - s->since > std::chrono::seconds(10);
    if (!gone && grace_over && !s->killed) {
      s->job.cancel(true);
      s->killed = true;
    }
    // A queue's tasks may still be stopping where the daemon cannot see them: 10 s.
    if (gone && (grace_over || s->job.track() == BackendTrack::kProcess)) {
      if (s->remove_workdir) {
        std::error_code ec;
        std::filesystem::remove_all(s->job.workdir(), ec);
      }
      done.push_back(s);
    } else if (now - s->since > std::chrono::minutes(10)) {
      done.push_back(s);  // leave it: logged once
      log(LogLevel::kWarn, "backend job still has processes 10 minutes after it was stopped",
          {{"workdir", s->job.workdir().string()}, {"backend", s->job.describe()}});
    }
  }
  const std::lock_guard<std::mutex> lock(mutex_);
  std::erase_if(stopping_jobs_, [&](const auto& s) {
    return std::find(done.begin(), done.end(), s) != done.end();
  });
}

}  // namespace fragsim::server
