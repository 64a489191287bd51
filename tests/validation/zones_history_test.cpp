// Whole histories on a site with two material zones (docs/physics.md, G15): fragments that only
// ever touch one zone give, bit for bit, the results of a site made of that zone's material
// alone; fragments that cross the boundary give neither.
#include <gtest/gtest.h>

#include "core/run/run.h"
#include "scenario_fixtures.h"

namespace fragsim::validation {
namespace {

// Steel spheres thrown with bounce from (0, 0, 1) toward azimuth `azimuth_deg` +- 30 deg, 5-25 deg
// up, at 25 m/s, over a 1.2 km plane: on level ground their horizontal velocity never reverses
// (no spin to start with, friction only slows it), so each stays on its side of x = 0 when
// thrown away from it.
run::Scenario thrown(double azimuth_deg) {
  run::Scenario sc = flat_site_scenario(600.0, 20.0);
  auto g = sphere_group(Vec3(0, 0, 1.0), 0.2, 25.0, 100.0, 400);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = 5.0;
  g.direction.elevation_max_deg = 25.0;
  g.direction.azimuth_min_deg = azimuth_deg - 30.0;
  g.direction.azimuth_max_deg = azimuth_deg + 30.0;
  sc.groups = {g};
  sc.settings.bounce = true;
  sc.settings.record_fragments = true;
  sc.settings.harmless_cutoff = false;  // 62 J: below the hazardous threshold, tracked anyway
  scene::MaterialSpec grass;            // illustrative test materials
  grass.friction = 0.8;
  grass.rolling_resistance = 0.3;
  grass.restitution.constant = 0.2;
  scene::MaterialSpec gravel;
  gravel.friction = 0.4;
  gravel.rolling_resistance = 0.05;
  gravel.restitution.constant = 0.5;
  sc.site.materials = {{"soil", grass}, {"gravel", gravel}};
  return sc;
}

// "soil" (grass) for x < 0, a "gravel" zone for x > 0.
run::Scenario zoned(run::Scenario sc) {
  sc.site.terrain.zones = {{"gravel", {{0, -600}, {600, -600}, {600, 600}, {0, 600}}}};
  return sc;
}

void expect_same_histories(const run::RunResult& a, const run::RunResult& b) {
  ASSERT_EQ(a.fragments.size(), b.fragments.size());
  for (std::size_t k = 0; k < a.fragments.size(); ++k) {
    EXPECT_EQ(a.fragments[k].end_position_m, b.fragments[k].end_position_m) << k;
    EXPECT_EQ(a.fragments[k].end_time_s, b.fragments[k].end_time_s) << k;
    EXPECT_EQ(a.fragments[k].bounces, b.fragments[k].bounces) << k;
  }
  EXPECT_EQ(a.ptn_density_per_m2, b.ptn_density_per_m2);
}

TEST(ZonesHistory, FragmentsOnOneZoneAreThatMaterialsRun) {
  // Toward -x: only grass is touched; toward +x: only gravel.
  const run::RunResult west_zoned = run::run(zoned(thrown(180.0)));
  const run::RunResult west_grass = run::run(thrown(180.0));
  expect_same_histories(west_zoned, west_grass);
  run::Scenario gravel_only = thrown(0.0);
  gravel_only.site.terrain.material = "gravel";
  const run::RunResult east_zoned = run::run(zoned(thrown(0.0)));
  expect_same_histories(east_zoned, run::run(gravel_only));
  for (const auto& f : east_zoned.fragments) {
    EXPECT_GT(f.end_position_m.x(), 0.0);
    EXPECT_GT(f.bounces, 0u);
  }
  // The two materials differ enough to tell apart: gravel lets the spheres run farther.
  double west = 0, east = 0;
  for (const auto& f : west_zoned.fragments) west += -f.end_position_m.x();
  for (const auto& f : east_zoned.fragments) east += f.end_position_m.x();
  EXPECT_GT(east, 1.2 * west);
}

// Thrown across the boundary (from x = -30 toward +x), fragments land on grass and run on onto
// gravel: their run-out lies strictly between the all-grass and all-gravel runs.
TEST(ZonesHistory, CrossingTheBoundaryGivesNeitherMaterialsRun) {
  const auto mean_x = [](const run::RunResult& r) {
    double s = 0;
    for (const auto& f : r.fragments) s += f.end_position_m.x();
    return s / static_cast<double>(r.fragments.size());
  };
  run::Scenario grass = thrown(0.0);
  grass.groups[0].frame.origin_m.x() = -30.0;
  run::Scenario gravel = grass;
  gravel.site.terrain.material = "gravel";
  const double x_grass = mean_x(run::run(grass)), x_gravel = mean_x(run::run(gravel));
  const double x_zoned = mean_x(run::run(zoned(grass)));
  EXPECT_GT(x_zoned, x_grass);
  EXPECT_LT(x_zoned, x_gravel);
  EXPECT_LT(x_gravel, 590.0);  // all stopped on the site
}

}  // namespace
}  // namespace fragsim::validation
