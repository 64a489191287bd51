// The polyhedron fragment's body: principal frame, mass properties against the other shapes,
// sizing by density, the support vertex against brute force.
#include "core/fragments/polyhedron.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <random>

#include "core/common/error.h"
#include "core/fragments/sampling.h"

namespace fragsim::fragments {
namespace {

std::vector<Vec3> box_corners(const Vec3& size) {
  std::vector<Vec3> pts;
  for (int k = 0; k < 8; ++k)
    pts.push_back(0.5 * Vec3(k & 1 ? size.x() : -size.x(), k & 2 ? size.y() : -size.y(),
                             k & 4 ? size.z() : -size.z()));
  return pts;
}

std::vector<Vec3> random_cloud(std::mt19937_64& rng, int n, const Vec3& scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i) pts.push_back(Vec3(u(rng), u(rng), u(rng)).cwiseProduct(scale));
  return pts;
}

TEST(Polyhedron, CuboidPolyhedronHasTheCuboidsMassProperties) {
  // Corners of an a x b x c box (any order of the sides), shifted: the body frame is the input
  // axes at the centre, vertices (±a/2, ±b/2, ±c/2); inertia, surface, presented area equal the
  // cuboid shape's to 1e-12 relative.
  const double m = 2.5;
  for (const Vec3& size : {Vec3(0.1, 0.2, 0.3), Vec3(0.5, 0.2, 0.05), Vec3(0.3, 0.3, 0.3)}) {
    std::vector<Vec3> pts = box_corners(size);
    for (Vec3& p : pts) p += Vec3(3.0, -1.0, 0.25);
    const ShapeSpec poly = polyhedron_shape(pts, std::nullopt);
    EXPECT_EQ(poly.polyhedron->rotation(), Mat3::Identity());
    EXPECT_NEAR((poly.polyhedron->centre_m() - Vec3(3.0, -1.0, 0.25)).norm(), 0.0, 1e-15);
    for (const Vec3& v : poly.polyhedron->vertices())
      EXPECT_NEAR((v.cwiseAbs() - 0.5 * size).norm(), 0.0, 1e-15);
    ShapeSpec box;
    box.type = ShapeType::kCuboid;
    box.dims_m = {size.x(), size.y(), size.z()};
    const MassProperties a = mass_properties(poly, m, std::nullopt);
    const MassProperties b = mass_properties(box, m, std::nullopt);
    for (int k = 0; k < 3; ++k)
      EXPECT_NEAR(a.inertia_kg_m2[k], b.inertia_kg_m2[k], 1e-12 * b.inertia_kg_m2[k]);
    EXPECT_NEAR(a.surface_m2, b.surface_m2, 1e-12 * b.surface_m2);
    EXPECT_NEAR(a.presented_area_m2, b.presented_area_m2, 1e-12 * b.surface_m2);
    EXPECT_NEAR((a.dims_m - b.dims_m).norm(), 0.0, 1e-15);
    EXPECT_EQ(a.scale, 1.0);
  }
}

TEST(Polyhedron, RotatedBoxIsBroughtBackToItsPrincipalFrame) {
  // A 0.1 x 0.2 x 0.4 box turned by a random rotation: the principal moments are the box's, and
  // the body-frame vertices are its corners (±0.05, ±0.1, ±0.2) to 1e-13.
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const Quat q = uniform_rotation(u(rng), u(rng), u(rng));
    std::vector<Vec3> pts = box_corners(Vec3(0.1, 0.2, 0.4));
    for (Vec3& p : pts) p = q * p;
    const auto p = Polyhedron::from_points(pts, "v");
    const double v = 0.1 * 0.2 * 0.4;
    const Vec3 want = v / 12 * Vec3(0.04 + 0.16, 0.01 + 0.16, 0.01 + 0.04);
    const Vec3 got = p->inertia_m5();
    // Sorted: the axis order is the input axes' nearest, not necessarily x, y, z of the box.
    std::vector<double> g(got.data(), got.data() + 3), w(want.data(), want.data() + 3);
    std::sort(g.begin(), g.end());
    std::sort(w.begin(), w.end());
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(g[k], w[k], 1e-12 * w[k]);
    EXPECT_NEAR(p->rotation().determinant(), 1.0, 1e-14);
    for (const Vec3& x : p->vertices()) {
      std::vector<double> c{std::abs(x.x()), std::abs(x.y()), std::abs(x.z())};
      std::sort(c.begin(), c.end());
      EXPECT_NEAR(c[0], 0.05, 1e-13);
      EXPECT_NEAR(c[1], 0.1, 1e-13);
      EXPECT_NEAR(c[2], 0.2, 1e-13);
    }
    // The stored frame maps the body vertices back onto the input points.
    for (const Vec3& x : p->vertices()) {
      const Vec3 back = p->centre_m() + p->rotation() * x;
      double best = 1e300;
      for (const Vec3& y : pts) best = std::min(best, (y - back).norm());
      EXPECT_LE(best, 1e-15);
    }
  }
}

