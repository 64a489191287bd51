// The chi-square machinery the sampler tests rely on, checked against closed forms and
// high-precision reference values (mpmath 1.3, gammainc(a, x, regularized=True), 30 digits).
#include "tests/core/fragments/chi_square.h"

#include <gtest/gtest.h>

#include <cmath>

namespace fragsim::fragments::testing {
namespace {

// Relative tolerance 1e-13 in these checks: the series / continued fraction stop at 1e-16 per
// term and the prefactor exp(a ln x - x - lgamma a) loses a few ulps times |a ln x - x| (<= 400).
TEST(GammaQ, ClosedForms) {
  for (double x : {0.01, 0.5, 1.0, 3.0, 10.0, 50.0}) {
    // Q(1, x) = e^-x  (chi-square with 2 degrees of freedom)
    EXPECT_NEAR(gamma_q(1.0, x), std::exp(-x), 1e-13 * std::exp(-x)) << x;
    // Q(2, x) = e^-x (1 + x)  (4 dof)
    EXPECT_NEAR(gamma_q(2.0, x), std::exp(-x) * (1 + x), 1e-13 * std::exp(-x) * (1 + x)) << x;
    // Q(1/2, x) = erfc(sqrt x)  (1 dof)
    const double q_half = std::erfc(std::sqrt(x));
    EXPECT_NEAR(gamma_q(0.5, x), q_half, 1e-13 * q_half) << x;
  }
}

TEST(GammaQ, ReferenceValues) {
  struct Case {
    double a, x, q;
  };
  const Case cases[] = {
      {50.0, 49.5, 0.50947219879837412664},      {49.5, 70.0, 0.0042282987698192479487},
      {49.5, 30.0, 0.99931999704984857623},      {4.5, 20.0, 7.5985252294642759823e-6},
      {49.5, 400.0, 3.9827511483360355706e-110}, {0.5, 1e-3, 0.96432940827032011458},
  };
  for (const auto& c : cases) {
    EXPECT_NEAR(gamma_q(c.a, c.x), c.q, 1e-12 * c.q) << "a=" << c.a << " x=" << c.x;
  }
}

TEST(ChiSquare, PerfectCountsGivePOne) {
  const std::vector<std::int64_t> counts(50, 1000);
  const auto r = equal_probability_test(counts);
  EXPECT_EQ(r.statistic, 0.0);
  EXPECT_EQ(r.dof, 49);
  EXPECT_NEAR(r.p_value, 1.0, 1e-15);
}

TEST(ChiSquare, LopsidedCountsGiveTinyP) {
  std::vector<std::int64_t> counts(50, 1000);
  counts[0] += 300;  // a 9.5-sigma excess in one bin
  counts[1] -= 300;
  const auto r = equal_probability_test(counts);
  EXPECT_NEAR(r.statistic, 180.0, 1e-9);
  EXPECT_LT(r.p_value, 1e-15);
}

}  // namespace
}  // namespace fragsim::fragments::testing
