#include "server/scheduler.h"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>

#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "core/common/error.h"
#include "core/run/run.h"
#include "server/log.h"

namespace fragsim::server {

namespace {

using Clock = std::chrono::steady_clock;

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

}  // namespace

Scheduler::Scheduler(Store& store, SiteRegistry& sites, std::filesystem::path jobs_dir, int threads,
                     int job_nice)
    : store_(store),
      sites_(sites),
      jobs_dir_(std::move(jobs_dir)),
      threads_(threads),
      job_nice_(job_nice) {}

Scheduler::~Scheduler() {
  shutdown();
}

void Scheduler::start() {
  worker_ = std::thread([this] {
    lower_thread_priority(job_nice_);  // inherited by the run's threads, which this one creates
    loop();
  });
}

void Scheduler::shutdown() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    cancel_run_ = true;
  }
  wake_.notify_all();
  if (worker_.joinable()) worker_.join();
}

void Scheduler::notify() {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    pending_ = true;
  }
  wake_.notify_all();
}

std::optional<JobState> Scheduler::cancel(const std::string& job_id) {
  const auto before = store_.cancel(job_id, utc_now());
  if (before != JobState::kRunning) return before;
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

std::optional<LiveProgress> Scheduler::running() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return live_;
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
    std::shared_ptr<const SiteEntry> entry;
    const api::SiteResolver resolve = [&](const std::string& site_id) -> const nlohmann::json* {
      entry = sites_.find(site_id);
      return entry ? &entry->normalised : nullptr;
    };
    const auto t_parse = Clock::now();
    api::ScenarioDocument doc =
        api::parse_scenario_document(api::parse_json_text(job.scenario_json), &resolve);
    doc.scenario.settings.threads = threads_;
    const auto t_build = Clock::now();
    // A stored site was built at upload (build_s 0 here); an inline one is built now.
    const std::shared_ptr<const scene::Site> site =
        entry ? entry->site : api::validate_scenario(doc.scenario);
    const auto t_run = Clock::now();

    auto last_flush = Clock::now();
    run::RunControl control;
    control.cancel = &cancel_run_;
    control.progress_interval_s = 0.2;
    control.on_progress = [&](const run::Progress& p) {
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
      }
      const auto now = Clock::now();
      if (now - last_flush >= std::chrono::seconds(1)) {
        last_flush = now;
        store_.update_progress(id, p.histories_done);
      }
    };
    run::RunResult result = run::run(doc.scenario, site, control);
    result.timing.parse_s = std::chrono::duration<double>(t_build - t_parse).count();
    result.timing.build_s = std::chrono::duration<double>(t_run - t_build).count();
    if (result.cancelled || cancel_run_.load()) {
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
      return;
    }

    api::Provenance provenance = api::build_provenance();
    provenance.scenario_sha256 = api::sha256_hex(job.scenario_json);
    const std::filesystem::path dir = job_dir(id);
    api::remove_stale_temporaries(dir);  // a killed earlier run of this job (we hold the data dir)
    {
      api::OutputDir out(dir);
      const auto summary = api::stage_run_outputs(out, result, *site, doc, provenance);
      out.commit();
      if (!store_.mark_done(id, utc_now(), result.histories_done, summary.dump(),
                            building_rows(result))) {
        // Cancelled between the end of the run and here: no result is presented.
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
        log(LogLevel::kInfo, "job cancelled", {{"job_id", id}});
        return;
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
         {"hfd_m", format_double(result.hazardous_fragment_distance_m)}});
  } catch (const InputError& e) {
    store_.mark_failed(id, utc_now(), "invalid_input", e.what());
    log(LogLevel::kWarn, "job failed", {{"job_id", id}, {"error", e.what()}});
  } catch (const std::bad_alloc&) {
    store_.mark_failed(id, utc_now(), "internal", "out of memory");
    log(LogLevel::kError, "job failed", {{"job_id", id}, {"error", "out of memory"}});
  } catch (const std::exception& e) {
    store_.mark_failed(id, utc_now(), "internal", e.what());
    log(LogLevel::kError, "job failed", {{"job_id", id}, {"error", e.what()}});
  }
}

}  // namespace fragsim::server
