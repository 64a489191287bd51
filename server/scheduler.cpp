#include "server/scheduler.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <fstream>
#include <sstream>

#include "api/compare_json.h"
#include "api/job_request.h"
#include "api/partial_file.h"
#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "api/summary_json.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "core/run/partial.h"
#include "core/run/run.h"
#include "server/log.h"

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

std::vector<BuildingRow> building_rows(const run::RunResult& r) {
  std::vector<BuildingRow> rows;
  for (const auto& b : r.buildings)
    rows.push_back(
        {b.id, b.impacts.mean, b.impacts.std_error, b.penetrations.mean, b.penetrations.std_error});
  return rows;
}

// Linux keeps a nice value per thread, and a new thread starts with its creator's.
void lower_thread_priority(int nice) {
  if (nice <= 0) return;
  const auto tid = static_cast<id_t>(::syscall(SYS_gettid));
  if (::setpriority(PRIO_PROCESS, tid, nice) != 0)
    log(LogLevel::kWarn, "job priority not lowered", {{"error", std::strerror(errno)}});
}

std::string join_words(const std::vector<std::string>& words) {
  std::string out;
  for (const auto& w : words) out += (out.empty() ? "" : " ") + w;
  return out;
}

// The shards' partial tallies merged and finished: the result run::run gives for the whole run,
// bit for bit, whatever the split (core/run/partial.h). Every partial must carry the identity of
// the scenario file the daemon wrote (api/partial_file.h).
run::RunResult merge_partials(const run::Scenario& scenario, const scene::Site& site,
                              const BackendJob& job) {
  api::PartialIdentity expected;
  expected.scenario_sha256 = api::sha256_hex(read_text_file(job.scenario_file()));
  const std::size_t bins = run::tally_bins(scenario, site).total;
  std::optional<run::PartialRun> merged;
  for (int k = 0; k < job.shards(); ++k) {
    const auto file = job.partial_file(k);
    api::PartialIdentity identity;
    run::PartialRun part = api::read_partial_file(file, bins, identity);
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

}  // namespace

struct Scheduler::Tracked {
  JobRow row;  // with its scenario
  BackendJob job;
  LiveProgress live;
  Clock::time_point started;
  Clock::time_point last_flush{};
};

struct Scheduler::Stopping {
  BackendJob job;
  Clock::time_point since;
  bool killed = false;
  bool remove_workdir = false;
};

Scheduler::Scheduler(Store& store, SiteRegistry& sites, std::filesystem::path jobs_dir, int threads,
                     int job_nice, ResolvedBackend backend, int max_crashes, const DiskGuard* disk)
    : store_(store),
      sites_(sites),
      jobs_dir_(std::move(jobs_dir)),
      threads_(threads),
      job_nice_(job_nice),
      backend_(std::move(backend)),
      max_crashes_(max_crashes),
      disk_(disk) {}

std::filesystem::path Scheduler::backend_dir(const std::string& job_id, int attempt) const {
  return job_dir(job_id) / ("backend-" + std::to_string(attempt));
}

Scheduler::~Scheduler() {
  shutdown();
}

void Scheduler::start() {
  if (backend_.local) {
    worker_ = std::thread([this] {
      lower_thread_priority(job_nice_);  // inherited by the run's threads, which this one creates
      loop();
    });
  }
  if (backend_.kind == "mpi" && !backend_.precision_run.empty())
    log(LogLevel::kInfo, "mpi backend: settings.precision jobs divided among fragsim-mpi ranks",
        {{"ranks", std::to_string(backend_.shards)},
         {"command", join_words(backend_.precision_run)}});
  else if (backend_.kind == "mpi")
    log(LogLevel::kWarn, "mpi backend: settings.precision jobs run as one process",
        {{"reason", backend_.precision_note}});
  // Backend jobs: submitted (backend mode) and followed (also those adopted in local mode).
  monitor_ = std::thread([this] {
    lower_thread_priority(job_nice_);  // and by the processes it starts (a local mpirun)
    monitor_loop();
  });
}

void Scheduler::shutdown() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    cancel_run_ = true;
  }
  wake_.notify_all();
  monitor_wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  if (monitor_.joinable()) monitor_.join();
}

