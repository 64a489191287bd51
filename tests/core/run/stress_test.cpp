// Numerical stress: every history terminates with a named outcome, nothing NaN leaves the core,
// geometry edge cases (launch inside or on surfaces, grazing paths, huge coordinates) behave.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

std::int64_t outcome_count(const RunResult& r, Outcome o) {
  return r.outcome_histories[static_cast<std::size_t>(o)];
}

void expect_all_finite(const RunResult& r) {
  for (double d : r.ptn_density_per_m2) ASSERT_TRUE(std::isfinite(d));
  for (double d : r.ptn_std_error_per_m2) ASSERT_TRUE(std::isfinite(d));
  for (const auto& b : r.buildings) {
    ASSERT_TRUE(std::isfinite(b.impacts.mean) && std::isfinite(b.impacts.std_error));
    ASSERT_TRUE(std::isfinite(b.penetrations.mean) && std::isfinite(b.residual_ke_j.mean));
  }
  for (const auto& f : r.fragments) {
    ASSERT_TRUE(f.end_position_m.allFinite() && f.end_velocity_mps.allFinite());
    ASSERT_TRUE(std::isfinite(f.end_time_s) && std::isfinite(f.impact_angle_deg));
  }
  std::int64_t total = 0;
  for (auto n : r.outcome_histories) total += n;
  EXPECT_EQ(total, r.samples);  // every history ended with exactly one outcome
  EXPECT_EQ(outcome_count(r, Outcome::kIntegrationFailed), 0);
}

// Hilly grid terrain (smooth bumps) with a few buildings, in UTM-sized coordinates if asked.
Scenario hilly_scenario(double x0, double y0, double z0) {
  Scenario sc;
  scene::GridTerrainSpec grid;
  grid.origin_m = {x0 - 500.0, y0 - 500.0};
  grid.spacing_m = 10.0;
  grid.nx = grid.ny = 101;
  for (int j = 0; j < grid.ny; ++j)
    for (int i = 0; i < grid.nx; ++i)
      grid.elevation_m.push_back(z0 + 8.0 * std::sin(i * 0.13) * std::cos(j * 0.11) + 0.02 * i);
  sc.site.terrain.geometry = grid;
  sc.site.terrain.material = "soil";
  sc.site.materials["soil"] = scene::MaterialSpec{};
  validation::add_wall_and_roof(sc, 5e5);
  auto b1 = validation::box_building("b1", x0 + 60, y0 - 20, x0 + 80, y0 + 20, 10.0);
  auto b2 = validation::box_building("b2", x0 - 150, y0 + 100, x0 - 120, y0 + 140, 6.0);
  b1.base_elevation_m.reset();  // on the terrain
  b2.base_elevation_m.reset();
  sc.site.buildings = {b1, b2};
  sc.settings.seed = 99;
  sc.settings.threads = 2;
  sc.settings.record_fragments = true;
  return sc;
}

TEST(Stress, LaunchBelowTerrainOrInsideABuildingIsNotFlown) {
  Scenario sc = hilly_scenario(0, 0, 100);
  auto below = validation::sphere_group(Vec3(0, 0, 50), 0.1, 300, 10, 20);     // terrain ~100 m
  auto inside = validation::sphere_group(Vec3(70, 0, 103), 0.1, 300, 10, 20);  // inside b1
  sc.groups = {below, inside};
  const RunResult r = run(sc);
  EXPECT_EQ(outcome_count(r, Outcome::kStartedInside), 40);
  expect_all_finite(r);
}

TEST(Stress, LaunchFromGroundLevelFliesAwayFromTheSurface) {
  // Fragments launched exactly at the terrain surface, upward: the surface they start on is not
  // an impact (it is met from behind).
  Scenario sc = hilly_scenario(0, 0, 100);
  auto site = scene::Site::build(sc.site);
  const Vec3 local = site->to_local(Vec3(-300, -300, 0));
  const double h = site->terrain_height(local.x(), local.y());
  auto g =
      validation::sphere_group(site->to_input(Vec3(local.x(), local.y(), h)), 0.1, 100, 10, 200);
  g.direction.elevation_min_deg = 10.0;
  g.direction.elevation_max_deg = 60.0;
  g.cd.constant = 0.5;
  sc.groups = {g};
  const RunResult r = run(sc, site);
  for (const auto& f : r.fragments) {
    EXPECT_GT(f.end_time_s, 1.0) << "history " << f.history << " stopped at launch";
  }
  expect_all_finite(r);
}

