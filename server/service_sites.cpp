// The Service: the routes of stored sites (server/service.h, docs/http-api.md).
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

// The site's terrain and buildings for a browser (formats/scene_binary.h).
Response Service::site_scene(const std::string& id) {
  const auto e = sites_.find(id);
  if (!e) return error_response(404, "not_found", "no site " + id);
  Response r;
  r.content_type = formats::kSceneContentType;
  r.file = scenes_.ensure(data_dir_ / "sites", SceneFiles::site_scene_name(id),
                          [&] { return formats::scene_from_site(*e->site); });
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

}  // namespace fragsim::server