void Scheduler::notify() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pending_ = true;
  }
  wake_.notify_all();
  monitor_wake_.notify_all();
}

std::optional<JobState> Scheduler::cancel(const std::string& job_id) {
  const auto before = store_.cancel(job_id, utc_now());
  if (before != JobState::kRunning) return before;
  std::unique_lock<std::mutex> lock(mutex_);
  if (const auto it = tracked_.find(job_id); it != tracked_.end()) {
    // A backend job: its cancel action runs now, on a copy (the monitor may be reading its
    // files); the monitor kills what is left after a grace and clears its work directory.
    const BackendJob job = it->second->job;
    tracked_.erase(it);
    lock.unlock();
    stop_backend_job(job, !backend_.keep_workdir);
    log(LogLevel::kInfo, "backend job cancelled",
        {{"job_id", job_id}, {"backend", job.describe()}});
    return before;
  }
  if (!live_ || live_->job_id != job_id) {
    // Marked running but not started yet: run_job() sees this and stops at once.
    cancel_pending_.insert(job_id);
  } else {
    cancel_run_ = true;
    released_.wait_for(lock, std::chrono::seconds(5),
                       [&] { return !live_ || live_->job_id != job_id; });
  }
  return before;
}

bool Scheduler::holds(const std::string& job_id) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (live_ && live_->job_id == job_id) return true;
  if (cancel_pending_.contains(job_id) || tracked_.contains(job_id)) return true;
  const auto dir = job_dir(job_id);
  return std::any_of(stopping_jobs_.begin(), stopping_jobs_.end(),
                     [&](const auto& s) { return s->job.workdir().parent_path() == dir; });
}

std::optional<LiveProgress> Scheduler::progress(const std::string& job_id) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (live_ && live_->job_id == job_id) return live_;
  if (const auto it = tracked_.find(job_id); it != tracked_.end()) return it->second->live;
  return std::nullopt;
}

double Scheduler::histories_per_s() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  double rate = live_ ? live_->histories_per_s : 0.0;
  for (const auto& [id, t] : tracked_) rate += t->live.histories_per_s;
  return rate;
}

std::int64_t Scheduler::histories_completed() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return completed_;
}

void Scheduler::loop() {
  while (true) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // The timeout is a safety net only: notify() wakes the worker when a job is queued.
      wake_.wait_for(lock, std::chrono::seconds(1), [&] { return stopping_ || pending_; });
      if (stopping_) return;
      pending_ = false;
    }
    try {
      while (true) {
        {
          const std::lock_guard<std::mutex> lock(mutex_);
          if (stopping_) return;
        }
        if (!room_to_start()) break;  // checked again on the next wake-up (1 s at most)
        const auto job = store_.next_queued();
        if (!job) break;
        if (!store_.mark_running(job->job_id, utc_now())) continue;  // cancelled meanwhile
        run_job(*job);
      }
    } catch (const std::exception& e) {
      // A database fault: keep the worker alive and try again on the next wake-up.
      log(LogLevel::kError, "scheduler error", {{"error", e.what()}});
    }
  }
}

// False while the data directory is short of space (the disk guard): queued jobs wait. Logged
// when that starts and when it ends. Called by one thread only (the worker, or the monitor with
// a backend).
bool Scheduler::room_to_start() {
  const auto found = disk_ != nullptr ? disk_->short_of_space() : std::nullopt;
  if (found.has_value() != disk_short_) {
    disk_short_ = found.has_value();
    if (found)
      log(LogLevel::kWarn, "queued jobs wait for disk space",
          {{"free_bytes", std::to_string(found->free_bytes)},
           {"min_free_bytes", std::to_string(disk_->min_free_bytes())}});
    else
      log(LogLevel::kInfo, "disk space back; queued jobs start");
  }
  return !found;
}

