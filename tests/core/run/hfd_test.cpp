// The HFD and where the terrain's boundary cuts it (core/run/hfd.h; issue 22): on given density
// fields the sectors flagged are exactly those with a boundary triangle at or above the
// threshold; in a whole run, a fan of fragments that leaves a small plane through its +x side
// flags the sectors on that side and no other, and on a plane large enough nothing is flagged
// while the densities of the triangles the two planes share are the same.
#include "core/run/hfd.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

constexpr double kThreshold = 1.0 / 55.74;

// Triangle 2k or 2k + 1 of cell (i, j) of a plane of n x n cells (terrain_builder.cpp's layout).
std::uint32_t cell_triangle(int n, int i, int j, int which) {
  return static_cast<std::uint32_t>(2 * (j * n + i) + which);
}

std::shared_ptr<const scene::Site> plane_site(double half_m, double cell_m) {
  return scene::Site::build(validation::flat_site_scenario(half_m, cell_m).site);
}

TEST(HfdSector, AzimuthsFromEastTowardNorthInTenDegreeSectors) {
  EXPECT_EQ(hfd_sector(1.0, 0.0), 0);
  EXPECT_EQ(hfd_sector(1.0, 0.17), 0);   // 9.6 deg
  EXPECT_EQ(hfd_sector(1.0, 0.18), 1);   // 10.2 deg
  EXPECT_EQ(hfd_sector(0.0, 1.0), 9);    // north
  EXPECT_EQ(hfd_sector(-1.0, 0.0), 18);  // west
  EXPECT_EQ(hfd_sector(0.0, -1.0), 27);  // south
  EXPECT_EQ(hfd_sector(1.0, -1e-9), 35);
  EXPECT_EQ(hfd_sector(0.0, 0.0), 0);  // the origin itself
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(hfd_sector(nan, 1.0), 0);  // never a cast of NaN to int
}

// A 200 m plane of 10 m cells (20 x 20), the HFD measured from its centre.
class HfdGeometryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    site_ = plane_site(100.0, 10.0);
    density_.assign(site_->terrain_triangle_count(), 0.0);
  }
  HfdGeometry geometry() const { return HfdGeometry(*site_, Vec3(0, 0, 0)); }
  std::shared_ptr<const scene::Site> site_;
  std::vector<double> density_;
};

TEST_F(HfdGeometryTest, NothingHazardousCutsNothing) {
  const HfdGeometry g = geometry();
  EXPECT_EQ(g.hfd(density_, kThreshold), 0.0);
  EXPECT_FALSE(g.cut(density_, kThreshold).any());
  EXPECT_EQ(g.max_boundary_density(density_), 0.0);
}

TEST_F(HfdGeometryTest, AHazardousBoundaryTriangleCutsItsSectorOnly) {
  // Cell (19, 10): the +x edge, just north of the x axis (centroids at azimuth ~3-6 deg).
  const std::uint32_t t = cell_triangle(20, 19, 10, 0);
  density_[t] = 2.0 * kThreshold;
  const HfdGeometry g = geometry();
  const BoundaryCut cut = g.cut(density_, kThreshold);
  EXPECT_EQ(cut.sector_count, 1);
  EXPECT_TRUE(cut.sectors[0]);
  for (int k = 1; k < kHfdSectors; ++k) EXPECT_FALSE(cut.sectors[k]) << k;
  const Vec3 c = site_->terrain_triangle_centroid(t);
  SectorFigures by_sector{};
  EXPECT_EQ(g.hfd(density_, kThreshold, &by_sector), std::hypot(c.x(), c.y()));
  EXPECT_EQ(by_sector[0], std::hypot(c.x(), c.y()));
  EXPECT_EQ(g.max_boundary_density(density_), 2.0 * kThreshold);
}

TEST_F(HfdGeometryTest, TheThresholdItselfCutsJustBelowItDoesNot) {
  const std::uint32_t corner = cell_triangle(20, 19, 19, 1);  // north-east corner cell: 45 deg
  density_[corner] = kThreshold;
  EXPECT_TRUE(geometry().cut(density_, kThreshold).sectors[4]);
  density_[corner] = std::nextafter(kThreshold, 0.0);
  EXPECT_FALSE(geometry().cut(density_, kThreshold).any());
  EXPECT_EQ(geometry().max_boundary_density(density_), std::nextafter(kThreshold, 0.0));
}

