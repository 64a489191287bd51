// The Service: the routes of a finished job's results (server/service.h, docs/http-api.md).
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

Response Service::job_summary(const std::string& id) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  Response r;
  r.file = scheduler_.job_dir(id) / api::kSummaryFileName;
  return r;
}

Response Service::job_buildings(const std::string& id) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  auto list = OJson::array();
  for (const auto& b : store_.buildings(id))
    list.push_back({{"id", b.building_id},
                    {"expected_impacts", b.expected_impacts},
                    {"impacts_std_error", b.impacts_std_error},
                    {"expected_penetrations", b.expected_penetrations},
                    {"penetrations_std_error", b.penetrations_std_error}});
  return json_response(200, OJson{{"job_id", id}, {"buildings", std::move(list)}});
}

Response Service::job_ptn(const Request& req, const std::string& id) {
  bool geojson = false;
  if (const auto it = req.query.find("format"); it != req.query.end()) {
    if (it->second == "geojson") {
      geojson = true;
    } else if (it->second != "json") {
      return error_response(400, "bad_parameter",
                            "must be json or geojson (got \"" + it->second + "\")", "format");
    }
  }
  std::optional<double> min_density;
  if (const auto it = req.query.find("min_density_per_m2"); it != req.query.end()) {
    if (!geojson)
      return error_response(400, "bad_parameter", "only with format=geojson", "min_density_per_m2");
    const auto v = query_number(it->second);
    if (!v || *v < 0.0)
      return error_response(400, "bad_parameter", "must be a number >= 0", "min_density_per_m2");
    min_density = *v;
  }
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const auto h5 = scheduler_.job_dir(id) / api::kResultsFileName;
  Response r;
  if (geojson) {
    r.content_type = "application/geo+json";
    // RFC 7946 (WGS 84) when the site's CRS is one PROJ knows (gis/; docs/http-api.md).
    auto writer =
        std::make_shared<api::PtnGeoJsonWriter>(h5, id, min_density, gis::wgs84_converter);
    r.stream = [writer](std::string& piece) { return writer->next(piece); };
  } else {
    r.body = api::render_ptn_json(h5, id);
  }
  return r;
}

// The job's terrain, density, buildings and a sample of its trajectories for a browser.
Response Service::job_scene(const Request& req, const std::string& id) {
  std::int64_t max_trajectories = formats::kDefaultSceneTrajectories;
  if (const auto it = req.query.find("max_trajectories"); it != req.query.end()) {
    const std::string& text = it->second;
    const bool digits =
        !text.empty() && text.size() <= 6 &&
        std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
    if (!digits || std::stoll(text) > formats::kMaxSceneTrajectories)
      return error_response(
          400, "bad_parameter",
          "must be an integer in [0, " + std::to_string(formats::kMaxSceneTrajectories) + "]",
          "max_trajectories");
    max_trajectories = std::stoll(text);
  }
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const auto dir = scheduler_.job_dir(id);
  const auto build = [&] {
    return formats::scene_from_results(dir / api::kResultsFileName, max_trajectories);
  };
  Response r;
  r.content_type = formats::kSceneContentType;
  if (max_trajectories == formats::kDefaultSceneTrajectories)
    r.file = scenes_.ensure(dir, SceneFiles::kJobSceneName, build);
  else
    r.body = scenes_.encode_now(build);
  return r;
}

// The site-plan boundary (gis/plan_boundary.h) of a done job, in its input coordinates; made on
// each request (0.03 s on the demo; about 2 s on thousands of islands: docs/gis.md).
Response Service::job_plan_boundary(const Request& req, const std::string& id) {
  gis::PlanBoundaryOptions options;
  if (const auto it = req.query.find("smoothing_m"); it != req.query.end()) {
    const auto v = query_number(it->second);
    if (!v || !(*v > 0.0))
      return error_response(400, "bad_parameter", "must be a number > 0 (metres)", "smoothing_m");
    options.smoothing_m = *v;
  }
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const gis::ResultsFile results =
      gis::read_results_file(scheduler_.job_dir(id) / api::kResultsFileName);
  OJson j{{"job_id", id}};
  j.update(gis::plan_boundary_json(gis::plan_boundary(results, options), results.offset));
  return json_response(200, j);
}

// compare.json or compare.h5 of a job submitted with compare_with (docs/comparison.md).
Response Service::job_compare(const std::string& id, bool h5) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  Response r;
  r.file = scheduler_.job_dir(id) / (h5 ? api::kCompareH5FileName : api::kCompareFileName);
  std::error_code ec;
  if (!std::filesystem::exists(*r.file, ec))
    return error_response(404, "not_found",
                          "job " + id + " is not a comparison (submit a job with compare_with)");
  if (h5) {
    r.content_type = "application/x-hdf5";
    r.headers.emplace_back("Content-Disposition", "attachment; filename=\"" + id + "-compare.h5\"");
  }
  return r;
}

