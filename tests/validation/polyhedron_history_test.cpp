// Whole histories (run::run, bounce on) of polyhedron fragments: random rocks (the hull of 40
// random points, 2700 kg/m^3, sized by mass) thrown with spin over bumpy terrain. Every impact
// passes the run's energy audit (stats.energy_rises = 0), every history ends (no ground step cap)
// with finite numbers, and the results are bit-identical for 1 and 2 threads.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

run::Scenario rock_scenario(std::int64_t samples) {
  run::Scenario sc = flat_site_scenario(150.0, 10.0);
  // Terrain: a 3 m grid of two crossing sines (slopes up to ~25 deg) over [-150, 150]^2.
  scene::GridTerrainSpec grid;
  grid.origin_m = {-150.0, -150.0};
  grid.spacing_m = 3.0;
  grid.nx = grid.ny = 101;
  for (int j = 0; j < grid.ny; ++j)
    for (int i = 0; i < grid.nx; ++i) {
      const double x = -150.0 + 3.0 * i, y = -150.0 + 3.0 * j;
      grid.elevation_m.push_back(2.0 * std::sin(0.17 * x) * std::cos(0.11 * y) +
                                 0.6 * std::sin(0.41 * x + 0.3 * y));
    }
  sc.site.terrain.geometry = grid;
  scene::MaterialSpec& m = sc.site.materials["soil"];
  m.friction = 0.5;
  m.rolling_resistance = 0.1;
  m.restitution.constant = 0.5;

  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < 40; ++i) pts.emplace_back(0.3 * u(rng), 0.2 * u(rng), 0.12 * u(rng));
  fragments::FragmentGroupSpec g = sphere_group(Vec3(0, 0, 2.0), 1.0, 0.0, 100.0, samples);
  g.name = "rocks";
  g.shape = fragments::polyhedron_shape(pts, 2700.0);
  g.mass_kg = fragments::Distribution::fixed(1.0);
  g.mass_kg.kind = fragments::Distribution::Kind::kUniform;
  g.mass_kg.min = 0.2;
  g.mass_kg.max = 20.0;
  g.mass_kg.has_min = g.mass_kg.has_max = true;
  g.speed_mps.kind = fragments::Distribution::Kind::kUniform;
  g.speed_mps.min = 5.0;
  g.speed_mps.max = 35.0;
  g.speed_mps.has_min = g.speed_mps.has_max = true;
  g.spin_radps.kind = fragments::Distribution::Kind::kUniform;
  g.spin_radps.min = 0.0;
  g.spin_radps.max = 30.0;
  g.spin_radps.has_min = g.spin_radps.has_max = true;
  g.direction.elevation_min_deg = -10.0;
  g.direction.elevation_max_deg = 45.0;
  g.cd.constant = 1.0;
  sc.groups = {g};
  sc.settings.bounce = true;
  sc.settings.harmless_cutoff = false;
  sc.settings.record_fragments = true;
  return sc;
}

TEST(PolyhedronHistory, RocksNeverGainEnergyAlwaysEndAndDoNotDependOnThreads) {
  run::Scenario sc = rock_scenario(1000);
  sc.settings.threads = 1;
  sc.settings.chunk_histories = 400;
  const run::RunResult a = run::run(sc);
  sc.settings.threads = 2;
  sc.settings.chunk_histories = 7;
  const run::RunResult b = run::run(sc);

  EXPECT_EQ(a.stats.energy_rises, 0);
  EXPECT_EQ(a.stats.ground_step_caps, 0);
  EXPECT_GT(a.stats.bounces, 1000);
  EXPECT_GT(a.stats.ground_steps, 0);
  ASSERT_EQ(a.fragments.size(), 1000u);
  int at_rest = 0;
  for (const auto& f : a.fragments) {
    EXPECT_TRUE(f.end_position_m.allFinite() && f.end_velocity_mps.allFinite() &&
                std::isfinite(f.end_time_s) && std::isfinite(f.ground_path_m))
        << f.history;
    at_rest += f.outcome == run::Outcome::kGround;
  }
  EXPECT_GT(at_rest, 500);
  for (const double d : a.ptn_density_per_m2) ASSERT_TRUE(std::isfinite(d));

  EXPECT_EQ(a.ptn_density_per_m2, b.ptn_density_per_m2);
  EXPECT_EQ(a.ptn_std_error_per_m2, b.ptn_std_error_per_m2);
  EXPECT_EQ(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m);
  ASSERT_EQ(a.fragments.size(), b.fragments.size());
  for (std::size_t k = 0; k < a.fragments.size(); ++k) {
    EXPECT_EQ(a.fragments[k].end_position_m, b.fragments[k].end_position_m);
    EXPECT_EQ(a.fragments[k].bounces, b.fragments[k].bounces);
    EXPECT_EQ(a.fragments[k].ground_path_m, b.fragments[k].ground_path_m);
  }
  std::printf(
      "[ measured ] 1000 rocks: %lld bounces, %lld ground steps, %d at rest on the ground, "
      "energy rises %lld\n",
      static_cast<long long>(a.stats.bounces), static_cast<long long>(a.stats.ground_steps),
      at_rest, static_cast<long long>(a.stats.energy_rises));
}

}  // namespace
}  // namespace fragsim::validation
