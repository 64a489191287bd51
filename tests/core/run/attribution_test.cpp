// What sets the HFD (core/run/attribution.h; issue 23): the plan of per-group fields, the
// triangles that set an HFD, and in whole runs: one group without bounce is all direct flight;
// with bounce on a flat plane the ground phase and ricochets appear; the shares at the HFD's
// triangles sum to 1; no mechanism's or group's field alone reaches farther than the whole;
// every bit the same whatever the threads, chunks and shards.
#include "core/run/attribution.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <numeric>

#include "core/run/partial.h"
#include "core/run/run.h"
#include "core/run/run_fixtures.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

constexpr double kThreshold = 1.0 / 55.74;

TEST(GroupFieldsPlan, OneGroupIsTheWholeFieldManyAreOmittedWithTheReason) {
  EXPECT_EQ(plan_group_fields(1, 80000).fields, 0u);
  EXPECT_EQ(plan_group_fields(1, 80000).omitted_reason, "");
  EXPECT_EQ(plan_group_fields(3, 80000).fields, 3u);
  const GroupFieldsPlan many = plan_group_fields(kMaxAttributedGroups + 1, 10);
  EXPECT_EQ(many.fields, 0u);
  EXPECT_NE(many.omitted_reason.find("at most 64 groups"), std::string::npos)
      << many.omitted_reason;
  const GroupFieldsPlan large = plan_group_fields(8, kMaxGroupFieldBins / 4);
  EXPECT_EQ(large.fields, 0u);
  EXPECT_NE(large.omitted_reason.find("bins"), std::string::npos) << large.omitted_reason;
  EXPECT_EQ(plan_group_fields(4, kMaxGroupFieldBins / 4).fields, 4u);  // at the limit: kept
}

TEST(HfdTriangles, TheFarthestHazardousTriangleSetsTheHfdAndEachSectorsOwn) {
  const auto site = scene::Site::build(validation::flat_site_scenario(100.0, 10.0).site);
  std::vector<double> density(site->terrain_triangle_count(), 0.0);
  const HfdGeometry g(*site, Vec3(0, 0, 0));
  HfdTriangles set_by;
  EXPECT_EQ(g.hfd(density, kThreshold, nullptr, &set_by), 0.0);
  EXPECT_EQ(set_by.overall, -1);
  // Two hazardous triangles: the farther sets the HFD; each sets its own sector's.
  const std::uint32_t near = 2 * (10 * 20 + 12), far = 2 * (10 * 20 + 18);  // row 10, +x side
  density[near] = density[far] = 2.0 * kThreshold;
  SectorFigures by_sector{};
  const double hfd = g.hfd(density, kThreshold, &by_sector, &set_by);
  const Vec3 c = site->terrain_triangle_centroid(far);
  EXPECT_EQ(hfd, std::hypot(c.x(), c.y()));
  EXPECT_EQ(set_by.overall, far);
  const int k = hfd_sector(c.x(), c.y());
  EXPECT_EQ(set_by.by_sector[static_cast<std::size_t>(k)], far);
  const HfdFigures f = g.figures(density, std::vector<double>(density.size(), 0.0), kThreshold);
  EXPECT_EQ(f.set_by.overall, far);
}

void expect_shares_sum_to_one(const DensityShares& s, std::size_t groups) {
  if (s.triangle < 0) return;
  EXPECT_NEAR(std::accumulate(s.by_mechanism.begin(), s.by_mechanism.end(), 0.0), 1.0, 1e-12);
  ASSERT_EQ(s.by_group.size(), groups);
  EXPECT_NEAR(std::accumulate(s.by_group.begin(), s.by_group.end(), 0.0), 1.0, 1e-12);
  EXPECT_GE(s.density_per_m2, kThreshold);
}

// No field alone reaches farther than the whole (densities are sums of non-negative parts).
void expect_parts_within_whole(const RunResult& r) {
  const HfdAttribution& a = r.hfd_attribution;
  for (const HfdFigures& f : a.by_mechanism) EXPECT_LE(f.hfd_m, r.hazardous_fragment_distance_m);
  for (const HfdFigures& f : a.by_group) EXPECT_LE(f.hfd_m, r.hazardous_fragment_distance_m);
}

TEST(HfdAttribution, OneGroupWithoutBounceIsAllDirectFlight) {
  Scenario sc = validation::fan_scenario(600.0, 4000);
  const RunResult r = run(sc);
  const HfdAttribution& a = r.hfd_attribution;
  ASSERT_GT(r.hazardous_fragment_distance_m, 0.0);
  ASSERT_GE(a.at_hfd.triangle, 0);
  EXPECT_EQ(a.at_hfd.distance_m, r.hazardous_fragment_distance_m);
  EXPECT_EQ(a.at_hfd.by_mechanism[0], 1.0);
  EXPECT_EQ(a.at_hfd.by_mechanism[1], 0.0);
  EXPECT_EQ(a.at_hfd.by_mechanism[2], 0.0);
  EXPECT_EQ(a.at_hfd.by_group, std::vector<double>{1.0});
  EXPECT_EQ(a.by_mechanism[0].hfd_m, r.hazardous_fragment_distance_m);
  EXPECT_EQ(a.by_mechanism[0].by_sector_m, r.hfd_by_sector_m);
  EXPECT_EQ(a.by_mechanism[1].hfd_m, 0.0);
  EXPECT_EQ(a.by_mechanism[2].hfd_m, 0.0);
  ASSERT_EQ(a.by_group.size(), 1u);
  EXPECT_EQ(a.by_group[0].hfd_m, r.hazardous_fragment_distance_m);
  EXPECT_EQ(a.by_group_omitted_reason, "");
  for (std::size_t k = 0; k < kHfdSectors; ++k) {
    EXPECT_EQ(a.at_sector_hfd[k].distance_m, r.hfd_by_sector_m[k]) << k;
    expect_shares_sum_to_one(a.at_sector_hfd[k], 1);
  }
}

