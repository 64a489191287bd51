// The least of ln(x_i) / k_i with logarithms taken only where needed (core/common/least_log.h):
// its lower bound holds over the whole range of doubles, and the minimum is the same double as
// std::min over every exact value, whatever the candidates (ties, zeros, subnormals, infinities,
// NaN, invalid ones).
#include "core/common/least_log.h"

#include <gtest/gtest.h>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

namespace fragsim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Positive doubles spread over every binade (random bits of exponent and mantissa), and the ends.
std::vector<double> positive_normals(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<double> xs = {std::numeric_limits<double>::min(),
                            std::numeric_limits<double>::max(),
                            1.0,
                            std::nextafter(1.0, 0.0),
                            std::nextafter(1.0, 2.0),
                            std::nextafter(2.0, 1.0),
                            2.0,
                            1.0 / std::numbers::ln2,
                            std::exp(1.0),
                            1e-300,
                            1e300};
  while (static_cast<int>(xs.size()) < n) {
    const double x = std::bit_cast<double>(rng() & 0x7fffffffffffffffULL);
    if (std::isnormal(x)) xs.push_back(x);
  }
  return xs;
}

// The bound: below the library's log by more than its own rounding, and within 0.0598 of it.
// (The largest gap is at m = 1 / ln 2, where log2 m - (m - 1) is largest: 0.0861 ln 2.)
TEST(LeastLog, RoughLnIsALowerBoundWithin006OverEveryBinade) {
  double widest = 0.0;
  for (double x : positive_normals(200000, 1)) {
    const double exact = std::log(x);
    const double rough = rough_ln_below(x);
    ASSERT_LT(rough, exact) << x;
    ASSERT_GT(rough, exact - 0.0598 - 2e-9) << x;
    widest = std::max(widest, exact - rough);
  }
  EXPECT_GT(widest, 0.059);  // the bound is as tight as its derivation says, not looser
}

double naive_min(double start, const std::vector<LogCandidate>& cs) {
  double least = start;
  for (const LogCandidate& c : cs)
    if (c.valid) least = std::min(least, std::log(c.x) / c.k);
  return least;
}

// What the impulse solver does: two candidates, then two more from the result, compared bit for
// bit with the plain minimum of every logarithm in the solver's order.
TEST(LeastLog, SameDoubleAsTheMinimumOfEveryLogarithm) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> exponent(-320.0, 320.0);
  std::uniform_int_distribution<int> pick(0, 15);
  const std::array<double, 4> ks = {26.0, 28.0, 13.0, 14.0};
  const auto draw = [&](double near) {
    switch (pick(rng)) {
      case 0: return 0.0;
      case 1: return 4.9e-324;  // subnormal
      case 2: return kInf;
      case 3: return kNaN;
      case 4: return near;  // an exact tie with another candidate
      case 5: return std::nextafter(near, kInf);
      default: return std::pow(10.0, exponent(rng));
    }
  };
  int ties = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    // Half the trials give every candidate the same k, so that equal x are equal values (ties).
    const bool same_k = trial % 2 == 1;
    std::array<LogCandidate, 4> c;
    const double near = std::pow(10.0, exponent(rng));
    for (std::size_t i = 0; i < 4; ++i)
      c[i] = LogCandidate(pick(rng) != 0, draw(near), same_k ? 14.0 : ks[i]);
    double fast = kInf;
    lower_into(fast, c[0], c[1]);
    const double slow_first = naive_min(kInf, {c[0], c[1]});
    ASSERT_EQ(std::bit_cast<std::uint64_t>(fast), std::bit_cast<std::uint64_t>(slow_first));
    lower_into(fast, c[2], c[3]);
    const double slow = naive_min(slow_first, {c[2], c[3]});
    ASSERT_EQ(std::bit_cast<std::uint64_t>(fast), std::bit_cast<std::uint64_t>(slow))
        << c[0].x << " " << c[1].x << " " << c[2].x << " " << c[3].x;
    if (same_k && c[0].valid && c[2].valid && c[0].x == c[2].x && std::isnormal(c[0].x)) ++ties;
  }
  EXPECT_GT(ties, 100);  // the draw did exercise equal inputs
}

// Candidates whose values differ by less than the bound's width: both logarithms are taken and
// the least is still exact (here x and x (1 + 1e-15) at the same k).
TEST(LeastLog, NearTiesAreResolvedExactly) {
  for (double x : positive_normals(20000, 3)) {
    const double y = x * (1.0 + 1e-15);
    if (!std::isnormal(y)) continue;
    double least = kInf;
    lower_into(least, LogCandidate(true, y, 14.0), LogCandidate(true, x, 14.0));
    ASSERT_EQ(least, std::min(std::log(x) / 14.0, std::log(y) / 14.0)) << x;
  }
}

}  // namespace
}  // namespace fragsim
