// Support function and contact point of the fragment shapes, against brute force over points of
// the body's surface and against the flat-landing cases worked by hand.
#include "core/fragments/support.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <optional>
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

// ---- toppling ----

double a_max(const ContactBody& b) {
  return b.half_m.maxCoeff();
}

// The body axis (signed, body axes) that points along -n at attitude q, if one does to 1e-12.
bool some_axis_along(const Quat& q, const Vec3& n, const Vec3& keep, Vec3* axis = nullptr) {
  const Vec3 db = -(q.conjugate() * n);
  const Vec3 f = keep.cwiseProduct(db);
  if (axis) *axis = db;
  return std::abs(f.norm() - 1.0) < 1e-12;
}

// A body is resting after toppled_attitude: the resting face's normal is -n to 1e-12, it is the
// face the line from the centre along -n leaves through (brute force: the first face plane met),
// and the centre never rises (the clearance after <= before; a property of that rule: for a
// cuboid sum a_i |d_i| = sum (a_i / |d_i|) d_i^2 >= a_k / |d_k| >= a_k).
TEST(Support, ToppledBodiesRestOnTheFaceUnderTheirCentre) {
  std::mt19937_64 rng(11);
  const ContactBody cuboid = body(ShapeType::kCuboid, Vec3(0.05, 0.03, 0.005));
  const ContactBody rod = body(ShapeType::kCylinder, Vec3(0.01, 0.01, 0.1));
  const ContactBody disc = body(ShapeType::kCylinder, Vec3(0.1, 0.1, 0.01));
  const ContactBody ellipsoid = body(ShapeType::kEllipsoid, Vec3(0.3, 0.1, 0.2));
  for (int trial = 0; trial < 500; ++trial) {
    const Quat q = random_rotation(rng);
    const Vec3 n = random_unit(rng);
    for (const ContactBody* b : {&cuboid, &rod, &disc, &ellipsoid}) {
      const Quat t = toppled_attitude(*b, q, n);
      EXPECT_LE(support_extent(*b, t, -n), support_extent(*b, q, -n) + 8e-8 * a_max(*b));
      const Vec3 db = -(q.conjugate() * n);
      const Vec3& a = b->half_m;
      if (b->type == ShapeType::kCuboid) {
        int exit = 0;  // smallest distance a_i / |d_i| to a face plane along db
        for (int i = 1; i < 3; ++i)
          if (a[i] / std::abs(db[i]) < a[exit] / std::abs(db[exit])) exit = i;
        EXPECT_TRUE(some_axis_along(t, n, Vec3::Unit(exit)));
        EXPECT_NEAR(support_extent(*b, t, -n), a[exit], 1e-15);
      } else if (b->type == ShapeType::kCylinder) {
        // The end disk is met first along db when L/2 / |d_z| < R / sqrt(1 - d_z^2).
        const double c = std::abs(db.z()), s = std::sqrt(1.0 - c * c);
        const bool end = a.z() * s < a.x() * c;
        EXPECT_TRUE(some_axis_along(t, n, end ? Vec3(0, 0, 1) : Vec3(1, 1, 0)));
        // The cylinder's support R sqrt(1 - d_z^2) + ... turns a rounding of d_z near 1 by k ulps
        // into R sqrt(2 k eps): the end-down clearance is exact only to that. The rotations
        // round d_z by a few ulps, and by how many depends on the CPU (glibc picks FMA or plain
        // sin/cos at load time): a CI machine saw k ~ 2.5 (3.3e-8 R); k <= 14 gives 7.9e-8 R.
        EXPECT_NEAR(support_extent(*b, t, -n), end ? a.z() : a.x(), 8e-8 * a.x());
      } else {
        EXPECT_TRUE(some_axis_along(t, n, Vec3::UnitY()));  // the shortest semi-axis
        EXPECT_NEAR(support_extent(*b, t, -n), 0.1, 1e-15);
      }
      // The least rotation: the rotation from q to t turns the face normal about an axis
      // perpendicular to it and to n, so it leaves the direction n x (q f) in place.
      const Vec3 f = t.conjugate() * (-n);  // the resting face normal, body axes
      const Vec3 axis = n.cross(q * f);
      if (axis.norm() > 1e-6) {
        EXPECT_NEAR((t * (q.conjugate() * axis) - axis).norm(), 0.0, 1e-12);
      }
    }
  }
}