// Records a failed job (its error as GET /v1/jobs/{id} shows it) and logs it.
void Scheduler::fail_job(const std::string& id, const std::string& code,
                         const std::string& message) {
  store_.mark_failed(id, utc_now(), code, message);
  log(code == "invalid_input" ? LogLevel::kWarn : LogLevel::kError, "job failed",
      {{"job_id", id}, {"code", code}, {"error", message}});
}

void Scheduler::run_job(const JobRow& job) {
  const std::string& id = job.job_id;
  const auto started = Clock::now();
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    cancel_run_ = stopping_ || cancel_pending_.erase(id) > 0;
    live_ = LiveProgress{id, 0, job.histories_total, 0.0, 0.0, nullptr};
  }
  // Whatever happens below, the worker lets go of the job and wakes a waiting cancel().
  struct Release {
    Scheduler& s;
    ~Release() {
      {
        const std::lock_guard<std::mutex> lock(s.mutex_);
        s.live_.reset();
      }
      s.released_.notify_all();
    }
  } release{*this};

  log(LogLevel::kInfo, "job started",
      {{"job_id", id}, {"histories", std::to_string(job.histories_total)}});
  try {
    const LoadedJob v = load(job);
    auto last_flush = Clock::now();
    run::RunControl control;
    control.cancel = &cancel_run_;
    control.progress_interval_s = 0.2;
    control.on_progress = [&](const run::Progress& p) { record_progress(id, p, last_flush); };
    if (v.compare_with) return run_comparison(job, v, control, started);
    run::RunResult result = run::run(v.doc.scenario, v.site, control);
    result.timing.parse_s = v.parse_s;
    result.timing.build_s = v.build_s;
    if (result.cancelled || cancel_run_.load()) return end_interrupted(id);
    if (!persist(job, v.doc, *v.site, result, started)) return;
  } catch (const InputError& e) {
    fail_job(id, "invalid_input", e.what());
  } catch (const api::StorageFullError& e) {
    fail_job(id, "storage_full", e.what());
  } catch (const std::bad_alloc&) {
    fail_job(id, "internal", "out of memory");
  } catch (const std::exception& e) {
    fail_job(id, "internal", e.what());
  }
}

// A stored job's request: its scenario parsed and its site built (a stored site: shared, built
// at upload; an inline one: built now), and compare_with.
Scheduler::LoadedJob Scheduler::load(const JobRow& job) {
  LoadedJob out;
  const api::SiteResolver resolve = sites_.resolver(out.entry);
  const auto t_parse = Clock::now();
  api::StoredRequest request = api::split_stored_request(api::parse_json_text(job.scenario_json));
  out.compare_with = std::move(request.compare_with);
  out.doc = api::parse_scenario_document(request.scenario, &resolve);
  out.doc.scenario.settings.threads = threads_;
  const auto t_build = Clock::now();
  out.site = out.entry ? out.entry->site : api::validate_scenario(out.doc.scenario);
  out.parse_s = std::chrono::duration<double>(t_build - t_parse).count();
  out.build_s = std::chrono::duration<double>(Clock::now() - t_build).count();
  return out;
}

// A job with compare_with (docs/comparison.md): the base job's scenario and this one paired; the
// job's results are the variant's, with compare.json and compare.h5 beside them.
void Scheduler::run_comparison(const JobRow& job, const LoadedJob& variant,
                               const run::RunControl& control,
                               std::chrono::steady_clock::time_point started) {
  const auto base_row = store_.job_with_scenario(*variant.compare_with);
  if (!base_row)
    throw InputError("compare_with", "the base job " + *variant.compare_with + " is gone");
  LoadedJob base = load(*base_row);
  const std::vector<std::string> changed =
      api::check_variant(api::scenario_to_json(base.doc), api::scenario_to_json(variant.doc));
  run::PairedRun paired =
      run::run_paired(base.doc.scenario, base.site, variant.doc.scenario, variant.site, control);
  if (paired.cancelled || cancel_run_.load()) return end_interrupted(job.job_id);
  paired.variant.timing.parse_s = variant.parse_s;
  paired.variant.timing.build_s = variant.build_s;
  api::CompareInputs in;
  in.paired = &paired;
  in.base = &base.doc.scenario;
  in.base_site = base.site.get();
  in.changed = changed;
  in.base_sha256 = api::sha256_hex(base_row->scenario_json);
  in.variant_sha256 = api::sha256_hex(job.scenario_json);
  in.provenance = api::build_provenance();
  const nlohmann::ordered_json compare = api::compare_to_json(in);
  persist(job, variant.doc, *variant.site, paired.variant, started, [&](api::OutputDir& out) {
    out.stage(api::kCompareH5FileName, [&](const std::filesystem::path& tmp) {
      api::write_compare_h5(tmp, paired, *base.site, compare);
    });
    out.stage_text(api::kCompareFileName, compare.dump(2) + "\n");
  });
}

