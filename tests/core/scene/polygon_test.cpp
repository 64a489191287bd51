// Triangulation of polygons with holes (courtyards): hole bridging and ear clipping.
#include "core/scene/polygon.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>

namespace fragsim::scene::detail {
namespace {

using Rings = std::vector<std::vector<Vec2>>;
using Triangles = std::vector<std::array<std::uint32_t, 3>>;

std::vector<Vec2> rect(double x0, double y0, double x1, double y1, bool clockwise) {
  std::vector<Vec2> r = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  if (clockwise) std::reverse(r.begin(), r.end());
  return r;
}

// Star-shaped polygon around (cx, cy): n vertices at jittered angles and radii in
// [0.5 r, r], counter-clockwise or clockwise.
std::vector<Vec2> star(std::mt19937_64& rng, double cx, double cy, double r, int n,
                       bool clockwise) {
  std::uniform_real_distribution<double> rad(0.5, 1.0), jit(-0.4, 0.4);
  std::vector<Vec2> p;
  for (int k = 0; k < n; ++k) {
    const double phi = 2 * kPi * (k + 0.5 + jit(rng)) / n, s = r * rad(rng);
    p.emplace_back(cx + s * std::cos(phi), cy + s * std::sin(phi));
  }
  if (clockwise) std::reverse(p.begin(), p.end());
  return p;
}

// Strictly inside the triangle (a, b, c), counter-clockwise.
bool strictly_inside(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& p) {
  return orient2d(a, b, p) > 0 && orient2d(b, c, p) > 0 && orient2d(c, a, p) > 0;
}

// Checks that `tris` partition the region inside `outer` (counter-clockwise) and outside every
// hole (clockwise): each triangle counter-clockwise and non-degenerate; their areas sum to the
// net area; every boundary edge is used once, in its own direction, and every other edge by two
// triangles in opposite directions (so none overlap and none is missing); random points are
// covered once inside the region and not at all outside it.
void expect_partition(const std::vector<Vec2>& outer, const Rings& holes, const Triangles& tris,
                      const std::string& what) {
  std::vector<Vec2> pts;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> boundary;  // directed edge -> uses
  const auto add_ring = [&](const std::vector<Vec2>& ring) {
    const auto first = static_cast<std::uint32_t>(pts.size());
    pts.insert(pts.end(), ring.begin(), ring.end());
    const auto n = static_cast<std::uint32_t>(ring.size());
    for (std::uint32_t k = 0; k < n; ++k) boundary[{first + k, first + (k + 1) % n}] = 0;
  };
  add_ring(outer);
  double net = signed_area(outer);
  std::size_t vertices = outer.size();
  for (const auto& h : holes) {
    add_ring(h);
    net += signed_area(h);  // negative: clockwise
    vertices += h.size();
  }
  ASSERT_GT(net, 0) << what;
  EXPECT_EQ(tris.size(), vertices + 2 * holes.size() - 2) << what;
  double sum = 0, sum_abs = 0;
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> inner;  // directed edge -> uses
  for (const auto& t : tris) {
    for (const std::uint32_t v : t) ASSERT_LT(v, pts.size()) << what;
    const double a = 0.5 * orient2d(pts[t[0]], pts[t[1]], pts[t[2]]);
    EXPECT_GT(a, 0.0) << what;  // counter-clockwise, non-degenerate
    sum += a;
    sum_abs += std::abs(a);
    for (int k = 0; k < 3; ++k) {
      const std::pair<std::uint32_t, std::uint32_t> e = {t[k], t[(k + 1) % 3]};
      if (const auto it = boundary.find(e); it != boundary.end())
        ++it->second;
      else
        ++inner[e];
    }
  }
  EXPECT_NEAR(sum, net, 1e-9 * net) << what;
  EXPECT_NEAR(sum_abs, net, 1e-9 * net) << what;
  for (const auto& [e, uses] : boundary)
    EXPECT_EQ(uses, 1) << what << ": boundary edge " << e.first << "-" << e.second;
  for (const auto& [e, uses] : inner) {
    EXPECT_EQ(uses, 1) << what << ": edge " << e.first << "-" << e.second;
    const auto back = inner.find({e.second, e.first});
    EXPECT_TRUE(back != inner.end() && back->second == 1)
        << what << ": inner edge " << e.first << "-" << e.second << " has no twin";
  }
  // Coverage of random points of the bounding box.
  Vec2 lo = outer[0], hi = outer[0];
  for (const Vec2& p : outer) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> ux(lo.x(), hi.x()), uy(lo.y(), hi.y());
  for (int s = 0; s < 2000; ++s) {
    const Vec2 p(ux(rng), uy(rng));
    bool in_region = point_in_polygon(outer, p);
    for (const auto& h : holes) in_region = in_region && !point_in_polygon(h, p);
    int covered = 0;
    for (const auto& t : tris) covered += strictly_inside(pts[t[0]], pts[t[1]], pts[t[2]], p);
    ASSERT_EQ(covered, in_region ? 1 : 0) << what << ": point " << p.transpose();
  }
}

TEST(PolygonWithHoles, NoHolesIsPlainEarClipping) {
  const std::vector<Vec2> l = {{0, 0}, {10, 0}, {20, 0}, {20, 5}, {5, 5}, {5, 15}, {0, 15}};
  EXPECT_EQ(triangulate_polygon_with_holes(l, {}), triangulate_polygon(l));
}

TEST(PolygonWithHoles, OneHole) {
  const auto outer = rect(0, 0, 30, 20, false);
  const Rings holes = {rect(10, 5, 20, 15, true)};
  const auto tris = triangulate_polygon_with_holes(outer, holes);
  expect_partition(outer, holes, tris, "one hole");
}

TEST(PolygonWithHoles, TwoHoles) {
  const auto outer = rect(0, 0, 50, 20, false);
  const Rings holes = {rect(5, 5, 15, 15, true), rect(30, 4, 45, 12, true)};
  expect_partition(outer, holes, triangulate_polygon_with_holes(outer, holes), "two holes");
}

TEST(PolygonWithHoles, FiveHolesOfSeveralShapes) {
  std::mt19937_64 rng(5);
  const auto outer = rect(0, 0, 100, 60, false);
  const Rings holes = {rect(5, 5, 20, 20, true),
                       {{40, 10}, {30, 25}, {50, 25}},  // clockwise triangle
                       star(rng, 75, 15, 10, 9, true),
                       rect(10, 35, 45, 50, true),
                       star(rng, 75, 42, 12, 14, true)};
  expect_partition(outer, holes, triangulate_polygon_with_holes(outer, holes), "five holes");
}

TEST(PolygonWithHoles, ConcaveOuter) {
  // A U (comb) with a courtyard in each arm and one in the base; the arms' inner edges are
  // reflex corners the bridges must not cross.
  const std::vector<Vec2> outer = {{0, 0},   {60, 0},  {60, 40}, {45, 40},
                                   {45, 15}, {15, 15}, {15, 40}, {0, 40}};
  const Rings holes = {
      rect(4, 20, 11, 35, true), rect(49, 20, 56, 35, true), {{30, 4}, {20, 8}, {30, 12}, {40, 8}}};
  ASSERT_LT(signed_area(holes[2]), 0);
  expect_partition(outer, holes, triangulate_polygon_with_holes(outer, holes), "concave outer");
}

TEST(PolygonWithHoles, BridgeAvoidsAnotherHole) {
  // Hole A (a tall C opening leftwards) is joined first (largest x). Hole B sits in the C's
  // mouth: the ray from B's rightmost vertex meets A's inner back, and the vertices of A's jaws
  // lie in Eberly's triangle, so the bridge must go to a jaw tip, not straight to the outer ring
  // (which would cross A).
  const auto outer = rect(0, 0, 100, 100, false);
  std::vector<Vec2> c = {{50, 10}, {80, 10}, {80, 90}, {50, 90},
                         {50, 70}, {60, 70}, {60, 30}, {50, 30}};  // counter-clockwise
  std::reverse(c.begin(), c.end());
  const Rings holes = {c, rect(30, 45, 55, 52, true)};
  const auto tris = triangulate_polygon_with_holes(outer, holes);
  expect_partition(outer, holes, tris, "bridge avoids hole");
  // B's rightmost vertex level with the upper jaw's inner edge: the ray meets the jaw's tip, a
  // vertex, exactly.
  const Rings level = {c, rect(30, 40, 45, 70, true)};
  expect_partition(outer, level, triangulate_polygon_with_holes(outer, level), "level");
}

TEST(PolygonWithHoles, AlignedGridOfSquareHoles) {
  // Every hole's rightmost vertices share their x and y with others: rays run along rows of
  // vertices and hit vertices exactly.
  const auto outer = rect(0, 0, 70, 70, false);
  Rings holes;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i)
      holes.push_back(rect(10 + 20 * i, 10 + 20 * j, 20 + 20 * i, 20 + 20 * j, true));
  expect_partition(outer, holes, triangulate_polygon_with_holes(outer, holes), "grid");
}

TEST(PolygonWithHoles, RandomStarsWithStarHoles) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> coin(0, 1), angle(0, 2 * kPi);
  for (int trial = 0; trial < 150; ++trial) {
    // Holes in the cells of a 4 x 4 grid of 20 m cells (some left empty), inside an outer star
    // whose radius (>= 120 m) keeps them strictly inside; all rotated at random.
    Rings holes;
    for (int j = 0; j < 4; ++j)
      for (int i = 0; i < 4; ++i)
        if (coin(rng) < 0.6)
          holes.push_back(star(rng, -30 + 20 * i, -30 + 20 * j, 9, 3 + trial % 9, true));
    std::vector<Vec2> outer;
    for (int k = 0; k < 40; ++k) {
      const double phi = 2 * kPi * (k + 0.3 * (coin(rng) - 0.5)) / 40;
      const double r = 120 + 60 * coin(rng);
      outer.emplace_back(r * std::cos(phi), r * std::sin(phi));
    }
    const double rot = angle(rng);
    const auto turn = [&](std::vector<Vec2>& ring) {
      for (Vec2& p : ring)
        p = Vec2(std::cos(rot) * p.x() - std::sin(rot) * p.y(),
                 std::sin(rot) * p.x() + std::cos(rot) * p.y());
    };
    turn(outer);
    for (auto& h : holes) turn(h);
    const auto tris = triangulate_polygon_with_holes(outer, holes);
    expect_partition(outer, holes, tris, "trial " + std::to_string(trial));
    if (::testing::Test::HasFailure()) break;
  }
}

}  // namespace
}  // namespace fragsim::scene::detail
