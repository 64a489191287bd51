#pragma once
// Fragment groups and distributions (internal to api/: scenario_json.h is the public interface).
#include <limits>
#include <string>

#include "api/json_fields.h"
#include "core/fragments/distribution.h"
#include "core/fragments/group.h"

namespace fragsim::api::detail {

// A number (fixed) or {"dist": "fixed"|"uniform"|"normal"|"lognormal"|"table"|"mott", ...}; checked
// with Distribution::validate(phys_lo, phys_hi), whose message is re-rooted at `path`.
fragments::Distribution parse_distribution(const Json& j, const std::string& path, double phys_lo,
                                           double phys_hi);
Json distribution_to_json(const fragments::Distribution& d);

fragments::FragmentGroupSpec parse_fragment_group(const Json& j, const std::string& path);
Json fragment_group_to_json(const fragments::FragmentGroupSpec& g);

}  // namespace fragsim::api::detail
