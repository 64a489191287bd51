#pragma once
// fragsimd's request handling, without sockets: a Request in, a Response out. The HTTP layer
// (http_server.cpp) only converts to and from cpp-httplib, so every route, status code and error
// body can be exercised by calling handle() directly.
//
// Order of checks for every request: route (404), method (405 with Allow), authentication (401),
// content type of a body (415), body size (413), then the route's own parsing (400 for text that
// is not JSON or is nested too deep, 422 for JSON that breaks the contract).
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "api/job_request.h"
#include "server/config.h"
#include "server/disk_guard.h"
#include "server/job_maps.h"
#include "server/job_reports.h"
#include "server/metrics.h"
#include "server/purge.h"
#include "server/scene_files.h"
#include "server/scheduler.h"
#include "server/site_registry.h"
#include "server/store.h"
#include "server/ui_assets.h"

namespace fragsim::server {

struct Request {
  std::string method;  // "GET", "POST", ...
  std::string path;    // without the query string
  std::map<std::string, std::string> query;
  std::map<std::string, std::string> headers;  // names in lower case
  std::string body;
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
  std::optional<std::filesystem::path> file;  // send this file's bytes instead of body
  // Or produce the body in pieces: each call appends the next piece to its argument and returns
  // false after the last (sent with chunked transfer encoding; memory stays at one piece).
  std::function<bool(std::string&)> stream;
  std::string route = "unmatched";  // the matched pattern, for metrics and logs
};

// Header names and media types compare case-insensitively.
std::string ascii_lower(std::string s);

// {"code": ..., "message": ..., "field": ... | null}
Response error_response(int status, const std::string& code, const std::string& message,
                        const std::optional<std::string>& field = std::nullopt);

// The routes fragsimd serves: pattern ("{id}" takes one path segment), methods, and whether the
// route is public (no token). api/openapi.yaml describes exactly these (tests/server check it).
struct RouteInfo {
  std::string pattern;
  std::vector<std::string> methods;
  bool public_route = false;
};
std::vector<RouteInfo> route_table();

class Service {
 public:
  // Opens (creates) the data directory and database, loads the sites, recovers jobs a dead daemon
  // left running, and starts the scheduler.
  explicit Service(Config config);
  ~Service();
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  Response handle(const Request& req);

  struct Route;
  // Stops the scheduler (a running job goes back to the queue).
  void shutdown();

  const Config& config() const { return config_; }
  Metrics& metrics() { return metrics_; }

 private:
  Response route_request(const Request& req);
  Response dispatch(const Request& req, const Route& route, const std::string& id,
                    const std::string& name, Role role);
  static std::optional<Response> method_refusal(const Request& req, const Route& route);
  static std::optional<Response> access_refusal(const Request& req, const Route& route,
                                                std::optional<Role> role);
  Response guarded_dispatch(const Request& req, const Route& route, const std::string& id,
                            const std::string& name, Role role);
  // The web viewer's files at /ui/ ("/" and "/ui" redirect there).
  static bool is_ui_path(const std::string& path);
  Response ui_file(const Request& req);
  static Response ui_answer(const Request& req, const std::string& path, UiContent content);
  // CORS for the configured origins only.
  bool cors_allowed(const Request& req) const;
  std::optional<Response> cors_preflight(const Request& req) const;
  void add_cors_headers(const Request& req, Response& r) const;

  // Routes
  Response health();
  Response openapi();
  Response metrics_page();
  Response post_site(const Request& req);
  Response list_sites();
  Response get_site(const std::string& id);
  Response delete_site(const std::string& id);
  Response site_scene(const std::string& id);
  Response post_job(const Request& req);
  void check_comparison(const api::JobRequest& jr);
  Response job_compare(const std::string& id, bool h5);
  Response list_jobs(const Request& req);
  Response get_job(const std::string& id);
  Response delete_job(const Request& req, const std::string& id, Role role);
  Response purge_job(const std::string& id, const std::optional<std::string>& by);
  Response retry_job(const Request& req, const std::string& id, Role role);
  std::optional<Response> not_own_job(const Request& req, const std::string& id, Role role,
                                      const char* action);
  Response whoami(const Request& req, Role role) const;
  Response storage_short(const DiskSpace& found) const;
  Response job_summary(const std::string& id);
  Response job_buildings(const std::string& id);
  Response job_ptn(const Request& req, const std::string& id);
  Response job_results_h5(const std::string& id);
  Response job_plan_boundary(const Request& req, const std::string& id);
  Response job_scene(const Request& req, const std::string& id);
  Response job_maps(const std::string& id);
  Response job_map_file(const std::string& id, const std::string& name);
  Response job_report(const Request& req, const std::string& id, bool pdf);

  // The role of the request's bearer token; nullopt: no valid token (401). Admin with auth off.
  std::optional<Role> role_of(const Request& req) const;
  void check_terrain_size(const scene::TerrainSpec& terrain, const std::string& field) const;
  // The built site a submitted job names or holds (an inline one checked and built now).
  std::shared_ptr<const scene::Site> job_site(const api::JobRequest& jr,
                                              const SiteEntry* held) const;
  std::optional<std::string> owner_of(const Request& req) const;
  nlohmann::ordered_json site_json(const SiteEntry& e);
  nlohmann::ordered_json job_json(const JobRow& row);
  // The job's row when its results can be served; else the error response to send.
  std::variant<JobRow, Response> finished_job(const std::string& id);

  // Held for the daemon's life: a second fragsimd on the same data directory refuses to start
  // (two schedulers would run the same jobs). The kernel releases it when the process dies.
  class DataDirLock {
   public:
    explicit DataDirLock(const std::filesystem::path& dir);
    ~DataDirLock();
    DataDirLock(const DataDirLock&) = delete;
    DataDirLock& operator=(const DataDirLock&) = delete;

   private:
    int fd_ = -1;
  };

  Config config_;
  std::filesystem::path data_dir_;
  DataDirLock lock_;
  std::vector<Token> tokens_;
  std::chrono::steady_clock::time_point started_;
  DiskGuard disk_;
  Store store_;
  SiteRegistry sites_;
  Scheduler scheduler_;
  Metrics metrics_;
  JobMaps maps_;
  JobReports reports_;
  SceneFiles scenes_;
  // Site deletion and job submission check and change "which jobs use which site" together;
  // a purge and a comparison's submission, "which job pairs with which".
  std::mutex catalogue_mutex_;
  JobPurger purger_;
  std::optional<RetentionTimer> retention_;  // started at the end of the constructor
};

}  // namespace fragsim::server
