// The work cap per history (Settings::max_history_work, outcome work_limit; issue 10): a history
// that would run on stops there, in flight and in the ground phase, and a run below the cap is
// unchanged by it.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>

#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

std::int64_t outcome_count(const RunResult& r, Outcome o) {
  return r.outcome_histories[static_cast<std::size_t>(o)];
}

// Spheres thrown up at 45 degrees over a 2 km plane: about 30 s of flight with drag.
Scenario lofted_spheres(std::int64_t samples) {
  Scenario sc = validation::flat_site_scenario(1000.0, 10.0);
  auto g = validation::sphere_group(Vec3(0, 0, 1), 0.05, 120.0, 10.0, samples);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = 40.0;
  g.direction.elevation_max_deg = 50.0;
  sc.groups = {g};
  sc.settings.record_fragments = true;
  sc.settings.harmless_cutoff = false;  // followed to the ground
  return sc;
}

TEST(WorkLimit, AFlightBeyondTheCapEndsAsWorkLimit) {
  Scenario sc = lofted_spheres(20);
  const RunResult full = run(sc);
  ASSERT_EQ(outcome_count(full, Outcome::kGround), 20);
  EXPECT_EQ(outcome_count(full, Outcome::kWorkLimit), 0);
  const double steps_per_history = static_cast<double>(full.stats.integrator_steps) / 20.0;
  ASSERT_GT(steps_per_history, 6.0);

  sc.settings.max_history_work = 5;  // fewer steps than any of these flights needs
  const RunResult capped = run(sc);
  EXPECT_EQ(outcome_count(capped, Outcome::kWorkLimit), 20);
  EXPECT_EQ(capped.stats.integrator_steps, 20 * 5);
  ASSERT_EQ(capped.fragments.size(), 20u);
  for (std::size_t k = 0; k < capped.fragments.size(); ++k) {
    const FragmentRecord& f = capped.fragments[k];
    EXPECT_EQ(f.outcome, Outcome::kWorkLimit);
    // Stopped in the air, where the fifth step ended, before the uncapped flight's end.
    EXPECT_TRUE(f.end_position_m.allFinite());
    EXPECT_GT(f.end_position_m.z(), 1.0);
    EXPECT_GT(f.end_time_s, 0.0);
    EXPECT_LT(f.end_time_s, full.fragments[k].end_time_s);
  }
}

TEST(WorkLimit, TheGroundPhaseStopsAtTheHistorysCapNotTheGroundStepCap) {
  // With bounce and no restitution, a sphere thrown low lands, then rolls on the plane for
  // seconds (no crest: no take-off). A cap between its flight work and its whole work ends it
  // rolling, as work_limit, before max_ground_steps would.
  Scenario sc = validation::rolling_sphere_scenario(1);  // followed to rest
  sc.settings.record_fragments = true;
  const RunResult full = run(sc);
  ASSERT_EQ(outcome_count(full, Outcome::kGround), 1);
  ASSERT_EQ(full.stats.takeoffs, 0);
  ASSERT_GT(full.stats.ground_steps, 4);
  const std::int64_t flight_work = full.stats.integrator_steps + full.stats.bounces;

  sc.settings.max_history_work = flight_work + full.stats.ground_steps / 2;
  const RunResult capped = run(sc);
  EXPECT_EQ(outcome_count(capped, Outcome::kWorkLimit), 1);
  EXPECT_EQ(capped.stats.ground_step_caps, 0);  // not the ground step cap
  EXPECT_EQ(capped.stats.ground_steps, full.stats.ground_steps / 2);
  const FragmentRecord& f = capped.fragments.at(0);
  EXPECT_EQ(f.outcome, Outcome::kWorkLimit);
  EXPECT_TRUE(f.end_position_m.allFinite());
  EXPECT_GT(f.end_velocity_mps.norm(), 0.0);  // still rolling
  EXPECT_GT(f.ground_path_m, 0.0);
  EXPECT_LT(f.ground_path_m, full.fragments.at(0).ground_path_m);

  // The ground step cap, when it comes first, ends the history as ground_step_cap.
  sc.settings.max_ground_steps = full.stats.ground_steps / 4;
  const RunResult ground_capped = run(sc);
  EXPECT_EQ(outcome_count(ground_capped, Outcome::kGroundStepCap), 1);
  EXPECT_EQ(outcome_count(ground_capped, Outcome::kWorkLimit), 0);
  EXPECT_EQ(ground_capped.stats.ground_step_caps, 1);
}

TEST(WorkLimit, AbsurdPhysicsPassedToCoreDirectlyIsBounded) {
  // What the api layer refuses (docs/scenario.md, "Limits"), given to core directly: a drag
  // coefficient of 1.8e19, a density of 1.8e19 kg/m^3 and 2.1e9 m/s^2 of gravity (found by
  // fuzzing) made 3.2 million tiny steps (2 s) per history. Each now stops at the cap, in well
  // under a second.
  Scenario sc = lofted_spheres(2);
  sc.groups[0].cd.constant = 1.8e19;
  sc.groups[0].shape.density_kg_m3 = 1.8e19;
  sc.gravity_mps2 = 2.1e9;
  const auto start = std::chrono::steady_clock::now();
  const RunResult r = run(sc);
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::int64_t ended = 0;
  for (auto n : r.outcome_histories) ended += n;
  EXPECT_EQ(ended, 2);
  EXPECT_EQ(outcome_count(r, Outcome::kWorkLimit), 2);
  for (const auto& f : r.fragments) {
    EXPECT_TRUE(f.end_position_m.allFinite());
    EXPECT_TRUE(std::isfinite(f.end_time_s));
  }
  std::printf("[ measured ] absurd physics: %.3f s for 2 histories, %lld integrator steps\n",
              wall_s, static_cast<long long>(r.stats.integrator_steps));
  EXPECT_EQ(r.stats.integrator_steps, 2 * sc.settings.max_history_work);
}

TEST(WorkLimit, OutcomeName) {
  EXPECT_STREQ(outcome_name(Outcome::kWorkLimit), "work_limit");
  EXPECT_STREQ(outcome_name(Outcome::kGroundStepCap), "ground_step_cap");
  EXPECT_EQ(static_cast<int>(Outcome::kGroundStepCap), kOutcomeCount - 1);
}

}  // namespace
}  // namespace fragsim::run
