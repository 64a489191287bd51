#include "server/scheduler.h"

#include <algorithm>
#include <chrono>

#include "api/compare_json.h"
#include "api/job_request.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "core/run/run.h"
#include "server/log.h"
#include "server/thread_nice.h"

namespace fragsim::server {

namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

Scheduler::Scheduler(Store& store, SiteRegistry& sites, std::filesystem::path jobs_dir, int threads,
                     int job_nice, ResolvedBackend backend, int max_crashes, const DiskGuard* disk)
    : store_(store),
      sites_(sites),
      threads_(threads),
      job_nice_(job_nice),
      local_(backend.local),
      results_(store, std::move(jobs_dir)),
      backends_(store, sites, results_, std::move(backend), max_crashes, disk),
      gate_(disk) {}

Scheduler::~Scheduler() {
  shutdown();
}

std::vector<std::string> Scheduler::adopt_backend_jobs() {
  return backends_.adopt();
}

void Scheduler::start() {
  if (local_) {
    worker_ = std::thread([this] {
      lower_thread_priority(job_nice_);  // inherited by the run's threads, which this one creates
      loop();
    });
  }
  backends_.start(job_nice_);
}

void Scheduler::shutdown() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    cancel_run_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
  backends_.shutdown();
}

void Scheduler::notify() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pending_ = true;
  }
  wake_.notify_all();
  backends_.notify();
}

std::optional<JobState> Scheduler::cancel(const std::string& job_id) {
  const auto before = store_.cancel(job_id, utc_now());
  if (before != JobState::kRunning) return before;
  if (backends_.cancel(job_id)) return before;
  std::unique_lock<std::mutex> lock(mutex_);
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
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (live_ && live_->job_id == job_id) return true;
    if (cancel_pending_.contains(job_id)) return true;
  }
  return backends_.holds(job_id);
}

std::optional<LiveProgress> Scheduler::progress(const std::string& job_id) const {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    if (live_ && live_->job_id == job_id) return live_;
  }
  return backends_.progress(job_id);
}

double Scheduler::histories_per_s() const {
  double rate = 0.0;
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    rate = live_ ? live_->histories_per_s : 0.0;
  }
  return rate + backends_.histories_per_s();
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
        if (!gate_.room()) break;  // checked again on the next wake-up (1 s at most)
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
    results_.commit(job, v.doc, *v.site, result, started);
  } catch (...) {
    results_.fail_with_current_exception(id, "internal");
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
  results_.commit(job, variant.doc, *variant.site, paired.variant, started,
                  [&](formats::OutputDir& out) {
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

}  // namespace fragsim::server