TEST(Stress, GrazingPathsOverFlatGroundLandWhereGeometrySays) {
  // Horizontal launch 1 mm above a plane, vacuum: lands after sqrt(2h/g) s at v sqrt(2h/g).
  Scenario sc = validation::flat_site_scenario(500.0, 10.0);
  auto g = validation::sphere_group(Vec3(-400, 3.3, 0.001), 0.1, 300, 1, 50);
  g.direction.elevation_min_deg = g.direction.elevation_max_deg = 0.0;
  g.direction.azimuth_min_deg = g.direction.azimuth_max_deg = 0.0;
  sc.groups = {g};
  sc.settings.record_fragments = true;
  const RunResult r = run(sc);
  const double t = std::sqrt(2 * 0.001 / 9.80665);
  for (const auto& f : r.fragments) {
    ASSERT_EQ(f.outcome, Outcome::kGround);
    EXPECT_NEAR(f.end_time_s, t, 1e-9);
    EXPECT_NEAR(f.end_position_m.x(), -400 + 300 * t, 1e-6);
    EXPECT_NEAR(f.impact_angle_deg, std::atan(9.80665 * t / 300) / kDegToRad, 1e-6);
  }
}

TEST(Stress, UtmSizedCoordinatesGiveTheSameResults) {
  // The same site and fragments near 0 and at UTM-like coordinates: local geometry is identical,
  // so the densities and building figures agree to rounding of the coordinate shift.
  auto make = [](double x0, double y0) {
    Scenario sc = hilly_scenario(x0, y0, 100);
    auto g = validation::sphere_group(Vec3(x0, y0, 110), 0.2, 250, 100, 3000);
    g.cd.constant = 0.6;
    g.direction.elevation_min_deg = -10;
    g.direction.elevation_max_deg = 50;
    sc.groups = {g};
    return sc;
  };
  const RunResult a = run(make(0, 0));
  const RunResult b = run(make(500000, 5000000));
  ASSERT_EQ(a.ptn_density_per_m2.size(), b.ptn_density_per_m2.size());
  double max_density = 0.0, max_diff = 0.0;
  for (std::size_t t = 0; t < a.ptn_density_per_m2.size(); ++t) {
    max_density = std::max(max_density, a.ptn_density_per_m2[t]);
    max_diff = std::max(max_diff, std::abs(a.ptn_density_per_m2[t] - b.ptn_density_per_m2[t]));
  }
  ASSERT_GT(max_density, 0.0);
  // Paths are computed in local doubles in both cases; only the launch point's conversion
  // differs (by ~1e-10 m), which may flip a handful of borderline crossings at most.
  EXPECT_LT(max_diff, 1e-3 * max_density);
  EXPECT_NEAR(a.buildings[0].impacts.mean, b.buildings[0].impacts.mean,
              0.01 * a.buildings[0].impacts.mean + 1e-12);
  EXPECT_NEAR(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m, 15.0);
}

TEST(Stress, UpdraftStrongerThanTerminalSpeedEndsAtMaxFlightTime) {
  Scenario sc = validation::flat_site_scenario(5000.0, 100.0);
  sc.atmosphere.wind_mps = Vec3(0, 0, 60.0);  // far above a light plate's terminal speed
  auto g = validation::sphere_group(Vec3(0, 0, 10), 0.001, 5.0, 1, 20);
  g.cd.constant = 1.0;
  g.area_m2 = 0.01;
  sc.groups = {g};
  sc.settings.max_flight_time_s = 20.0;
  sc.settings.record_fragments = true;
  sc.settings.hazardous_ke_j = 1e-6;  // so that the light fragments are flown, not skipped
  const RunResult r = run(sc);
  EXPECT_EQ(outcome_count(r, Outcome::kMaxFlightTime), 20);
  for (const auto& f : r.fragments) EXPECT_NEAR(f.end_time_s, 20.0, 1e-9);
  expect_all_finite(r);
}