TEST(HfdAttribution, BounceOnAFlatPlaneAddsGroundAndRicochetDensity) {
  Scenario sc = validation::fan_scenario(600.0, 4000);
  sc.settings.bounce = true;
  const RunResult r = run(sc);
  const HfdAttribution& a = r.hfd_attribution;
  ASSERT_GT(r.hazardous_fragment_distance_m, 0.0);
  expect_shares_sum_to_one(a.at_hfd, 1);
  for (const auto& s : a.at_sector_hfd) expect_shares_sum_to_one(s, 1);
  expect_parts_within_whole(r);
  // Fragments landing at up to 60 m/s slide on: the ground phase makes hazardous density of its
  // own (here not as far out as the flights': they lose the hazardous energy within metres).
  EXPECT_GT(a.by_mechanism[2].hfd_m, 0.0);
  EXPECT_GT(a.by_mechanism[2].set_by.overall, -1);
  // Without bounce the same fan has no ground or ricochet density at all.
  sc.settings.bounce = false;
  const RunResult flat = run(sc);
  EXPECT_EQ(flat.hfd_attribution.by_mechanism[1].hfd_m, 0.0);
  EXPECT_EQ(flat.hfd_attribution.by_mechanism[2].hfd_m, 0.0);
}

template <class T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

void expect_same_figures(const HfdFigures& a, const HfdFigures& b) {
  EXPECT_TRUE(same_bits(a.hfd_m, b.hfd_m));
  EXPECT_TRUE(same_bits(a.lower_m, b.lower_m));
  EXPECT_TRUE(same_bits(a.upper_m, b.upper_m));
  EXPECT_TRUE(same_bits(a.by_sector_m, b.by_sector_m));
  EXPECT_EQ(a.set_by.overall, b.set_by.overall);
  EXPECT_EQ(a.cut.sectors, b.cut.sectors);
}

void expect_same_shares(const DensityShares& a, const DensityShares& b) {
  EXPECT_EQ(a.triangle, b.triangle);
  EXPECT_TRUE(same_bits(a.density_per_m2, b.density_per_m2));
  EXPECT_TRUE(same_bits(a.by_mechanism, b.by_mechanism));
  ASSERT_EQ(a.by_group.size(), b.by_group.size());
  for (std::size_t g = 0; g < a.by_group.size(); ++g)
    EXPECT_TRUE(same_bits(a.by_group[g], b.by_group[g]));
}

void expect_same_attribution(const HfdAttribution& a, const HfdAttribution& b) {
  for (int m = 0; m < kPtnMechanismCount; ++m)
    expect_same_figures(a.by_mechanism[static_cast<std::size_t>(m)],
                        b.by_mechanism[static_cast<std::size_t>(m)]);
  ASSERT_EQ(a.by_group.size(), b.by_group.size());
  for (std::size_t g = 0; g < a.by_group.size(); ++g)
    expect_same_figures(a.by_group[g], b.by_group[g]);
  expect_same_shares(a.at_hfd, b.at_hfd);
  for (std::size_t k = 0; k < kHfdSectors; ++k)
    expect_same_shares(a.at_sector_hfd[k], b.at_sector_hfd[k]);
}

TEST(HfdAttribution, TwoGroupsWithBounceSameBitsWhateverThreadsChunksAndShards) {
  Scenario sc = testing::mixed_scenario(1501, 999);
  sc.settings.bounce = true;
  sc.settings.threads = 1;
  sc.settings.chunk_histories = 256;
  const RunResult a = run(sc);
  ASSERT_GT(a.hazardous_fragment_distance_m, 0.0);
  ASSERT_EQ(a.hfd_attribution.by_group.size(), 2u);
  expect_shares_sum_to_one(a.hfd_attribution.at_hfd, 2);
  for (const auto& s : a.hfd_attribution.at_sector_hfd) expect_shares_sum_to_one(s, 2);
  expect_parts_within_whole(a);

  sc.settings.threads = 2;
  sc.settings.chunk_histories = 7;
  expect_same_attribution(a.hfd_attribution, run(sc).hfd_attribution);

  const auto site = scene::Site::build(sc.site);
  PartialRun all = run_partial(sc, site, Shard{2, 3});
  merge(all, run_partial(sc, site, Shard{0, 3}));
  merge(all, run_partial(sc, site, Shard{1, 3}));
  expect_same_attribution(a.hfd_attribution, finish(sc, *site, std::move(all)).hfd_attribution);
}

}  // namespace
}  // namespace fragsim::run
