#pragma once
// Small scenarios built directly in core types (no JSON) for physics validation tests.
#include <cmath>

#include "core/run/run.h"

namespace fragsim::validation {

// Flat plane terrain at z = 0 over [-half, half]^2 with square cells, material "soil".
inline run::Scenario flat_site_scenario(double half_m, double cell_m) {
  run::Scenario sc;
  scene::PlaneTerrainSpec plane;
  plane.elevation_m = 0.0;
  plane.extent_m = {-half_m, -half_m, half_m, half_m};
  plane.cell_m = cell_m;
  sc.site.terrain.geometry = plane;
  sc.site.terrain.material = "soil";
  sc.site.materials["soil"] = scene::MaterialSpec{};
  sc.atmosphere.model = flight::AtmosphereSpec::Model::kConstant;
  sc.atmosphere.density_kg_m3 = 1.225;
  sc.settings.seed = 12345;
  sc.settings.threads = 2;
  return sc;
}

// Launch directions of group g within elevation [el_min, el_max] and azimuth [az_min, az_max]
// (degrees).
inline void aim(fragments::FragmentGroupSpec& g, double el_min, double el_max, double az_min,
                double az_max) {
  g.direction.elevation_min_deg = el_min;
  g.direction.elevation_max_deg = el_max;
  g.direction.azimuth_min_deg = az_min;
  g.direction.azimuth_max_deg = az_max;
}

// A square grid terrain of n x n points with 10 m cells, its corner at (origin_m, origin_m), the
// height at point (i, j) z(i, j).
template <class Z>
scene::GridTerrainSpec square_grid(double origin_m, int n, Z&& z) {
  scene::GridTerrainSpec grid;
  grid.origin_m = {origin_m, origin_m};
  grid.spacing_m = 10.0;
  grid.nx = grid.ny = n;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) grid.elevation_m.push_back(z(i, j));
  return grid;
}

// A group of steel spheres (fixed mass and speed) launched from `origin` within the direction
// ranges; cd = 0 unless set by the caller.
inline fragments::FragmentGroupSpec sphere_group(const Vec3& origin, double mass_kg,
                                                 double speed_mps, double count,
                                                 std::int64_t samples) {
  fragments::FragmentGroupSpec g;
  g.name = "spheres";
  g.count = count;
  g.samples = samples;
  g.frame.origin_m = origin;
  g.shape.type = fragments::ShapeType::kSphere;
  g.shape.density_kg_m3 = 7850.0;
  g.mass_kg = fragments::Distribution::fixed(mass_kg);
  g.speed_mps = fragments::Distribution::fixed(speed_mps);
  g.cd.constant = 0.0;
  return g;
}

// Steel spheres (0.1 kg, 60 m/s, Cd 0.47, 20,000 real fragments) fanned toward +x (azimuth
// -20 ... 20 deg, 10-40 deg elevation: they land 100-360 m out) from 1 m above the centre of a
// plane of half-width `half_m` in 10 m cells. On 200 m the hazardous area runs off the +x side
// well above the HFD threshold; on 600 m nothing leaves (core/run/hfd_test.cpp).
inline run::Scenario fan_scenario(double half_m, std::int64_t samples) {
  run::Scenario sc = flat_site_scenario(half_m, 10.0);
  auto g = sphere_group(Vec3(0, 0, 1.0), 0.1, 60.0, 20000.0, samples);
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = 10.0;
  g.direction.elevation_max_deg = 40.0;
  g.direction.azimuth_min_deg = -20.0;
  g.direction.azimuth_max_deg = 20.0;
  sc.groups = {g};
  return sc;
}

// With bounce: 0.05 kg steel spheres thrown at 20 m/s, 5-10 deg up, from 0.5 m over a 2 km plane
// of the default material (no restitution): they land and roll for seconds, nothing cut off as
// harmless (tests of the ground phase's caps).
inline run::Scenario rolling_sphere_scenario(std::int64_t samples) {
  run::Scenario sc = flat_site_scenario(1000.0, 10.0);
  auto g = sphere_group(Vec3(0, 0, 0.5), 0.05, 20.0, 1.0, samples);
  g.direction.elevation_min_deg = 5.0;
  g.direction.elevation_max_deg = 10.0;
  sc.groups = {g};
  sc.settings.bounce = true;
  sc.settings.harmless_cutoff = false;
  return sc;
}

// Steel spheres of uniform mass in [0.01, max_mass_kg] (Cd 0.47) thrown -5 to 40 deg up in every
// azimuth from `origin`: with box buildings, a small whole-run case where PTN densities, the HFD
// and building hits are all non-zero (run_fixtures.h, precision_test, partial_file_test).
inline fragments::FragmentGroupSpec mixed_sphere_group(const Vec3& origin, double max_mass_kg,
                                                       double speed_mps, double count,
                                                       std::int64_t samples) {
  auto g = sphere_group(origin, 0.05, speed_mps, count, samples);
  g.mass_kg.kind = fragments::Distribution::Kind::kUniform;
  g.mass_kg.min = 0.01;
  g.mass_kg.max = max_mass_kg;
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = -5.0;
  g.direction.elevation_max_deg = 40.0;
  return g;
}

// Materials "wall" and "roof" that a fragment penetrates above `ke_per_area_j_per_m2` (normal
// kinetic energy per presented area), for box_building.
inline void add_wall_and_roof(run::Scenario& sc, double ke_per_area_j_per_m2) {
  scene::MaterialSpec wall;
  wall.penetration_ke_per_area_j_per_m2 = ke_per_area_j_per_m2;
  sc.site.materials["wall"] = wall;
  sc.site.materials["roof"] = wall;
}

// A footprint box building with the given materials.
inline scene::BuildingSpec box_building(const std::string& id, double x0, double y0, double x1,
                                        double y1, double height_m) {
  scene::BuildingSpec b;
  b.id = id;
  b.footprint_m = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  b.height_m = height_m;
  b.base_elevation_m = 0.0;
  b.wall = "wall";
  b.roof = "roof";
  return b;
}

}  // namespace fragsim::validation
