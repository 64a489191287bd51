#include "server/site_registry.h"

#include <algorithm>
#include <fstream>
#include <sstream>

#include "api/scenario_json.h"
#include "formats/output_dir.h"
#include "server/log.h"
#include "server/scene_files.h"

namespace fragsim::server {

SiteRegistry::SiteRegistry(Store& store, std::filesystem::path dir)
    : store_(store), dir_(std::move(dir)) {}

nlohmann::ordered_json SiteRegistry::summarise(const SiteEntry& e, const api::SiteDocument& doc) {
  const scene::Site& s = *e.site;
  nlohmann::ordered_json j;
  j["site_id"] = e.site_id;
  j["created_utc"] = e.created_utc;
  j["terrain_triangles"] = s.terrain_triangle_count();
  std::size_t building_triangles = 0;
  auto ids = nlohmann::ordered_json::array();
  for (const auto& b : s.buildings()) {
    building_triangles += b.triangle_count;
    ids.push_back(b.id);
  }
  j["building_triangles"] = building_triangles;
  j["buildings"] = s.buildings().size();
  j["building_ids"] = std::move(ids);
  auto materials = nlohmann::ordered_json::array();
  for (const auto& [name, spec] : doc.spec.materials) materials.push_back(name);
  j["materials"] = std::move(materials);
  const Box3& box = s.bounds();
  const Vec3 lo = s.to_input(box.lo);
  const Vec3 hi = s.to_input(box.hi);
  j["extent_m"] = {lo.x(), lo.y(), lo.z(), hi.x(), hi.y(), hi.z()};
  return j;
}

void SiteRegistry::load() {
  for (const SiteRow& row : store_.sites()) {
    const std::filesystem::path file = dir_ / (row.site_id + ".json");
    try {
      if (!api::is_site_id(row.site_id)) throw std::runtime_error("malformed site id");
      std::ifstream in(file, std::ios::binary);
      if (!in) throw std::runtime_error("cannot read " + file.string());
      std::ostringstream text;
      text << in.rdbuf();
      const api::SiteDocument doc = api::parse_site_document(api::parse_json_text(text.str()));
      if (doc.site_id != row.site_id)
        throw std::runtime_error("content does not match its id (file changed on disk?)");
      auto e = std::make_shared<SiteEntry>();
      e->site_id = row.site_id;
      e->created_utc = row.created_utc;
      e->normalised = doc.normalised;
      e->site = api::build_site(doc);
      e->summary = summarise(*e, doc);
      const std::lock_guard<std::mutex> lock(mutex_);
      sites_[row.site_id] = std::move(e);
      order_.push_back(row.site_id);
    } catch (const std::exception& ex) {
      log(LogLevel::kError, "site not loaded", {{"site_id", row.site_id}, {"error", ex.what()}});
    }
  }
}

std::shared_ptr<const SiteEntry> SiteRegistry::prepare(const api::SiteDocument& doc) {
  auto e = std::make_shared<SiteEntry>();
  e->site_id = doc.site_id;
  e->created_utc = utc_now();
  e->normalised = doc.normalised;
  e->site = api::build_site(doc);
  e->summary = summarise(*e, doc);
  return e;
}

SiteRegistry::Added SiteRegistry::insert(std::shared_ptr<const SiteEntry> e,
                                         std::int64_t max_sites) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (const auto it = sites_.find(e->site_id); it != sites_.end()) return {it->second, false};
  if (static_cast<std::int64_t>(sites_.size()) >= max_sites)
    throw LimitError("", "the daemon holds " + std::to_string(sites_.size()) +
                             " sites, its limit (--max-sites); delete one first");
  formats::OutputDir out(dir_);
  out.stage_text(e->site_id + ".json", e->normalised.dump());
  out.commit();
  SiteRow row{e->site_id, e->created_utc, e->summary.dump()};
  store_.insert_site(row);
  sites_[e->site_id] = e;
  order_.push_back(e->site_id);
  return {e, true};
}

SiteRegistry::Added SiteRegistry::add(const api::SiteDocument& doc, std::int64_t max_sites) {
  if (auto existing = find(doc.site_id)) return {existing, false};
  return insert(prepare(doc), max_sites);
}

std::shared_ptr<const SiteEntry> SiteRegistry::find(const std::string& site_id) const {
  const std::lock_guard<std::mutex> lock(mutex_);
  const auto it = sites_.find(site_id);
  return it == sites_.end() ? nullptr : it->second;
}

std::vector<std::shared_ptr<const SiteEntry>> SiteRegistry::list() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::shared_ptr<const SiteEntry>> out;
  for (const auto& id : order_) out.push_back(sites_.at(id));
  return out;
}

std::size_t SiteRegistry::size() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return sites_.size();
}

bool SiteRegistry::remove(const std::string& site_id) {
  const std::lock_guard<std::mutex> lock(mutex_);
  if (sites_.erase(site_id) == 0) return false;
  order_.erase(std::remove(order_.begin(), order_.end(), site_id), order_.end());
  store_.delete_site(site_id);
  std::error_code ec;
  for (const std::string& name : SceneFiles::site_scene_names(site_id))
    std::filesystem::remove(dir_ / name, ec);
  std::filesystem::remove(dir_ / (site_id + ".json"), ec);
  if (ec)
    log(LogLevel::kWarn, "site file not removed", {{"site_id", site_id}, {"error", ec.message()}});
  return true;
}

}  // namespace fragsim::server
