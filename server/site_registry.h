#pragma once
// The sites fragsimd holds in memory: each one's normalised JSON and its built scene::Site
// (terrain and buildings in an Embree scene), shared read-only by every job on that site.
// Persisted as <data>/sites/<site_id>.json plus a row in the store; reloaded at start.
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "api/scenario_json.h"
#include "api/site_document.h"
#include "core/scene/site.h"
#include "server/store.h"

namespace fragsim::server {

struct SiteEntry {
  std::string site_id;
  std::string created_utc;
  nlohmann::json normalised;       // the site JSON a scenario's "site" would hold
  nlohmann::ordered_json summary;  // SiteSummary without jobs_using
  std::shared_ptr<const scene::Site> site;
};

class SiteRegistry {
 public:
  SiteRegistry(Store& store, std::filesystem::path dir);

  // Loads every stored site (at start). A site file that fails to load is logged and skipped.
  void load();

  struct Added {
    std::shared_ptr<const SiteEntry> entry;
    bool created = false;  // false: the identical site was already stored
  };
  // Builds the site (InputError with site-relative paths on bad geometry): the expensive part,
  // which takes no lock, so that a caller can run it outside its own locks (issue 10: a site
  // built under the service's catalogue lock held every job submission for as long).
  static std::shared_ptr<const SiteEntry> prepare(const api::SiteDocument& doc);
  // Stores a prepared entry: writes the file atomically, then the row. Returns the stored entry
  // instead if a site with that id is already there. Throws LimitError when max_sites would be
  // exceeded. Fast: no geometry work.
  Added insert(std::shared_ptr<const SiteEntry> e, std::int64_t max_sites);
  // prepare, then insert (after a check that the site is not stored already).
  Added add(const api::SiteDocument& doc, std::int64_t max_sites);

  std::shared_ptr<const SiteEntry> find(const std::string& site_id) const;
  // A resolver of "site_id" for api::parse_scenario_document that keeps the site it finds alive
  // in `held` (the caller's), even if the site is deleted meanwhile.
  api::SiteResolver resolver(std::shared_ptr<const SiteEntry>& held) const {
    return [this, &held](const std::string& site_id) -> const nlohmann::json* {
      held = find(site_id);
      return held ? &held->normalised : nullptr;
    };
  }
  std::vector<std::shared_ptr<const SiteEntry>> list() const;  // oldest first
  std::size_t size() const;
  // Removes from memory, store and disk. The caller has checked that no job needs it.
  bool remove(const std::string& site_id);

 private:
  static nlohmann::ordered_json summarise(const SiteEntry& e, const api::SiteDocument& doc);

  Store& store_;
  std::filesystem::path dir_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const SiteEntry>> sites_;
  std::vector<std::string> order_;
};

// A configured limit reached (422 limit_exceeded).
class LimitError : public std::runtime_error {
 public:
  LimitError(std::string field, const std::string& message)
      : std::runtime_error(message), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

}  // namespace fragsim::server