// Random groups (shapes, masses, speeds, directions, tilted moving frames, Cd tables, wind) over
// hilly terrain with buildings: every history terminates, nothing is NaN, and the outcome counts
// add up.
Scenario random_scenario(std::mt19937_64& rng, int trial) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  {
    Scenario sc = hilly_scenario(0, 0, 100);
    sc.atmosphere.model =
        trial % 2 ? flight::AtmosphereSpec::Model::kIsa : flight::AtmosphereSpec::Model::kConstant;
    sc.atmosphere.wind_mps = Vec3(20 * u(rng) - 10, 20 * u(rng) - 10, -2 * u(rng));
    sc.settings.max_flight_time_s = 60.0;
    for (int gi = 0; gi < 3; ++gi) {
      fragments::FragmentGroupSpec g;
      g.count = 1 + 1000 * u(rng);
      g.samples = 300;
      g.frame.origin_m = Vec3(400 * u(rng) - 200, 400 * u(rng) - 200, 112 + 20 * u(rng));
      g.frame.yaw_deg = 360 * u(rng);
      g.frame.pitch_deg = 180 * u(rng) - 90;
      g.frame.roll_deg = 360 * u(rng);
      g.frame.velocity_mps = Vec3(100 * u(rng), 0, 50 * u(rng));
      const int shape = static_cast<int>(5 * u(rng));
      g.shape.type = static_cast<fragments::ShapeType>(shape);
      if (g.shape.type == fragments::ShapeType::kPoint) {
        g.area_m2 = 1e-3;
      } else {
        g.shape.density_kg_m3 = 2000 + 6000 * u(rng);
        if (g.shape.type != fragments::ShapeType::kSphere) {
          g.shape.aspect = g.shape.type == fragments::ShapeType::kCylinder
                               ? std::vector<double>{1.0, 0.2 + 5 * u(rng)}
                               : std::vector<double>{1.0, 0.1 + u(rng), 0.05 + u(rng)};
        }
      }
      g.mass_kg.kind = fragments::Distribution::Kind::kLognormal;
      g.mass_kg.median = 0.001 + 2 * u(rng);
      g.mass_kg.sigma_ln = 1.0;
      g.speed_mps.kind = fragments::Distribution::Kind::kUniform;
      g.speed_mps.min = 0.0;
      g.speed_mps.max = 50 + 1500 * u(rng);
      if (gi == 1) {
        g.cd.mach = {0.0, 0.8, 1.2, 3.0};
        g.cd.cd = {0.8, 0.9, 1.5, 1.2};
      } else {
        g.cd.constant = 0.3 + u(rng);
      }
      sc.groups.push_back(g);
    }
    return sc;
  }
}

TEST(Stress, RandomScenariosTerminateWithFiniteResults) {
  std::mt19937_64 rng(2024);
  for (int trial = 0; trial < 6; ++trial) {
    const RunResult r = run(random_scenario(rng, trial));
    SCOPED_TRACE("trial " + std::to_string(trial));
    expect_all_finite(r);
  }
}

// No impact added energy: the run's audit (stats.energy_rises, core/run/energy_audit.h) compares
// the body's energy, translational and rotational kinetic plus m g z, just after every impulse
// (from flight and on the ground) with just before. The audit's own trigger is tested in
// energy_audit_test.cpp; here it must have had impacts to look at.
void expect_no_energy_rise(const RunResult& r) {
  EXPECT_GT(r.stats.bounces + r.stats.ground_impacts, 0);
  EXPECT_EQ(r.stats.energy_rises, 0);
}

// The same random scenarios with bounce, slide and roll, random restitution and friction:
// every history ends, nothing is NaN, no energy is gained.
TEST(Stress, RandomScenariosWithBounceTerminateWithFiniteResults) {
  std::mt19937_64 rng(77);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 6; ++trial) {
    Scenario sc = random_scenario(rng, trial);
    sc.settings.bounce = true;
    for (auto& g : sc.groups) g.samples = 150;
    auto& soil = sc.site.materials["soil"];
    soil.friction = 1.5 * u(rng);
    soil.rolling_resistance = 0.3 * u(rng);
    if (trial % 2) {
      soil.restitution.constant = u(rng);
    } else {
      soil.restitution.normal_speed_mps = {0.0, 5.0, 50.0};
      soil.restitution.e = {u(rng), u(rng), u(rng)};
    }
    const RunResult r = run(sc);
    SCOPED_TRACE("trial " + std::to_string(trial));
    expect_all_finite(r);
    expect_no_energy_rise(r);
    EXPECT_GT(r.stats.bounces, 0);
    EXPECT_EQ(r.stats.ground_step_caps, 0);
  }
}

// An endless bounce sequence: e = 1, mu = 0, a ball dropped on flat ground bounces forever in
// the physics; the bounce cap ends it, and it then rests (it has no horizontal speed).
TEST(Stress, PerfectlyElasticBouncingEndsAtTheBounceCap) {
  Scenario sc = validation::flat_site_scenario(50.0, 10.0);
  sc.site.materials["soil"].restitution.constant = 1.0;
  sc.site.materials["soil"].friction = 0.0;
  sc.settings.bounce = true;
  sc.settings.record_fragments = true;
  sc.settings.max_bounces = 40;
  sc.settings.hazardous_ke_j = 1e-9;
  auto g = validation::sphere_group(Vec3(0.5, 0.5, 3.0), 0.2, 0.0, 1.0, 4);
  sc.groups = {g};
  const RunResult r = run(sc);
  expect_all_finite(r);
  expect_no_energy_rise(r);
  for (const auto& f : r.fragments) {
    EXPECT_EQ(f.bounces, 40u);
    EXPECT_EQ(f.outcome, Outcome::kGround);
  }
}

