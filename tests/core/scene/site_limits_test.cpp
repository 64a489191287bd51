// Site limits (core/scene/site_limits.h) and the build's robustness against extreme but finite
// coordinates (issue 10, found by fuzzing): no hang, no out-of-range double -> int conversion,
// no NaN geometry.
#include "core/scene/site_limits.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <set>

#include "core/scene/terrain_index.h"
#include "scene_test_util.h"

namespace fragsim::scene {
namespace {

using testing::box_building;
using testing::expect_input_error;
using testing::grid_site;
using testing::make_grid;
using testing::plane_site;

SiteSpec mesh_site(MeshSpec mesh) {
  SiteSpec s = plane_site();
  s.terrain.geometry = std::move(mesh);
  return s;
}

MeshSpec triangle_at(double r) {
  MeshSpec m;
  m.vertices_m = {Vec3(-r, -r, 0), Vec3(r, -r, 0), Vec3(0, r, 0)};
  m.triangles = {{0, 1, 2}};
  return m;
}

TEST(SiteLimits, MeshVerticesNearTheLargestDoublesAreRefusedNotIndexed) {
  // Used to spin forever sizing the bucket index of a 3.6e308 m wide terrain.
  expect_input_error(mesh_site(triangle_at(1e308)), "site.terrain.mesh.vertices_m[0][0]",
                     "must be in [-1e+08, 1e+08] (got -1e+308)");
  MeshSpec high = triangle_at(100);
  high.vertices_m[2].z() = 2e5;
  expect_input_error(mesh_site(high), "site.terrain.mesh.vertices_m[2][2]",
                     "must be in [-1e+05, 1e+05] (got 2e+05)");
}

TEST(SiteLimits, MeshIndexOfAnOverflowingExtentThrowsInsteadOfSpinning) {
  // Called directly (Site::build refuses such a terrain first): the extent overflows to inf.
  const MeshSpec m = triangle_at(1e308);
  const std::vector<std::array<std::uint32_t, 3>> tris = {{0, 1, 2}};
  EXPECT_THROW(detail::make_mesh_index(m.vertices_m, tris), std::length_error);
}

TEST(SiteLimits, PlaneExtentNearTheLargestDoublesIsRefused) {
  // Its centre overflowed (1e308 + 1.7e308) and the site was built with NaN vertices.
  expect_input_error(plane_site({1e308, 0, 1.7e308, 10}, 1e307), "site.terrain.plane.extent_m[0]",
                     "must be in [-1e+08, 1e+08]");
  expect_input_error(plane_site({-1.5e5, 0, 1.5e5, 10}, 100), "site.terrain.plane.extent_m",
                     "spans 3e+05 m in x; a terrain may span at most 2e+05 m");
}

TEST(SiteLimits, TerrainExtentAndCountsAreBounded) {
  MeshSpec wide = triangle_at(100);
  wide.vertices_m[1].x() = 2.5e5;
  expect_input_error(
      mesh_site(wide), "site.terrain.mesh.vertices_m[1]",
      "spans 250100 m in x; a terrain may span at most 2e+05 m (from vertices_m[0])");
  expect_input_error(grid_site(make_grid(0, 0, 1e5, 4, 2, [](double, double) { return 0.0; })),
                     "site.terrain.grid.spacing_m", "spans 3e+05 m in x");
  SiteSpec many = plane_site();
  many.buildings.assign(kMaxBuildings + 1, box_building("b", 60, -10, 80, 10, 6));
  expect_input_error(many, "site.buildings", "has 100001 buildings; at most 100000");
  SiteSpec jagged = plane_site();
  BuildingSpec b = box_building("b", 60, -10, 80, 10, 6);
  b.footprint_m.clear();
  for (int k = 0; k <= 1000; ++k) {
    const double a = 2 * M_PI * k / 1001;
    b.footprint_m.push_back({70 + 5 * std::cos(a), 5 * std::sin(a)});
  }
  jagged.buildings = {b};
  expect_input_error(jagged, "site.buildings[0].footprint_m", "has 1001 vertices; at most 1000");
  SiteSpec tall = plane_site();
  tall.buildings = {box_building("b", 60, -10, 80, 10, 2e4)};
  expect_input_error(tall, "site.buildings[0].height_m", "must be <= 10000 (got 20000)");
  SiteSpec far = plane_site();
  far.buildings = {box_building("b", 60, -10, 1e307, 10, 6)};
  expect_input_error(far, "site.buildings[0].footprint_m[1][0]", "must be in [-1e+08, 1e+08]");
}

TEST(SiteLimits, UtmCoordinatesStayAccepted) {
  // UTM zone 11N near the demo site, and a southern-hemisphere northing near 1e7 m.
  EXPECT_NO_THROW(Site::build(grid_site(
      make_grid(452300, 3839800, 10, 101, 101, [](double x, double) { return 400 + 0.01 * x; }))));
  SiteSpec south = plane_site({600000, 9990000, 602000, 9992000}, 20, 1500);
  south.buildings = {box_building("b", 600900, 9990900, 600920, 9990920, 6)};
  const auto s = Site::build(south);
  EXPECT_EQ(s->local_origin(), Vec3(601000, 9991000, 1500));
}

TEST(SiteLimits, ASegmentAcrossTheLargestDoublesVisitsTheBucketsItCrosses) {
  // Ends at +-1.5e308: finite, but their difference overflows; 0 * inf was NaN in the walk.
  const auto s = Site::build(plane_site({0, 0, 40, 10}, 10));  // 4 x 1 cells
  std::set<std::uint32_t> seen;
  s->terrain_index().for_each_candidate(Vec2(-1.5e308, 5), Vec2(1.5e308, 5),
                                        [&](std::uint32_t t) { seen.insert(t); });
  EXPECT_EQ(seen, (std::set<std::uint32_t>{0, 1, 2, 3, 4, 5, 6, 7}));
}

TEST(SiteLimits, AFootprintAroundAFineTerrainFindsItsLowestVertex) {
  // A millimetre mesh (buckets of about 0.5 mm) under a footprint 2e7 m wide: the footprint's
  // bucket range (+-2e10) is beyond int. The conversion used to be undefined (on x86 both ends
  // became bucket 0, and the lowest vertex, in the far corner, was missed).
  MeshSpec m;
  constexpr int n = 4;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) m.vertices_m.emplace_back(1e-3 * i, 1e-3 * j, -1.0 * (i + j));
  for (int j = 0; j + 1 < n; ++j) {
    for (int i = 0; i + 1 < n; ++i) {
      const std::int64_t v = j * n + i;
      m.triangles.push_back({v, v + 1, v + n + 1});
      m.triangles.push_back({v, v + n + 1, v + n});
    }
  }
  SiteSpec spec = mesh_site(m);
  BuildingSpec b = box_building("b", -1e7, -1e7, 1e7, 1e7, 10);
  b.base_elevation_m.reset();  // from the terrain
  spec.buildings = {b};
  const auto s = Site::build(spec);
  EXPECT_EQ(s->to_input(s->buildings()[0].bounds.lo).z(), -6.0);
}

TEST(SiteLimits, BuildingTrianglesCountCourtyardsAsBuilt) {
  // 4 + 498 + 498 vertices and 2 holes: 4 * 1000 + 4 * 2 - 4 = 4004 triangles as built, which
  // is what the limit on the building triangles adds up (counting only the outline, 12).
  BuildingSpec b = box_building("b", -100, -100, 100, 100, 6);
  for (const double cx : {-50.0, 50.0}) {
    std::vector<std::array<double, 2>> round;
    for (int k = 0; k < 498; ++k) {
      const double a = 2 * M_PI * k / 498;
      round.push_back({cx + 30 * std::cos(a), 30 * std::sin(a)});
    }
    b.holes_m.push_back(round);
  }
  SiteSpec one = plane_site();
  one.buildings = {b};
  const std::size_t per = Site::build(one)->buildings()[0].triangle_count;
  ASSERT_EQ(per, 4004u);
  // The first building over 2^24 triangles in all is number 4190 (4191 * 4004 = 16780764).
  const std::size_t over = kMaxBuildingTriangles / per;
  SiteSpec many = plane_site();
  many.buildings.assign(over + 1, b);
  try {
    check_site_limits(many);
    ADD_FAILURE() << "no limit";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "site.buildings[" + std::to_string(over) + "]");
    EXPECT_EQ(e.message(), "brings the building triangles to " + std::to_string((over + 1) * per) +
                               "; at most 16777216 in all");
  }
}

}  // namespace
}  // namespace fragsim::scene
