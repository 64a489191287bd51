#pragma once
// summary.json's "ground_bracket" (docs/scenario.md; core/run/bracket.h): the study's HFD and
// building totals at each end of each uncertain ground constant's range, one at a time, widest
// HFD swing first (a tornado table); and the text summary's lines on it.
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "api/units.h"
#include "core/run/result.h"

namespace fragsim::api {

// null without settings.ground_bracket.
nlohmann::ordered_json ground_bracket_json(const run::GroundBracket* bracket);

// (label, value) lines of the text summary from a summary's "ground_bracket" (none without one).
std::vector<std::pair<std::string, std::string>> ground_bracket_text(
    const nlohmann::ordered_json& summary, UnitSystem units = UnitSystem::kSi);

}  // namespace fragsim::api
