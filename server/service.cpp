#include "server/service.h"

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
#include "server/service_support.h"
#include "server/ui_assets.h"
#include "server/utf8.h"

namespace fragsim::server {

namespace {

enum class RouteId {
  kHealth,
  kOpenapi,
  kMetrics,
  kSites,
  kSite,
  kSiteScene,
  kJobs,
  kJob,
  kJobSummary,
  kJobBuildings,
  kJobPtn,
  kJobResults,
  kJobMaps,
  kJobMap,
  kJobReportHtml,
  kJobReportPdf,
  kJobScene,
  kJobPlanBoundary,
  kJobCompare,
  kJobCompareH5,
  kJobRetry,
  kWhoami
};

}  // namespace

Response json_response(int status, const OJson& j) {
  Response r;
  r.status = status;
  r.body = j.dump(-1, ' ', false, OJson::error_handler_t::replace);
  return r;
}

namespace {

// Constant-time comparison: a wrong token takes as long whatever its common prefix.
bool same_token(const std::string& a, const std::string& b) {
  unsigned char diff = a.size() == b.size() ? 0 : 1;
  const std::size_t n = std::max(a.size(), b.size());
  for (std::size_t k = 0; k < n; ++k) {
    const unsigned char x = k < a.size() ? static_cast<unsigned char>(a[k]) : 0;
    const unsigned char y = k < b.size() ? static_cast<unsigned char>(b[k]) : 0;
    diff = static_cast<unsigned char>(diff | (x ^ y));
  }
  return diff == 0;
}

}  // namespace

std::string new_job_id() {
  static std::mutex m;
  static std::random_device device;
  static std::mt19937_64 engine(
      (static_cast<std::uint64_t>(device()) << 32) ^ device() ^
      static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()));
  const std::lock_guard<std::mutex> lock(m);
  char buf[24];
  std::snprintf(buf, sizeof buf, "j_%016llx", static_cast<unsigned long long>(engine()));
  return buf;
}

std::optional<Response> check_query(const Request& req, std::initializer_list<const char*> known) {
  for (const auto& entry : req.query) {
    // Not a structured binding: C++20 lets a lambda capture one, clang before 16 does not.
    const std::string& key = entry.first;
    if (std::find_if(known.begin(), known.end(), [&](const char* k) { return key == k; }) ==
        known.end())
      return error_response(400, "bad_parameter", "unknown query parameter", key);
  }
  return std::nullopt;
}

nlohmann::json parse_body(const Request& req) {
  return api::parse_json_text(req.body);
}

std::optional<Response> check_json_content_type(const Request& req) {
  const auto it = req.headers.find("content-type");
  std::string type = it == req.headers.end() ? "" : ascii_lower(it->second);
  if (const auto semi = type.find(';'); semi != std::string::npos) type.resize(semi);
  while (!type.empty() && type.back() == ' ') type.pop_back();
  if (type != kJsonType)
    return error_response(
        415, "unsupported_media_type",
        "the body must be sent with Content-Type: application/json" +
            (type.empty() ? std::string(" (none given)") : " (got " + type + ")"));
  return std::nullopt;
}

std::string ascii_lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::optional<double> query_number(const std::string& text) {
  std::size_t used = 0;
  double v = 0.0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    return std::nullopt;
  }
  if (used == 0 || used != text.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

Response error_response(int status, const std::string& code, const std::string& message,
                        const std::optional<std::string>& field) {
  OJson j;
  j["code"] = code;
  j["message"] = escape_invalid_utf8(message);  // messages echo client text
  j["field"] = field ? OJson(escape_invalid_utf8(*field)) : OJson(nullptr);
  return json_response(status, j);
}

struct Service::Route {
  RouteId id;
  const char* pattern;
  std::vector<const char*> methods;
  bool public_route = false;  // no token needed
};

Service::DataDirLock::DataDirLock(const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const std::filesystem::path file = dir / "fragsimd.lock";
  fd_ = ::open(file.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0)
    throw std::runtime_error("cannot open " + file.string() + ": " + std::strerror(errno));
  if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
    ::close(fd_);
    fd_ = -1;
    throw std::runtime_error("data directory " + dir.string() +
                             " is in use by another fragsimd (lock " + file.string() + ")");
  }
}

