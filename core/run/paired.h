#pragma once
// A paired comparison (docs/comparison.md): the same histories, i.e. the same launch states drawn
// from the same per-history random streams, flown over a base site and a variant site, and the
// difference of each figure (variant - base) with its paired standard error (common random
// numbers).
//
// Each history contributes x_i to a base figure and y_i to the variant's; the difference is
// tallied per history, d_i = y_i - x_i, in the run's own strata (core/run/launch_strata.h), so
//   se(D)^2 = se(X)^2 + se(Y)^2 - 2 cov(X, Y)
// is estimated directly and is small when the sites treat most histories alike. A history that
// diverges (hits the variant's new wall) is still paired: D stays unbiased, it only gains less.
// The HFD is not a sum over histories: its difference gets a delete-a-group jackknife standard
// error over kJackknifeGroups interleaved groups of histories (indicative: docs/comparison.md).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include "core/run/hfd.h"
#include "core/run/result.h"
#include "core/run/run.h"
#include "core/run/scenario.h"
#include "core/scene/site.h"

namespace fragsim::run {

inline constexpr int kJackknifeGroups = 16;

struct BuildingDifference {
  std::string id;
  bool in_base = false, in_variant = false;          // a building of one site only compares with 0
  std::int32_t base_index = -1, variant_index = -1;  // into each result's buildings
  Estimate impacts, penetrations;                    // variant - base, paired se
};

// variant - base of the HFD and each sector's HFD, with delete-a-group jackknife standard errors.
struct HfdDifference {
  Estimate hfd_m;
  std::array<Estimate, kHfdSectors> by_sector_m{};
};

struct PairedDifference {
  std::vector<BuildingDifference> buildings;  // the base's in order, then the variant's new ones
  std::array<Estimate, kOutcomeCount> outcome_fragments{};
  Estimate left_hazardous;  // real fragments that left the site while hazardous
  // Both sites have the same terrain triangles (same vertices, same order): the density
  // difference per triangle and its paired se. Empty otherwise.
  bool same_terrain = false;
  std::vector<double> density_per_m2, density_std_error_per_m2;
  double max_abs_density_per_m2 = 0.0;
  std::int64_t max_abs_triangle = -1;
  HfdDifference hfd;
  int jackknife_groups = kJackknifeGroups;
};

struct PairedRun {
  RunResult base, variant;
  PairedDifference difference;
  bool cancelled = false;  // either run was cancelled: no difference is reported
};

// Whether the two sites' terrains are the same triangles (exactly).
bool same_terrain(const scene::Site& a, const scene::Site& b);

// The core's part of the pairing check (api/compare_json.h checks that groups and settings are
// the same): the same groups' samples, and no settings.precision (its batches stop on a site's own
// figures) or settings.ground_bracket (not run in a comparison). Throws InputError.
void check_pairable(const Scenario& base, const Scenario& variant);

// Runs the base, then the variant, pairing their histories. `control.on_progress` sees the two
// runs as one of twice the histories; `control.cancel` stops either.
PairedRun run_paired(const Scenario& base, std::shared_ptr<const scene::Site> base_site,
                     const Scenario& variant, std::shared_ptr<const scene::Site> variant_site,
                     const RunControl& control = {});

}  // namespace fragsim::run