TEST_F(HfdGeometryTest, InteriorTrianglesAndNonNumbersNeverCut) {
  density_[cell_triangle(20, 18, 10, 0)] = 100.0;  // one cell in from the +x edge
  density_[cell_triangle(20, 0, 10, 1)] = std::numeric_limits<double>::quiet_NaN();  // -x edge
  const HfdGeometry g = geometry();
  EXPECT_FALSE(g.cut(density_, kThreshold).any());
  EXPECT_GT(g.hfd(density_, kThreshold), 80.0);
}

TEST(HfdCut, AFanLeavingASmallPlaneFlagsTheSectorsOnItsSideOnly) {
  const Scenario small = validation::fan_scenario(200.0, 2000);
  const RunResult r = run::run(small);
  const SiteBoundary& b = r.site_boundary;
  EXPECT_TRUE(b.hfd_cut);
  EXPECT_GE(b.hfd_sectors_cut, 2);
  for (int k = 0; k < kHfdSectors; ++k) {
    // The fan spans azimuth -20 ... 20 deg (sectors 34, 35, 0, 1); a boundary triangle it
    // crosses at its edge may have its centroid in the next sector (10 m cells at 200 m span
    // ~3 deg), so sectors 2 and 33 may be cut too, no other.
    const bool fan_side = k <= 2 || k >= 33;
    if (!fan_side) {
      EXPECT_FALSE(b.hfd_sector_cut[k]) << "sector " << k;
    }
  }
  EXPECT_TRUE(b.hfd_sector_cut[0] || b.hfd_sector_cut[35]);
  EXPECT_GT(b.max_boundary_density_per_m2, kThreshold);
  // The fragments that flew on past x = 200 m left the site while hazardous (60 m/s, 0.1 kg:
  // 180 J at launch), through the +x side: sectors 34, 35, 0, 1 (the corners are at 45 deg).
  EXPECT_GT(b.left_hazardous_histories, 0);
  EXPECT_GT(b.left_hazardous.mean, 0.0);
  double in_fan = 0.0, total = 0.0;
  for (int k = 0; k < kHfdSectors; ++k) {
    total += b.left_hazardous_by_sector[k].mean;
    if (k <= 1 || k >= 34) in_fan += b.left_hazardous_by_sector[k].mean;
  }
  EXPECT_DOUBLE_EQ(in_fan, total);
  EXPECT_NEAR(total, b.left_hazardous.mean, 1e-9 * b.left_hazardous.mean);
  EXPECT_LE(b.left_hazardous_histories,
            r.outcome_histories[static_cast<std::size_t>(Outcome::kLeftSite)]);
  // The band's upper end (mean + se) reaches the boundary wherever the mean does.
  EXPECT_TRUE(b.band_upper_cut);

  // On a 1.2 km plane about the same origin nothing leaves and nothing is cut; the triangles the
  // two planes share (the same cells, to the bit) carry the same densities.
  const RunResult big = run::run(validation::fan_scenario(600.0, 2000));
  EXPECT_FALSE(big.site_boundary.hfd_cut);
  EXPECT_FALSE(big.site_boundary.band_lower_cut);
  EXPECT_FALSE(big.site_boundary.band_upper_cut);
  EXPECT_EQ(big.site_boundary.hfd_sectors_cut, 0);
  EXPECT_EQ(big.site_boundary.left_hazardous_histories, 0);
  EXPECT_GT(big.hazardous_fragment_distance_m, 200.0) << "the HFD was cut on the small plane";
  for (int j = 0; j < 40; ++j) {
    for (int i = 0; i < 40; ++i) {
      for (int w = 0; w < 2; ++w) {
        const std::uint32_t ts = cell_triangle(40, i, j, w),
                            tb = cell_triangle(120, i + 40, j + 40, w);
        ASSERT_EQ(r.ptn_density_per_m2[ts], big.ptn_density_per_m2[tb]) << i << ", " << j;
      }
    }
  }
  // A sector the small plane did not cut has the same HFD on both, unless fragments crossed its
  // boundary above person height while hazardous (no density on its boundary triangles, ground
  // beyond it that the small plane does not model): then it reports them.
  for (int k = 0; k < kHfdSectors; ++k) {
    if (b.hfd_sector_cut[k] || r.hfd_by_sector_m[k] == big.hfd_by_sector_m[k]) continue;
    EXPECT_GT(b.left_hazardous_by_sector[k].mean, 0.0) << "sector " << k;
  }
}

}  // namespace
}  // namespace fragsim::run