// A plate balanced exactly on an edge, or on a corner (its centre straight over it), falls flat:
// its thinnest axis along n. A flat one (any turn about n, either side down) is left exactly as
// it is, bit for bit, as is a sphere.
TEST(Support, PlateOnAnEdgeOrACornerFallsFlatAndAFlatOneIsUnchanged) {
  const ContactBody plate = body(ShapeType::kCuboid, Vec3(0.05, 0.03, 0.005));
  const Vec3 n = Vec3::UnitZ();
  const Vec3 edge_down = Vec3(0.0, 0.03, 0.005).normalized();  // body axes, to point along -n
  const Vec3 corner_down = Vec3(0.05, 0.03, 0.005).normalized();
  for (const Vec3& down : {edge_down, corner_down, Vec3(0.0, 1.0, 1.0).normalized()}) {
    const Quat q = Quat::FromTwoVectors(down, -n);
    ASSERT_FALSE(some_axis_along(q, n, Vec3::UnitZ()));
    const Quat t = toppled_attitude(plate, q, n);
    EXPECT_TRUE(some_axis_along(t, n, Vec3::UnitZ()));
    EXPECT_NEAR(support_extent(plate, t, -n), 0.005, 1e-15);
    EXPECT_LT(support_extent(plate, t, -n), support_extent(plate, q, -n) - 1e-3);
  }
  for (int k = 0; k < 8; ++k) {
    const Quat q = Quat(Eigen::AngleAxisd(0.37 * k, Vec3::UnitZ())) *
                   Quat(Eigen::AngleAxisd(k % 2 ? kPi : 0.0, Vec3::UnitX()));
    const Quat t = toppled_attitude(plate, q, n);
    EXPECT_EQ(t.coeffs(), q.coeffs()) << k;
  }
  const ContactBody ball = body(ShapeType::kSphere, Vec3::Constant(0.02));
  const Quat q(Eigen::AngleAxisd(0.7, Vec3(1, 2, 3).normalized()));
  EXPECT_EQ(toppled_attitude(ball, q, n).coeffs(), q.coeffs());
}

// Cylinders: a rod (L/2 = 10 R) tipped 30 degrees from upright lies down; a disc (R = 10 L/2)
// tipped 60 degrees falls onto its face; a squat one (R = L/2) goes to the nearer of the two
// (45 degrees divides them).
TEST(Support, CylindersFallOntoTheFaceUnderTheirCentre) {
  const Vec3 n = Vec3::UnitZ();
  const auto tipped = [](double deg) {
    return Quat(Eigen::AngleAxisd(kPi + deg * kPi / 180.0, Vec3::UnitX()));  // +z end down
  };
  const ContactBody rod = body(ShapeType::kCylinder, Vec3(0.01, 0.01, 0.1));
  EXPECT_TRUE(some_axis_along(toppled_attitude(rod, tipped(30.0), n), n, Vec3(1, 1, 0)));
  EXPECT_TRUE(some_axis_along(toppled_attitude(rod, tipped(5.0), n), n, Vec3(0, 0, 1)));
  const ContactBody disc = body(ShapeType::kCylinder, Vec3(0.1, 0.1, 0.01));
  EXPECT_TRUE(some_axis_along(toppled_attitude(disc, tipped(60.0), n), n, Vec3(0, 0, 1)));
  const ContactBody squat = body(ShapeType::kCylinder, Vec3(0.05, 0.05, 0.05));
  EXPECT_TRUE(some_axis_along(toppled_attitude(squat, tipped(44.0), n), n, Vec3(0, 0, 1)));
  EXPECT_TRUE(some_axis_along(toppled_attitude(squat, tipped(46.0), n), n, Vec3(1, 1, 0)));
  // On its side already: unchanged, whatever its turn about its axis.
  const Quat side(Eigen::AngleAxisd(kPi / 2, Vec3::UnitX()));
  EXPECT_EQ(toppled_attitude(rod, side, n).coeffs(), side.coeffs());
}

// ---- projected area ----

