#include "server/job_results.h"

#include <new>
#include <system_error>
#include <utility>
#include <vector>

#include "api/run_outputs.h"
#include "api/sha256.h"
#include "api/summary_json.h"
#include "core/common/error.h"
#include "server/log.h"

namespace fragsim::server {

namespace {

std::vector<BuildingRow> building_rows(const run::RunResult& r) {
  std::vector<BuildingRow> rows;
  for (const auto& b : r.buildings)
    rows.push_back(
        {b.id, b.impacts.mean, b.impacts.std_error, b.penetrations.mean, b.penetrations.std_error});
  return rows;
}

}  // namespace

JobResults::JobResults(Store& store, std::filesystem::path jobs_dir)
    : store_(store), jobs_dir_(std::move(jobs_dir)) {}

bool JobResults::commit(const JobRow& job, const api::ScenarioDocument& doc,
                        const scene::Site& site, const run::RunResult& result,
                        std::chrono::steady_clock::time_point started,
                        const std::function<void(formats::OutputDir&)>& stage_more) {
  const std::string& id = job.job_id;
  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = api::sha256_hex(job.scenario_json);
  const std::filesystem::path dir = job_dir(id);
  formats::remove_stale_temporaries(
      dir);  // a killed earlier run of this job (we hold the data dir)
  {
    formats::OutputDir out(dir);
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
  completed_ += result.histories_done;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
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

void JobResults::fail(const std::string& id, const std::string& code, const std::string& message) {
  store_.mark_failed(id, utc_now(), code, message);
  log(code == "invalid_input" ? LogLevel::kWarn : LogLevel::kError, "job failed",
      {{"job_id", id}, {"code", code}, {"error", message}});
}

void JobResults::fail_with_current_exception(const std::string& id, const std::string& other_code,
                                             const std::string& doing) {
  try {
    throw;
  } catch (const InputError& e) {
    fail(id, "invalid_input", e.what());
  } catch (const formats::StorageFullError& e) {
    fail(id, "storage_full", e.what());
  } catch (const std::bad_alloc&) {
    fail(id, "internal", doing.empty() ? "out of memory" : "out of memory while " + doing);
  } catch (const std::exception& e) {
    fail(id, other_code, e.what());
  }
}

}  // namespace fragsim::server
