// Convex hull and mesh mass properties: closed forms (cube, cuboid, regular tetrahedron), random
// clouds against brute-force containment and Monte Carlo moments, degenerate and bad inputs.
#include "core/fragments/convex_hull.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <set>

#include "core/common/error.h"

namespace fragsim::fragments {
namespace {

// Largest height of any point above any face plane of the hull, relative to the cloud's size.
double worst_outside(const HullMesh& h, const std::vector<Vec3>& pts) {
  double worst = -1e300, size = 0.0;
  for (const Vec3& p : pts) size = std::max(size, p.cwiseAbs().sum());
  for (const auto& t : h.triangles) {
    const Vec3 a = h.vertices[t[0]];
    const Vec3 n = (h.vertices[t[1]] - a).cross(h.vertices[t[2]] - a).normalized();
    for (const Vec3& p : pts) worst = std::max(worst, n.dot(p - a));
  }
  return worst / size;
}

// The points of an n x n x n lattice filling the box [lo, hi]: many coplanar and collinear.
std::vector<Vec3> lattice(const Vec3& lo, const Vec3& hi, int n) {
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j)
      for (int k = 0; k < n; ++k)
        pts.push_back(lo + (hi - lo).cwiseProduct(Vec3(i, j, k) / (n - 1.0)));
  return pts;
}

TEST(ConvexHull, LatticeCuboidHasEightCornersAndExactMoments) {
  // Box a x b x c, 6^3 lattice points (faces, edges, interior): 8 vertices, 12 triangles; volume
  // abc, centroid the centre, I = (b^2 + c^2, a^2 + c^2, a^2 + b^2) V / 12 to 1e-13 relative.
  const double a = 0.3, b = 0.7, c = 1.9;
  const Vec3 lo(-1.0, 2.0, 0.5);
  const HullMesh h = convex_hull(lattice(lo, lo + Vec3(a, b, c), 6), "v");
  EXPECT_EQ(h.vertices.size(), 8u);
  EXPECT_EQ(h.triangles.size(), 12u);
  const MeshMass m = mesh_mass(h);
  const double v = a * b * c;
  EXPECT_NEAR(m.volume_m3, v, 1e-14 * v);
  EXPECT_NEAR((m.centroid_m - (lo + 0.5 * Vec3(a, b, c))).norm(), 0.0, 1e-14);
  const Vec3 want = Vec3(b * b + c * c, a * a + c * c, a * a + b * b) * v / 12.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      EXPECT_NEAR(m.inertia_m5(i, j), i == j ? want[i] : 0.0, 1e-13 * want.maxCoeff());
  EXPECT_NEAR(m.surface_m2, 2 * (a * b + b * c + c * a), 1e-14 * 10);
}

TEST(ConvexHull, RegularTetrahedronIsIsotropic) {
  // Edge a: volume a^3 / (6 sqrt 2), I = m a^2 / 20 about every axis through the centroid.
  const double a = 0.4;
  const double s = a / (2.0 * std::sqrt(2.0));  // (±s, ±s, ±s) with an even number of minus signs
  std::vector<Vec3> pts = {{s, s, s}, {s, -s, -s}, {-s, s, -s}, {-s, -s, s}};
  pts.push_back(Vec3(0.01, -0.02, 0.03));  // an interior point, dropped
  const HullMesh h = convex_hull(pts, "v");
  EXPECT_EQ(h.vertices.size(), 4u);
  const MeshMass m = mesh_mass(h);
  const double v = a * a * a / (6.0 * std::sqrt(2.0));
  EXPECT_NEAR(m.volume_m3, v, 1e-14 * v);
  const double want = v * a * a / 20.0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(m.inertia_m5(i, j), i == j ? want : 0.0, 1e-13 * want);
  EXPECT_NEAR(m.surface_m2, std::sqrt(3.0) * a * a, 1e-14);
}

TEST(ConvexHull, RandomCloudsContainEveryPointAndKeepOnlyInputPoints) {
  // 30 clouds of 20-3000 points (box, ball, thin slab, far from the origin): no input point is
  // more than 1e-12 (the build tolerance) of the size above any face; the hull is closed (every
  // directed edge once, Euler checked inside) and its vertices are input points.
  std::mt19937_64 rng(11);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = -1.0;
  for (int trial = 0; trial < 30; ++trial) {
    const int n = trial < 10 ? 20 + 7 * trial : 200 + 100 * trial;
    std::vector<Vec3> pts;
    const Vec3 shift = trial % 5 == 4 ? Vec3(1e3, -2e3, 5e2) : Vec3::Zero();
    for (int i = 0; i < n; ++i) {
      Vec3 p = trial % 2 == 0
                   ? Vec3(u(rng), u(rng), u(rng))
                   : Vec3(g(rng), g(rng), g(rng)).normalized() * std::cbrt(0.5 + 0.5 * u(rng));
      if (trial % 3 == 2) p.z() *= 1e-3;  // a slab
      pts.push_back(p + shift);
    }
    const HullMesh h = convex_hull(pts, "v");
    worst = std::max(worst, worst_outside(h, pts));
    std::set<std::pair<std::uint32_t, std::uint32_t>> edges;
    for (const auto& t : h.triangles)
      for (int k = 0; k < 3; ++k) EXPECT_TRUE(edges.insert({t[k], t[(k + 1) % 3]}).second);
    for (const auto& [a, b] : edges) EXPECT_EQ(edges.count({b, a}), 1u);
    for (const Vec3& v : h.vertices) EXPECT_NE(std::find(pts.begin(), pts.end(), v), pts.end());
    EXPECT_GT(mesh_mass(h).volume_m3, 0.0);
  }
  std::printf("[ measured ] worst point above a hull face: %.3g of the size\n", worst);
  EXPECT_LE(worst, 1e-12);
}

TEST(ConvexHull, MomentsOfARandomCloudMatchMonteCarlo) {
  // Volume, centroid and inertia of the hull of 60 random points against 400,000 uniform samples
  // of its bounding box tested against the face planes. Tolerance 5 standard errors.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Vec3> pts;
  for (int i = 0; i < 60; ++i) pts.emplace_back(2.0 * u(rng), u(rng), 0.5 * u(rng));
  const HullMesh h = convex_hull(pts, "v");
  const MeshMass m = mesh_mass(h);
  std::vector<Vec3> n;
  std::vector<double> d;
  for (const auto& t : h.triangles) {
    const Vec3 a = h.vertices[t[0]];
    n.push_back((h.vertices[t[1]] - a).cross(h.vertices[t[2]] - a).normalized());
    d.push_back(n.back().dot(a));
  }
  const int samples = 400000;
  const double box = 2.0 * 1.0 * 0.5;
  double hits = 0;
  Vec3 s1 = Vec3::Zero();
  Mat3 s2 = Mat3::Zero();
  for (int k = 0; k < samples; ++k) {
    const Vec3 p(2.0 * u(rng), u(rng), 0.5 * u(rng));
    bool in = true;
    for (std::size_t f = 0; f < n.size() && in; ++f) in = n[f].dot(p) <= d[f];
    if (!in) continue;
    hits += 1;
    const Vec3 r = p - m.centroid_m;
    s1 += p;
    s2 += (r.squaredNorm() * Mat3::Identity() - r * r.transpose());
  }
  const double frac = hits / samples;
  const double v_mc = box * frac, se = box * std::sqrt(frac * (1 - frac) / samples);
  EXPECT_NEAR(m.volume_m3, v_mc, 5 * se);
  // The centroid and inertia per hit: their spread is below the hull's size (1) squared.
  const double se_c = 1.0 / std::sqrt(hits);
  EXPECT_NEAR((s1 / hits - m.centroid_m).norm(), 0.0, 5 * se_c);
  const Mat3 i_mc = s2 / hits * m.volume_m3;
  EXPECT_LE((i_mc - m.inertia_m5).norm(), 5 * se_c * m.volume_m3);
  std::printf("[ measured ] hull volume %.6f, Monte Carlo %.6f +- %.6f; inertia diff %.3g\n",
              m.volume_m3, v_mc, se, (i_mc - m.inertia_m5).norm());
}

TEST(ConvexHull, SpherePointsAllOnTheHull) {
  // 2000 points on a sphere (Fibonacci lattice): every one is a vertex; volume below 4/3 pi.
  std::vector<Vec3> pts;
  const int n = 2000;
  for (int i = 0; i < n; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / n, r = std::sqrt(1 - z * z);
    const double phi = i * kPi * (3.0 - std::sqrt(5.0));
    pts.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  const HullMesh h = convex_hull(pts, "v");
  EXPECT_EQ(h.vertices.size(), static_cast<std::size_t>(n));
  EXPECT_EQ(h.triangles.size(), static_cast<std::size_t>(2 * n - 4));
  const double v = mesh_mass(h).volume_m3;
  EXPECT_LT(v, 4.0 / 3.0 * kPi);
  EXPECT_GT(v, 0.995 * 4.0 / 3.0 * kPi);
}

// Sets built to be degenerate at rounding level, 600 of them: turned lattices (many coplanar and
// collinear points in no axis plane), random points on the faces of a turned cube, a turned
// cylinder grid (coplanar rings), clusters of near-duplicates (1e-14 apart), a slab 1e-6 thin
// 1 km from the origin. Every hull closes (Euler, checked inside), none is refused, the lattice's
// volume is exact to 1e-12, and no point is above a face plane by more than 1e-9 of the size:
// beyond the build tolerance (1e-12) only through sliver triangles, whose planes are defined to
// rounding only (measured: up to ~1e-10 for the slab and the cube faces, 1e-15 for the others).
TEST(ConvexHull, RoundingLevelDegenerateSetsBuildClosedHulls) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> g;
  double worst = 0.0;
  for (int trial = 0; trial < 600; ++trial) {
    std::vector<Vec3> pts;
    const int kind = trial % 5;
    const Quat q =
        Quat(Eigen::AngleAxisd(2 * kPi * u(rng), Vec3(g(rng), g(rng), g(rng)).normalized()));
    const int n = 2 + trial % 7;
    switch (kind) {
      case 0:
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k) pts.push_back(q * Vec3(i, j, k) * 0.01);
        break;
      case 1:
        for (int k = 0; k < 300; ++k) {
          Vec3 p(u(rng), u(rng), u(rng));
          p[k % 3] = (k / 3) % 2;
          pts.push_back(q * p);
        }
        break;
      case 2:
        for (int i = 0; i < 24; ++i)
          for (int j = 0; j < 7; ++j)
            pts.push_back(q * Vec3(std::cos(kPi * i / 12), std::sin(kPi * i / 12), 0.3 * j));
        break;
      case 3: {
        std::vector<Vec3> base;
        for (int k = 0; k < 10; ++k) base.emplace_back(g(rng), g(rng), g(rng));
        for (int k = 0; k < 200; ++k)
          pts.push_back(base[k % 10] + 1e-14 * Vec3(g(rng), g(rng), g(rng)));
        break;
      }
      default:
        for (int k = 0; k < 300; ++k)
          pts.push_back(Vec3(1e3, -500, 20) + q * Vec3(g(rng), g(rng), 1e-6 * g(rng)));
    }
    HullMesh h;
    ASSERT_NO_THROW(h = convex_hull(pts, "v")) << "trial " << trial;
    const double v = mesh_mass(h).volume_m3;
    EXPECT_GT(v, 0.0);
    if (kind == 0) {
      const double want = std::pow(0.01 * (n - 1), 3);
      EXPECT_NEAR(v, want, 1e-12 * want);
    }
    const double w = worst_outside(h, pts);
    worst = std::max(worst, w);
    EXPECT_LE(w, 1e-9) << "trial " << trial << " kind " << kind;
  }
  std::printf("[ measured ] degenerate sets: worst point above a face plane %.3g of the size\n",
              worst);
}

TEST(ConvexHull, RefusesWhatHasNoVolume) {
  const auto error_of = [](const std::vector<Vec3>& pts) -> std::string {
    try {
      convex_hull(pts, "shape.vertices_m");
    } catch (const InputError& e) {
      return e.what();
    }
    return "(no throw)";
  };
  EXPECT_EQ(error_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}),
            "shape.vertices_m: a polyhedron needs at least 4 points (got 3)");
  EXPECT_NE(
      error_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}, {0.5, 0.5, 1e-12}}).find("coplanar"),
      std::string::npos);
  EXPECT_NE(error_of({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3 + 1e-13}}).find("collinear"),
            std::string::npos);
  EXPECT_NE(error_of({{1, 1, 1}, {1, 1, 1}, {1, 1, 1}, {1, 1, 1}}).find("coincide"),
            std::string::npos);
  EXPECT_EQ(error_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, NAN}}),
            "shape.vertices_m[3]: not finite");
  // Flat at the threshold and just above it: a plate 1e-8 of its size thick is a body.
  EXPECT_EQ(error_of({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 1e-8}}), "(no throw)");
}

}  // namespace
}  // namespace fragsim::fragments