Service::DataDirLock::~DataDirLock() {
  if (fd_ >= 0) ::close(fd_);
}

namespace {

// A daemon killed while writing a site or a job's results leaves its temporaries; with the data
// directory's lock held none can be in use, so they go (sites/ and every jobs/<id>/).
std::size_t clean_stale_temporaries(const std::filesystem::path& data_dir) {
  std::size_t n = formats::remove_stale_temporaries(data_dir / "sites");
  std::error_code ec;
  for (std::filesystem::directory_iterator it(data_dir / "jobs", ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_directory(ec))
      n += formats::remove_stale_temporaries(it->path()) + JobMaps::remove_stale(it->path()) +
           JobReports::remove_stale(it->path());
  }
  return n;
}

}  // namespace

Service::Service(Config config)
    : config_(std::move(config)),
      data_dir_(config_.data_dir),
      lock_(data_dir_),
      tokens_(config_.auth ? read_tokens(config_.token_file) : std::vector<Token>{}),
      started_(std::chrono::steady_clock::now()),
      disk_(data_dir_, config_.min_free_bytes),
      store_(data_dir_ / "fragsimd.sqlite"),
      sites_(store_, data_dir_ / "sites"),
      scheduler_(store_, sites_, data_dir_ / "jobs", config_.threads, config_.job_nice,
                 resolve_backend(config_.backend), config_.max_crashes, &disk_),
      purger_(store_, scheduler_, data_dir_ / "jobs", catalogue_mutex_) {
  if (const int from = store_.upgraded_from(); from > 0 && from < kStoreSchemaVersion)
    log(LogLevel::kWarn, "store upgraded",
        {{"from_schema", std::to_string(from)},
         {"to_schema", std::to_string(kStoreSchemaVersion)}});
  if (const std::size_t n = clean_stale_temporaries(data_dir_); n > 0)
    log(LogLevel::kWarn, "removed temporaries left by a killed daemon",
        {{"files", std::to_string(n)}});
  if (const std::size_t n = purger_.sweep_orphans(); n > 0)
    log(LogLevel::kWarn, "removed the directories of jobs purged by a killed daemon",
        {{"directories", std::to_string(n)}});
  sites_.load();
  // Backend jobs an earlier daemon submitted go on where they run; the rest is requeued.
  const auto adopted = scheduler_.adopt_backend_jobs();
  for (const auto& id : store_.recover_interrupted(config_.max_crashes, utc_now(), adopted))
    log(LogLevel::kWarn, "job interrupted by a previous daemon; queued again", {{"job_id", id}});
  scheduler_.start();
  retention_.emplace(purger_, RetentionPolicy{config_.retain_days, config_.retain_bytes,
                                              config_.retain_interval_s});
}

Service::~Service() {
  shutdown();
}

void Service::shutdown() {
  if (retention_) retention_->stop();
  scheduler_.shutdown();
}

// A job's owner: who submitted it, named without revealing the token (null with auth off).
std::optional<std::string> Service::owner_of(const Request& req) const {
  if (!config_.auth) return std::nullopt;
  const auto it = req.headers.find("authorization");
  if (it == req.headers.end() || it->second.size() <= 7) return std::nullopt;
  return "tok_" + api::sha256_hex(it->second.substr(7)).substr(0, 16);
}

std::optional<Role> Service::role_of(const Request& req) const {
  if (!config_.auth) return Role::kAdmin;  // loopback only (check_config)
  const auto it = req.headers.find("authorization");
  if (it == req.headers.end()) return std::nullopt;
  const std::string& h = it->second;
  constexpr std::string_view kBearer = "bearer ";
  if (h.size() <= kBearer.size() || ascii_lower(h.substr(0, kBearer.size())) != kBearer)
    return std::nullopt;
  const std::string token = h.substr(kBearer.size());
  std::optional<Role> role;
  for (const auto& t : tokens_)  // no early exit
    if (same_token(token, t.secret)) role = t.role;
  return role;
}

