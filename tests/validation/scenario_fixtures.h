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
