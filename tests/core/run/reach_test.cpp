// The pilot estimate of fragments landing beyond the terrain (core/run/reach.h; issue 22): a group
// that plainly reaches beyond a small plane warns and is named, the same group on a large plane
// does not, the landing point in vacuum is the closed-form range, harmless fragments and groups
// launched off the terrain do not warn, and the budget shrinks K when there are many groups.
#include "core/run/reach.h"

#include <gtest/gtest.h>

#include <cmath>

#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

// Steel spheres (0.05 kg, 300 m/s, Cd 0.47) from 1 m above a plane of half-width `half_m` in the
// ISA: the minimal example's group with a fixed mass and speed.
Scenario steel_spheres(double half_m, double cell_m) {
  Scenario sc = validation::flat_site_scenario(half_m, cell_m);
  sc.atmosphere.model = flight::AtmosphereSpec::Model::kIsa;
  auto g = validation::sphere_group(Vec3(0, 0, 1), 0.05, 300.0, 1000.0, 2000);
  g.name = "steel spheres";
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = 0.0;
  g.direction.elevation_max_deg = 45.0;
  sc.groups = {g};
  return sc;
}

std::vector<ReachWarning> warnings_of(const Scenario& sc) {
  return groups_beyond_terrain(sc, *scene::Site::build(sc.site));
}

TEST(Reach, AGroupThatPlainlyReachesBeyondASmallPlaneWarnsAndIsNamed) {
  const Scenario sc = steel_spheres(200.0, 10.0);
  const auto w = warnings_of(sc);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].group, 0u);
  EXPECT_EQ(w[0].group_name, "steel spheres");
  EXPECT_EQ(w[0].pilot, 256);
  EXPECT_GT(w[0].fraction, 0.5);
  EXPECT_NEAR(w[0].real_fragments, 1000.0 * w[0].fraction, 1e-9);
  EXPECT_NEAR(w[0].fraction_se, std::sqrt(w[0].fraction * (1 - w[0].fraction) / 256.0), 1e-12);
  EXPECT_GT(w[0].farthest_m, 283.0);
  // The square's edge is between 200 m (across) and 283 m (to a corner) from its centre.
  EXPECT_GE(w[0].terrain_edge_m, 200.0 - 1e-3);
  EXPECT_LE(w[0].terrain_edge_m, 200.0 * std::sqrt(2.0) + 1e-3);
  EXPECT_EQ(reach_field(w[0]), "fragment_groups[0]");
  const std::string m = reach_message(w[0]);
  EXPECT_EQ(m.rfind("fragment_groups[0] (\"steel spheres\"): about ", 0), 0u) << m;
  EXPECT_NE(m.find("extend the terrain"), std::string::npos) << m;
  EXPECT_STREQ(w[0].severity(), "warning");
}

TEST(Reach, TheSameGroupOnALargeEnoughPlaneDoesNotWarn) {
  EXPECT_TRUE(warnings_of(steel_spheres(3000.0, 250.0)).empty());
}

// Vacuum (Cd 0), launched from the ground at 100 m/s, 30 deg, toward +x: the range is
// v^2 sin(2 theta) / g = 883.07 m. DOPRI5 and its dense output are exact for the quadratic path,
// so the landing point is found to ~1e-9 s (the root tolerance): 1e-6 of the range is asked.
// The plane's +x edge 0.5 m short of the range: beyond; 0.5 m past it: on the terrain.
Scenario vacuum_shot(double x_edge_m) {
  Scenario sc = validation::flat_site_scenario(100.0, 10.0);
  auto& plane = std::get<scene::PlaneTerrainSpec>(sc.site.terrain.geometry);
  plane.extent_m = {-100.0, -100.0, x_edge_m, 100.0};
  auto g = validation::sphere_group(Vec3(0, 0, 0), 0.05, 100.0, 10.0, 100);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 30.0;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  sc.groups = {g};
  return sc;
}

TEST(Reach, InVacuumTheLandingPointIsTheClosedFormRange) {
  const double range = 100.0 * 100.0 * std::sin(60.0 * kDegToRad) / kStandardGravity_mps2;
  const auto w = warnings_of(vacuum_shot(range - 0.5));
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].beyond, 256);
  EXPECT_DOUBLE_EQ(w[0].fraction, 1.0);
  EXPECT_NEAR(w[0].farthest_m, range, 1e-6 * range);
  EXPECT_NEAR(w[0].farthest_azimuth_deg, 0.0, 1e-9);
  EXPECT_NEAR(w[0].terrain_edge_m, range - 0.5, 1e-3);  // bisected to a millimetre
  EXPECT_TRUE(warnings_of(vacuum_shot(range + 0.5)).empty());
}