// The ground phase at its edges: frictionless ground (drag alone never quite stops a slide: the
// time limit ends it), a block launched overlapping the ground (lifted onto it), bodies dropped
// exactly onto grid vertices and edges of a bumpy terrain, UTM-sized coordinates. Every history
// ends with a named outcome, nothing is NaN, no energy is gained, no step cap is hit.
TEST(Stress, GroundPhaseEdgeCasesTerminate) {
  {  // frictionless, drag only
    Scenario sc = validation::flat_site_scenario(5000.0, 10.0);
    sc.site.materials["soil"].friction = 0.0;
    sc.site.materials["soil"].rolling_resistance = 0.0;
    sc.settings.bounce = true;
    sc.settings.record_fragments = true;
    sc.settings.max_flight_time_s = 30.0;
    sc.settings.hazardous_ke_j = 1e-9;
    auto g = validation::sphere_group(Vec3(0.0, 0.0, 0.5), 0.2, 20.0, 1.0, 4);
    g.shape.type = fragments::ShapeType::kCuboid;
    g.attitude = fragments::AttitudeSpec{};
    g.cd.constant = 1.0;
    g.direction.elevation_min_deg = g.direction.elevation_max_deg = -5.0;
    sc.groups = {g};
    const RunResult r = run(sc);
    expect_all_finite(r);
    expect_no_energy_rise(r);
    for (const auto& f : r.fragments) {
      EXPECT_EQ(f.outcome, Outcome::kMaxFlightTime);
      EXPECT_GT(f.ground_path_m, 100.0);  // slid on, slower and slower
    }
    EXPECT_EQ(r.stats.ground_step_caps, 0);
  }
  for (const double x0 : {0.0, 500000.0}) {  // overlapping launches, vertex and edge drops
    const double y0 = x0 == 0.0 ? 0.0 : 5000000.0;
    Scenario sc = hilly_scenario(x0, y0, 100);
    sc.settings.bounce = true;
    sc.settings.hazardous_ke_j = 1e-9;
    sc.site.materials["soil"].friction = 0.6;
    sc.site.materials["soil"].restitution.constant = 0.3;
    sc.groups.clear();
    const auto h = [&](double x, double y) {  // the grid's own height function, at a vertex
      const double i = (x - (x0 - 500.0)) / 10.0, j = (y - (y0 - 500.0)) / 10.0;
      return 100.0 + 8.0 * std::sin(i * 0.13) * std::cos(j * 0.11) + 0.02 * i;
    };
    // Straight down onto a vertex, and onto the middle of a cell edge, from 2 m.
    for (const Vec3& at : {Vec3(x0 + 30.0, y0 + 40.0, 0.0), Vec3(x0 + 35.0, y0 - 20.0, 0.0)}) {
      auto g = validation::sphere_group(Vec3(at.x(), at.y(), h(at.x(), at.y()) + 2.0), 0.5, 3.0,
                                        1.0, 20);
      g.shape.type = fragments::ShapeType::kCuboid;
      g.direction.elevation_min_deg = g.direction.elevation_max_deg = -90.0;
      sc.groups.push_back(g);
    }
    // A block 10 cm thick whose centre is 1 cm above the ground: it overlaps it.
    auto over = validation::sphere_group(Vec3(x0 + 10.0, y0 + 10.0, h(x0 + 10.0, y0 + 10.0) + 0.01),
                                         5.0, 4.0, 1.0, 10);
    over.shape.type = fragments::ShapeType::kCuboid;
    over.shape.aspect = {1.0, 1.0, 1.0};
    over.attitude = fragments::AttitudeSpec{};
    over.direction.elevation_min_deg = over.direction.elevation_max_deg = 0.0;
    sc.groups.push_back(over);
    const RunResult r = run(sc);
    SCOPED_TRACE("x0 " + std::to_string(x0));
    expect_all_finite(r);
    expect_no_energy_rise(r);
    EXPECT_EQ(r.stats.ground_step_caps, 0);
    for (const auto& f : r.fragments) {
      EXPECT_NE(f.outcome, Outcome::kMaxFlightTime);
      EXPECT_NE(f.outcome, Outcome::kStartedInside);  // overlapping is not inside: lifted
    }
  }
}

}  // namespace
}  // namespace fragsim::run
