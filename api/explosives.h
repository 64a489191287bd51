#pragma once
// The built-in table of explosives for `fragsim groups from-munition` (docs/scenario.md,
// "Explosives"): Gurney velocity sqrt(2E) and Mott constant B, each with its source and whether
// it could be checked against a source text. examples/munitions/explosives.json is the same
// table as data (tests/api/munition_json_test.cpp keeps them equal).
#include <span>
#include <string_view>

#include "api/json_fields.h"

namespace fragsim::api {

struct Explosive {
  std::string_view name;
  double gurney_velocity_mps;  // sqrt(2E)
  std::string_view gurney_source;
  bool gurney_verified;     // checked against a source text (not only as quoted in issue 26)
  double mott_constant_us;  // B, oz^(1/2) in^(-7/6); 0: none in the table
  std::string_view mott_source;
  bool mott_verified;
};

std::span<const Explosive> explosives();
// By name, ignoring ASCII case ("comp b" finds "Comp B"); nullptr when absent.
const Explosive* find_explosive(std::string_view name);
// The table as examples/munitions/explosives.json holds it.
Json explosives_json();

}  // namespace fragsim::api
