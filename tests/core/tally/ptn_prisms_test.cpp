// PTN prism geometry (paper eqs. 38-39) against closed forms.
#include "core/tally/ptn_prisms.h"

#include <gtest/gtest.h>

#include <random>

#include "core/scene/site.h"

namespace fragsim::tally {
namespace {

// One flat triangle (0,0)-(4,0)-(0,3) at z = 2: area 6, edges 4, 3, 5.
std::shared_ptr<const scene::Site> one_triangle_site() {
  scene::SiteSpec s;
  scene::MeshSpec m;
  m.vertices_m = {Vec3(0, 0, 2), Vec3(4, 0, 2), Vec3(0, 3, 2)};
  m.triangles = {{0, 1, 2}};
  s.terrain.geometry = m;
  s.terrain.material = "soil";
  s.materials["soil"] = scene::MaterialSpec{};
  return scene::Site::build(s);
}

TEST(PtnPrisms, VerticalFallSeesTheTriangleArea) {
  auto site = one_triangle_site();
  PtnPrisms p(*site, 1.8);
  // Exact: only the top (or bottom) face faces a vertical path.
  EXPECT_NEAR(p.projected_area(0, Vec3(0, 0, -1)), 6.0, 1e-12);
  EXPECT_NEAR(p.projected_area(0, Vec3(0, 0, 1)), 6.0, 1e-12);
}

TEST(PtnPrisms, HorizontalPathSeesHeightTimesWidth) {
  auto site = one_triangle_site();
  const double h = 1.8;
  PtnPrisms p(*site, h);
  // Along +x the triangle's width across the path is its y-extent, 3 m.
  EXPECT_NEAR(p.projected_area(0, Vec3(1, 0, 0)), h * 3.0, 1e-12);
  EXPECT_NEAR(p.projected_area(0, Vec3(-1, 0, 0)), h * 3.0, 1e-12);
  EXPECT_NEAR(p.projected_area(0, Vec3(0, 1, 0)), h * 4.0, 1e-12);
  // Perpendicular to the hypotenuse (direction (3,4)/5): width = 5 m.
  EXPECT_NEAR(p.projected_area(0, Vec3(0.6, 0.8, 0)), h * 5.0, 1e-12);
}

TEST(PtnPrisms, ProjectedAreaEqualsHalfTheSumOfAbsoluteFaceProjections) {
  // For a closed convex body sum_i A_i max(0, n_i.d) = 1/2 sum_i A_i |n_i.d| (silhouette).
  auto site = one_triangle_site();
  const double h = 1.8;
  PtnPrisms p(*site, h);
  std::mt19937 rng(7);
  std::normal_distribution<double> nd;
  for (int i = 0; i < 200; ++i) {
    Vec3 d(nd(rng), nd(rng), nd(rng));
    d.normalize();
    // Faces: top/bottom area 6 normal z; sides: y=0 (len 4, normal -y), x=0 (len 3, normal -x),
    // hypotenuse (len 5, normal (3,4)/5).
    const double half_abs =
        0.5 * (2 * 6 * std::abs(d.z()) + h * 4 * std::abs(d.y()) + h * 3 * std::abs(d.x()) +
               h * 5 * std::abs(0.6 * d.x() + 0.8 * d.y()));
    EXPECT_NEAR(p.projected_area(0, d), half_abs, 1e-12);
  }
}

TEST(PtnPrisms, ClipKeepsThePartInsideTheBand) {
  auto site = one_triangle_site();
  PtnPrisms p(*site, 1.8);
  // Prisms live in site-local coordinates.
  auto L = [&](double x, double y, double z) { return site->to_local(Vec3(x, y, z)); };
  double s0, s1;
  // Horizontal path at 1 m above the ground (z = 3) along y = 1 from x = -1 to x = 5:
  // the triangle spans x in [0, 4 - 4/3] at y = 1.
  ASSERT_TRUE(p.clip(0, L(-1, 1, 3), L(5, 1, 3), s0, s1));
  EXPECT_NEAR(s0, 1.0 / 6.0, 1e-12);
  EXPECT_NEAR(s1, (1.0 + 4.0 - 4.0 / 3.0) / 6.0, 1e-12);
  // Same path above the band (z = 4 > 2 + 1.8): no crossing.
  EXPECT_FALSE(p.clip(0, L(-1, 1, 4), L(5, 1, 4), s0, s1));
  // Below the ground: no crossing.
  EXPECT_FALSE(p.clip(0, L(-1, 1, 1.5), L(5, 1, 1.5), s0, s1));
  // Vertical fall through the band at (1, 1): from z = 10 to z = 2 -> s in [(10-3.8)/8, 1].
  ASSERT_TRUE(p.clip(0, L(1, 1, 10), L(1, 1, 2), s0, s1));
  EXPECT_NEAR(s0, (10 - 3.8) / 8.0, 1e-12);
  EXPECT_NEAR(s1, 1.0, 1e-12);
  // Vertical fall outside the triangle.
  EXPECT_FALSE(p.clip(0, L(3, 3, 10), L(3, 3, 2), s0, s1));
  EXPECT_NEAR(p.top_z(), L(0, 0, 3.8).z(), 1e-12);
}

}  // namespace
}  // namespace fragsim::tally
