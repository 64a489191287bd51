// The stratified estimator closes a stratum by visiting only the bins it touched; the figures
// must equal those of the formula applied to every bin (core/tally/stratified_estimator.h).
#include "core/tally/stratified_estimator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

namespace fragsim::tally {
namespace {

TEST(StratifiedEstimator, ManySmallStrataGiveTheFormulasOverEveryBin) {
  constexpr std::size_t kBins = 50;
  std::mt19937_64 gen(7);
  std::uniform_int_distribution<std::size_t> bin(0, kBins - 1);
  std::uniform_real_distribution<double> value(-1.0, 3.0);
  StratifiedEstimator e(kBins);
  std::vector<double> mean(kBins, 0.0), var(kBins, 0.0);
  for (int stratum = 0; stratum < 300; ++stratum) {
    const int n = 2 + stratum % 4;
    std::vector<double> s(kBins, 0.0), q(kBins, 0.0);
    for (int h = 0; h < n; ++h) {
      // Each history touches a few bins once (its whole contribution), some with 0.
      for (int k = 0; k < 3; ++k) {
        const std::size_t b = (bin(gen) + static_cast<std::size_t>(k) * 17) % kBins;
        const double x = (stratum + h + k) % 5 == 0 ? 0.0 : value(gen);
        e.add(b, x);
        s[b] += x;
        q[b] += x * x;
      }
    }
    e.end_group(n);
    for (std::size_t b = 0; b < kBins; ++b) {
      mean[b] += s[b];
      var[b] += std::max(0.0, n / (n - 1.0) * (q[b] - s[b] * s[b] / n));
    }
  }
  for (std::size_t b = 0; b < kBins; ++b) {
    EXPECT_DOUBLE_EQ(e.mean(b), mean[b]) << b;
    EXPECT_NEAR(e.std_error(b), std::sqrt(var[b]), 1e-12 * (1.0 + std::sqrt(var[b]))) << b;
  }
}

TEST(StratifiedEstimator, AStratumOfOneHistoryAddsItsMeanAndNoVariance) {
  StratifiedEstimator e(2);
  e.add(0, 2.0);
  e.end_group(1);
  e.add(0, 1.0);
  e.add(0, 3.0);  // two histories of the next stratum in the same bin: 2 (1 + 9 - 16/2) = 4
  e.end_group(2);
  EXPECT_DOUBLE_EQ(e.mean(0), 6.0);
  EXPECT_DOUBLE_EQ(e.std_error(0), 2.0);
  EXPECT_EQ(e.mean(1), 0.0);
  EXPECT_EQ(e.std_error(1), 0.0);
}

// Two partitions into strata, closed independently: the mean is the plain sum, the standard
// error the larger of the two partitions' (the stratified launch sampling's conservative
// estimate, docs/precision.md).
TEST(StratifiedEstimator, TwoPartitionsReportTheLargerVariance) {
  StratifiedEstimator e(1, 2);
  ASSERT_EQ(e.partitions(), 2u);
  // Histories 1, 1, 3, 3: partition 0 strata {1, 1} {3, 3} (variance 0); partition 1 strata
  // {1} {1, 3} {3}: 2 (1 + 9 - 16/2) = 4.
  const double x[] = {1.0, 1.0, 3.0, 3.0};
  e.add(0, x[0]);
  e.end_stratum(1, 1);
  e.add(0, x[1]);
  e.end_stratum(0, 2);
  e.add(0, x[2]);
  e.end_stratum(1, 2);
  e.add(0, x[3]);
  e.end_stratum(0, 2);  // {3, 3}
  e.end_stratum(1, 1);  // {3}
  EXPECT_DOUBLE_EQ(e.mean(0), 8.0);
  EXPECT_DOUBLE_EQ(e.std_error(0), 2.0);
}

}  // namespace
}  // namespace fragsim::tally