// Along the body axes the closed forms by hand (1e-15 relative): a cuboid 0.4 x 0.2 x 0.1 m shows
// 0.2 x 0.1 along x; an ellipsoid pi b c; a cylinder pi R^2 along its axis, 2 R L across it; a
// sphere pi r^2 in any direction. The attitude turns the body, not the flow: the same areas with
// q and d turned together.
TEST(Support, ProjectedAreaAlongTheAxes) {
  const ContactBody cuboid = body(ShapeType::kCuboid, Vec3(0.2, 0.1, 0.05));
  const ContactBody ellipsoid = body(ShapeType::kEllipsoid, Vec3(0.3, 0.2, 0.1));
  const ContactBody cylinder = body(ShapeType::kCylinder, Vec3(0.05, 0.05, 0.3));
  const ContactBody sphere = body(ShapeType::kSphere, Vec3::Constant(0.1));
  const Quat turn(Eigen::AngleAxisd(0.9, Vec3(1, -2, 0.5).normalized()));
  for (const Quat& q : {Quat::Identity(), turn}) {
    const auto area = [&](const ContactBody& b, const Vec3& d) {
      return projected_area(b, q, q * d);
    };
    EXPECT_NEAR(area(cuboid, Vec3::UnitX()), 0.2 * 0.1, 1e-15);
    EXPECT_NEAR(area(cuboid, -Vec3::UnitY()), 0.4 * 0.1, 1e-15);
    EXPECT_NEAR(area(cuboid, Vec3::UnitZ()), 0.4 * 0.2, 1e-15);
    EXPECT_NEAR(area(ellipsoid, Vec3::UnitX()), kPi * 0.2 * 0.1, 1e-15);
    EXPECT_NEAR(area(ellipsoid, Vec3::UnitZ()), kPi * 0.3 * 0.2, 1e-15);
    EXPECT_NEAR(area(cylinder, -Vec3::UnitZ()), kPi * 0.05 * 0.05, 1e-15);
    EXPECT_NEAR(area(cylinder, Vec3(1, 1, 0).normalized()), 2 * 0.05 * 0.6, 1e-15);
    EXPECT_NEAR(area(sphere, Vec3(0.6, 0, 0.8)), kPi * 0.01, 1e-15);
  }
  // A cube seen along its diagonal shows a regular hexagon of area sqrt(3) a^2 (a the edge).
  const ContactBody cube = body(ShapeType::kCuboid, Vec3::Constant(0.5));
  EXPECT_NEAR(projected_area(cube, Quat::Identity(), Vec3(1, 1, 1).normalized()), std::sqrt(3.0),
              1e-15);
}

// Cauchy: averaged over uniformly random directions, the projected area of a convex body is its
// surface / 4 (mass_properties' tumble-averaged area). 200,000 directions: the mean is within 4
// of its standard errors (a false failure about 1 in 16,000); the errors are ~0.05 % here.
TEST(Support, ProjectedAreaAveragesToAQuarterOfTheSurface) {
  std::mt19937_64 rng(23);
  struct Case {
    ShapeType type;
    std::vector<double> dims;
  };
  for (const Case& c :
       {Case{ShapeType::kCuboid, {0.4, 0.2, 0.05}}, Case{ShapeType::kEllipsoid, {0.6, 0.3, 0.1}},
        Case{ShapeType::kCylinder, {0.1, 0.5}}}) {
    ShapeSpec spec;
    spec.type = c.type;
    spec.dims_m = c.dims;
    const MassProperties mp = mass_properties(spec, 1.0, std::nullopt);
    const ContactBody b = contact_body(c.type, mp);
    const Quat q = random_rotation(rng);
    const int n = 200000;
    double sum = 0.0, sum2 = 0.0;
    for (int k = 0; k < n; ++k) {
      const double a = projected_area(b, q, random_unit(rng));
      sum += a;
      sum2 += a * a;
    }
    const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, 0.25 * mp.surface_m2, 4.0 * se) << shape_type_name(c.type);
    EXPECT_NEAR(mp.presented_area_m2, 0.25 * mp.surface_m2, 1e-15);
    EXPECT_LT(se, 1e-3 * mean);
  }
}

// ---- polyhedron ----

