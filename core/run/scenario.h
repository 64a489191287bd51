#pragma once
// A complete simulation request in core terms: the site, the atmosphere, the fragment groups and
// the run settings. The api layer builds it from JSON (docs/scenario.md); the core validates
// what it needs to (geometry) and trusts the api layer for the rest.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/flight/atmosphere.h"
#include "core/fragments/group.h"
#include "core/scene/site_spec.h"

namespace fragsim::run {

// settings.precision (docs/precision.md): run in batches, each batch `samples` histories of every
// group, until every requested target holds at a batch boundary, or a cap is reached. A target
// that is not given is not checked; with no target at all the run is exactly max_batches batches.
// Relative/absolute pairs hold when either holds.
// settings.precision.direction_importance (docs/precision.md, "Importance sampling"): from
// batch 1 on, each group's launch directions (and speeds) are drawn from a piecewise-constant
// density over elevation x azimuth (x speed) cells, learnt from the batches before, mixed with
// the group's own density.
struct DirectionImportanceSettings {
  int elevation_cells = 24;  // 24 x 72 measured best on the demo (docs/benchmarks.md)
  int azimuth_cells = 72;
  int speed_cells = 1;              // cells across the speed distribution's quantiles
  double defensive_fraction = 0.3;  // share of the group's own density in the mixture
  int mass_cells = 4;  // cells across the mass distribution's quantiles (docs/benchmarks.md §8)
};

struct PrecisionSettings {
  std::optional<double> hfd_half_band_m;       // (hfd_upper - hfd_lower) / 2 <= this
  std::optional<double> hfd_half_band_rel;     // ... <= this * HFD
  std::optional<double> building_rel_error;    // se <= this * mean, impacts and penetrations
  std::optional<double> building_abs_error;    // ... or se <= this (real fragments)
  std::vector<std::string> buildings;          // building ids the targets apply to; empty: all
  std::optional<double> ptn_rel_error_at_hfd;  // rms se/density, hazardous triangles near the HFD
  std::int64_t min_batches = 2;
  std::int64_t max_batches = 100;
  double max_wall_s = 0.0;  // 0: no wall-time cap (a wall-time stop depends on the machine)
  std::optional<DirectionImportanceSettings> direction_importance;
  bool has_targets() const {
    return hfd_half_band_m || hfd_half_band_rel || building_rel_error || building_abs_error ||
           ptn_rel_error_at_hfd;
  }
};

// settings.stratified_launch (docs/precision.md, "Stratified launch sampling"): within each batch,
// group g's samples_g histories form J_g = samples_g / histories_per_stratum strata of the launch
// cell variable u_cell, each holding histories_per_stratum consecutive histories (the last also
// the remainder); each stratum is closed as a stratum of the estimators, so the standard errors
// are those of stratified sampling. Without importance sampling the cells are equal, about one
// per stratum (DirectionCells::for_strata); with it, the learnt cells.
// method "sobol" instead: randomized quasi-Monte Carlo. Group g's histories of a batch form
// `replicates` blocks of consecutive histories, each an independently Owen-scrambled Sobol net
// over the launch variables (core/fragments/sobol.h); the blocks are the units of the variance
// estimate (docs/precision.md, "Scrambled Sobol launch").
enum class LaunchStratification { kStrata, kSobol };
struct StratifiedLaunchSettings {
  LaunchStratification method = LaunchStratification::kStrata;
  std::int64_t histories_per_stratum = 2;  // >= 2: the within-stratum variance needs two
  bool speed = false;            // equal cells across speed too (only without importance sampling)
  std::int64_t replicates = 16;  // sobol: independent nets per group and batch (>= 2)
};

// settings.ground_bracket (docs/physics.md, "The bracket"): after the study, the terrain
// material's uncertain constants (scene::effective_ranges) are run at each end of their range,
// one at a time, with the same seed, each run with the groups' samples x samples_scale.
struct GroundBracketSettings {
  double samples_scale = 1.0;  // (0, 1]
};

struct Settings {
  std::uint64_t seed = 1;
  double person_height_m = 1.8;  // H_r of the PTN prisms (paper eq. 37)
  double hazardous_ke_j = 79.0;  // 58 ft-lb (DDESB TP-16 / DoD 6055.09-M hazardous fragment)
  double hfd_threshold_per_m2 = 1.0 / 55.74;  // 1 hazardous fragment per 600 ft^2
  std::optional<Vec3> hfd_origin_m;  // input coordinates; default: first group's frame origin
  double max_flight_time_s = 120.0;
  double rtol = 1e-6;       // integrator.rtol
  double sagitta_m = 0.05;  // integrator.sagitta_m: chord sagitta tolerance
  bool bounce = false;      // ground impact ends the history when false
  // Bounce limits (settings.bounce_limits): after a bounce whose centre-of-mass rebound speed
  // along the normal is below the floor, or after max_bounces, the fragment slides or rolls.
  double min_rebound_speed_mps = 0.5;  // hop height v^2 / 2g = 1.3 cm
  std::int64_t max_bounces = 100;
  std::int64_t max_ground_steps = 100000;
  int threads = 0;                     // 0: all hardware threads
  std::int64_t chunk_histories = 256;  // scheduling granularity (results do not depend on it)
  bool record_fragments = false;       // per-history table in results.h5
  bool record_trajectories = false;    // sampled trajectory points in results.h5
  std::int64_t max_recorded_trajectories = 1000;
  bool profile = false;  // time split integration / geometry / tally (costs a bit)
  // Stop tracking a fragment that provably can neither be hazardous again nor reach a building
  // (outcome `harmless`, docs/architecture.md). Not a scenario key: it never changes a tally,
  // only outcomes and cost, and tests compare runs with and without it.
  bool harmless_cutoff = true;
  // Skip the body-contact search of a chord whose clearance over a plane or grid terrain proves
  // that the body cannot reach it (docs/physics.md K2). Not a scenario key: it never changes a
  // result, only cost, and a test compares runs with and without it.
  bool terrain_clearance_skip = true;
  // Work cap per history: integrator steps (flight and ground) and events (impacts, ground
  // events) together. A history that reaches it ends (outcome `work_limit`), so that no history
  // runs unbounded whatever the inputs. Not a scenario key: real histories stay far below it
  // (the demo: about 22 steps per history; 100 bounces and 1e5 ground steps are the default
  // caps), and at ~1 us a unit it bounds a history to about a second. Tests lower it.
  std::int64_t max_history_work = 1'000'000;
  std::optional<PrecisionSettings> precision;  // absent: one batch (the groups' samples)
  std::optional<StratifiedLaunchSettings> stratified_launch;  // absent: independent histories
  std::optional<GroundBracketSettings> ground_bracket;        // absent: no bracket runs
};

struct Scenario {
  scene::SiteSpec site;
  flight::AtmosphereSpec atmosphere;
  double gravity_mps2 = kStandardGravity_mps2;
  std::vector<fragments::FragmentGroupSpec> groups;
  Settings settings;
};

}  // namespace fragsim::run
