#pragma once
// A munition description (case, charge, explosive, spray zones) to ordinary fragment groups, for
// `fragsim groups from-munition` (docs/scenario.md, "Fragment groups from a munition"). The
// Gurney/Mott arithmetic is core/fragments/munition.h; this reads the document, names the field
// of any problem (InputError "case.wall_thickness_m: must be > 0 (got -0.01)") and writes the
// groups with the derivation of every number as text.
#include <string>
#include <vector>

#include "api/json_fields.h"

namespace fragsim::api {

struct MunitionGroups {
  Json groups = Json::array();     // the fragment_groups elements, one per zone
  std::vector<std::string> steps;  // the derivation, one line each
  std::vector<std::string> notes;  // constants used that are unverified / illustrative
};

MunitionGroups groups_from_munition(const Json& munition);

}  // namespace fragsim::api