TEST(Reach, FragmentsHarmlessAtLandingDoNotWarn) {
  // 1 g at 100 m/s lands 883 m away in vacuum with 5 J, below the 79 J threshold.
  Scenario sc = vacuum_shot(200.0);
  sc.groups[0].mass_kg = fragments::Distribution::fixed(0.001);
  EXPECT_TRUE(warnings_of(sc).empty());
  sc.settings.hazardous_ke_j = 4.0;  // ... and 5 J is hazardous above a 4 J threshold
  EXPECT_EQ(warnings_of(sc).size(), 1u);
}

TEST(Reach, GroupsLaunchedOffOrUnderTheTerrainAreSkipped) {
  Scenario sc = steel_spheres(200.0, 10.0);
  auto off = sc.groups[0];
  off.frame.origin_m = Vec3(1000.0, 0.0, 1.0);
  auto under = sc.groups[0];
  under.frame.origin_m = Vec3(0.0, 0.0, -5.0);
  sc.groups = {off, under};
  EXPECT_TRUE(warnings_of(sc).empty());
  sc.groups.push_back(steel_spheres(200.0, 10.0).groups[0]);
  const auto w = warnings_of(sc);
  ASSERT_EQ(w.size(), 1u);
  EXPECT_EQ(w[0].group, 2u);
  EXPECT_EQ(w[0].pilot, 256);  // the skipped groups took no share of the budget
}

TEST(Reach, ManyGroupsShareTheBudget) {
  EXPECT_EQ(pilot_size(1), 256);
  EXPECT_EQ(pilot_size(16), 256);
  EXPECT_EQ(pilot_size(20), 204);
  EXPECT_EQ(pilot_size(5000), 1);
}

// A warning as groups_beyond_terrain makes it: `beyond` of 256 pilot fragments, 79 J.
ReachWarning pilot_warning(std::uint32_t group, const std::string& name, double count,
                           std::int64_t beyond, double farthest_m, double azimuth_deg,
                           double edge_m) {
  ReachWarning w;
  w.group = group;
  w.group_name = name;
  w.count = count;
  w.pilot = 256;
  w.beyond = beyond;
  w.fraction = static_cast<double>(beyond) / 256.0;
  w.fraction_se = std::sqrt(w.fraction * (1 - w.fraction) / 256.0);
  w.real_fragments = count * w.fraction;
  w.hazardous_ke_j = 79.0;
  w.farthest_m = farthest_m;
  w.farthest_azimuth_deg = azimuth_deg;
  w.terrain_edge_m = edge_m;
  return w;
}

TEST(Reach, TheMessageGivesTheEstimateInRoundFigures) {
  const ReachWarning w = pilot_warning(0, "steel spheres", 1000.0, 161, 1234.5, 39.7, 283.2);
  EXPECT_EQ(reach_message(w),
            "fragment_groups[0] (\"steel spheres\"): about 63 % of its fragments (~630 real "
            "fragments) land beyond the terrain while still hazardous (>= 79 J); the farthest "
            "about 1,230 m from its origin toward azimuth 40 deg, where the terrain ends at 283 m. "
            "Where they land is not modelled and the hazardous fragment distance may be cut by "
            "the site boundary (the run says whether it is): extend the terrain. (Estimate from "
            "256 drag trajectories, 161 of them beyond, standard error 3 %, over flat ground at "
            "the launch level; no terrain relief, no bounce.)");
  EXPECT_STREQ(w.severity(), "warning");
}

// A single pilot fragment beyond (the demo's head closure, 1 of 256) says only that the tail of
// the group can get there: a note, not a warning.
TEST(Reach, ASinglePilotFragmentBeyondIsANote) {
  ReachWarning w = pilot_warning(1, "head closure", 200.0, 1, 1110.0, 17.0, 1050.0);
  EXPECT_FALSE(w.plain());
  EXPECT_STREQ(w.severity(), "note");
  const std::string m = reach_message(w);
  EXPECT_EQ(m.rfind("fragment_groups[1] (\"head closure\"): a few of its fragments (one pilot "
                    "fragment of 256, ~0.78 real fragments) can land beyond the terrain",
                    0),
            0u)
      << m;
  EXPECT_EQ(m.find("extend the terrain"), std::string::npos) << m;
  w.beyond = 2;
  EXPECT_STREQ(w.severity(), "warning");
}

}  // namespace
}  // namespace fragsim::run
