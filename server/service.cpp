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
#include "api/output_dir.h"
#include "api/ptn_json.h"
#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/scene_binary.h"
#include "api/sha256.h"
#include "api/site_document.h"
#include "api/summary_json.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "core/run/reach.h"
#include "core/scene/site_limits.h"
#include "fragsim/version.h"
#include "gis/gdal_support.h"
#include "gis/plan_boundary.h"
#include "gis/results_file.h"
#include "server/log.h"
#include "server/openapi_text.h"
#include "server/ui_assets.h"
#include "server/utf8.h"

namespace fragsim::server {

using OJson = nlohmann::ordered_json;

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

constexpr const char* kJsonType = "application/json";

// Strings in a body are valid UTF-8 by construction (client text passes escape_invalid_utf8);
// should one not be, it is replaced rather than turning the answer into an exception.
Response json_response(int status, const OJson& j) {
  Response r;
  r.status = status;
  r.body = j.dump(-1, ' ', false, OJson::error_handler_t::replace);
  return r;
}

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

// Query parameters a route accepts; anything else is refused (a misspelt filter would otherwise
// silently return everything).
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

// Text -> JSON with the 400 errors of the contract.
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

}  // namespace

std::string ascii_lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

// A query parameter's value as a finite number, the whole text and nothing else.
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
  std::size_t n = api::remove_stale_temporaries(data_dir / "sites");
  std::error_code ec;
  for (std::filesystem::directory_iterator it(data_dir / "jobs", ec), end; !ec && it != end;
       it.increment(ec)) {
    if (it->is_directory(ec))
      n += api::remove_stale_temporaries(it->path()) + JobMaps::remove_stale(it->path()) +
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

// ---- The web viewer (docs/viewer.md) ----

bool Service::is_ui_path(const std::string& path) {
  return path == "/" || path == "/ui" || path.rfind("/ui/", 0) == 0;
}

// The page is public: it holds no data, and a browser cannot send a token to load it. Every
// file is sent with a content security policy that allows only the daemon's own scripts, styles
// and API (no inline script, no other origin): text the page shows from a scenario cannot run.
Response Service::ui_file(const Request& req) {
  Response r;
  if (req.method != "GET" && req.method != "HEAD") {
    r = error_response(405, "method_not_allowed",
                       req.method + " is not allowed on /ui/ (allowed: GET)");
    r.headers.emplace_back("Allow", "GET");
  } else if (config_.ui && (req.path == "/" || req.path == "/ui")) {
    r.status = 302;
    r.headers.emplace_back("Location", "/ui/");
    r.content_type = "text/plain; charset=utf-8";
    r.body = "the viewer is at /ui/\n";
  } else {
    const auto path =
        req.path.size() >= 4 ? ui_file_path(std::string_view(req.path).substr(4)) : std::nullopt;
    auto content = config_.ui && path ? read_ui_file(config_.ui_dir, *path) : std::nullopt;
    if (content) {
      r = ui_answer(req, *path, std::move(*content));
    } else {
      r = error_response(404, "not_found", "no route " + req.path);
    }
  }
  r.route = "/ui/";
  return r;
}

// A viewer file, or a 304 when the browser holds it already (with no-cache, a browser
// revalidates each file on every load).
Response Service::ui_answer(const Request& req, const std::string& path, UiContent content) {
  Response r;
  r.headers.emplace_back("ETag", content.etag);
  if (const auto it = req.headers.find("if-none-match");
      it != req.headers.end() && it->second.find(content.etag) != std::string::npos) {
    r.status = 304;
  } else {
    r.content_type = ui_content_type(path);
    r.body = std::move(content.bytes);
  }
  r.headers.emplace_back("Content-Security-Policy",
                         "default-src 'self'; img-src 'self' data: blob:; style-src 'self'; "
                         "script-src 'self'; connect-src 'self'; object-src 'none'; "
                         "base-uri 'none'; frame-ancestors 'none'; form-action 'self'");
  r.headers.emplace_back("X-Content-Type-Options", "nosniff");
  r.headers.emplace_back("Referrer-Policy", "no-referrer");
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

// ---- CORS (off unless origins are configured) ----

bool Service::cors_allowed(const Request& req) const {
  const auto it = req.headers.find("origin");
  return it != req.headers.end() &&
         std::find(config_.cors_origins.begin(), config_.cors_origins.end(), it->second) !=
             config_.cors_origins.end();
}

std::optional<Response> Service::cors_preflight(const Request& req) const {
  if (req.method != "OPTIONS" || !req.headers.count("access-control-request-method") ||
      !cors_allowed(req))
    return std::nullopt;
  Response r;
  r.status = 204;
  r.content_type.clear();
  r.route = "preflight";
  r.headers.emplace_back("Access-Control-Allow-Methods", "GET, POST, DELETE");
  r.headers.emplace_back("Access-Control-Allow-Headers", "Authorization, Content-Type");
  r.headers.emplace_back("Access-Control-Max-Age", "600");
  add_cors_headers(req, r);
  return r;
}

void Service::add_cors_headers(const Request& req, Response& r) const {
  if (config_.cors_origins.empty()) return;
  r.headers.emplace_back("Vary", "Origin");
  if (!cors_allowed(req)) return;
  r.headers.emplace_back("Access-Control-Allow-Origin", req.headers.at("origin"));
  r.headers.emplace_back("Access-Control-Expose-Headers", "Location, Content-Disposition");
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
  } catch (const api::StorageFullError& e) {
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

// ---- Sites ----

OJson Service::site_json(const SiteEntry& e) {
  OJson j = e.summary;
  j["jobs_using"] = store_.active_jobs_using(e.site_id);
  return j;
}

// Refuses, before anything is built, a site larger than this daemon's memory budget allows.
void Service::check_terrain_size(const scene::TerrainSpec& terrain,
                                 const std::string& field) const {
  const double n = scene::terrain_triangles_of(terrain);
  if (n > static_cast<double>(config_.max_terrain_triangles))
    throw LimitError(field, "the terrain would have " +
                                std::to_string(static_cast<std::int64_t>(n)) +
                                " triangles; this daemon accepts at most " +
                                std::to_string(config_.max_terrain_triangles) +
                                " per site (--max-terrain-triangles)");
}

Response Service::post_site(const Request& req) {
  if (auto bad = check_json_content_type(req)) return *bad;
  const api::SiteDocument doc = api::parse_site_document(parse_body(req));
  check_terrain_size(doc.spec.terrain, "terrain");
  std::shared_ptr<const SiteEntry> entry = sites_.find(doc.site_id);
  bool created = false;
  if (!entry) {
    if (const auto found = disk_.short_of_space()) return storage_short(*found);
    // Built with no lock held: job submissions and site deletions go on meanwhile. Only the
    // insertion, which is quick, is serialised with them.
    const auto prepared = SiteRegistry::prepare(doc);
    const std::lock_guard<std::mutex> lock(catalogue_mutex_);
    const auto added = sites_.insert(prepared, config_.max_sites);
    entry = added.entry;
    created = added.created;
  }
  if (created)
    log(LogLevel::kInfo, "site added",
        {{"site_id", entry->site_id},
         {"terrain_triangles", std::to_string(entry->site->terrain_triangle_count())}});
  Response r = json_response(created ? 201 : 200, site_json(*entry));
  r.headers.emplace_back("Location", "/v1/sites/" + entry->site_id);
  return r;
}

Response Service::list_sites() {
  auto list = OJson::array();
  for (const auto& e : sites_.list()) list.push_back(site_json(*e));
  return json_response(200, OJson{{"sites", std::move(list)}});
}

Response Service::get_site(const std::string& id) {
  const auto e = sites_.find(id);
  if (!e) return error_response(404, "not_found", "no site " + id);
  return json_response(200, site_json(*e));
}

// The site's terrain and buildings for a browser (api/scene_binary.h).
Response Service::site_scene(const std::string& id) {
  const auto e = sites_.find(id);
  if (!e) return error_response(404, "not_found", "no site " + id);
  Response r;
  r.content_type = api::kSceneContentType;
  r.file = scenes_.ensure(data_dir_ / "sites", SceneFiles::site_scene_name(id),
                          [&] { return api::scene_from_site(*e->site); });
  return r;
}

Response Service::delete_site(const std::string& id) {
  const std::lock_guard<std::mutex> lock(catalogue_mutex_);
  if (!sites_.find(id)) return error_response(404, "not_found", "no site " + id);
  if (const auto n = store_.active_jobs_using(id); n > 0)
    return error_response(409, "conflict",
                          "site " + id + " is used by " + std::to_string(n) +
                              " queued or running job" + (n == 1 ? "" : "s") +
                              "; cancel them or wait until they finish");
  sites_.remove(id);
  log(LogLevel::kInfo, "site deleted", {{"site_id", id}});
  Response r;
  r.status = 204;
  r.content_type.clear();
  return r;
}

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
  std::int64_t max_trajectories = api::kDefaultSceneTrajectories;
  if (const auto it = req.query.find("max_trajectories"); it != req.query.end()) {
    const std::string& text = it->second;
    const bool digits =
        !text.empty() && text.size() <= 6 &&
        std::all_of(text.begin(), text.end(), [](unsigned char c) { return std::isdigit(c); });
    if (!digits || std::stoll(text) > api::kMaxSceneTrajectories)
      return error_response(
          400, "bad_parameter",
          "must be an integer in [0, " + std::to_string(api::kMaxSceneTrajectories) + "]",
          "max_trajectories");
    max_trajectories = std::stoll(text);
  }
  auto job = finished_job(id);
  if (auto* r = std::get_if<Response>(&job)) return *r;
  const auto dir = scheduler_.job_dir(id);
  const auto build = [&] {
    return api::scene_from_results(dir / api::kResultsFileName, max_trajectories);
  };
  Response r;
  r.content_type = api::kSceneContentType;
  if (max_trajectories == api::kDefaultSceneTrajectories)
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