TEST(Polyhedron, BodyFrameIsPrincipalForRandomClouds) {
  // The inertia of the body-frame hull is diagonal (off-diagonal < 1e-12 of the trace), the
  // centroid at the origin, and the moments as reported.
  std::mt19937_64 rng(9);
  for (int trial = 0; trial < 10; ++trial) {
    const auto p = Polyhedron::from_points(random_cloud(rng, 50, Vec3(1.0, 0.6, 0.3)), "v");
    const MeshMass m = mesh_mass(HullMesh{p->vertices(), p->triangles()});
    EXPECT_NEAR(m.centroid_m.norm(), 0.0, 1e-14);
    EXPECT_NEAR(m.volume_m3, p->volume_m3(), 1e-14);
    const double tr = m.inertia_m5.trace();
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j)
        EXPECT_NEAR(m.inertia_m5(i, j), i == j ? p->inertia_m5()[i] : 0.0, 1e-12 * tr);
  }
}

TEST(Polyhedron, DensityScalesTheHullToEachMass) {
  // With a density the hull is scaled about its centre: volume = m / rho to 1e-14, inertia
  // m s^2 J0 / V0; without, it keeps its size and the sampled mass (density m / V0).
  std::mt19937_64 rng(2);
  const std::vector<Vec3> pts = random_cloud(rng, 40, Vec3(0.2, 0.1, 0.1));
  const ShapeSpec dense = polyhedron_shape(pts, 2700.0);
  const ShapeSpec fixed = polyhedron_shape(pts, std::nullopt);
  const double v0 = dense.polyhedron->volume_m3();
  for (double m : {1e-3, 0.5, 40.0}) {
    const MassProperties a = mass_properties(dense, m, std::nullopt);
    EXPECT_NEAR(std::pow(a.scale, 3) * v0, m / 2700.0, 1e-14 * m / 2700.0);
    const MassProperties b = mass_properties(fixed, m, std::nullopt);
    EXPECT_EQ(b.scale, 1.0);
    for (int k = 0; k < 3; ++k) {
      const double j0 = dense.polyhedron->inertia_m5()[k];
      EXPECT_NEAR(a.inertia_kg_m2[k], m / v0 * a.scale * a.scale * j0, 1e-14 * a.inertia_kg_m2[k]);
      EXPECT_NEAR(b.inertia_kg_m2[k], m / v0 * j0, 1e-14 * b.inertia_kg_m2[k]);
    }
    EXPECT_NEAR(a.surface_m2, a.scale * a.scale * dense.polyhedron->surface_m2(), 1e-14);
    EXPECT_NEAR(a.presented_area_m2, a.surface_m2 / 4, 1e-16);
  }
  try {
    polyhedron_shape({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, 1000.0,
                     "fragment_groups[2].shape.vertices_m");
    FAIL() << "3 points must throw";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "fragment_groups[2].shape.vertices_m");
  }
}

TEST(Polyhedron, SupportVertexMatchesBruteForce) {
  // 10 clouds (8 to 3000 points, some flat), 2000 random directions each: the hill-climbing
  // support value equals the maximum over all hull vertices to 1e-15 of the size.
  std::mt19937_64 rng(17);
  std::normal_distribution<double> g;
  double worst = 0.0;
  for (int trial = 0; trial < 10; ++trial) {
    const int n = trial == 0 ? 8 : 300 * trial;
    const Vec3 scale = trial % 3 == 0 ? Vec3(1, 1, 1) : Vec3(1.0, 0.4, trial % 3 == 1 ? 0.01 : 0.2);
    std::vector<Vec3> pts = random_cloud(rng, n, scale);
    if (trial % 2 == 1)  // a rounded cloud (points on an ellipsoid): many hull vertices
      for (Vec3& p : pts) p = p.normalized().cwiseProduct(scale);
    const auto p = Polyhedron::from_points(pts, "v");
    for (int k = 0; k < 2000; ++k) {
      const Vec3 d = Vec3(g(rng), g(rng), g(rng)).normalized();
      double best = -1e300;
      for (const Vec3& v : p->vertices()) best = std::max(best, d.dot(v));
      const double h = d.dot(p->vertices()[p->support_vertex(d)]);
      worst = std::max(worst, best - h);
      EXPECT_LE(best - h, 1e-15) << "trial " << trial;
    }
  }
  std::printf("[ measured ] hill-climbing support: worst shortfall %.3g\n", worst);
}

}  // namespace
}  // namespace fragsim::fragments
