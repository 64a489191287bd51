// The Service: the routes of the job queue (server/service.h, docs/http-api.md).
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <random>
#include <sstream>

#include "api/compare_json.h"
#include "api/job_request.h"
#include "api/ptn_json.h"
#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/sha256.h"
#include "api/site_document.h"
#include "api/summary_json.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "core/run/reach.h"
#include "core/scene/site_limits.h"
#include "formats/output_dir.h"
#include "formats/scene_binary.h"
#include "fragsim/version.h"
#include "gis/gdal_support.h"
#include "gis/plan_boundary.h"
#include "gis/results_file.h"
#include "server/log.h"
#include "server/openapi_text.h"
#include "server/service.h"
#include "server/service_support.h"
#include "server/ui_assets.h"
#include "server/utf8.h"

namespace fragsim::server {

// ---- Jobs ----

OJson Service::job_json(const JobRow& row) {
  OJson j;
  j["job_id"] = row.job_id;
  j["site_id"] = row.site_id ? OJson(*row.site_id) : OJson(nullptr);
  j["state"] = job_state_name(row.state);
  j["priority"] = row.priority;
  j["idempotency_key"] = row.idempotency_key ? OJson(*row.idempotency_key) : OJson(nullptr);
  j["owner"] = row.owner ? OJson(*row.owner) : OJson(nullptr);
  j["created_utc"] = row.created_utc;
  j["started_utc"] = row.started_utc ? OJson(*row.started_utc) : OJson(nullptr);
  j["finished_utc"] = row.finished_utc ? OJson(*row.finished_utc) : OJson(nullptr);
  std::int64_t done = row.histories_done;
  OJson rate = nullptr;
  OJson eta = nullptr;
  OJson precision = nullptr;
  if (row.state == JobState::kRunning) {
    if (const auto live = scheduler_.progress(row.job_id)) {
      done = std::max(done, live->histories_done);
      if (live->histories_per_s > 0) {
        rate = live->histories_per_s;
        eta = static_cast<double>(row.histories_total - done) / live->histories_per_s;
      }
      if (live->precision) {  // toward the targets when they come before max_batches
        precision = api::precision_report_json(*live->precision);
        const double to_targets = live->precision->eta_s;
        if (std::isfinite(to_targets) && (eta.is_null() || to_targets < eta.get<double>()))
          eta = to_targets;
      }
    }
  }
  j["histories_done"] = done;
  j["histories_total"] = row.histories_total;
  j["progress"] = row.histories_total > 0
                      ? static_cast<double>(done) / static_cast<double>(row.histories_total)
                      : 0.0;
  j["histories_per_s"] = rate;
  j["eta_s"] = eta;
  j["precision"] = std::move(precision);
  j["attempts"] = row.attempts;
  j["error"] = row.error_code
                   ? OJson{{"code", *row.error_code}, {"message", row.error_message.value_or("")}}
                   : OJson(nullptr);
  const std::string self = "/v1/jobs/" + row.job_id;
  j["links"] = {{"self", self},
                {"summary", self + "/summary"},
                {"buildings", self + "/buildings"},
                {"ptn", self + "/ptn"},
                {"results_h5", self + "/results.h5"},
                {"maps", self + "/maps"},
                {"plan_boundary", self + "/plan_boundary"}};
  // A done job submitted with compare_with (docs/comparison.md) also links its comparison.
  std::error_code missing;
  if (row.state == JobState::kDone &&
      std::filesystem::exists(scheduler_.job_dir(row.job_id) / api::kCompareFileName, missing)) {
    j["links"]["compare"] = self + "/compare";
    j["links"]["compare_h5"] = self + "/compare.h5";
  }
  return j;
}

namespace {

// Fragment groups of a submitted job that can plainly reach beyond the terrain (core/run/reach.h,
// issue 22): warnings, not errors; the job is queued all the same.
OJson reach_warnings(const run::Scenario& sc, const scene::Site& site) {
  OJson list = OJson::array();
  for (const run::ReachWarning& w : run::groups_beyond_terrain(sc, site))
    list.push_back(OJson{{"field", run::reach_field(w)},
                         {"severity", w.severity()},
                         {"message", run::reach_message(w)}});
  return list;
}

// "job queued", then a "job warning" line for each warning.
void log_queued(const JobRow& row, const OJson& warnings) {
  log(LogLevel::kInfo, "job queued",
      {{"job_id", row.job_id},
       {"site_id", row.site_id.value_or("inline")},
       {"priority", std::to_string(row.priority)},
       {"histories", std::to_string(row.histories_total)},
       {"owner", row.owner.value_or("-")},
       {"warnings", std::to_string(warnings.size())}});
  for (const OJson& w : warnings)
    log(LogLevel::kWarn, "job warning",
        {{"job_id", row.job_id},
         {"field", w.at("field").get<std::string>()},
         {"message", w.at("message").get<std::string>()}});
}

// An accepted submission (202 queued anew, 200 a retry of one): the job with its warnings.
Response job_accepted(int status, OJson job, OJson warnings) {
  const std::string location = "/v1/jobs/" + job["job_id"].get<std::string>();
  job["warnings"] = std::move(warnings);
  Response r = json_response(status, job);
  r.headers.emplace_back("Location", location);
  return r;
}

}  // namespace

// The site a job will run on: an inline site gets the full geometry check now, not when the job
// runs; a stored site (`held`) was checked when it was uploaded.
std::shared_ptr<const scene::Site> Service::job_site(const api::JobRequest& jr,
                                                     const SiteEntry* held) const {
  if (jr.document.site_id) return held != nullptr ? held->site : nullptr;
  check_terrain_size(jr.document.scenario.site.terrain, "site.terrain");
  return api::validate_scenario(jr.document.scenario);
}

Response Service::post_job(const Request& req) {
  if (auto bad = check_json_content_type(req)) return *bad;
  const nlohmann::json body = parse_body(req);
  // `held` keeps the site's JSON alive while the request is parsed, even if the site is
  // deleted meanwhile (that is caught below, under the catalogue lock).
  std::shared_ptr<const SiteEntry> held;
  const api::SiteResolver resolve = sites_.resolver(held);
  const api::JobRequest jr = api::parse_job_request(body, resolve);
  check_comparison(jr);
  if (jr.total_samples > config_.max_samples_per_job)
    throw LimitError(jr.document.scenario.settings.precision ? "settings.precision.max_batches"
                                                             : "fragment_groups",
                     "the job asks for up to " + std::to_string(jr.total_samples) +
                         " samples in all; this daemon allows at most " +
                         std::to_string(config_.max_samples_per_job) + " (--max-samples-per-job)");
  // The bracket's runs are work of the same job.
  if (jr.bracket_samples > config_.max_samples_per_job - jr.total_samples)
    throw LimitError("settings.ground_bracket",
                     "the study and its bracket ask for " +
                         std::to_string(jr.total_samples + jr.bracket_samples) +
                         " samples in all; this daemon allows at most " +
                         std::to_string(config_.max_samples_per_job) +
                         " (--max-samples-per-job): lower samples_scale or the ranges");
  const std::shared_ptr<const scene::Site> site = job_site(jr, held.get());
  OJson warnings = site ? reach_warnings(jr.document.scenario, *site) : OJson::array();

  JobRow row;
  row.job_id = new_job_id();
  row.site_id = jr.document.site_id;
  row.priority = jr.priority;
  row.idempotency_key = jr.idempotency_key;
  row.request_sha256 = api::sha256_hex(body.dump());  // the whole body, priority included
  row.scenario_json = jr.scenario.dump();
  row.histories_total = jr.total_samples;
  row.created_utc = utc_now();
  row.owner = owner_of(req);
  // A new job on a short disk is refused; a retry of one accepted earlier writes nothing.
  if (const auto found = disk_.short_of_space();
      found && !(row.idempotency_key && store_.has_idempotency_key(*row.idempotency_key)))
    return storage_short(*found);

  Store::Insert inserted;
  {
    const std::lock_guard<std::mutex> lock(catalogue_mutex_);
    if (row.site_id && !sites_.find(*row.site_id))  // deleted while the request was parsed
      throw InputError("site_id", "unknown site \"" + *row.site_id + "\"");
    if (jr.compare_with && !store_.has_job(*jr.compare_with))  // purged meanwhile
      throw InputError("compare_with", "no job " + *jr.compare_with);
    // A retry of a request already accepted is answered below whatever the queue holds.
    const bool retry = row.idempotency_key && store_.has_idempotency_key(*row.idempotency_key);
    const auto queued = store_.job_counts()[static_cast<std::size_t>(JobState::kQueued)];
    if (!retry && queued >= config_.max_queued_jobs)
      throw LimitError("", std::to_string(queued) +
                               " jobs are queued, the limit (--max-queued-jobs); try later");
    inserted = store_.insert_job(row);
  }
  if (!inserted.created) {
    if (inserted.job.request_sha256 != row.request_sha256)
      return error_response(409, "conflict",
                            "idempotency_key \"" + *row.idempotency_key +
                                "\" was used for a different request (job " + inserted.job.job_id +
                                ")",
                            "idempotency_key");
    // The same request: the same scenario and site, so the same warnings.
    return job_accepted(200, job_json(inserted.job), std::move(warnings));
  }
  scheduler_.notify();
  log_queued(row, warnings);
  return job_accepted(202, job_json(inserted.job), std::move(warnings));
}

Response Service::list_jobs(const Request& req) {
  std::optional<JobState> state;
  int limit = 1000;
  if (const auto it = req.query.find("state"); it != req.query.end()) {
    state = parse_job_state(it->second);
    if (!state)
      return error_response(
          400, "bad_parameter",
          "must be queued, running, done, failed or cancelled (got \"" + it->second + "\")",
          "state");
  }
  if (const auto it = req.query.find("limit"); it != req.query.end()) {
    const std::string& v = it->second;
    const bool digits = !v.empty() && v.size() <= 4 && std::all_of(v.begin(), v.end(), [](char c) {
      return c >= '0' && c <= '9';
    });
    limit = digits ? std::stoi(v) : 0;
    if (limit < 1 || limit > 1000)
      return error_response(400, "bad_parameter", "must be an integer in [1, 1000]", "limit");
  }
  auto list = OJson::array();
  for (const auto& row : store_.jobs(state, limit)) list.push_back(job_json(row));
  return json_response(200, OJson{{"jobs", std::move(list)}});
}

Response Service::get_job(const std::string& id) {
  const auto row = store_.job(id);
  if (!row) return error_response(404, "not_found", "no job " + id);
  return json_response(200, job_json(*row));
}

// DELETE /v1/jobs/{id}: cancels a queued or running job; with ?purge=true removes a finished
// one and its files (server/purge.h).
Response Service::delete_job(const Request& req, const std::string& id, Role role) {
  const std::optional<std::string> by = owner_of(req);
  if (const auto it = req.query.find("purge"); it != req.query.end()) {
    if (it->second == "true") return purge_job(id, by);
    if (it->second != "false")
      return error_response(400, "bad_parameter",
                            "must be true or false (got \"" + it->second + "\")", "purge");
  }
  if (auto refused = not_own_job(req, id, role, "cancel")) return *refused;
  const auto before = scheduler_.cancel(id);
  if (!before) return error_response(404, "not_found", "no job " + id);
  if (is_final(*before))
    return error_response(409, "conflict",
                          "job " + id + " is already " + job_state_name(*before) +
                              "; only queued or running jobs can be cancelled");
  const auto row = store_.job(id);
  log(LogLevel::kInfo, "job cancelled by request",
      {{"job_id", id},
       {"was", job_state_name(*before)},
       {"by", by.value_or("-")},
       {"owner", row->owner.value_or("-")}});
  return json_response(200, job_json(*row));
}

Response Service::purge_job(const std::string& id, const std::optional<std::string>& by) {
  const PurgeResult r = purger_.purge(id, PurgeReason::kRequest, by.value_or("-"));
  const std::string state = job_state_name(r.state);
  switch (r.outcome) {
    case PurgeResult::Outcome::kNoSuchJob: return error_response(404, "not_found", "no job " + id);
    case PurgeResult::Outcome::kNotFinished:
      return error_response(409, "conflict",
                            "job " + id + " is " + state +
                                "; only a finished job can be purged (cancel it first: DELETE "
                                "without purge)");
    case PurgeResult::Outcome::kStillStopping: {
      Response e = error_response(409, "conflict",
                                  "job " + id +
                                      " is cancelled but still letting go of its files; "
                                      "purge it again in a moment");
      e.headers.emplace_back("Retry-After", "1");
      return e;
    }
    case PurgeResult::Outcome::kComparisonBase:
      return error_response(409, "conflict",
                            "job " + id + " is the base of " + std::to_string(r.comparisons) +
                                " queued or running comparison" + (r.comparisons == 1 ? "" : "s") +
                                " (compare_with); purge it when they have finished");
    case PurgeResult::Outcome::kPurged: break;
  }
  return json_response(
      200,
      OJson{{"job_id", id}, {"purged", true}, {"state", state}, {"bytes_freed", r.bytes_freed}});
}

// POST /v1/jobs/{id}/retry: a failed job queued again under its id (after a full disk was freed,
// a crash, a backend fault); not one that failed for its input, which would fail again.
Response Service::retry_job(const Request& req, const std::string& id, Role role) {
  if (auto refused = not_own_job(req, id, role, "retry")) return *refused;
  // Checked before the guard (a job that cannot be retried says so whatever the disk), and
  // again by Store::retry, atomically, for a job that changed meanwhile.
  const auto refusal = [&](const JobRow& row) -> std::optional<Response> {
    if (row.state != JobState::kFailed)
      return error_response(
          409, "conflict",
          "job " + id + " is " + job_state_name(row.state) + "; only a failed job can be retried");
    if (row.error_code == "invalid_input")
      return error_response(409, "conflict",
                            "job " + id +
                                " failed for its input (invalid_input) and would fail again; "
                                "submit a corrected job");
    return std::nullopt;
  };
  const auto row = store_.job(id);
  if (!row) return error_response(404, "not_found", "no job " + id);
  if (auto r = refusal(*row)) return *r;
  if (const auto found = disk_.short_of_space()) return storage_short(*found);
  const auto before = store_.retry(id);
  if (!before) return error_response(404, "not_found", "no job " + id);  // purged meanwhile
  if (auto r = refusal(*before)) return *r;
  scheduler_.notify();
  log(LogLevel::kInfo, "job queued again by request",
      {{"job_id", id},
       {"failed_with", before->error_code.value_or("-")},
       {"by", owner_of(req).value_or("-")}});
  Response r = json_response(202, job_json(*store_.job(id)));
  r.headers.emplace_back("Location", "/v1/jobs/" + id);
  return r;
}

// A submit token acts on its own jobs only (admin: on any). nullopt: allowed, or no such job
// (the handler answers 404).
std::optional<Response> Service::not_own_job(const Request& req, const std::string& id, Role role,
                                             const char* action) {
  if (role != Role::kSubmit) return std::nullopt;
  const auto row = store_.job(id);
  if (!row || (row->owner && row->owner == owner_of(req))) return std::nullopt;
  return error_response(403, "forbidden",
                        std::string("job ") + id + " was submitted by another token (" +
                            row->owner.value_or("none recorded") + "); a submit token may " +
                            action + " only its own jobs, admin any");
}

// GET /v1/whoami: what the token presented may do (the viewer shows only that).
Response Service::whoami(const Request& req, Role role) const {
  OJson j;
  j["role"] = role_name(role);
  j["owner"] = owner_of(req) ? OJson(*owner_of(req)) : OJson(nullptr);
  j["auth"] = config_.auth;
  return json_response(200, j);
}

Response Service::storage_short(const DiskSpace& found) const {
  return error_response(507, "storage_full", disk_.refusal(found));
}

std::variant<JobRow, Response> Service::finished_job(const std::string& id) {
  auto row = store_.job(id);
  if (!row) return error_response(404, "not_found", "no job " + id);
  if (row->state != JobState::kDone) {
    std::string why = "job " + id + " is " + job_state_name(row->state);
    if (row->state == JobState::kCancelled || row->state == JobState::kFailed)
      why += "; it has no results (partial results are never served)";
    else
      why += "; results appear when it is done";
    return error_response(409, "not_ready", why);
  }
  return *row;
}

}  // namespace fragsim::server