// compare_with (docs/comparison.md): the base job exists, runs where this one will (the local
// backend: both runs in one process), and its scenario pairs with this one's.
void Service::check_comparison(const api::JobRequest& jr) {
  if (!jr.compare_with) return;
  if (config_.backend.kind != "local")
    throw InputError("compare_with",
                     "a paired comparison runs both sites in one process; this "
                     "daemon's backend is \"" +
                         config_.backend.kind +
                         "\" (use `fragsim compare`, or a local-backend daemon)");
  const auto base = store_.job_with_scenario(*jr.compare_with);
  if (!base) throw InputError("compare_with", "no job " + *jr.compare_with);
  std::shared_ptr<const SiteEntry> held;
  const api::SiteResolver resolve = sites_.resolver(held);
  api::ScenarioDocument base_doc;
  try {
    base_doc = api::parse_scenario_document(
        api::split_stored_request(api::parse_json_text(base->scenario_json)).scenario, &resolve);
  } catch (const InputError& e) {
    throw InputError("compare_with",
                     "the base job's scenario no longer loads: " + std::string(e.what()));
  }
  api::check_variant(api::scenario_to_json(base_doc), api::scenario_to_json(jr.document));
  run::check_pairable(base_doc.scenario, jr.document.scenario);
}

Response Service::job_results_h5(const std::string& id) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  Response r;
  r.content_type = "application/x-hdf5";
  r.file = scheduler_.job_dir(id) / api::kResultsFileName;
  r.headers.emplace_back("Content-Disposition", "attachment; filename=\"" + id + ".h5\"");
  return r;
}

// The maps are made on the first request (seconds for a large site; the request waits).
Response Service::job_maps(const std::string& id) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const MapSet m = maps_.ensure(scheduler_.job_dir(id));
  OJson files = OJson::array();
  for (const auto& f : m.files)
    files.push_back({{"name", f.name},
                     {"url", "/v1/jobs/" + id + "/maps/" + f.name},
                     {"content_type", f.content_type},
                     {"bytes", f.bytes}});
  return json_response(200, OJson{{"job_id", id},
                                  {"crs", m.crs.empty() ? OJson(nullptr) : OJson(m.crs)},
                                  {"pixel_m", m.pixel_m},
                                  {"raster_cols", m.raster_cols},
                                  {"raster_rows", m.raster_rows},
                                  {"hazardous_triangles", m.hazardous_triangles},
                                  {"files", std::move(files)},
                                  {"notes", m.notes}});
}

// The study report (server/job_reports.h): ?units=si (default) or us.
Response Service::job_report(const Request& req, const std::string& id, bool pdf) {
  std::optional<api::UnitSystem> units = api::UnitSystem::kSi;
  if (const auto it = req.query.find("units"); it != req.query.end()) {
    units = api::parse_unit_system(it->second);
    if (!units)
      return error_response(400, "bad_parameter", "must be si or us (got \"" + it->second + "\")",
                            "units");
  }
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  Response r;
  try {
    r.file = reports_.ensure(scheduler_.job_dir(id), *units, pdf);
  } catch (const JobReports::Busy& e) {
    Response busy = error_response(503, "busy", e.what());
    busy.headers.emplace_back("Retry-After", "5");
    return busy;
  } catch (const InputError& e) {
    if (e.field() == "--pdf")
      return error_response(503, "pdf_unavailable", "the PDF could not be printed: " + e.message());
    return error_response(409, "report_unavailable", e.message());
  } catch (const std::exception& e) {
    return error_response(503, "pdf_unavailable",
                          std::string("the report could not be made: ") + e.what());
  }
  r.content_type = pdf ? "application/pdf" : "text/html; charset=utf-8";
  // The page runs only its own inline script (the figures) and fetches nothing.
  r.headers.emplace_back("Content-Security-Policy",
                         "default-src 'none'; script-src 'unsafe-inline'; style-src "
                         "'unsafe-inline'; img-src data: blob:; frame-ancestors 'none'");
  r.headers.emplace_back("Content-Disposition", std::string(pdf ? "attachment" : "inline") +
                                                    "; filename=\"" + id + "_" +
                                                    JobReports::file_name(*units, pdf) + "\"");
  return r;
}

Response Service::job_map_file(const std::string& id, const std::string& name) {
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const MapSet m = maps_.ensure(scheduler_.job_dir(id));
  std::string known;
  for (const auto& f : m.files) {
    if (f.name != name) {
      known += (known.empty() ? "" : ", ") + f.name;
      continue;
    }
    Response r;
    r.content_type = f.content_type;
    r.file = scheduler_.job_dir(id) / JobMaps::kDirName / f.name;
    r.headers.emplace_back("Content-Disposition",
                           "attachment; filename=\"" + id + "_" + f.name + "\"");
    return r;
  }
  return error_response(404, "not_found",
                        "job " + id + " has no map \"" + name + "\" (it has: " + known + ")");
}

}  // namespace fragsim::server
