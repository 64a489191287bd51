// The Service: the web viewer's files and CORS (server/service.h).
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

}  // namespace fragsim::server
