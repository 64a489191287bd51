#include "core/impact/contacts.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace fragsim::impact {
namespace {

// For a parabola (vacuum flight) the sagitta of a chord of duration dt at the apex is
// g dt^2 / 8, and the curvature there is the largest on the path (g / vx^2): chord_count with that
// curvature must keep every chord's sagitta under the tolerance, without wasting chords.
TEST(ChordCount, SagittaOfEachChordStaysBelowTolerance) {
  const double g = 9.81, vx = 100.0;
  const Vec3 a(0, 0, -g);
  for (double T : {0.5, 2.0, 10.0}) {
    for (double tol : {0.01, 0.05, 1.0}) {
      const double kappa = path_curvature(Vec3(vx, 0, 0), a);  // apex, mid-step
      EXPECT_NEAR(kappa, g / (vx * vx), 1e-15);
      const double length = vx * T;  // horizontal extent; the arc is longer by < 1%
      const int n = chord_count(length, kappa, tol);
      const double dt = T / n;
      EXPECT_LE(g * dt * dt / 8.0, tol * (1 + 1e-12)) << "T=" << T << " tol=" << tol;
      if (n > 1) {  // one chord fewer would break the tolerance
        const double dt1 = T / (n - 1);
        EXPECT_GT(g * dt1 * dt1 / 8.0, tol) << "T=" << T << " tol=" << tol;
      }
    }
  }
}

TEST(ChordCount, StraightPathNeedsOneChordAndZeroSpeedIsCapped) {
  EXPECT_EQ(chord_count(100.0, path_curvature(Vec3(1, 0, 0), Vec3(0, 0, 0)), 0.05), 1);
  EXPECT_EQ(chord_count(1.0, path_curvature(Vec3(0, 0, 0), Vec3(0, 0, -9.8)), 0.05, 64), 64);
}

// chord_deviation_bound: a circular arc of radius R strays from its chord by its sagitta
// R - sqrt(R^2 - L^2/4). The bound must hold for every arc with up to 4x the curvature it is given
// (a peak between the caller's samples) up to kappa L = 1/4, and give up (+inf) beyond.
TEST(ChordDeviationBound, CoversArcsWithFourTimesTheGivenCurvature) {
  for (double kl : {1e-6, 1e-3, 0.1, 0.2, 0.25}) {
    for (double length : {0.01, 1.0, 300.0}) {
      const double kappa = kl / length;
      const double bound = chord_deviation_bound(length, kappa);
      const double r = 1.0 / (4.0 * kappa);  // the true curvature 4x the one given
      const double sagitta = r - std::sqrt(r * r - 0.25 * length * length);
      EXPECT_LE(sagitta, bound) << "kappa L = " << kl << ", L = " << length;
      // Not loose beyond its factors: 8 times the plain sagitta kappa L^2 / 8.
      EXPECT_LE(bound, 8.0 * kappa * length * length / 8.0 * (1 + 1e-15));
    }
  }
  EXPECT_TRUE(std::isinf(chord_deviation_bound(1.0, 0.26)));  // kappa L = 0.26
  EXPECT_TRUE(std::isinf(chord_deviation_bound(1.0, std::numeric_limits<double>::infinity())));
  EXPECT_TRUE(std::isinf(chord_deviation_bound(1.0, std::nan(""))));
  EXPECT_EQ(chord_deviation_bound(5.0, 0.0), 0.0);  // a straight path
}

TEST(RefinePlaneCrossing, FindsTheCrossingOfAParabolaToMachinePrecision) {
  // z(t) = 10 + 20 t - 4.9 t^2 crosses z = 0 at t = (20 + sqrt(400 + 196)) / 9.8.
  auto pos = [](double t) { return Vec3(30 * t, 0, 10 + 20 * t - 4.9 * t * t); };
  const double exact = (20.0 + std::sqrt(400.0 + 196.0)) / 9.8;
  const double t = refine_plane_crossing(pos, Vec3(0, 0, 1), Vec3(0, 0, 0), 3.0, 6.0);
  EXPECT_NEAR(t, exact, 1e-12);
  // Slanted plane through (50, 0, 0) with normal (1, 0, 1)/sqrt 2: x - 50 + z = 0.
  const double t2 =
      refine_plane_crossing(pos, Vec3(1, 0, 1).normalized(), Vec3(50, 0, 0), 0.0, 6.0);
  EXPECT_NEAR(pos(t2).x() - 50 + pos(t2).z(), 0.0, 1e-9);
  // No sign change -> NaN.
  EXPECT_TRUE(std::isnan(refine_plane_crossing(pos, Vec3(0, 0, 1), Vec3(0, 0, -100), 0.0, 1.0)));
}

TEST(ImpactAngle, GrazingAndHeadOn) {
  EXPECT_NEAR(impact_angle_deg(Vec3(1, 0, 0), Vec3(0, 0, 1)), 0.0, 1e-12);
  EXPECT_NEAR(impact_angle_deg(Vec3(0, 0, -3), Vec3(0, 0, 1)), 90.0, 1e-12);
  EXPECT_NEAR(impact_angle_deg(Vec3(1, 0, -1), Vec3(0, 0, 1)), 45.0, 1e-12);
  EXPECT_EQ(impact_angle_deg(Vec3(0, 0, 0), Vec3(0, 0, 1)), 0.0);
}

}  // namespace
}  // namespace fragsim::impact