namespace {

const std::vector<Service::Route>& routes() {
  static const std::vector<Service::Route> kRoutes = {
      {RouteId::kHealth, "/v1/health", {"GET"}, true},
      {RouteId::kOpenapi, "/v1/openapi.yaml", {"GET"}, true},
      {RouteId::kMetrics, "/metrics", {"GET"}},
      {RouteId::kSites, "/v1/sites", {"GET", "POST"}},
      {RouteId::kSite, "/v1/sites/{id}", {"GET", "DELETE"}},
      {RouteId::kSiteScene, "/v1/sites/{id}/scene", {"GET"}},
      {RouteId::kJobs, "/v1/jobs", {"GET", "POST"}},
      {RouteId::kJob, "/v1/jobs/{id}", {"GET", "DELETE"}},
      {RouteId::kJobSummary, "/v1/jobs/{id}/summary", {"GET"}},
      {RouteId::kJobBuildings, "/v1/jobs/{id}/buildings", {"GET"}},
      {RouteId::kJobPtn, "/v1/jobs/{id}/ptn", {"GET"}},
      {RouteId::kJobResults, "/v1/jobs/{id}/results.h5", {"GET"}},
      {RouteId::kJobMaps, "/v1/jobs/{id}/maps", {"GET"}},
      {RouteId::kJobMap, "/v1/jobs/{id}/maps/{name}", {"GET"}},
      {RouteId::kJobReportHtml, "/v1/jobs/{id}/report.html", {"GET"}},
      {RouteId::kJobReportPdf, "/v1/jobs/{id}/report.pdf", {"GET"}},
      {RouteId::kJobScene, "/v1/jobs/{id}/scene", {"GET"}},
      {RouteId::kJobPlanBoundary, "/v1/jobs/{id}/plan_boundary", {"GET"}},
      {RouteId::kJobCompare, "/v1/jobs/{id}/compare", {"GET"}},
      {RouteId::kJobCompareH5, "/v1/jobs/{id}/compare.h5", {"GET"}},
      {RouteId::kJobRetry, "/v1/jobs/{id}/retry", {"POST"}},
      {RouteId::kWhoami, "/v1/whoami", {"GET"}},
  };
  return kRoutes;
}

// The least role a request needs (docs/operations.md, "Roles"): reading anything is read;
// submitting a job or a site, cancelling or retrying a job is submit (its own jobs: checked by
// the handler); purging a job or deleting a site is admin.
Role needed_role(RouteId route, const Request& req) {
  if (req.method == "GET" || req.method == "HEAD") return Role::kRead;
  if (route == RouteId::kSite) return Role::kAdmin;
  if (route == RouteId::kJob) {
    const auto it = req.query.find("purge");
    return it != req.query.end() && it->second == "true" ? Role::kAdmin : Role::kSubmit;
  }
  return Role::kSubmit;
}

// Whether `path` matches `pattern` segment by segment ("{id}" and "{name}" take one non-empty
// segment each, returned in `id` and `name`).
bool match_route(std::string_view pattern, std::string_view path, std::string& id,
                 std::string& name) {
  while (!pattern.empty() || !path.empty()) {
    if (pattern.empty() || path.empty() || pattern[0] != '/' || path[0] != '/') return false;
    pattern.remove_prefix(1);
    path.remove_prefix(1);
    const std::string_view p = pattern.substr(0, pattern.find('/'));
    const std::string_view s = path.substr(0, path.find('/'));
    if (p == "{id}" || p == "{name}") {
      if (s.empty()) return false;
      (p == "{id}" ? id : name) = std::string(s);
    } else if (p != s) {
      return false;
    }
    pattern.remove_prefix(p.size());
    path.remove_prefix(s.size());
  }
  return true;
}

}  // namespace

std::vector<RouteInfo> route_table() {
  std::vector<RouteInfo> out;
  for (const auto& r : routes())
    out.push_back({r.pattern, {r.methods.begin(), r.methods.end()}, r.public_route});
  return out;
}

Response Service::handle(const Request& req) {
  if (auto r = cors_preflight(req)) return *r;
  Response r = is_ui_path(req.path) ? ui_file(req) : route_request(req);
  add_cors_headers(req, r);
  return r;
}

