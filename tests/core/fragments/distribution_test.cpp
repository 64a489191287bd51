// Distribution sampling (chi-square goodness of fit on Philox streams), truncation, tails and
// validation messages.
#include "core/fragments/distribution.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <string>

#include "core/common/random.h"
#include "core/fragments/sampling.h"
#include "tests/core/fragments/chi_square.h"

namespace fragsim::fragments {
namespace {

using testing::EqualProbabilityBins;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr int kSamples = 100000;
constexpr int kBins = 100;
constexpr std::uint64_t kSeed = 20240611;
// Goodness-of-fit threshold: with a fixed seed the test is deterministic; p > 1e-4 would fail by
// chance once in 10,000 seeds for a correct sampler, while a wrong one gives p < 1e-6 (see
// ChiSquareRejectsWrongSigma).
constexpr double kMinP = 1e-4;

// Reference CDFs written independently of the code under test (std::erfc, not normal_cdf).
double phi_ref(double x) {
  return 0.5 * std::erfc(-x / std::sqrt(2.0));
}
double q_ref(double x) {
  return 0.5 * std::erfc(x / std::sqrt(2.0));
}  // 1 - Phi, no cancellation

Distribution normal(double mean, double sigma) {
  Distribution d;
  d.kind = Distribution::Kind::kNormal;
  d.mean = mean;
  d.sigma = sigma;
  return d;
}
Distribution lognormal(double median, double sigma_ln) {
  Distribution d;
  d.kind = Distribution::Kind::kLognormal;
  d.median = median;
  d.sigma_ln = sigma_ln;
  return d;
}
Distribution mott(double mu) {
  Distribution d;
  d.kind = Distribution::Kind::kMott;
  d.mu = mu;
  return d;
}
// Mott's CDF, F(x) = 1 - exp(-sqrt(x / mu)) (Mott 1947), written out here rather than taken from
// mott_survival.
double mott_cdf_ref(double x, double mu) {
  return x <= 0.0 ? 0.0 : -std::expm1(-std::sqrt(x / mu));
}
Distribution truncated(Distribution d, double lo, double hi) {
  d.has_min = d.has_max = true;
  d.min = lo;
  d.max = hi;
  return d;
}

// Draws kSamples variates of `d` from Philox streams (seed, group, history i, slot kSlotMass)
// and bins them by the reference CDF into kBins equal-probability bins. Each test uses its own
// group number: inversion maps F(sample) back onto u, so tests sharing a stream would share bins.
testing::ChiSquareResult fit(const Distribution& d, double phys_lo, double phys_hi,
                             const std::function<double(double)>& cdf, const char* name,
                             std::uint32_t group) {
  EqualProbabilityBins bins(kBins);
  for (int i = 0; i < kSamples; ++i) {
    const RandomStream rng(kSeed, group, static_cast<std::uint64_t>(i));
    bins.add_cdf(cdf(d.sample(rng.uniform(kSlotMass), phys_lo, phys_hi)));
  }
  const auto r = bins.test();
  std::printf("[ measured ] %-34s chi2 = %7.2f  dof = %d  p = %.4g\n", name, r.statistic, r.dof,
              r.p_value);
  return r;
}

TEST(DistributionSample, Fixed) {
  const Distribution d = Distribution::fixed(2.5);
  for (int i = 0; i < 1000; ++i) {
    const RandomStream rng(kSeed, 3, static_cast<std::uint64_t>(i));
    EXPECT_EQ(d.sample(rng.uniform(kSlotMass), 0.0, kInf), 2.5);
  }
}

TEST(DistributionSample, UniformChiSquare) {
  Distribution d;
  d.kind = Distribution::Kind::kUniform;
  d.min = 3.0;
  d.max = 7.0;
  const auto r = fit(
      d, 0.0, kInf, [](double x) { return (x - 3.0) / 4.0; }, "uniform [3, 7]", 1);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, NormalChiSquare) {
  const auto r = fit(
      normal(10.0, 2.0), -kInf, kInf, [](double x) { return phi_ref((x - 10.0) / 2.0); },
      "normal (10, 2)", 2);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, NormalTruncatedByPhysicalRange) {
  // Mass-like: normal(1, 1) on (0, inf) cuts off Phi(-1) = 16% of the mass.
  const double pa = phi_ref(-1.0);
  const auto r = fit(
      normal(1.0, 1.0), kMassRange.lo, kMassRange.hi,
      [&](double x) { return (phi_ref(x - 1.0) - pa) / (1.0 - pa); }, "normal (1, 1) on (0, inf)",
      3);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, TruncatedNormalChiSquareTightRanges) {
  struct Case {
    double lo, hi;
    const char* name;
    std::uint32_t group;
  };
  // Upper tail (complementary side), far upper tail (mass 2.7e-7), lower tail, and a narrow
  // range across the median.
  const Case cases[] = {{2.5, 3.0, "truncated normal [2.5, 3.0] sd", 21},
                        {5.0, 5.5, "truncated normal [5.0, 5.5] sd", 22},
                        {-3.0, -2.5, "truncated normal [-3.0, -2.5] sd", 23},
                        {-0.1, 0.2, "truncated normal [-0.1, 0.2] sd", 24}};
  for (const auto& c : cases) {
    const double mean = 4.0, sigma = 0.5;
    const double a = c.lo, b = c.hi;
    std::function<double(double)> cdf;
    if (a >= 0.0) {
      cdf = [=](double x) {
        return (q_ref(a) - q_ref((x - mean) / sigma)) / (q_ref(a) - q_ref(b));
      };
    } else {
      cdf = [=](double x) {
        return (phi_ref((x - mean) / sigma) - phi_ref(a)) / (phi_ref(b) - phi_ref(a));
      };
    }
    const Distribution d = truncated(normal(mean, sigma), mean + a * sigma, mean + b * sigma);
    const auto r = fit(d, -kInf, kInf, cdf, c.name, c.group);
    EXPECT_GT(r.p_value, kMinP) << c.name;
  }
}

TEST(DistributionSample, LognormalChiSquare) {
  const auto r = fit(
      lognormal(2.0, 0.5), kMassRange.lo, kMassRange.hi,
      [](double x) { return phi_ref(std::log(x / 2.0) / 0.5); },
      "lognormal (median 2, sigma_ln 0.5)", 4);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, TruncatedLognormalChiSquare) {
  const double za = std::log(1.5 / 2.0) / 0.5, zb = std::log(2.5 / 2.0) / 0.5;
  const auto r = fit(
      truncated(lognormal(2.0, 0.5), 1.5, 2.5), kMassRange.lo, kMassRange.hi,
      [&](double x) {
        return (phi_ref(std::log(x / 2.0) / 0.5) - phi_ref(za)) / (phi_ref(zb) - phi_ref(za));
      },
      "lognormal truncated [1.5, 2.5]", 5);
  EXPECT_GT(r.p_value, kMinP);
}

// Table with a flat CDF segment on (1, 2): no probability there.
Distribution flat_table() {
  Distribution d;
  d.kind = Distribution::Kind::kTable;
  d.table_values = {0.0, 1.0, 2.0, 3.0, 5.0};
  d.table_cdf = {0.0, 0.2, 0.2, 0.7, 1.0};
  return d;
}
double flat_table_cdf(double x) {
  const double xs[] = {0.0, 1.0, 2.0, 3.0, 5.0}, fs[] = {0.0, 0.2, 0.2, 0.7, 1.0};
  if (x <= xs[0]) return 0.0;
  for (int k = 0; k < 4; ++k) {
    if (x <= xs[k + 1]) return fs[k] + (fs[k + 1] - fs[k]) * (x - xs[k]) / (xs[k + 1] - xs[k]);
  }
  return 1.0;
}

TEST(DistributionSample, TableChiSquareAndFlatSegment) {
  const Distribution d = flat_table();
  const auto r = fit(d, 0.0, kInf, flat_table_cdf, "table with flat segment", 6);
  EXPECT_GT(r.p_value, kMinP);
  // No sample may fall strictly inside the flat segment (1, 2).
  int inside = 0;
  for (int i = 0; i < kSamples; ++i) {
    const RandomStream rng(kSeed, 3, static_cast<std::uint64_t>(i));
    const double x = d.sample(rng.uniform(kSlotMass), 0.0, kInf);
    inside += (x > 1.0 && x < 2.0);
  }
  EXPECT_EQ(inside, 0);
  // The generalised inverse at the flat level returns the segment's left end.
  EXPECT_EQ(d.sample(0.2, 0.0, kInf), 1.0);
}

TEST(DistributionSample, TruncatedTableChiSquare) {
  // Table truncated to [0.5, 4]: F restricted and renormalised.
  Distribution d = truncated(flat_table(), 0.5, 4.0);
  const double fa = flat_table_cdf(0.5), fb = flat_table_cdf(4.0);
  const auto r = fit(
      d, 0.0, kInf, [&](double x) { return (flat_table_cdf(x) - fa) / (fb - fa); },
      "table truncated [0.5, 4]", 7);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, MottChiSquare) {
  const double mu = 0.004;  // kg: mean fragment 8 g
  const auto r = fit(
      mott(mu), kMassRange.lo, kMassRange.hi, [&](double x) { return mott_cdf_ref(x, mu); },
      "mott (mu 4 g)", 30);
  EXPECT_GT(r.p_value, kMinP);
}

TEST(DistributionSample, TruncatedMottChiSquare) {
  // Across the bulk [0.2 mu, 5 mu] (F from 0.36 to 0.89) and far in the upper tail
  // [20 mu, 60 mu] (mass 0.0114 - 0.00043), each renormalised.
  struct Case {
    double lo, hi;
    const char* name;
    std::uint32_t group;
  };
  const double mu = 0.004;
  const Case cases[] = {{0.2 * mu, 5 * mu, "mott truncated [0.2, 5] mu", 31},
                        {20 * mu, 60 * mu, "mott truncated [20, 60] mu", 32},
                        {1e-9, 0.5 * mu, "mott truncated [1e-9 kg, 0.5 mu]", 33}};
  for (const auto& c : cases) {
    const double fa = mott_cdf_ref(c.lo, mu), fb = mott_cdf_ref(c.hi, mu);
    // Upper-tail case: 1 - F carries the digits, so the reference works with survivals.
    const auto cdf = [&](double x) {
      return (std::exp(-std::sqrt(c.lo / mu)) - std::exp(-std::sqrt(x / mu))) / (fb - fa);
    };
    const auto r =
        fit(truncated(mott(mu), c.lo, c.hi), kMassRange.lo, kMassRange.hi, cdf, c.name, c.group);
    EXPECT_GT(r.p_value, kMinP) << c.name;
  }
  // The same machinery rejects a Mott of mu 10 % larger (at 5 % it gives p = 2.5e-5: a scale
  // error of 2.5 % in sqrt(m) is near what 10^5 draws resolve).
  const auto bad = fit(
      mott(1.10 * mu), kMassRange.lo, kMassRange.hi, [&](double x) { return mott_cdf_ref(x, mu); },
      "REJECT mott mu 1.10 vs 1.0", 34);
  EXPECT_LT(bad.p_value, 1e-6);
}

TEST(DistributionSample, MottMeanIsTwoMu) {
  // E[m] = mu E[a^2] with a = sqrt(m / mu) ~ Exp(1): 2 mu; Var m = mu^2 (E a^4 - 4) = 20 mu^2, so
  // the standard error of a mean of 10^5 draws is 0.0141 mu. Tolerance 4 standard errors.
  const double mu = 0.004;
  const Distribution d = mott(mu);
  double sum = 0.0;
  for (int i = 0; i < kSamples; ++i) {
    const RandomStream rng(kSeed, 35, static_cast<std::uint64_t>(i));
    sum += d.sample(rng.uniform(kSlotMass), kMassRange.lo, kMassRange.hi);
  }
  const double mean = sum / kSamples;
  const double se = std::sqrt(20.0) * mu / std::sqrt(double(kSamples));
  std::printf("[ measured ] mott mean %.6g kg vs 2 mu = %.6g kg (se %.3g)\n", mean, 2 * mu, se);
  EXPECT_NEAR(mean, 2.0 * mu, 4.0 * se);
  // Deterministically: the midpoint rule over u of the quantile mu ln(1/(1-u))^2 gives 2 mu to
  // 1e-4 relative with 10^6 points (the integrable log^2 singularity at u = 1 costs ~1e-5).
  double q = 0.0;
  const int n = 1000000;
  for (int k = 0; k < n; ++k) q += d.sample((k + 0.5) / n, kMassRange.lo, kMassRange.hi);
  EXPECT_NEAR(q / n, 2.0 * mu, 1e-4 * 2.0 * mu);
  // And the closed form at three points: the median is mu (ln 2)^2.
  EXPECT_NEAR(d.sample(0.5, 0.0, kInf), mu * std::log(2.0) * std::log(2.0), 1e-15);
  EXPECT_NEAR(mott_survival(4 * mu, mu), std::exp(-2.0), 1e-16);
}

TEST(DistributionSample, ChiSquareRejectsWrongSigma) {
  // The same machinery must reject a wrong distribution: samples from normal(0, 1.05) tested
  // against normal(0, 1). Expected noncentrality ~ N * 2 (0.05)^2 = 500: p must be < 1e-6.
  const auto r = fit(normal(0.0, 1.05), -kInf, kInf, phi_ref, "REJECT normal sd 1.05 vs 1.0", 8);
  EXPECT_LT(r.p_value, 1e-6);
  // And a truncated normal against the untruncated-tail shape of a neighbouring range.
  const double a = 2.5, b = 3.0, a2 = 2.45;
  const auto r2 = fit(
      truncated(normal(0.0, 1.0), a, b), -kInf, kInf,
      [&](double x) { return (q_ref(a2) - q_ref(x)) / (q_ref(a2) - q_ref(b)); },
      "REJECT trunc [2.5,3] vs [2.45,3]", 9);
  EXPECT_LT(r2.p_value, 1e-6);
}

TEST(DistributionSample, FarTailsAccurate) {
  // Truncation [6, 6.5] sd: Phi(6) = 1 - 9.9e-10 keeps only 7 digits, so this works only through
  // the upper-tail probabilities. References from mpmath (50 digits). Tolerance 1e-13 relative.
  const Distribution d = truncated(normal(0.0, 1.0), 6.0, 6.5);
  EXPECT_NEAR(d.sample(0.5, -kInf, kInf), 6.105195750495481768, 1e-13 * 6.1);
  EXPECT_NEAR(d.sample(0.25, -kInf, kInf), 6.0443686997174794458, 1e-13 * 6.1);
  // Mirror image in the lower tail.
  const Distribution m = truncated(normal(0.0, 1.0), -6.5, -6.0);
  EXPECT_NEAR(m.sample(0.5, -kInf, kInf), -6.105195750495481768, 1e-13 * 6.1);
  EXPECT_NEAR(m.sample(0.75, -kInf, kInf), -6.0443686997174794458, 1e-13 * 6.1);
  const Distribution t = truncated(normal(0.0, 1.0), 5.0, 5.5);
  EXPECT_NEAR(t.sample(0.9, -kInf, kInf), 5.3428201936252159355, 1e-13 * 5.3);
  // Lognormal upper tail: ln X = mu + sigma_ln z.
  const Distribution l = truncated(lognormal(1.0, 0.1), std::exp(0.6), std::exp(0.65));
  EXPECT_NEAR(std::log(l.sample(0.5, kMassRange.lo, kMassRange.hi)), 0.6105195750495481768, 1e-13);
}

TEST(DistributionSample, BoundsHardAndMonotoneInU) {
  // Inversion is monotone in u, and results never leave the truncation range, including u at
  // the extremes of RandomStream's output (2^-54 and 1 - 2^-54).
  const Distribution dists[] = {normal(0.3, 1.0),
                                truncated(normal(0.0, 1.0), -0.1, 0.2),
                                truncated(normal(0.0, 1.0), 3.0, 3.5),
                                lognormal(2.0, 1.5),
                                truncated(lognormal(2.0, 0.5), 1.5, 2.5),
                                flat_table(),
                                mott(0.004),
                                truncated(mott(0.004), 0.001, 0.02),
                                truncated(mott(0.004), 0.5, 0.6)};
  for (const auto& d : dists) {
    double lo = kMassRange.lo, hi = kInf;
    if (d.has_min) lo = std::max(lo, d.min);
    if (d.has_max) hi = std::min(hi, d.max);
    double prev = -kInf;
    for (int k = 0; k <= 200000; ++k) {
      const double u = k == 0 ? 0x1p-54 : (k == 200000 ? 1.0 - 0x1p-54 : k / 200000.0);
      const double x = d.sample(u, kMassRange.lo, kMassRange.hi);
      ASSERT_TRUE(std::isfinite(x)) << u;
      ASSERT_GE(x, lo) << u;
      ASSERT_LE(x, hi) << u;
      ASSERT_GE(x, prev) << "not monotone at u=" << u;
      prev = x;
    }
  }
}

TEST(DistributionValidate, AcceptsValid) {
  EXPECT_EQ(Distribution::fixed(1.0).validate(kMassRange.lo, kMassRange.hi), "");
  EXPECT_EQ(Distribution::fixed(0.0).validate(kSpeedRange.lo, kSpeedRange.hi), "");
  EXPECT_EQ(normal(1.0, 0.2).validate(kMassRange.lo, kMassRange.hi), "");
  EXPECT_EQ(truncated(normal(0.0, 1.0), 5.0, 6.0).validate(-kInf, kInf), "");
  EXPECT_EQ(lognormal(2.0, 0.5).validate(kMassRange.lo, kMassRange.hi), "");
  EXPECT_EQ(flat_table().validate(0.0, kInf), "");
  EXPECT_EQ(flat_table().validate(kMassRange.lo, kMassRange.hi), "");  // value 0 is cut off
  EXPECT_EQ(mott(0.01).validate(kMassRange.lo, kMassRange.hi), "");
  EXPECT_EQ(truncated(mott(0.01), 0.001, 1.0).validate(kMassRange.lo, kMassRange.hi), "");
}

TEST(DistributionValidate, NamesTheField) {
  const double lo = kMassRange.lo, hi = kMassRange.hi;
  EXPECT_EQ(normal(1.0, 0.0).validate(lo, hi), "sigma: must be > 0");
  EXPECT_EQ(normal(1.0, -1.0).validate(lo, hi), "sigma: must be > 0");
  EXPECT_EQ(normal(1.0, std::nan("")).validate(lo, hi), "sigma: must be a finite number");
  EXPECT_EQ(normal(kInf, 1.0).validate(lo, hi), "mean: must be a finite number");
  EXPECT_EQ(lognormal(0.0, 1.0).validate(lo, hi), "median: must be > 0");
  EXPECT_EQ(lognormal(1.0, 0.0).validate(lo, hi), "sigma_ln: must be > 0");
  EXPECT_EQ(lognormal(1.0, kInf).validate(lo, hi), "sigma_ln: must be a finite number");
  EXPECT_EQ(Distribution::fixed(0.0).validate(lo, hi), "value: must be > 0");
  EXPECT_EQ(Distribution::fixed(-1.0).validate(0.0, kInf), "value: must be >= 0");
  EXPECT_EQ(Distribution::fixed(std::nan("")).validate(lo, hi), "value: must be a finite number");

  Distribution u;
  u.kind = Distribution::Kind::kUniform;
  u.min = 2.0;
  u.max = 1.0;
  EXPECT_EQ(u.validate(lo, hi), "max: must be > min");
  u.min = -1.0;
  u.max = 1.0;
  EXPECT_EQ(u.validate(0.0, kInf), "min: must be >= 0");
  u.min = std::nan("");
  EXPECT_EQ(u.validate(0.0, kInf), "min: must be a finite number");

  EXPECT_EQ(truncated(normal(1.0, 1.0), 3.0, 2.0).validate(lo, hi), "max: must be > min");
  EXPECT_EQ(truncated(normal(1.0, 1.0), std::nan(""), 2.0).validate(lo, hi),
            "min: must be a finite number");
  EXPECT_EQ(truncated(lognormal(1.0, 1.0), 0.5, kInf).validate(lo, hi),
            "max: must be a finite number");
  Distribution n = normal(100.0, 10.0);
  n.has_max = true;
  n.max = 0.0;
  EXPECT_EQ(n.validate(0.0, kInf), "mean: truncation range [0, 0] has no probability mass");
  // 8 sd beyond the mean: mass 6e-16 < kMinTruncatedMass.
  Distribution far = normal(0.0, 1.0);
  far.has_min = true;
  far.min = 8.0;
  EXPECT_EQ(far.validate(-kInf, kInf), "mean: truncation range [8, inf] has no probability mass");
  // Normal mass entirely below zero, for a quantity that must be > 0.
  EXPECT_EQ(normal(-100.0, 1.0).validate(lo, hi),
            "mean: truncation range (0, 1e+05] has no probability mass");
  // Beyond the physical upper limits (sampling.h; docs/scenario.md, "Limits").
  EXPECT_EQ(Distribution::fixed(1.8e19).validate(lo, hi), "value: must be <= 1e+05");
  EXPECT_EQ(normal(1e9, 1.0).validate(kSpeedRange.lo, kSpeedRange.hi),
            "mean: truncation range [0, 20000] has no probability mass");
  EXPECT_EQ(truncated(lognormal(1.0, 0.1), 10.0, 20.0).validate(lo, hi),
            "median: truncation range [10, 20] has no probability mass");

  Distribution t = flat_table();
  t.table_cdf.back() = 0.9;
  EXPECT_EQ(t.validate(lo, hi), "table_cdf: must end at 1");
  t = flat_table();
  t.table_cdf.front() = 0.1;
  EXPECT_EQ(t.validate(lo, hi), "table_cdf: must start at 0");
  t = flat_table();
  t.table_cdf[2] = 0.1;
  EXPECT_EQ(t.validate(lo, hi), "table_cdf: must be nondecreasing");
  t = flat_table();
  t.table_values[2] = 1.0;
  EXPECT_EQ(t.validate(lo, hi), "table_values: must be strictly increasing");
  t = flat_table();
  t.table_values[3] = kInf;
  EXPECT_EQ(t.validate(lo, hi), "table_values[3]: must be a finite number");
  t = flat_table();
  t.table_cdf.pop_back();
  EXPECT_EQ(t.validate(lo, hi), "table_cdf: must have as many entries as table_values");
  EXPECT_EQ(mott(0.0).validate(lo, hi), "mu: must be > 0");
  EXPECT_EQ(mott(-1.0).validate(lo, hi), "mu: must be > 0");
  EXPECT_EQ(mott(kInf).validate(lo, hi), "mu: must be a finite number");
  EXPECT_EQ(truncated(mott(0.01), 0.2, 0.1).validate(lo, hi), "max: must be > min");
  // 100 kg with mu 1 g: S = exp(-316), no mass.
  EXPECT_EQ(truncated(mott(0.001), 100.0, 200.0).validate(lo, hi),
            "mu: truncation range [100, 200] has no probability mass");
  t = truncated(flat_table(), 1.2, 1.8);  // inside the flat segment
  EXPECT_EQ(t.validate(lo, hi),
            "table_values: truncation range [1.2, 1.8] has no probability mass");
}

}  // namespace
}  // namespace fragsim::fragments
