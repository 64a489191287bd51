#pragma once
// Can a fragment group plainly reach beyond the terrain? (issue 22) A terrain model too small for
// its fragments cuts the hazardous fragment distance at the site boundary: every fragment that
// leaves the terrain ends its history (`left_site`). Before a run, `fragsim validate`,
// `fragsim run` and fragsimd's job submission warn about such groups from a cheap pilot: per
// group K fragments drawn with the run's own sampler (the scenario's seed, histories 0..K-1),
// each flown as a point mass with drag (the run's atmosphere, wind, Cd, presented area and mass)
// over flat ground at the terrain height below the group's frame origin: no terrain relief, no
// buildings, no bounce. A pilot fragment is *beyond* when it comes down outside the terrain's
// horizontal extent with at least the hazardous kinetic energy. docs/scenario.md, "Warnings:
// fragments that can reach beyond the terrain".
#include <cstdint>
#include <string>
#include <vector>

#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

// The cost bound: a submission with many groups must not hold an HTTP handler for long.
struct ReachOptions {
  std::int64_t pilot_per_group = 256;  // K when the budget allows
  std::int64_t pilot_budget = 4096;    // pilot trajectories per scenario in all (>= 1 per group)
  std::int64_t max_steps = 1000;       // integrator steps per trajectory (then: not landed)
  double rtol = 1e-4;                  // the landing point to ~1e-4 of the range is plenty here
};

// One group with at least one pilot fragment beyond the terrain.
struct ReachWarning {
  std::uint32_t group = 0;
  std::string group_name;
  double count = 0.0;                 // real fragments of the group
  std::int64_t pilot = 0;             // K: pilot trajectories flown
  std::int64_t beyond = 0;            // of them: landed off the terrain with KE >= hazardous_ke_j
  double fraction = 0.0;              // beyond / K
  double fraction_se = 0.0;           // binomial standard error sqrt(f (1 - f) / K)
  double real_fragments = 0.0;        // count x fraction
  double hazardous_ke_j = 0.0;        // settings.hazardous_ke_j
  double farthest_m = 0.0;            // horizontal distance of the farthest beyond landing ...
  double farthest_azimuth_deg = 0.0;  // ... its azimuth from the origin, +x toward +y, [0, 360)
  double terrain_edge_m = 0.0;        // where the terrain ends along that azimuth (horizontal)
  // Plain: at least kPlainBeyond pilot fragments beyond (a "warning"); a single one is a "note"
  // (one draw of K says little more than that the tail of the group can get there).
  static constexpr std::int64_t kPlainBeyond = 2;
  bool plain() const { return beyond >= kPlainBeyond; }
  const char* severity() const { return plain() ? "warning" : "note"; }
};

// K for each of `groups` groups under `options`: the per-group pilot, less when the budget
// would be exceeded, but at least 1.
std::int64_t pilot_size(std::size_t groups, const ReachOptions& options = {});

// The groups (in scenario order) with at least one pilot fragment beyond the terrain. Groups
// whose frame origin is off the terrain, under it or inside a building are skipped (the run
// reports their histories as left_site or started_inside) and take no share of the budget.
std::vector<ReachWarning> groups_beyond_terrain(const Scenario& sc, const scene::Site& site,
                                                const ReachOptions& options = {});

// "fragment_groups[2]": the group's path in the scenario document.
std::string reach_field(const ReachWarning& w);
// One paragraph for a user: the field and the group's name, the estimate, what to do about it,
// and how the estimate was made.
std::string reach_message(const ReachWarning& w);

}  // namespace fragsim::run