Response Service::route_request(const Request& req) {
  // The HTTP layer refuses larger bodies before reading them; this holds for any other caller.
  if (static_cast<std::int64_t>(req.body.size()) > config_.max_body_bytes)
    return error_response(413, "payload_too_large",
                          "the request body is larger than this daemon accepts (" +
                              std::to_string(config_.max_body_bytes) + " bytes)");
  for (const Route& route : routes()) {
    std::string id, name;
    if (!match_route(route.pattern, req.path, id, name)) continue;
    Response r;
    const std::optional<Role> role = route.public_route ? Role::kRead : role_of(req);
    if (auto refused = method_refusal(req, route)) {
      r = std::move(*refused);
    } else if (auto denied = access_refusal(req, route, role)) {
      r = std::move(*denied);
    } else {
      r = guarded_dispatch(req, route, id, name, *role);
    }
    r.route = route.pattern;
    return r;
  }
  return error_response(404, "not_found", "no route " + req.path);
}

// 405 for a method the route does not serve, with the Allow header.
std::optional<Response> Service::method_refusal(const Request& req, const Route& route) {
  const std::string method = req.method == "HEAD" ? "GET" : req.method;
  if (std::find(route.methods.begin(), route.methods.end(), method) != route.methods.end())
    return std::nullopt;
  std::string allow;
  for (const char* m : route.methods) allow += (allow.empty() ? "" : ", ") + std::string(m);
  Response r = error_response(
      405, "method_not_allowed",
      req.method + " is not allowed on " + route.pattern + " (allowed: " + allow + ")");
  r.headers.emplace_back("Allow", allow);
  return r;
}

// 401 without a valid token; 403 when the token's role may not do this (docs/operations.md).
std::optional<Response> Service::access_refusal(const Request& req, const Route& route,
                                                std::optional<Role> role) {
  if (!role) {
    Response r = error_response(401, "unauthorized",
                                req.headers.count("authorization")
                                    ? "the bearer token is not valid"
                                    : "this route needs an Authorization: Bearer <token> header");
    r.headers.emplace_back("WWW-Authenticate", "Bearer realm=\"fragsimd\"");
    return r;
  }
  const Role needed = needed_role(route.id, req);
  if (*role >= needed) return std::nullopt;
  return error_response(
      403, "forbidden",
      std::string("this token's role (") + role_name(*role) + ") may not " + req.method + " " +
          route.pattern +
          (route.id == RouteId::kJob && needed == Role::kAdmin ? "?purge=true" : "") +
          "; that needs " + role_name(needed) + (needed == Role::kSubmit ? " or admin" : ""));
}

// The route's handler, its exceptions turned into their error answers.
Response Service::guarded_dispatch(const Request& req, const Route& route, const std::string& id,
                                   const std::string& name, Role role) {
  try {
    return dispatch(req, route, id, name, role);
  } catch (const api::JsonTooDeepError& e) {
    return error_response(400, "too_deep", e.message(), e.field());
  } catch (const api::MalformedJsonError& e) {
    return error_response(400, "malformed_json", e.message());
  } catch (const InputError& e) {
    // An empty path is the body as a whole (e.g. an array where an object belongs).
    return error_response(422, "invalid_input", e.message(),
                          e.field().empty() ? std::nullopt : std::optional(e.field()));
  } catch (const LimitError& e) {
    return error_response(422, "limit_exceeded", e.what(),
                          e.field().empty() ? std::nullopt : std::optional(e.field()));
  } catch (const formats::StorageFullError& e) {
    log(LogLevel::kError, "storage full", {{"path", req.path}, {"error", e.what()}});
    return error_response(507, "storage_full", e.what());
  } catch (const std::bad_alloc&) {
    return error_response(500, "internal", "out of memory while handling the request");
  } catch (const std::exception& e) {
    log(LogLevel::kError, "internal error", {{"path", req.path}, {"error", e.what()}});
    return error_response(500, "internal", std::string("internal error: ") + e.what());
  }
}

