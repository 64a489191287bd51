// The impact energy audit's trigger (core/run/energy_audit.h): the stress tests assert that it
// never fires over random scenarios, so it must be shown to fire on a rise.
#include "core/run/energy_audit.h"

#include <gtest/gtest.h>

namespace fragsim::run {
namespace {

TEST(EnergyAudit, ARiseIsCounted) {
  // 1 kg at 10 m/s (50 J) leaving at 10.1 m/s (51.005 J), 100 m up (981 J): +1 J of 1032 J.
  const BodyEnergy before{50.0, 980.665};
  EXPECT_TRUE(energy_rose(before, {51.005, 980.665}));
  // Spin turned into more speed than it had: 5 J of spin, 50 J of speed -> 56 J of speed.
  EXPECT_TRUE(energy_rose({55.0, 0.0}, {56.0, 0.0}));
  // A rise of 10^-8 of the energy is beyond rounding (allowance 10^-9).
  EXPECT_TRUE(energy_rose({1000.0, 0.0}, {1000.0 + 1e-5, 0.0}));
}

TEST(EnergyAudit, ALossOrRoundingIsNot) {
  EXPECT_FALSE(energy_rose({50.0, 980.665}, {20.0, 980.665}));  // a dissipative bounce
  EXPECT_FALSE(energy_rose({50.0, 980.665}, {50.0, 980.665}));  // e = 1, mu = 0
  // A few ulps of the terms: a large m g z (z far from the local origin) rounds the total.
  EXPECT_FALSE(energy_rose({50.0, 1e6}, {50.0 + 1e-10, 1e6}));
  EXPECT_FALSE(energy_rose({50.0, -1e6}, {50.0 + 1e-10, -1e6}));
  // At rest at z = 0: only the absolute floor (10^-12 J) applies.
  EXPECT_FALSE(energy_rose({0.0, 0.0}, {1e-13, 0.0}));
  EXPECT_TRUE(energy_rose({0.0, 0.0}, {1e-11, 0.0}));
}

}  // namespace
}  // namespace fragsim::run
