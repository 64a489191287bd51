// TerrainIndex2D: bucket contents, max_z, and the segment traversal against brute force.
#include "core/scene/terrain_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "core/scene/polygon.h"
#include "scene_test_util.h"

namespace fragsim::scene {
namespace {

using testing::grid_site;
using testing::jittered_mesh;
using testing::make_grid;
using testing::plane_site;

// Triangle t's xy-projection shrunk towards its centroid by a relative 1e-7: a segment meeting
// it passes through the triangle's interior ("crosses" it), not just along an edge or corner.
std::array<Vec2, 3> shrunk(const Site& s, std::uint32_t t) {
  const auto& tri = s.terrain_triangles()[t];
  std::array<Vec2, 3> p;
  for (int k = 0; k < 3; ++k) p[k] = s.terrain_vertices()[tri[k]].head<2>();
  const Vec2 c = (p[0] + p[1] + p[2]) / 3.0;
  for (auto& q : p) q = c + (1 - 1e-7) * (q - c);
  return p;
}

bool in_triangle(const std::array<Vec2, 3>& p, const Vec2& x, double tol = 0) {
  const double a = detail::orient2d(p[0], p[1], p[2]);
  return detail::orient2d(p[0], p[1], x) >= -tol * a &&
         detail::orient2d(p[1], p[2], x) >= -tol * a && detail::orient2d(p[2], p[0], x) >= -tol * a;
}

bool segment_meets_triangle(const std::array<Vec2, 3>& p, const Vec2& a, const Vec2& b) {
  if (in_triangle(p, a) || in_triangle(p, b)) return true;
  for (int k = 0; k < 3; ++k)
    if (detail::segments_intersect(a, b, p[k], p[(k + 1) % 3])) return true;
  return false;
}

// Checks one segment; returns the number of triangles it crosses.
std::size_t check_segment(const Site& s, const Vec2& a, const Vec2& b) {
  std::set<std::uint32_t> reported;
  s.terrain_index().for_each_candidate(a, b, [&](std::uint32_t t) { reported.insert(t); });
  std::size_t crossed = 0;
  for (std::uint32_t t = 0; t < s.terrain_triangle_count(); ++t) {
    if (!segment_meets_triangle(shrunk(s, t), a, b)) continue;
    ++crossed;
    EXPECT_TRUE(reported.count(t)) << "triangle " << t << " missed by segment (" << a.transpose()
                                   << ") -> (" << b.transpose() << ")";
  }
  // Every point of the segment over the terrain lies in some reported triangle (covers segments
  // running exactly along bucket edges, which cross no interior).
  for (int k = 0; k <= 40; ++k) {
    const Vec2 x = a + (b - a) * (k / 40.0);
    if (std::isnan(s.terrain_height(x.x(), x.y()))) continue;
    bool covered = false;
    for (const std::uint32_t t : reported) {
      std::array<Vec2, 3> p;
      for (int q = 0; q < 3; ++q)
        p[q] = s.terrain_vertices()[s.terrain_triangles()[t][q]].head<2>();
      covered = covered || in_triangle(p, x, 1e-9);
    }
    EXPECT_TRUE(covered) << "point " << x.transpose() << " of segment not covered";
  }
  return crossed;
}

void check_random_segments(const Site& s, std::uint64_t seed, int count) {
  const Box3& box = s.terrain_bounds();
  const Vec2 lo = box.lo.head<2>(), size = (box.hi - box.lo).head<2>();
  const TerrainIndex2D& ix = s.terrain_index();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-0.2, 1.2), unit(0, 1);
  const auto point = [&] { return Vec2(lo.x() + u(rng) * size.x(), lo.y() + u(rng) * size.y()); };
  const auto node = [&] {  // a bucket corner
    return Vec2(ix.origin.x() + std::floor(unit(rng) * (ix.nx + 1)) * ix.cell.x(),
                ix.origin.y() + std::floor(unit(rng) * (ix.ny + 1)) * ix.cell.y());
  };
  std::size_t crossed = 0;
  for (int k = 0; k < count; ++k) {
    Vec2 a = point(), b = point();
    switch (k % 8) {
      case 1: b.y() = a.y(); break;           // parallel to x
      case 2: b.x() = a.x(); break;           // parallel to y
      case 3: b = a; break;                   // zero length
      case 4: b = a + 0.01 * (b - a); break;  // short chord
      case 5:
        a = node();
        b = node();
        break;  // corner to corner (through corners)
      case 6:
        a = node();
        b = Vec2(a.x() + (unit(rng) - 0.5) * size.x(), a.y());
        break;  // on a bucket edge
      case 7:
        a = node();
        b = Vec2(a.x(), a.y() + (unit(rng) - 0.5) * size.y());
        break;
      default: break;
    }
    crossed += check_segment(s, a, b);
    if (::testing::Test::HasFailure()) return;
  }
  EXPECT_GT(crossed, static_cast<std::size_t>(count));  // the segments do cross the terrain
}

TEST(TerrainIndex, PlaneBucketsAreCells) {
  const auto s = Site::build(plane_site({0, 0, 105, 47}, 10, 0));  // 11 x 5 non-square cells
  const TerrainIndex2D& ix = s->terrain_index();
  ASSERT_EQ(ix.nx, 11);
  ASSERT_EQ(ix.ny, 5);
  for (int b = 0; b < ix.nx * ix.ny; ++b) {
    ASSERT_EQ(ix.start[b + 1] - ix.start[b], 2u);
    EXPECT_EQ(ix.triangles[ix.start[b]], 2u * b);
    EXPECT_EQ(ix.triangles[ix.start[b] + 1], 2u * b + 1);
  }
  check_random_segments(*s, 11, 800);
}

TEST(TerrainIndex, GridBucketsAndMaxZ) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> zd(-10, 10);
  const auto g = make_grid(1000.3, -200.7, 4.0, 30, 20, [&](double, double) { return zd(rng); });
  const auto s = Site::build(grid_site(g));
  const TerrainIndex2D& ix = s->terrain_index();
  ASSERT_EQ(ix.nx, 29);
  ASSERT_EQ(ix.ny, 19);
  const double oz = s->local_origin().z();
  for (int j = 0; j < ix.ny; ++j) {
    for (int i = 0; i < ix.nx; ++i) {
      const std::size_t b = static_cast<std::size_t>(j) * ix.nx + i;
      ASSERT_EQ(ix.start[b + 1] - ix.start[b], 2u);
      const auto z = [&](int a, int c) {
        return g.elevation_m[static_cast<std::size_t>(c) * 30 + a] - oz;
      };
      const double zmax = std::max({z(i, j), z(i + 1, j), z(i, j + 1), z(i + 1, j + 1)});
      EXPECT_GE(static_cast<double>(ix.max_z[b]), zmax);         // an upper bound...
      EXPECT_LE(static_cast<double>(ix.max_z[b]), zmax + 1e-5);  // ...and a tight one
    }
  }
  check_random_segments(*s, 12, 800);
}

