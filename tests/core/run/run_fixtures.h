#pragma once
// A small mixed case for whole-run tests: a flat site with two buildings (penetrable walls), two
// fragment groups (spheres and cuboids, uniform masses, drag), so that PTN densities, the HFD
// and building hits are all non-zero (determinism_test, partial_test).
#include <gtest/gtest.h>

#include <cstring>
#include <vector>

#include "core/run/result.h"
#include "core/run/scenario.h"
#include "validation/scenario_fixtures.h"

namespace fragsim::run::testing {

inline Scenario mixed_scenario(std::int64_t samples1 = 3001, std::int64_t samples2 = 1999) {
  Scenario sc = validation::flat_site_scenario(300.0, 5.0);
  sc.atmosphere.model = flight::AtmosphereSpec::Model::kIsa;
  validation::add_wall_and_roof(sc, 2.0e6);
  sc.site.buildings = {validation::box_building("a", 40, -10, 60, 10, 8.0),
                       validation::box_building("b", -80, 20, -60, 50, 12.0)};
  auto g = validation::mixed_sphere_group(Vec3(0, 0, 1.0), 0.5, 400.0, 500.0, samples1);
  auto g2 = g;
  g2.samples = samples2;
  g2.shape.type = fragments::ShapeType::kCuboid;
  g2.shape.aspect = {1.0, 0.5, 0.2};
  sc.groups = {g, g2};
  sc.settings.record_fragments = true;
  return sc;
}

// Bit-for-bit equality of a value (trivially copyable) or of a vector of them.
template <class T>
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}
template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}

// Every figure of two runs to the bit (density, se, HFDs, buildings, outcomes, records), and
// the same work (integrator steps, scene queries).
inline void expect_same_figures(const RunResult& a, const RunResult& b) {
  EXPECT_TRUE(same_bits(a.ptn_density_per_m2, b.ptn_density_per_m2));
  EXPECT_TRUE(same_bits(a.ptn_std_error_per_m2, b.ptn_std_error_per_m2));
  EXPECT_TRUE(same_bits(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m));
  EXPECT_TRUE(same_bits(a.hfd_lower_m, b.hfd_lower_m));
  EXPECT_TRUE(same_bits(a.hfd_upper_m, b.hfd_upper_m));
  EXPECT_TRUE(same_bits(a.hfd_by_sector_m, b.hfd_by_sector_m));
  ASSERT_EQ(a.buildings.size(), b.buildings.size());
  for (std::size_t i = 0; i < a.buildings.size(); ++i) {
    EXPECT_TRUE(same_bits(a.buildings[i].impacts, b.buildings[i].impacts)) << i;
    EXPECT_TRUE(same_bits(a.buildings[i].penetrations, b.buildings[i].penetrations)) << i;
    EXPECT_TRUE(same_bits(a.buildings[i].impacts_by_surface, b.buildings[i].impacts_by_surface));
    EXPECT_TRUE(same_bits(a.buildings[i].residual_ke_j, b.buildings[i].residual_ke_j));
  }
  EXPECT_TRUE(same_bits(a.outcome_fragments, b.outcome_fragments));
  EXPECT_EQ(a.outcome_histories, b.outcome_histories);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.histories_done, b.histories_done);
  EXPECT_EQ(a.stats.integrator_steps, b.stats.integrator_steps);
  EXPECT_EQ(a.stats.scene_queries, b.stats.scene_queries);
  ASSERT_EQ(a.fragments.size(), b.fragments.size());
  for (std::size_t i = 0; i < a.fragments.size(); ++i) {
    EXPECT_EQ(a.fragments[i].history, b.fragments[i].history);
    EXPECT_TRUE(same_bits(a.fragments[i].end_position_m, b.fragments[i].end_position_m));
  }
  ASSERT_EQ(a.trajectories.size(), b.trajectories.size());
  for (std::size_t i = 0; i < a.trajectories.size(); ++i) {
    EXPECT_EQ(a.trajectories[i].group, b.trajectories[i].group);
    EXPECT_EQ(a.trajectories[i].history, b.trajectories[i].history);
    EXPECT_TRUE(same_bits(a.trajectories[i].t_s, b.trajectories[i].t_s));
  }
}

}  // namespace fragsim::run::testing