void Scheduler::record_progress(const std::string& id, const run::Progress& p,
                                Clock::time_point& last_flush) {
  bool flush = false;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (live_) {
      live_->histories_done = p.histories_done;
      live_->histories_total = p.histories_total;
      live_->elapsed_s = p.elapsed_s;
      live_->histories_per_s =
          p.elapsed_s > 0 ? static_cast<double>(p.histories_done) / p.elapsed_s : 0.0;
      live_->precision = p.precision;
    }
    const auto now = Clock::now();
    if (now - last_flush >= std::chrono::seconds(1)) {
      last_flush = now;
      flush = true;
    }
  }
  if (flush) store_.update_progress(id, p.histories_done);
}

void Scheduler::end_interrupted(const std::string& id) {
  bool stopping = false;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping = stopping_;
  }
  if (stopping) {
    store_.requeue(id);  // only if still running (not cancelled by a client)
    log(LogLevel::kInfo, "job interrupted by shutdown; queued again", {{"job_id", id}});
  } else {
    log(LogLevel::kInfo, "job cancelled", {{"job_id", id}});
  }
}

bool Scheduler::persist(const JobRow& job, const api::ScenarioDocument& doc,
                        const scene::Site& site, const run::RunResult& result,
                        Clock::time_point started,
                        const std::function<void(api::OutputDir&)>& stage_more) {
  const std::string& id = job.job_id;
  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = api::sha256_hex(job.scenario_json);
  const std::filesystem::path dir = job_dir(id);
  api::remove_stale_temporaries(dir);  // a killed earlier run of this job (we hold the data dir)
  {
    api::OutputDir out(dir);
    const auto summary = api::stage_run_outputs(out, result, site, doc, provenance);
    if (stage_more) stage_more(out);
    out.commit();
    if (!store_.mark_done(id, utc_now(), result.histories_done, summary.dump(),
                          building_rows(result))) {
      // Cancelled between the end of the run and here: no result is presented.
      std::error_code ec;
      std::filesystem::remove_all(dir, ec);
      log(LogLevel::kInfo, "job cancelled", {{"job_id", id}});
      return false;
    }
  }
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    completed_ += result.histories_done;
  }
  const double wall = std::chrono::duration<double>(Clock::now() - started).count();
  log(LogLevel::kInfo, "job done",
      {{"job_id", id},
       {"wall_s", format_double(wall)},
       {"histories", std::to_string(result.histories_done)},
       {"hfd_m", format_double(result.hazardous_fragment_distance_m)},
       {"hfd_bound", result.site_boundary.hfd_cut ? "lower" : "none"}});
  if (result.site_boundary.hfd_cut)
    log(LogLevel::kWarn, "job hfd is a lower bound",
        {{"job_id", id}, {"note", api::hfd_bound_note(result)}});
  return true;
}

// ---- Backend jobs ----

