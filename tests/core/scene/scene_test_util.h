#pragma once
// Site specs shared by the core/scene tests.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <optional>
#include <random>
#include <string>

#include "core/common/error.h"
#include "core/scene/site.h"

namespace fragsim::scene::testing {

inline std::map<std::string, MaterialSpec> test_materials() {
  std::map<std::string, MaterialSpec> m;
  MaterialSpec soil;
  soil.friction = 0.9;
  soil.restitution.constant = 0.2;
  m["soil"] = soil;
  MaterialSpec concrete;
  concrete.restitution.normal_speed_mps = {3, 30, 300};
  concrete.restitution.e = {0.5, 0.3, 0.1};
  concrete.penetration_ke_per_area_j_per_m2 = 2.0e6;
  m["concrete_wall"] = concrete;
  MaterialSpec metal;
  metal.friction = 0.4;
  metal.restitution.constant = 0.3;
  metal.penetration_ke_per_area_j_per_m2 = 1.5e5;
  m["metal_roof"] = metal;
  MaterialSpec glass;
  glass.restitution.constant = 0.1;
  glass.penetration_ke_per_area_j_per_m2 = 1e3;
  m["glass"] = glass;
  return m;
}

inline SiteSpec plane_site(std::array<double, 4> extent = {-200, -200, 200, 200}, double cell = 10,
                           double elevation = 0) {
  SiteSpec s;
  PlaneTerrainSpec p;
  p.elevation_m = elevation;
  p.extent_m = extent;
  p.cell_m = cell;
  s.terrain.geometry = p;
  s.terrain.material = "soil";
  s.materials = test_materials();
  return s;
}

inline GridTerrainSpec make_grid(double x0, double y0, double spacing, int nx, int ny,
                                 const std::function<double(double, double)>& z) {
  GridTerrainSpec g;
  g.origin_m = {x0, y0};
  g.spacing_m = spacing;
  g.nx = nx;
  g.ny = ny;
  g.elevation_m.resize(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny));
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i)
      g.elevation_m[static_cast<std::size_t>(j) * nx + i] = z(i * spacing, j * spacing);
  return g;
}

inline SiteSpec grid_site(const GridTerrainSpec& g) {
  SiteSpec s;
  s.terrain.geometry = g;
  s.terrain.material = "soil";
  s.materials = test_materials();
  return s;
}

inline BuildingSpec box_building(std::string id, double x0, double y0, double x1, double y1,
                                 double height, bool clockwise = false) {
  BuildingSpec b;
  b.id = std::move(id);
  b.footprint_m = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  if (clockwise) std::reverse(b.footprint_m.begin(), b.footprint_m.end());
  b.height_m = height;
  b.wall = "concrete_wall";
  b.roof = "metal_roof";
  return b;
}

// Jittered lattice (n x n vertices around (x0, y0)) with random diagonals: irregular triangles
// of varying size and shape.
inline MeshSpec jittered_mesh(std::uint64_t seed, int n, double spacing, double x0 = 5e5,
                              double y0 = 4e6) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> jit(-0.3 * spacing, 0.3 * spacing), zd(0, 15), coin(0, 1);
  MeshSpec m;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      m.vertices_m.emplace_back(x0 + i * spacing + jit(rng), y0 + j * spacing + jit(rng), zd(rng));
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const std::int64_t v = j * n + i;
      if (coin(rng) < 0.5) {
        m.triangles.push_back({v, v + 1, v + n + 1});
        m.triangles.push_back({v, v + n + 1, v + n});
      } else {
        m.triangles.push_back({v, v + 1, v + n});
        m.triangles.push_back({v + 1, v + n + 1, v + n});
      }
    }
  }
  return m;
}

// Runs Site::build and checks that it throws InputError with exactly this field and a message
// containing `message_part`.
inline void expect_input_error(const SiteSpec& spec, const std::string& field,
                               const std::string& message_part) {
  try {
    Site::build(spec);
    ADD_FAILURE() << "expected InputError at " << field;
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), field) << e.what();
    EXPECT_NE(e.message().find(message_part), std::string::npos) << e.what();
  }
}

// Double-precision Moller-Trumbore segment/triangle test (reference for Embree results).
inline std::optional<double> ray_triangle(const Vec3& o, const Vec3& d, const Vec3& a,
                                          const Vec3& b, const Vec3& c) {
  const Vec3 e1 = b - a, e2 = c - a, p = d.cross(e2);
  const double det = e1.dot(p);
  if (std::abs(det) < 1e-300) return std::nullopt;
  const Vec3 tv = o - a;
  const double u = tv.dot(p) / det;
  const Vec3 q = tv.cross(e1);
  const double v = d.dot(q) / det;
  if (u < 0 || v < 0 || u + v > 1) return std::nullopt;
  return e2.dot(q) / det;
}

// Nearest terrain hit by brute force over all terrain triangles, t in [0, tmax].
inline std::optional<double> brute_force_terrain_hit(const Site& site, const Vec3& o, const Vec3& d,
                                                     double tmax) {
  std::optional<double> best;
  const auto& v = site.terrain_vertices();
  for (const auto& t : site.terrain_triangles()) {
    const auto h = ray_triangle(o, d, v[t[0]], v[t[1]], v[t[2]]);
    if (h && *h >= 0 && *h <= tmax && (!best || *h < *best)) best = h;
  }
  return best;
}

}  // namespace fragsim::scene::testing
