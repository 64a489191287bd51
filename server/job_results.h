#pragma once
// The one place a job's end is recorded, for a local run and a backend job alike: its results
// staged and renamed into <data>/jobs/<job_id>/ and marked done in one transaction (a job
// cancelled meanwhile keeps no files), or its failure recorded with its error code.
#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "api/scenario_json.h"
#include "core/run/result.h"
#include "core/scene/site.h"
#include "formats/output_dir.h"
#include "server/store.h"

namespace fragsim::server {

class JobResults {
 public:
  JobResults(Store& store, std::filesystem::path jobs_dir);

  std::filesystem::path job_dir(const std::string& job_id) const { return jobs_dir_ / job_id; }

  // Stages and commits the job's results (and what `stage_more` stages beside them), then marks
  // it done and logs it (`started`: when its run began). False: cancelled meanwhile (its files
  // are removed again).
  bool commit(const JobRow& job, const api::ScenarioDocument& doc, const scene::Site& site,
              const run::RunResult& result, std::chrono::steady_clock::time_point started,
              const std::function<void(formats::OutputDir&)>& stage_more = {});

  // Records a failed job (its error as GET /v1/jobs/{id} shows it) and logs it.
  void fail(const std::string& job_id, const std::string& code, const std::string& message);
  // From a catch block: records the exception being handled as the job's failure.
  // InputError: invalid_input; formats::StorageFullError: storage_full; std::bad_alloc: internal
  // ("out of memory" and `doing`); any other: `other_code`.
  void fail_with_current_exception(const std::string& job_id, const std::string& other_code,
                                   const std::string& doing = "");

  // Histories of the jobs done since start: a counter, it never goes down.
  std::int64_t histories_completed() const { return completed_.load(); }

 private:
  Store& store_;
  const std::filesystem::path jobs_dir_;
  std::atomic<std::int64_t> completed_{0};
};

}  // namespace fragsim::server
