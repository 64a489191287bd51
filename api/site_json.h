#pragma once
// The `site` part of a scenario (internal to api/: scenario_json.h is the public interface).
#include <map>
#include <string>

#include "api/json_fields.h"
#include "api/scenario_json.h"
#include "core/scene/site_spec.h"

namespace fragsim::api::detail {

// Parses `j` (at `path`, normally "site"); records every material's provenance in `notes`.
scene::SiteSpec parse_site(const Json& j, const std::string& path,
                           std::map<std::string, MaterialNotes>& notes);

// `notes` may be null (materials then carry no illustrative/source keys).
Json site_to_json(const scene::SiteSpec& site, const std::map<std::string, MaterialNotes>* notes);

}  // namespace fragsim::api::detail
