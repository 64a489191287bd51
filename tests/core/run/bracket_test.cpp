// settings.ground_bracket (core/run/bracket.h): the study again at each end of each uncertain
// ground constant's range, one at a time, same seed.
#include "core/run/bracket.h"

#include <gtest/gtest.h>

#include <atomic>

#include "core/common/error.h"
#include "core/run/run.h"
#include "run_fixtures.h"

namespace fragsim::run {
namespace {

// The mixed case (two groups, two buildings, fragments at 400 m/s grazing the ground) with
// bounce, soil with a fast-contact law and a friction range, and a bracket at a quarter of the
// samples.
Scenario bracket_scenario() {
  Scenario sc = testing::mixed_scenario(401, 199);
  sc.settings.bounce = true;
  sc.settings.record_fragments = false;
  scene::MaterialSpec& soil = sc.site.materials.at("soil");
  soil.fast_contact = scene::FastContactSpec{};
  soil.ranges["friction"] = {0.4, 0.8};
  sc.settings.ground_bracket = GroundBracketSettings{0.5};
  return sc;
}

TEST(GroundBracket, NeedsBounceAndRanges) {
  Scenario sc = bracket_scenario();
  sc.settings.bounce = false;
  EXPECT_THROW(check_ground_bracket(sc), InputError);
  sc = bracket_scenario();
  scene::MaterialSpec& soil = sc.site.materials.at("soil");
  soil.fast_contact.reset();
  soil.ranges.clear();
  EXPECT_THROW(check_ground_bracket(sc), InputError);
  soil.ranges["restitution"] = {0.1, 0.3};
  EXPECT_NO_THROW(check_ground_bracket(sc));
}

TEST(GroundBracket, RunsEveryRangeAtBothEndsWidestSwingFirst) {
  const Scenario sc = bracket_scenario();
  const auto b = run_ground_bracket(sc);
  ASSERT_TRUE(b);
  EXPECT_FALSE(b->cancelled);
  EXPECT_EQ(b->material, "soil");
  EXPECT_EQ(b->histories_per_run, 201 + 100);  // 401 x 0.5 and 199 x 0.5, rounded
  // friction, and fast_contact's five constants at their documented ranges.
  ASSERT_EQ(b->rows.size(), 6u);
  for (std::size_t k = 1; k < b->rows.size(); ++k) {
    const auto swing = [](const BracketRow& r) { return std::abs(r.high.hfd_m - r.low.hfd_m); };
    EXPECT_GE(swing(b->rows[k - 1]), swing(b->rows[k]));
  }
  for (const BracketRow& r : b->rows) {
    const auto range = scene::effective_ranges(sc.site.materials.at("soil")).at(r.constant);
    EXPECT_EQ(r.low.value, range[0]) << r.constant;
    EXPECT_EQ(r.high.value, range[1]) << r.constant;
  }
}

// Common random numbers: a range that is the nominal value itself reproduces the nominal run
// bit for bit, so every row's difference is the constant's doing, not sampling noise.
TEST(GroundBracket, AnEndAtTheNominalValueReproducesTheNominalRun) {
  Scenario sc = bracket_scenario();
  scene::MaterialSpec& soil = sc.site.materials.at("soil");
  soil.ranges["roughness_deg"] = {2.0, 2.0};  // the nominal
  const auto b = run_ground_bracket(sc);
  ASSERT_TRUE(b);
  const auto row = std::find_if(b->rows.begin(), b->rows.end(),
                                [](const BracketRow& r) { return r.constant == "roughness_deg"; });
  ASSERT_NE(row, b->rows.end());
  for (const BracketFigures* f : {&row->low, &row->high}) {
    EXPECT_EQ(f->hfd_m, b->nominal.hfd_m);
    EXPECT_EQ(f->building_impacts, b->nominal.building_impacts);
    EXPECT_EQ(f->building_penetrations, b->nominal.building_penetrations);
  }
  // The constants the fan of grazing fragments is sensitive to move something.
  bool moved = false;
  for (const BracketRow& r : b->rows)
    moved = moved || r.low.building_impacts != r.high.building_impacts;
  EXPECT_TRUE(moved);
}

// The study's own figures are those of a run without the bracket; the bracket rides along.
TEST(GroundBracket, LeavesTheStudysFiguresAlone) {
  Scenario with = bracket_scenario();
  Scenario without = with;
  without.settings.ground_bracket.reset();
  const RunResult a = run(with);
  const RunResult b = run(without);
  ASSERT_TRUE(a.ground_bracket);
  EXPECT_FALSE(b.ground_bracket);
  EXPECT_EQ(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m);
  EXPECT_EQ(a.ptn_density_per_m2, b.ptn_density_per_m2);
}

TEST(GroundBracket, ACancelledBracketSaysSo) {
  const Scenario sc = bracket_scenario();
  std::atomic<bool> cancel{true};
  RunControl control;
  control.cancel = &cancel;
  const auto b = run_ground_bracket(sc, control);
  ASSERT_TRUE(b);
  EXPECT_TRUE(b->cancelled);
}

}  // namespace
}  // namespace fragsim::run
