// ExactSum (core/tally/exact_sum.h): the exact sum of doubles, rounded once to the nearest double
// (ties to even). The reference is tests/core/tally/reference_sum.h: a sign-magnitude big-integer
// accumulation in units of 2^-1074 (every finite double is an integer multiple), rounded bit by
// bit; it is itself checked against the hardware's correctly rounded a + b.
#include "core/tally/exact_sum.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <limits>
#include <random>
#include <stdexcept>
#include <vector>

#include "reference_sum.h"

namespace fragsim::tally {
namespace {

using testing::reference_sum;
using testing::ReferenceSum;

constexpr std::uint64_t kMantissa = (std::uint64_t{1} << 52) - 1;

std::uint64_t bits(double x) {
  return std::bit_cast<std::uint64_t>(x);
}

ExactSum sum_of(std::initializer_list<double> terms) {
  ExactSum s;
  for (const double x : terms) s.add(x);
  return s;
}
ExactSum sum_of(const std::vector<double>& terms) {
  ExactSum s;
  for (const double x : terms) s.add(x);
  return s;
}

// +-10^u, u uniform in [lo, hi], with all 52 mantissa bits random.
double wide(std::mt19937_64& g, double lo, double hi) {
  std::uniform_real_distribution<double> u(lo, hi);
  const double x = std::pow(10.0, u(g));
  const double y = std::bit_cast<double>((bits(x) & ~kMantissa) | (g() & kMantissa));
  return (g() & 1u) != 0 ? -y : y;
}

// x rounded to the nearest multiple of 2^-160, ties to even: what the header promises for a term
// below 2^-107 (ldexp by a power of two is exact here, nearbyint rounds ties to even).
double to_grid(double x) {
  return std::ldexp(std::nearbyint(std::ldexp(x, 160)), -160);
}

// --- the reference itself --------------------------------------------------------------------

TEST(ReferenceSum, AgreesWithTheHardwaresCorrectlyRoundedAdditionOfTwoTerms) {
  std::mt19937_64 g(1);
  for (int i = 0; i < 20000; ++i) {
    // Wide exponent ranges, subnormals included, and pairs of close magnitudes (cancellation).
    const double a = wide(g, -320.0, 300.0);
    const double b = i % 3 == 0 ? -a * (1.0 + std::ldexp(wide(g, -16.0, -1.0), -1))
                                : wide(g, std::log10(std::abs(a)) - 20.0, 300.0);
    const double want = a + b;
    ASSERT_EQ(bits(reference_sum(std::vector<double>{a, b})), bits(want)) << a << " + " << b;
  }
  EXPECT_EQ(bits(reference_sum(std::vector<double>{0.1, 0.2})), bits(0.1 + 0.2));
  EXPECT_EQ(bits(reference_sum(std::vector<double>{DBL_TRUE_MIN, DBL_TRUE_MIN})),
            bits(2 * DBL_TRUE_MIN));
  EXPECT_EQ(bits(reference_sum(std::vector<double>{})), bits(0.0));
}

// --- exactness -------------------------------------------------------------------------------

TEST(ExactSum, ValueIsTheCorrectlyRoundedExactSumOfWideRangeTerms) {
  std::mt19937_64 g(2);
  for (const int n : {1, 2, 3, 5, 10, 100, 1000, 3000}) {
    for (int trial = 0; trial < 20; ++trial) {
      std::vector<double> t(static_cast<std::size_t>(n));
      for (double& x : t) x = wide(g, -30.0, 30.0);
      ASSERT_EQ(bits(sum_of(t).value()), bits(reference_sum(t))) << n << " " << trial;
    }
  }
  // Deep cancellation: large terms cancel in pairs (in a shuffled order), leaving the small
  // ones, which naive double summation loses.
  for (int trial = 0; trial < 50; ++trial) {
    std::vector<double> t;
    for (int k = 0; k < 200; ++k) {
      const double big = wide(g, 10.0, 30.0);
      t.push_back(big);
      t.push_back(-big);
      t.push_back(wide(g, -30.0, -5.0));
    }
    std::shuffle(t.begin(), t.end(), g);
    ASSERT_EQ(bits(sum_of(t).value()), bits(reference_sum(t))) << trial;
  }
  // Two terms: the exact sum rounded once is the hardware's a + b.
  for (int i = 0; i < 20000; ++i) {
    const double a = wide(g, -30.0, 30.0), b = wide(g, -30.0, 30.0);
    ASSERT_EQ(bits(sum_of({a, b}).value()), bits(a + b)) << a << " + " << b;
  }
}

TEST(ExactSum, TheOrderOfTermsAndTheSplitIntoPiecesDoNotChangeABit) {
  std::mt19937_64 g(3);
  std::vector<double> t;
  for (int k = 0; k < 1500; ++k) t.push_back(wide(g, -30.0, 30.0));
  for (int k = 0; k < 300; ++k) t.push_back(wide(g, -48.0, -33.0));  // rounded to the grid
  for (int k = 0; k < 300; ++k) {
    const double big = wide(g, 20.0, 40.0);
    t.push_back(big);
    t.push_back(-big);
  }
  const ExactSum one = sum_of(t);
  std::vector<double> grid;
  for (const double x : t) grid.push_back(std::abs(x) < std::ldexp(1.0, -107) ? to_grid(x) : x);
  EXPECT_EQ(bits(one.value()), bits(reference_sum(grid)));

  std::vector<double> order = t;
  for (int r = 0; r < 20; ++r) {
    std::shuffle(order.begin(), order.end(), g);
    ASSERT_EQ(sum_of(order).limbs(), one.limbs()) << "shuffle " << r;
  }
  for (int r = 0; r < 20; ++r) {
    std::shuffle(order.begin(), order.end(), g);
    // Random cut points into 1 .. 60 pieces (some empty), each summed on its own.
    std::vector<std::size_t> cuts{0, order.size()};
    const int pieces = std::uniform_int_distribution<int>(1, 60)(g);
    for (int c = 1; c < pieces; ++c)
      cuts.push_back(std::uniform_int_distribution<std::size_t>(0, order.size())(g));
    std::sort(cuts.begin(), cuts.end());
    std::vector<ExactSum> part;
    for (std::size_t c = 0; c + 1 < cuts.size(); ++c)
      part.push_back(
          sum_of(std::vector<double>(order.begin() + static_cast<std::ptrdiff_t>(cuts[c]),
                                     order.begin() + static_cast<std::ptrdiff_t>(cuts[c + 1]))));
    // Merged into an empty sum in a random order...
    std::shuffle(part.begin(), part.end(), g);
    ExactSum flat;
    for (const ExactSum& p : part) flat.add(p);
    ASSERT_EQ(flat.limbs(), one.limbs()) << "pieces " << r;
    // ... and pairwise, as a random tree.
    while (part.size() > 1) {
      const std::size_t i = std::uniform_int_distribution<std::size_t>(0, part.size() - 1)(g);
      std::size_t j = std::uniform_int_distribution<std::size_t>(0, part.size() - 2)(g);
      if (j >= i) ++j;
      part[i].add(part[j]);
      part.erase(part.begin() + static_cast<std::ptrdiff_t>(j));
    }
    ASSERT_EQ(part[0].limbs(), one.limbs()) << "tree " << r;
    EXPECT_TRUE(part[0] == one);
  }
  // The limbs are the whole state.
  EXPECT_EQ(bits(ExactSum::from_limbs(one.limbs()).value()), bits(one.value()));
}

TEST(ExactSum, KeepsWhatDoubleSummationLosesToCancellation) {
  volatile double big = 1e16;       // volatile: the naive sums below are run, not folded
  EXPECT_EQ(big + 1.0 - big, 0.0);  // the case is a real one for doubles
  EXPECT_EQ(sum_of({1e16, 1.0, -1e16}).value(), 1.0);
  EXPECT_EQ(sum_of({1e30, 1e-30, -1e30}).value(), 1e-30);

  // Ten times the double nearest 0.1 (0.1000000000000000055511151231257827...): the exact sum
  // is 1.000000000000000055511151231257827..., whose nearest double is 1, not the naive
  // 0.9999999999999999.
  const double tenth = 0.1;
  volatile double naive = 0.0;
  ExactSum s;
  std::vector<double> t;
  for (int k = 0; k < 10; ++k) {
    naive = naive + tenth;
    s.add(tenth);
    t.push_back(tenth);
  }
  EXPECT_EQ(naive, 0.9999999999999999);
  EXPECT_EQ(s.value(), 1.0);
  EXPECT_EQ(bits(s.value()), bits(reference_sum(t)));
}

// --- range -----------------------------------------------------------------------------------

TEST(ExactSum, TermsAndSumsOutOfRangeThrow) {
  const double two158 = std::ldexp(1.0, 158), two157 = std::ldexp(1.0, 157);
  const double below = std::nextafter(two158, 0.0);  // 2^158 - 2^105, the largest term
  for (const double x :
       {two158, -two158, 1e100, -1e100, DBL_MAX, std::numeric_limits<double>::infinity(),
        -std::numeric_limits<double>::infinity(), std::numeric_limits<double>::quiet_NaN()}) {
    ExactSum s = sum_of({1.0});
    EXPECT_THROW(s.add(x), std::overflow_error) << x;
    EXPECT_EQ(s.value(), 1.0) << x;  // a rejected term leaves the sum as it was
  }
  EXPECT_EQ(sum_of({below}).value(), below);
  EXPECT_EQ(sum_of({-below}).value(), -below);
  // The whole range at once: 2^157 and 2^-160 are both kept exactly.
  EXPECT_EQ(sum_of({two157, std::ldexp(1.0, -160), -two157}).value(), std::ldexp(1.0, -160));
  EXPECT_EQ(sum_of({below, std::ldexp(1.0, 104)}).value(), two158);  // sum < 2^158, rounded up

  // Sums that reach 2^158 by accumulation, term by term or by merging.
  ExactSum a = sum_of({two157});
  EXPECT_THROW(a.add(two157), std::overflow_error);
  ExactSum b = sum_of({below});
  EXPECT_THROW(b.add(std::ldexp(1.0, 105)), std::overflow_error);
  ExactSum c = sum_of({two157}), d = sum_of({two157});
  EXPECT_THROW(c.add(d), std::overflow_error);
  ExactSum e = sum_of({-two157, -std::ldexp(1.0, 156)});
  EXPECT_THROW(e.add(-two157), std::overflow_error);
  ExactSum f = sum_of({-two157}), h = sum_of({-below});
  EXPECT_THROW(f.add(h), std::overflow_error);
  // Many in-range terms whose sum is out of range.
  const auto many = [] {
    ExactSum s;
    for (int k = 0; k < 10; ++k) s.add(std::ldexp(1.0, 155));
  };
  EXPECT_THROW(many(), std::overflow_error);
}

// --- rounding --------------------------------------------------------------------------------

TEST(ExactSum, RoundsTiesToEvenAtThe53BitBoundary) {
  const double p53 = std::ldexp(1.0, 53), p84 = std::ldexp(1.0, 84);
  const double tiny = std::ldexp(1.0, -160);  // the lowest bit, a sticky bit far below
  struct Case {
    std::vector<double> terms;
    double want;
  };
  const Case cases[] = {
      {{p53, 1.0}, p53},                   // tie, 2^53 even
      {{p53, 3.0}, p53 + 4.0},             // tie, 2^53 + 4 even (2^53 + 2 odd)
      {{p53, 2.0, 1.0}, p53 + 4.0},        // the same from other parts
      {{p53, 1.0, tiny}, p53 + 2.0},       // just above the tie
      {{p53, 1.0, -tiny}, p53},            // just below it
      {{p53, 3.0, -tiny}, p53 + 2.0},      // just below the tie that rounds up
      {{p53, 0.5, 0.25}, p53},             // below half
      {{1.0, std::ldexp(1.0, -53)}, 1.0},  // tie at 1
      {{1.0, std::ldexp(3.0, -53)}, 1.0 + std::ldexp(1.0, -51)},
      {{1.0, std::ldexp(1.0, -53), tiny}, 1.0 + std::ldexp(1.0, -52)},
      // 2^84: the kept bits start at a limb boundary (bit 192), the half bit tops the limb below.
      {{p84, std::ldexp(1.0, 31)}, p84},
      {{p84, std::ldexp(3.0, 31)}, p84 + std::ldexp(1.0, 33)},
      {{p84, std::ldexp(1.0, 31), tiny}, p84 + std::ldexp(1.0, 32)},
      {{p84, std::ldexp(1.0, 30), std::ldexp(1.0, 30)}, p84},
  };
  for (const Case& c : cases) {
    ASSERT_EQ(bits(reference_sum(c.terms)), bits(c.want));  // the expectation itself
    EXPECT_EQ(bits(sum_of(c.terms).value()), bits(c.want)) << c.want;
    // The same terms in reverse order.
    const std::vector<double> rev(c.terms.rbegin(), c.terms.rend());
    EXPECT_EQ(bits(sum_of(rev).value()), bits(c.want)) << c.want;
  }
}

TEST(ExactSum, NegativeSumsRoundLikeTheirMagnitudes) {
  const double p53 = std::ldexp(1.0, 53), tiny = std::ldexp(1.0, -160);
  EXPECT_EQ(bits(sum_of({-p53, -1.0}).value()), bits(-p53));
  EXPECT_EQ(bits(sum_of({-p53, -3.0}).value()), bits(-(p53 + 4.0)));
  EXPECT_EQ(bits(sum_of({-p53, -1.0, -tiny}).value()), bits(-(p53 + 2.0)));
  EXPECT_EQ(bits(sum_of({-p53, -1.0, tiny}).value()), bits(-p53));
  EXPECT_EQ(bits(sum_of({1.0, -3.5}).value()), bits(-2.5));
  EXPECT_EQ(bits(sum_of({-tiny}).value()), bits(-tiny));
  EXPECT_TRUE(sum_of({-1.0}).negative());
  EXPECT_FALSE(sum_of({1.0}).negative());
  // Negating every term negates the rounded sum exactly (rounding is symmetric).
  std::mt19937_64 g(4);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<double> t(50), neg(50);
    for (std::size_t k = 0; k < t.size(); ++k) {
      t[k] = wide(g, -30.0, 30.0);
      neg[k] = -t[k];
    }
    ASSERT_EQ(bits(sum_of(neg).value()), bits(-sum_of(t).value())) << trial;
    ASSERT_EQ(bits(sum_of(neg).value()), bits(reference_sum(neg))) << trial;
  }
}

TEST(ExactSum, RoundingUpCarriesIntoTheNextPowerOfTwo) {
  const double p53 = std::ldexp(1.0, 53), p54 = std::ldexp(1.0, 54), p96 = std::ldexp(1.0, 96);
  // 2^54 - 1: a tie between 2^54 - 2 (odd mantissa, all ones) and 2^54.
  EXPECT_EQ(bits(sum_of({p54 - 2.0, 1.0}).value()), bits(p54));
  EXPECT_EQ(bits(sum_of({p54 - 2.0, 1.0, -1.0}).value()), bits(p54 - 2.0));
  // 2^53 - 1/2 and 2^53 - 1/4 round to 2^53 (53 ones plus a half carry to bit 53).
  EXPECT_EQ(bits(sum_of({p53 - 1.0, 0.5}).value()), bits(p53));
  EXPECT_EQ(bits(sum_of({p53 - 1.0, 0.5, 0.25}).value()), bits(p53));
  EXPECT_EQ(bits(sum_of({p53 - 1.0, 0.25}).value()), bits(p53 - 1.0));
  // Across a limb: 2^96 - 2^42 has its top bit at bit 255 (the top of limb 3) and rounds to
  // 2^96 at bit 256 (limb 4).
  const double ones = p96 - std::ldexp(1.0, 43);  // the largest double below 2^96
  ASSERT_EQ(ones, std::nextafter(p96, 0.0));
  EXPECT_EQ(bits(sum_of({ones, std::ldexp(1.0, 42)}).value()), bits(p96));
  EXPECT_EQ(bits(sum_of({-ones, -std::ldexp(1.0, 42)}).value()), bits(-p96));
  EXPECT_EQ(bits(sum_of({ones, std::ldexp(1.0, 41)}).value()), bits(ones));
  // The smallest results: a few units of 2^-160, exact.
  EXPECT_EQ(sum_of({std::ldexp(3.0, -160)}).value(), std::ldexp(3.0, -160));
  EXPECT_EQ(sum_of({std::ldexp(1.0, -100), -std::ldexp(1.0, -100), std::ldexp(5.0, -160)}).value(),
            std::ldexp(5.0, -160));
}

TEST(ExactSum, ExactCancellationGivesPositiveZero) {
  const auto positive_zero = [](const ExactSum& s) {
    return s.zero() && bits(s.value()) == bits(0.0) && !s.negative();
  };
  EXPECT_TRUE(positive_zero(ExactSum()));
  EXPECT_TRUE(positive_zero(sum_of({-0.0})));
  EXPECT_TRUE(positive_zero(sum_of({-5.0, 5.0})));
  EXPECT_TRUE(positive_zero(sum_of({0.1, 0.2, -0.1, -0.2})));
  EXPECT_TRUE(positive_zero(sum_of({-1e30, 1e-30, 1e30, -1e-30})));
  ExactSum a = sum_of({-0.3, 1e-20}), b = sum_of({0.3, -1e-20});
  a.add(b);
  EXPECT_TRUE(positive_zero(a));
  EXPECT_FALSE(positive_zero(sum_of({-5.0, 5.0, -std::ldexp(1.0, -160)})));
}

// Terms below 2^-107 are rounded to the nearest multiple of 2^-160 (ties to even), at most
// 2^-161 each; from 2^-107 up every double is placed exactly.
TEST(ExactSum, TermsBelow2ToTheMinus107AreRoundedToMultiplesOf2ToTheMinus160) {
  const double unit = std::ldexp(1.0, -160), half = std::ldexp(1.0, -161);
  EXPECT_EQ(sum_of({unit}).value(), unit);
  EXPECT_TRUE(sum_of({half}).zero());                               // tie: 0 is even
  EXPECT_EQ(sum_of({3 * half}).value(), 2 * unit);                  // tie: 2 is even
  EXPECT_EQ(sum_of({5 * half}).value(), 2 * unit);                  // tie: 2 is even
  EXPECT_EQ(sum_of({-3 * half}).value(), -2 * unit);                // symmetric
  EXPECT_EQ(sum_of({half + std::ldexp(1.0, -200)}).value(), unit);  // above the tie
  EXPECT_TRUE(sum_of({std::nextafter(half, 0.0)}).zero());          // below it
  EXPECT_TRUE(sum_of({DBL_TRUE_MIN, -DBL_MIN, 1e-300}).zero());
  // Ten terms of 0.6 units give 10, not 6 units: each is rounded on its own.
  ExactSum ten;
  for (int k = 0; k < 10; ++k) ten.add(0.6 * unit);
  EXPECT_EQ(ten.value(), 10 * unit);

  std::mt19937_64 g(5);
  // Below the bound: each term is rounded to the grid, by at most half a unit.
  for (int i = 0; i < 20000; ++i) {
    const double x = wide(g, -60.0, std::log10(std::ldexp(1.0, -107)));
    const double r = to_grid(x);
    ASSERT_LE(std::abs(r - x), half) << x;
    ASSERT_EQ(bits(sum_of({x}).value()), bits(r == 0.0 ? 0.0 : r)) << x;
  }
  // From the bound up: exact (2^-107 itself, its binade, and above).
  for (const double x : {std::ldexp(1.0, -107), std::nextafter(std::ldexp(1.0, -107), 1.0),
                         std::nextafter(std::ldexp(1.0, -106), 0.0), 6e-33, 1e-32})
    EXPECT_EQ(sum_of({x, 1.0, -1.0}).value(), x) << x;
  for (int i = 0; i < 20000; ++i) {
    const double x = wide(g, std::log10(std::ldexp(1.0, -107)), -20.0);
    ASSERT_EQ(std::ldexp(x, 160), std::nearbyint(std::ldexp(x, 160))) << x;  // on the grid
    ASSERT_EQ(bits(sum_of({x, 1.0, -1.0}).value()), bits(x)) << x;
  }
  // A sum of many tiny and ordinary terms is the correctly rounded exact sum of the rounded
  // terms, within n 2^-161 of the true one.
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> t, grid;
    for (int k = 0; k < 500; ++k) {
      const double x = k % 2 == 0 ? wide(g, -60.0, -33.0) : wide(g, -33.0, -25.0);
      t.push_back(x);
      grid.push_back(std::abs(x) < std::ldexp(1.0, -107) ? to_grid(x) : x);
    }
    const ExactSum s = sum_of(t);
    ASSERT_EQ(bits(s.value()), bits(reference_sum(grid))) << trial;
    ReferenceSum error;  // exactly: rounded terms minus the terms
    for (std::size_t k = 0; k < t.size(); ++k) {
      error.add(grid[k]);
      error.add(-t[k]);
    }
    EXPECT_LE(std::abs(error.rounded()), static_cast<double>(t.size()) * half) << trial;
  }
}

}  // namespace
}  // namespace fragsim::tally
