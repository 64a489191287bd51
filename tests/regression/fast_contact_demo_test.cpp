// The demo with bounce on (its soil has a fast_contact law, examples/demo/scenario.json): fast
// fragments meet the soil under the law (stats.fast_contacts > 0), and no ground piece starts
// faster than the switch speed (stats.fast_slides == 0: F6 in core/scene/site_spec.h forbids a
// slide above v_s, and the counter is kept only to catch one).
#include <gtest/gtest.h>

#include "regression/regression.h"

namespace fragsim::regression {
namespace {

// 5 % of the demo's samples (4,000 histories, under a second): thousands of fast contacts,
// so a count of 0 is a failure, not chance. Measured (seed of the file): 3,085 fast contacts, 0
// fast slides, 0.2 s on this machine's threads.
TEST(FastContactDemo, BounceRunHasFastContactsAndNoFastSlides) {
  const Case c{"demo-bounce-5pct", "examples/demo/scenario.json", true, 0.05,
               "settings.bounce = true, samples x 0.05"};
  const CaseRun r = run_case(c);
  std::printf("%lld fast contacts, %lld fast slides, %lld bounces; %.2f s\n",
              static_cast<long long>(r.result.stats.fast_contacts),
              static_cast<long long>(r.result.stats.fast_slides),
              static_cast<long long>(r.result.stats.bounces), r.wall_s);
  EXPECT_GT(r.result.stats.fast_contacts, 1000);
  EXPECT_EQ(r.result.stats.fast_slides, 0);
}

}  // namespace
}  // namespace fragsim::regression
