// Scrambled Sobol points (core/fragments/sobol.h): the net properties that make them worth using,
// kept by the scramble, and the scramble's uniformity. The direction numbers were checked once
// against boost::random::sobol (Boost 1.74, the same Joe-Kuo table): its first 1,024 points in 8
// dimensions are ours but for the origin, which Boost skips; the values pinned below are Boost's.
#include "core/fragments/sobol.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <random>
#include <set>
#include <vector>

namespace fragsim::fragments {
namespace {

constexpr int kM = 10;  // 2^10 points
constexpr std::uint32_t kN = 1u << kM;

// Each of the 2^m intervals of width 2^-m holds exactly one of the first 2^m points.
bool stratified_1d(const std::vector<std::uint32_t>& x) {
  std::set<std::uint32_t> cells;
  for (const std::uint32_t v : x) cells.insert(v >> (32 - kM));
  return cells.size() == x.size();
}

// A (0, m, 2)-net in base 2: every box of 2^-a x 2^-(m-a) holds exactly one point.
bool net_2d(const std::vector<std::uint32_t>& x, const std::vector<std::uint32_t>& y) {
  for (int a = 0; a <= kM; ++a) {
    std::set<std::uint64_t> boxes;
    for (std::size_t i = 0; i < x.size(); ++i) {
      const std::uint64_t bx = a == 0 ? 0 : x[i] >> (32 - a);
      const std::uint64_t by = a == kM ? 0 : y[i] >> (32 - (kM - a));
      boxes.insert(bx << 32 | by);
    }
    if (boxes.size() != x.size()) return false;
  }
  return true;
}

std::vector<std::uint32_t> coordinates(int d, std::uint32_t key, bool scrambled) {
  std::vector<std::uint32_t> x;
  for (std::uint32_t i = 0; i < kN; ++i) {
    const std::uint32_t v = sobol_points().raw(i, d);
    x.push_back(scrambled ? SobolPoints::scramble(v, key) : v);
  }
  return x;
}

TEST(Sobol, FirstPointsAreBoostsJoeKuoPoints) {
  const double scale = 0x1.0p-32;
  const double p2[] = {0.25, 0.75, 0.75, 0.75, 0.25, 0.25, 0.75, 0.25};
  const double p3[] = {0.75, 0.25, 0.25, 0.25, 0.75, 0.75, 0.25, 0.75};
  const double p4[] = {0.375, 0.375, 0.625, 0.875, 0.375, 0.125, 0.375, 0.875};
  for (int d = 0; d < SobolPoints::kDimensions; ++d) {
    const auto ud = static_cast<std::size_t>(d);
    EXPECT_EQ(sobol_points().raw(0, d), 0u);
    EXPECT_EQ(sobol_points().raw(1, d) * scale, 0.5) << d;
    EXPECT_EQ(sobol_points().raw(2, d) * scale, p2[ud]) << d;
    EXPECT_EQ(sobol_points().raw(3, d) * scale, p3[ud]) << d;
    // Boost's fourth point is our index 6 (Gray-code order: 0, 1, 3, 2, 6, ...; Boost starts at 1).
    EXPECT_EQ(sobol_points().raw(6, d) * scale, p4[ud]) << d;
  }
}

TEST(Sobol, EveryDimensionIsStratifiedAndTheFirstTwoAreA0m2Net) {
  for (int d = 0; d < SobolPoints::kDimensions; ++d)
    EXPECT_TRUE(stratified_1d(coordinates(d, 0, false))) << d;
  EXPECT_TRUE(net_2d(coordinates(0, 0, false), coordinates(1, 0, false)));
  // Unscrambled, a pair of later dimensions is not a (0, m, 2)-net (t > 0): the check can fail.
  EXPECT_FALSE(net_2d(coordinates(2, 0, false), coordinates(3, 0, false)));
}

TEST(Sobol, TheScrambleKeepsTheNet) {
  std::mt19937 gen(11);
  for (int k = 0; k < 8; ++k) {
    const auto kx = static_cast<std::uint32_t>(gen()), ky = static_cast<std::uint32_t>(gen());
    const auto x = coordinates(0, kx, true), y = coordinates(1, ky, true);
    EXPECT_TRUE(stratified_1d(x));
    EXPECT_TRUE(net_2d(x, y));
    EXPECT_NE(x, coordinates(0, 0, false));  // it did scramble
  }
}

// Over random keys a scrambled point is uniform on the unit interval: chi-square of its 16
// leading-digit cells over 16,000 keys, for a few points and dimensions, below the 0.999 quantile
// of chi-square with 15 degrees of freedom (37.7).
TEST(Sobol, AScrambledPointIsUniformOverKeys) {
  std::mt19937 gen(12);
  for (const std::uint32_t i : {0u, 1u, 5u, 777u}) {
    for (const int d : {0, 3, 7}) {
      std::vector<double> count(16, 0.0);
      const int keys = 16000;
      for (int k = 0; k < keys; ++k)
        count[SobolPoints::scramble(sobol_points().raw(i, d), static_cast<std::uint32_t>(gen())) >>
              28] += 1.0;
      double chi2 = 0.0;
      for (const double c : count) chi2 += (c - keys / 16.0) * (c - keys / 16.0) / (keys / 16.0);
      EXPECT_LT(chi2, 37.7) << "point " << i << " dimension " << d;
    }
  }
}

}  // namespace
}  // namespace fragsim::fragments