Response Service::dispatch(const Request& req, const Route& route, const std::string& id,
                           const std::string& name, Role role) {
  const bool get = req.method == "GET" || req.method == "HEAD";
  // Query parameters first (the same order on every route), then the id in the path.
  std::optional<Response> bad;
  if (route.id == RouteId::kJobs && get) {
    bad = check_query(req, {"state", "limit"});
  } else if (route.id == RouteId::kJobPtn) {
    bad = check_query(req, {"format", "min_density_per_m2"});
  } else if (route.id == RouteId::kJobScene) {
    bad = check_query(req, {"max_trajectories"});
  } else if (route.id == RouteId::kJobReportHtml || route.id == RouteId::kJobReportPdf) {
    bad = check_query(req, {"units"});
  } else if (route.id == RouteId::kJobPlanBoundary) {
    bad = check_query(req, {"smoothing_m"});
  } else if (route.id == RouteId::kJob && req.method == "DELETE") {
    bad = check_query(req, {"purge"});
  } else {
    bad = check_query(req, {});
  }
  if (bad) return *bad;
  switch (route.id) {
    case RouteId::kHealth: return health();
    case RouteId::kOpenapi: return openapi();
    case RouteId::kMetrics: return metrics_page();
    case RouteId::kSites: return get ? list_sites() : post_site(req);
    case RouteId::kSite:
      if (!api::is_site_id(id)) return error_response(404, "not_found", "no site " + id);
      return get ? get_site(id) : delete_site(id);
    case RouteId::kSiteScene:
      if (!api::is_site_id(id)) return error_response(404, "not_found", "no site " + id);
      return site_scene(id);
    case RouteId::kJobs: return get ? list_jobs(req) : post_job(req);
    case RouteId::kWhoami: return whoami(req, role);
    default: break;
  }
  if (!api::is_job_id(id)) return error_response(404, "not_found", "no job " + id);
  if (route.id == RouteId::kJobPtn) return job_ptn(req, id);
  if (route.id == RouteId::kJobScene) return job_scene(req, id);
  if (route.id == RouteId::kJobPlanBoundary) return job_plan_boundary(req, id);
  switch (route.id) {
    case RouteId::kJob: return get ? get_job(id) : delete_job(req, id, role);
    case RouteId::kJobSummary: return job_summary(id);
    case RouteId::kJobBuildings: return job_buildings(id);
    case RouteId::kJobResults: return job_results_h5(id);
    case RouteId::kJobMaps: return job_maps(id);
    case RouteId::kJobMap: return job_map_file(id, name);
    case RouteId::kJobReportHtml: return job_report(req, id, false);
    case RouteId::kJobReportPdf: return job_report(req, id, true);
    case RouteId::kJobCompare: return job_compare(id, false);
    case RouteId::kJobCompareH5: return job_compare(id, true);
    case RouteId::kJobRetry: return retry_job(req, id, role);
    default: return error_response(404, "not_found", "no route " + req.path);
  }
}

// ---- Service routes ----

Response Service::health() {
  const auto counts = store_.job_counts();
  OJson j;
  j["status"] = "ok";
  j["version"] = kVersion;
  j["git_sha"] = kGitSha;
  j["uptime_s"] =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  j["jobs"] = {{"queued", counts[static_cast<std::size_t>(JobState::kQueued)]},
               {"running", counts[static_cast<std::size_t>(JobState::kRunning)]}};
  if (const auto space = disk_space(data_dir_))
    j["storage"] = {
        {"free_bytes", space->free_bytes},
        {"total_bytes", space->total_bytes},
        {"min_free_bytes", disk_.min_free_bytes()},
        {"short", disk_.min_free_bytes() > 0 && space->free_bytes < disk_.min_free_bytes()}};
  return json_response(200, j);
}

Response Service::openapi() {
  Response r;
  r.content_type = "application/yaml";
  r.body = std::string(openapi_yaml());
  return r;
}

Response Service::metrics_page() {
  Metrics::Gauges g;
  const auto counts = store_.job_counts();
  for (std::size_t k = 0; k < counts.size(); ++k) g.jobs_by_state[k] = counts[k];
  g.queue_length = counts[static_cast<std::size_t>(JobState::kQueued)];
  g.histories_total = scheduler_.histories_completed();
  g.histories_per_s = scheduler_.histories_per_s();
  g.sites = static_cast<std::int64_t>(sites_.size());
  g.uptime_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const auto purged = purger_.counters();
  g.purged_jobs = purged.jobs;
  g.purged_bytes = purged.bytes;
  if (const auto space = disk_space(data_dir_)) g.data_free_bytes = space->free_bytes;
  g.data_min_free_bytes = disk_.min_free_bytes();
  metrics_.fill_connection_gauges(g);
  Response r;
  r.content_type = "text/plain; version=0.0.4";
  r.body = metrics_.render(g);
  return r;
}

}  // namespace fragsim::server