ContactBody polyhedron_body(const std::vector<Vec3>& pts, std::optional<double> density,
                            double mass) {
  const ShapeSpec spec = polyhedron_shape(pts, density);
  return contact_body(ShapeType::kPolyhedron, mass_properties(spec, mass, std::nullopt));
}

std::vector<Vec3> random_cloud(std::mt19937_64& rng, int n, const Vec3& scale) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i) pts.push_back(Vec3(u(rng), u(rng), u(rng)).cwiseProduct(scale));
  return pts;
}

// Area of the 2-D convex hull of points (monotone chain, shoelace).
double hull_area_2d(std::vector<Vec2> p) {
  std::sort(p.begin(), p.end(), [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  const auto cross = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Vec2> h(2 * p.size());
  std::size_t k = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (std::size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  double a = 0.0;
  for (std::size_t i = 0; i + 1 < k; ++i) a += h[i].x() * h[i + 1].y() - h[i + 1].x() * h[i].y();
  return 0.5 * a;
}

// A random rock (the hull of 200 points in a 0.3 x 0.2 x 0.1 box, scaled by a density to 3 kg):
// support extent = the maximum over its (scaled, turned) vertices to 1e-15; the contact point
// touches at that extent; the frontal area is the area of the vertices' projection (2-D hull) to
// 1e-14 relative; the bounding radius bounds every vertex.
TEST(Support, PolyhedronMatchesBruteForceOverItsVertices) {
  std::mt19937_64 rng(31);
  const std::vector<Vec3> pts = random_cloud(rng, 200, Vec3(0.3, 0.2, 0.1));
  const ContactBody b = polyhedron_body(pts, 2700.0, 3.0);
  EXPECT_NEAR(body_volume(b), 3.0 / 2700.0, 1e-15);
  std::vector<Vec3> verts;
  for (const Vec3& v : b.polyhedron->vertices()) verts.push_back(b.scale * v);
  double rmax = 0.0;
  for (const Vec3& v : verts) rmax = std::max(rmax, v.norm());
  EXPECT_NEAR(bounding_radius(b), rmax, 1e-15);
  for (int trial = 0; trial < 500; ++trial) {
    const Quat q = random_rotation(rng);
    const Vec3 d = random_unit(rng);
    double best = -1e300;
    for (const Vec3& v : verts) best = std::max(best, d.dot(q * v));
    EXPECT_NEAR(support_extent(b, q, d), best, 1e-15);
    const Vec3 c = contact_point(b, q, -d, 1e-12);
    EXPECT_NEAR(d.dot(c), best, 1e-15);
    const Vec3 e1 = d.unitOrthogonal(), e2 = d.cross(e1);
    std::vector<Vec2> shadow;
    for (const Vec3& v : verts) shadow.emplace_back(e1.dot(q * v), e2.dot(q * v));
    const double area = hull_area_2d(shadow);
    EXPECT_NEAR(projected_area(b, q, d), area, 1e-14 * area);
  }
}

// A cuboid given as its 8 corners behaves as the cuboid shape: the same support extent, contact
// point (corner, edge midpoint, face centre: flat attitudes included), toppled attitude and
// frontal area, for 2000 random attitudes and normals, to 1e-15 m (1e-12 for the attitude).
TEST(Support, CubePolyhedronMatchesTheCuboid) {
  const Vec3 half(0.05, 0.03, 0.01);
  std::vector<Vec3> corners;
  for (int k = 0; k < 8; ++k)
    corners.emplace_back(k & 1 ? half.x() : -half.x(), k & 2 ? half.y() : -half.y(),
                         k & 4 ? half.z() : -half.z());
  const ContactBody poly = polyhedron_body(corners, std::nullopt, 1.0);
  const ContactBody box = body(ShapeType::kCuboid, half);
  EXPECT_NEAR((poly.half_m - half).norm(), 0.0, 1e-16);
  std::mt19937_64 rng(41);
  std::vector<Quat> attitudes;
  for (int k = 0; k < 2000; ++k) attitudes.push_back(random_rotation(rng));
  for (int k = 0; k < 24; ++k)  // flat and on-edge attitudes
    attitudes.push_back(Quat(Eigen::AngleAxisd(k * kPi / 4, Vec3::Unit(k % 3))));
  for (const Quat& q : attitudes) {
    const Vec3 n = attitudes.size() % 2 ? Vec3::UnitZ() : random_unit(rng);
    for (const Vec3& nn : {Vec3(Vec3::UnitZ()), n}) {
      EXPECT_NEAR(support_extent(poly, q, -nn), support_extent(box, q, -nn), 1e-15);
      EXPECT_NEAR((contact_point(poly, q, nn, 1e-9) - contact_point(box, q, nn, 1e-9)).norm(), 0.0,
                  1e-15);
      const Quat tp = toppled_attitude(poly, q, nn), tb = toppled_attitude(box, q, nn);
      EXPECT_LE(std::min((tp.coeffs() - tb.coeffs()).norm(), (tp.coeffs() + tb.coeffs()).norm()),
                1e-12);
      EXPECT_NEAR(projected_area(poly, q, nn), projected_area(box, q, nn), 1e-15);
    }
  }
}

// A random rock topples onto a stable face: the line from the centre along -n leaves through
// the face it lies on (brute force over the faces: the first face plane met has the normal -n),
// that face's normal is along -n to 1e-12, its centre never rises, and a second topple changes
// nothing. From its first tip (the face the line along -n leaves through, brute force) it falls
// on while its centre does not stand over its face: count how often that happens.
TEST(Support, ToppledPolyhedronRestsOnAStableFace) {
  std::mt19937_64 rng(43);
  const ContactBody b = polyhedron_body(random_cloud(rng, 100, Vec3(0.3, 0.2, 0.1)), 2700.0, 1.0);
  const Polyhedron& p = *b.polyhedron;
  const auto exit_normal = [&](const Vec3& d) {
    double best_t = 1e300;
    Vec3 face = Vec3::Zero();
    for (std::size_t f = 0; f < p.normals().size(); ++f) {
      const double c = p.normals()[f].dot(d);
      if (c > 0 && p.offsets()[f] / c < best_t) best_t = p.offsets()[f] / c, face = p.normals()[f];
    }
    return face;
  };
  int fell_on = 0;
  for (int trial = 0; trial < 500; ++trial) {
    const Quat q = random_rotation(rng);
    const Vec3 n = random_unit(rng);
    const Quat t = toppled_attitude(b, q, n);
    const Vec3 down = t.conjugate() * (-n);  // body axes
    EXPECT_NEAR((exit_normal(down) - down).norm(), 0.0, 1e-12);
    EXPECT_LE(support_extent(b, t, -n), support_extent(b, q, -n) + 1e-15);
    EXPECT_EQ(toppled_attitude(b, t, n).coeffs(), t.coeffs());
    if ((exit_normal(-(q.conjugate() * n)) - down).norm() > 1e-9) ++fell_on;
  }
  std::printf("[ measured ] random rock: %d of 500 topples fell on past the first face\n", fell_on);
  EXPECT_GT(fell_on, 0);  // the test sees the case it is for
}

// Cauchy for the polyhedron: the frontal area averaged over 100,000 directions is surface / 4
// within 4 standard errors, and the tumble-averaged area is surface / 4.
TEST(Support, PolyhedronProjectedAreaAveragesToAQuarterOfTheSurface) {
  std::mt19937_64 rng(47);
  const ShapeSpec spec = polyhedron_shape(random_cloud(rng, 60, Vec3(0.4, 0.2, 0.05)), 1000.0);
  const MassProperties mp = mass_properties(spec, 2.0, std::nullopt);
  const ContactBody b = contact_body(ShapeType::kPolyhedron, mp);
  const int n = 100000;
  double sum = 0.0, sum2 = 0.0;
  for (int k = 0; k < n; ++k) {
    const double a = projected_area(b, Quat::Identity(), random_unit(rng));
    sum += a;
    sum2 += a * a;
  }
  const double mean = sum / n, se = std::sqrt((sum2 / n - mean * mean) / n);
  EXPECT_NEAR(mean, 0.25 * mp.surface_m2, 4.0 * se);
  EXPECT_NEAR(mp.presented_area_m2, 0.25 * mp.surface_m2, 1e-15);
}

}  // namespace
}  // namespace fragsim::fragments