TEST(TerrainIndex, MeshTraversalMatchesBruteForce) {
  SiteSpec spec = plane_site();
  spec.terrain.geometry = jittered_mesh(9, 25, 8.0);
  const auto s = Site::build(spec);
  const TerrainIndex2D& ix = s->terrain_index();
  const double occupancy = detail::mean_bucket_occupancy(ix);
  std::cout << "mesh index: " << ix.nx << " x " << ix.ny << " buckets of " << ix.cell.x()
            << " m for " << s->terrain_triangle_count() << " triangles; mean " << occupancy
            << " triangles per non-empty bucket\n";
  EXPECT_LT(occupancy, 4.0);
  EXPECT_GT(occupancy, 1.0);
  // max_z bounds every listed triangle.
  for (std::size_t b = 0; b + 1 < ix.start.size(); ++b)
    for (std::uint32_t k = ix.start[b]; k < ix.start[b + 1]; ++k)
      for (const auto v : s->terrain_triangles()[ix.triangles[k]])
        ASSERT_LE(s->terrain_vertices()[v].z(), static_cast<double>(ix.max_z[b]));
  check_random_segments(*s, 13, 800);
}

// The clearance walk and the culled candidate walk (the flight's terrain-query and PTN skips):
// random 3-D segments over a bumpy grid and a mesh, at heights from below the terrain to above it.
//   - clearance is a lower bound of the segment's height above the terrain at every point over it
//     (sampled at 200 points), so a segment with clearance > 0 meets no terrain;
//   - with `enough`, the walk stops at a value <= enough, or returns the full walk's value;
//   - for_each_candidate_below(H) reports every triangle whose prism (0..H above it) the segment
//     enters: checked against a brute-force scan of all triangles at the sampled points.
void check_clearance(const Site& s, std::uint64_t seed, int count, double h) {
  const Box3& box = s.terrain_bounds();
  const TerrainIndex2D& ix = s.terrain_index();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-0.1, 1.1), zu(-3, 25);
  const Vec3 size = box.hi - box.lo;
  const auto point = [&] {
    return Vec3(box.lo.x() + u(rng) * size.x(), box.lo.y() + u(rng) * size.y(),
                box.lo.z() + zu(rng) * std::max(1.0, size.z()) / 10);
  };
  int culled_some = 0, clear_some = 0;
  for (int k = 0; k < count; ++k) {
    const Vec3 a = point();
    const Vec3 b = (k % 3 == 0) ? Vec3(a + 0.05 * (point() - a)) : point();  // short chords too
    const double c = ix.clearance(a, b);
    const double stop = ix.clearance(a, b, 0.5);
    EXPECT_TRUE(stop == c || stop <= 0.5) << stop << " vs " << c;
    std::set<std::uint32_t> below, all;
    ix.for_each_candidate_below(a, b, h, [&](std::uint32_t t) { below.insert(t); });
    ix.for_each_candidate(a.head<2>(), b.head<2>(), [&](std::uint32_t t) { all.insert(t); });
    if (below.size() < all.size()) ++culled_some;
    if (c > 0) ++clear_some;
    for (int q = 0; q <= 200; ++q) {
      const Vec3 x = a + (b - a) * (q / 200.0);
      const std::int64_t t = s.terrain_triangle_at(x.x(), x.y());
      if (t < 0) continue;
      const double above = x.z() - s.terrain_height(x.x(), x.y());
      ASSERT_LE(c, above + 1e-9) << "clearance above the segment's height at " << x.transpose();
      // Inside the prism of the triangle under x: it must be among the reported candidates.
      if (above >= 0 && above <= h) {
        ASSERT_TRUE(below.count(static_cast<std::uint32_t>(t)))
            << "triangle " << t << " under " << x.transpose() << " (" << above << " m up) culled";
      }
    }
  }
  // The cases are not vacuous: some segments are clear, and some walks skip buckets.
  EXPECT_GT(clear_some, count / 10);
  EXPECT_GT(culled_some, count / 10);
}

