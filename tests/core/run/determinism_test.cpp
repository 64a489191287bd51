// Same scenario + seed => bit-identical results for any thread count and chunk size.
#include <gtest/gtest.h>

#include <cstring>

#include "core/run/run.h"
#include "core/run/run_fixtures.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run {
namespace {

using testing::mixed_scenario;

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