std::string Scheduler::stand_alone_scenario(const JobRow& job) {
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

std::vector<std::string> Scheduler::adopt_backend_jobs() {
  std::vector<std::string> adopted;
  for (auto& row : store_.running_jobs()) {
    const auto dir = backend_dir(row.job_id, row.attempts);
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

void Scheduler::monitor_loop() {
  const auto interval = std::chrono::duration<double>(backend_.poll_interval_s);
  while (true) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      monitor_wake_.wait_for(lock, interval, [&] { return stopping_ || pending_; });
      if (stopping_) return;
      if (!backend_.local) pending_ = false;
    }
    try {
      follow_backend_jobs();
      sweep_stopping();
      if (!backend_.local) submit_queued();
    } catch (const std::exception& e) {
      log(LogLevel::kError, "scheduler error", {{"error", e.what()}});
    }
  }
}

void Scheduler::submit_queued() {
  while (true) {
    {
      const std::lock_guard<std::mutex> lock(mutex_);
      if (stopping_ || static_cast<int>(tracked_.size()) >= backend_.max_jobs) return;
    }
    if (!room_to_start()) return;
    const auto job = store_.next_queued();
    if (!job) return;
    if (!store_.mark_running(job->job_id, utc_now())) continue;  // cancelled meanwhile
    const std::string& id = job->job_id;
    JobRow row = *job;
    row.attempts += 1;  // mark_running counted this start
    const auto dir = backend_dir(id, row.attempts);
    try {
      // Parsed here so that a scenario the run would refuse fails as it would locally.
      const std::string scenario = stand_alone_scenario(row);
      const auto doc = api::parse_scenario_document_text(scenario);
      // A settings.precision run decides at each batch boundary from all the batch's histories:
      // it runs as one shard (on the mpi preset, fragsim-mpi's ranks exchanging every batch).
      const bool precision = doc.scenario.settings.precision.has_value();
      const ResolvedBackend b = precision ? precision_backend(backend_) : backend_;
      auto submitted = BackendJob::submit(b, id, row.attempts, dir, scenario);
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
      if (cancelled) stop_backend_job(t->job, !backend_.keep_workdir);
    } catch (const InputError& e) {
      fail_job(id, "invalid_input", e.what());
    } catch (const api::StorageFullError& e) {
      fail_job(id, "storage_full", e.what());
    } catch (const std::exception& e) {
      fail_job(id, "backend", e.what());
    }
  }
}

void Scheduler::follow_backend_jobs() {
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
      stop_backend_job(t->job, false);  // the other shards; the directory is kept for its logs
      continue;
    }
    finish_backend_job(*t);
    const std::lock_guard<std::mutex> lock(mutex_);
    tracked_.erase(id);
  }
}

namespace {

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
  api::fsync_path(file);
  return n;
}

}  // namespace

void Scheduler::finish_backend_job(Tracked& t) {
  const JobRow& job = t.row;
  const std::string& id = job.job_id;
  const auto started = Clock::now();
  try {
    if (const int n = count_finish_attempt(t.job.workdir()); n > max_crashes_) {
      fail_job(id, "crashed",
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
    if (!persist(job, doc, *site, result, started)) return;
    if (!backend_.keep_workdir) {
      std::error_code ec;
      std::filesystem::remove_all(t.job.workdir(), ec);
    }
  } catch (const InputError& e) {
    fail_job(id, "invalid_input", e.what());
  } catch (const api::StorageFullError& e) {
    fail_job(id, "storage_full", e.what());
  } catch (const std::bad_alloc&) {
    fail_job(id, "internal", "out of memory while merging the shards");
  } catch (const std::exception& e) {
    fail_job(id, "backend", e.what());
  }
}

void Scheduler::stop_backend_job(const BackendJob& job, bool remove_workdir) {
  BackendJob copy = job;
  copy.cancel(false);
  const std::lock_guard<std::mutex> lock(mutex_);
  stopping_jobs_.push_back(
      std::make_shared<Stopping>(Stopping{std::move(copy), Clock::now(), false, remove_workdir}));
}

// Cancelled or failed backend jobs: SIGKILL for what is still at work after 10 s; the work
// directory of a cancelled one goes once nothing writes to it any more.
void Scheduler::sweep_stopping() {
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