TEST(TerrainIndex, ClearanceBoundsTheHeightAndTheCullKeepsEveryPrism) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> zd(0, 12);
  const auto g = make_grid(1000.3, -200.7, 4.0, 30, 20, [&](double, double) { return zd(rng); });
  check_clearance(*Site::build(grid_site(g)), 31, 600, 2.0);
  SiteSpec spec = plane_site();
  spec.terrain.geometry = jittered_mesh(9, 25, 8.0);
  check_clearance(*Site::build(spec), 32, 600, 2.0);
  check_clearance(*Site::build(plane_site({0, 0, 100, 100}, 10, 3)), 33, 300, 2.0);
}

TEST(TerrainIndex, DegenerateInputsVisitNothingOrOneBucket) {
  const auto s = Site::build(plane_site({0, 0, 100, 100}, 10, 0));
  const auto count = [&](const Vec2& a, const Vec2& b) {
    int n = 0;
    s->terrain_index().for_each_candidate(a, b, [&](std::uint32_t) { ++n; });
    return n;
  };
  const double nan = std::nan("");
  EXPECT_EQ(count(Vec2(nan, 0), Vec2(10, 10)), 0);
  EXPECT_EQ(count(Vec2(0, 0), Vec2(std::numeric_limits<double>::infinity(), 10)), 0);
  EXPECT_EQ(count(Vec2(-60, -60), Vec2(-70, -20)), 0);  // entirely outside
  EXPECT_EQ(count(Vec2(1, 1), Vec2(1, 1)), 2);          // a point: one bucket, two triangles
  // A long diagonal through every bucket corner visits exactly the diagonal cells plus at most
  // one neighbour per corner.
  const int n = count(Vec2(-50, -50), Vec2(150, 150));
  EXPECT_GE(n, 2 * 10);
  EXPECT_LE(n, 2 * 21);
}

}  // namespace
}  // namespace fragsim::scene
