#pragma once
// summary.json's "hfd_attribution" (docs/scenario.md, core/run/attribution.h): the HFD of the
// density field each PTN mechanism and each fragment group makes alone, and the shares of the
// density at the triangles that set the HFD and each sector's HFD; and the text summary's lines
// on it.
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "api/units.h"
#include "core/run/result.h"
#include "core/run/scenario.h"

namespace fragsim::api {

nlohmann::ordered_json hfd_attribution_json(const run::HfdAttribution& attribution,
                                            const run::Scenario& scenario);

// (label, value) lines of the text summary from a summary's "hfd_attribution" (none without
// one): what sets the HFD at its triangle, and the HFD of each mechanism and group alone.
std::vector<std::pair<std::string, std::string>> hfd_attribution_text(
    const nlohmann::ordered_json& summary, UnitSystem units = UnitSystem::kSi);

}  // namespace fragsim::api
