// Same scenario + seed => bit-identical results for any thread count and chunk size.
#include <gtest/gtest.h>

#include <cstring>

#include "core/run/run.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

Scenario mixed_scenario() {
  Scenario sc = validation::flat_site_scenario(300.0, 5.0);
  sc.atmosphere.model = flight::AtmosphereSpec::Model::kIsa;
  scene::MaterialSpec wall;
  wall.penetration_ke_per_area_j_per_m2 = 2.0e6;
  sc.site.materials["wall"] = wall;
  sc.site.materials["roof"] = wall;
  sc.site.buildings = {validation::box_building("a", 40, -10, 60, 10, 8.0),
                       validation::box_building("b", -80, 20, -60, 50, 12.0)};
  auto g = validation::sphere_group(Vec3(0, 0, 1.0), 0.05, 400.0, 500.0, 3001);
  g.mass_kg.kind = fragments::Distribution::Kind::kUniform;
  g.mass_kg.min = 0.01;
  g.mass_kg.max = 0.5;
  g.cd.constant = 0.47;
  g.direction.elevation_min_deg = -5.0;
  g.direction.elevation_max_deg = 40.0;
  auto g2 = g;
  g2.samples = 1999;
  g2.shape.type = fragments::ShapeType::kCuboid;
  g2.shape.aspect = {1.0, 0.5, 0.2};
  sc.groups = {g, g2};
  sc.settings.record_fragments = true;
  return sc;
}

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

TEST(Determinism, ThreadCountAndChunkSizeDoNotChangeAnyBit) {
  Scenario sc = mixed_scenario();
  sc.settings.threads = 1;
  sc.settings.chunk_histories = 256;
  const RunResult a = run(sc);
  sc.settings.threads = 2;
  sc.settings.chunk_histories = 7;
  const RunResult b = run(sc);
  sc.settings.threads = 2;
  sc.settings.chunk_histories = 1000;
  const RunResult c = run(sc);
  ASSERT_GT(a.max_ptn_density_per_m2, 0.0);
  for (const RunResult* x : {&b, &c}) {
    EXPECT_TRUE(same_bits(a.ptn_density_per_m2, x->ptn_density_per_m2));
    EXPECT_TRUE(same_bits(a.ptn_std_error_per_m2, x->ptn_std_error_per_m2));
    ASSERT_EQ(a.buildings.size(), x->buildings.size());
    for (std::size_t i = 0; i < a.buildings.size(); ++i) {
      EXPECT_EQ(std::memcmp(&a.buildings[i].impacts, &x->buildings[i].impacts, sizeof(Estimate)),
                0);
      EXPECT_EQ(std::memcmp(&a.buildings[i].penetrations, &x->buildings[i].penetrations,
                            sizeof(Estimate)),
                0);
    }
    EXPECT_EQ(a.hazardous_fragment_distance_m, x->hazardous_fragment_distance_m);
    ASSERT_EQ(a.fragments.size(), x->fragments.size());
    for (std::size_t i = 0; i < a.fragments.size(); ++i) {
      EXPECT_EQ(a.fragments[i].end_position_m, x->fragments[i].end_position_m);
      EXPECT_EQ(a.fragments[i].end_time_s, x->fragments[i].end_time_s);
    }
  }
  EXPECT_GT(a.buildings[0].impacts.mean + a.buildings[1].impacts.mean, 0.0);
}

TEST(Determinism, CancelReturnsAPartialResultMarkedCancelled) {
  Scenario sc = mixed_scenario();
  std::atomic<bool> cancel{true};
  RunControl control;
  control.cancel = &cancel;
  const RunResult r = run(sc, control);
  EXPECT_TRUE(r.cancelled);
  EXPECT_LT(r.histories_done, r.samples);
}

}  // namespace
}  // namespace fragsim::run
