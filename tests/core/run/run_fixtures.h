#pragma once
// A small mixed case for whole-run tests: a flat site with two buildings (penetrable walls), two
// fragment groups (spheres and cuboids, uniform masses, drag), so that PTN densities, the HFD
// and building hits are all non-zero (determinism_test, partial_test).
#include "core/run/scenario.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run::testing {

inline Scenario mixed_scenario(std::int64_t samples1 = 3001, std::int64_t samples2 = 1999) {
  Scenario sc = validation::flat_site_scenario(300.0, 5.0);
  sc.atmosphere.model = flight::AtmosphereSpec::Model::kIsa;
  scene::MaterialSpec wall;
  wall.penetration_ke_per_area_j_per_m2 = 2.0e6;
  sc.site.materials["wall"] = wall;
  sc.site.materials["roof"] = wall;
  sc.site.buildings = {validation::box_building("a", 40, -10, 60, 10, 8.0),
                       validation::box_building("b", -80, 20, -60, 50, 12.0)};
  auto g = validation::sphere_group(Vec3(0, 0, 1.0), 0.05, 400.0, 500.0, samples1);
  g.mass_kg.kind = fragments::Distribution::Kind::kUniform;
  g.mass_kg.min = 0.01;
  g.mass_kg.max = 0.5;
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = -5.0;
  g.direction.elevation_max_deg = 40.0;
  auto g2 = g;
  g2.samples = samples2;
  g2.shape.type = fragments::ShapeType::kCuboid;
  g2.shape.aspect = {1.0, 0.5, 0.2};
  sc.groups = {g, g2};
  sc.settings.record_fragments = true;
  return sc;
}

}  // namespace fragsim::run::testing
