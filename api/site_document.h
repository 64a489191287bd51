#pragma once
// A site uploaded on its own (fragsimd's POST /v1/sites): the `site` member of a scenario as a
// document of its own. Field paths in errors are relative to the site ("terrain.grid.nx").
//
// A site's id is a content hash of its normalised JSON, so the same site uploaded twice (whatever
// its key order, number spelling or whitespace) gets the same id.
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "api/scenario_json.h"
#include "core/scene/site.h"
#include "core/scene/site_spec.h"

namespace fragsim::api {

struct SiteDocument {
  scene::SiteSpec spec;
  std::map<std::string, MaterialNotes> material_notes;
  nlohmann::json normalised;  // every default filled in; what a scenario's "site" would hold
  std::string site_id;        // "s_" + 16 hex digits of the SHA-256 of normalised.dump()
};

// Parses and type-checks (no geometry); throws InputError with site-relative paths.
SiteDocument parse_site_document(const nlohmann::json& j);

// Builds the site (geometry checks, Embree scene); InputError paths are site-relative.
std::shared_ptr<const scene::Site> build_site(const SiteDocument& doc);

// True for the form site ids take ("s_" + 16 lowercase hex digits). Anything else is not a site
// id, and is never used to build a path.
bool is_site_id(std::string_view s);

}  // namespace fragsim::api
