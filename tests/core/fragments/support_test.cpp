// Support function and contact point of the fragment shapes, against brute force over points of
// the body's surface and against the flat-landing cases worked by hand.
#include "core/fragments/support.h"

#include <gtest/gtest.h>

#include <random>
#include <vector>

namespace fragsim::fragments {
namespace {

ContactBody body(ShapeType t, Vec3 half) {
  ContactBody b;
  b.type = t;
  b.half_m = half;
  return b;
}

// Points on the body's surface (body axes), dense enough that the support over them is within
// ~1e-4 of the true support for bodies of unit size; corners and rims included exactly.
std::vector<Vec3> surface_points(const ContactBody& b) {
  std::vector<Vec3> pts;
  const Vec3& a = b.half_m;
  const int n = 400;
  switch (b.type) {
    case ShapeType::kCuboid:
      for (int k = 0; k < 8; ++k)
        pts.emplace_back((k & 1 ? 1 : -1) * a.x(), (k & 2 ? 1 : -1) * a.y(),
                         (k & 4 ? 1 : -1) * a.z());
      break;
    case ShapeType::kCylinder:
      for (int k = 0; k < n; ++k) {
        const double phi = 2 * kPi * k / n;
        for (double z : {-a.z(), a.z()})
          pts.emplace_back(a.x() * std::cos(phi), a.x() * std::sin(phi), z);
      }
      break;
    default:  // sphere, ellipsoid
      for (int i = 0; i <= n; ++i) {
        const double th = kPi * i / n;
        for (int k = 0; k < 2 * n; ++k) {
          const double phi = kPi * k / n;
          pts.emplace_back(a.x() * std::sin(th) * std::cos(phi),
                           a.y() * std::sin(th) * std::sin(phi), a.z() * std::cos(th));
        }
      }
  }
  return pts;
}

Quat random_rotation(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return uniform_rotation(u(rng), u(rng), u(rng));
}

Vec3 random_unit(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Vec3(g(rng), g(rng), g(rng)).normalized();
}

TEST(Support, ExtentMatchesBruteForceOverTheSurface) {
  std::mt19937_64 rng(7);
  const std::vector<ContactBody> bodies = {
      body(ShapeType::kSphere, Vec3::Constant(0.3)),
      body(ShapeType::kCuboid, Vec3(0.5, 0.2, 0.1)),
      body(ShapeType::kEllipsoid, Vec3(0.6, 0.3, 0.15)),
      body(ShapeType::kCylinder, Vec3(0.2, 0.2, 0.7)),
  };
  for (const auto& b : bodies) {
    const auto pts = surface_points(b);
    double rmax = 0.0;
    for (const auto& p : pts) rmax = std::max(rmax, p.norm());
    EXPECT_NEAR(bounding_radius(b), rmax, 1e-4) << shape_type_name(b.type);
    for (int trial = 0; trial < 200; ++trial) {
      const Quat q = random_rotation(rng);
      const Vec3 d = random_unit(rng);
      double best = -1e300;
      for (const auto& p : pts) best = std::max(best, d.dot(q * p));
      const double h = support_extent(b, q, d);
      // Exact for cuboid corners; the sampled curved surfaces sit at most ~1e-4 inside.
      EXPECT_GE(h, best - 1e-12) << shape_type_name(b.type);
      EXPECT_LE(h, best + 2e-4) << shape_type_name(b.type);
      EXPECT_LE(h, bounding_radius(b) + 1e-12);
      // The contact point for a plane with normal -d lies on the body at that extent.
      const Vec3 c = contact_point(b, q, -d, 1e-12);
      EXPECT_NEAR(d.dot(c), h, 1e-12) << shape_type_name(b.type);
    }
  }
}

TEST(Support, CubeLandingFlatTouchesUnderItsCentre) {
  const ContactBody cube = body(ShapeType::kCuboid, Vec3::Constant(0.1));
  // Any of the cube's 24 face-down attitudes that are a symmetry of the cube: same contact point.
  for (int k = 0; k < 4; ++k) {
    const Quat q(Eigen::AngleAxisd(k * kPi / 2, Vec3::UnitZ()));
    for (const Quat& flip : {Quat::Identity(), Quat(Eigen::AngleAxisd(kPi, Vec3::UnitX())),
                             Quat(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()))}) {
      const Vec3 c = contact_point(cube, q * flip, Vec3::UnitZ(), 1e-9);
      EXPECT_NEAR(c.x(), 0.0, 1e-15);
      EXPECT_NEAR(c.y(), 0.0, 1e-15);
      EXPECT_NEAR(c.z(), -0.1, 1e-15);
    }
  }
  // On an edge: the edge's midpoint. Tilted 45 degrees about x.
  const Quat edge(Eigen::AngleAxisd(kPi / 4, Vec3::UnitX()));
  const Vec3 c = contact_point(cube, edge, Vec3::UnitZ(), 1e-9);
  EXPECT_NEAR(c.x(), 0.0, 1e-15);
  EXPECT_NEAR(c.y(), 0.0, 1e-15);
  EXPECT_NEAR(c.z(), -0.1 * std::sqrt(2.0), 1e-15);
  // Slightly off flat (beyond the tolerance): a single corner.
  const Quat tilt(Eigen::AngleAxisd(1e-3, Vec3(1, 1, 0).normalized()));
  const Vec3 v = tilt.conjugate() * contact_point(cube, tilt, Vec3::UnitZ(), 1e-9);
  EXPECT_NEAR(std::abs(v.x()), 0.1, 1e-15);
  EXPECT_NEAR(std::abs(v.y()), 0.1, 1e-15);
}

TEST(Support, CylinderOnItsEndAndOnItsSide) {
  const ContactBody cyl = body(ShapeType::kCylinder, Vec3(0.05, 0.05, 0.2));
  const Vec3 end = contact_point(cyl, Quat::Identity(), Vec3::UnitZ(), 1e-9);
  EXPECT_NEAR((end - Vec3(0, 0, -0.2)).norm(), 0.0, 1e-15);
  const Quat side(Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()));  // axis along y
  const Vec3 line = contact_point(cyl, side, Vec3::UnitZ(), 1e-9);
  EXPECT_NEAR((line - Vec3(0, 0, -0.05)).norm(), 0.0, 1e-15);
  EXPECT_NEAR(support_extent(cyl, side, -Vec3::UnitZ()), 0.05, 1e-15);
  EXPECT_NEAR(support_extent(cyl, Quat::Identity(), -Vec3::UnitZ()), 0.2, 1e-15);
}

TEST(Support, PointMassIsASmallSphereOfItsPresentedArea) {
  MassProperties mp;
  mp.mass_kg = 0.2;
  mp.presented_area_m2 = 1e-3;
  const ContactBody b = contact_body(ShapeType::kPoint, mp);
  const double r = std::sqrt(1e-3 / kPi);
  EXPECT_EQ(b.type, ShapeType::kSphere);
  EXPECT_NEAR(b.half_m.x(), r, 1e-15);
  EXPECT_NEAR(b.inertia_kg_m2.x(), 0.4 * 0.2 * r * r, 1e-18);
  EXPECT_NEAR(support_extent(b, Quat::Identity(), Vec3(0.6, 0.0, 0.8)), r, 1e-15);
}

}  // namespace
}  // namespace fragsim::fragments
