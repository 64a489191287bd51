#pragma once
// The least of a few values ln(x_i) / k_i without taking every logarithm: the impulse solver's
// step size (impact/collision.cpp, docs/physics.md C6) is exp of such a minimum. A cheap lower
// bound of each candidate rules out those that cannot be the least, and only the others'
// logarithms are taken. The result is the same double as std::min over every exact value: the
// minimum of doubles does not depend on the order they are compared in.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>

namespace fragsim {

// A lower bound of ln x for a positive normal x, within 0.06 of it: the binary exponent plus the
// mantissa m in [1, 2) taken as log2 m ~ m - 1 (log2 is concave and equal to m - 1 at both ends,
// so 0 <= log2 m - (m - 1) <= 1 - (1 + ln ln 2) / ln 2 = 0.0861, times ln 2: 0.0597), less 1e-9
// for the rounding of this sum (< 4e-13 for |ln x| <= 745) and of std::log (one ulp, < 1.2e-13).
inline double rough_ln_below(double x) {
  const auto bits = std::bit_cast<std::uint64_t>(x);
  const auto biased = static_cast<int>(bits >> 52);  // sign bit 0 for x > 0
  const double m = std::bit_cast<double>((bits & 0x000fffffffffffffULL) | 0x3ff0000000000000ULL);
  return (static_cast<double>(biased - 1023) + (m - 1.0)) * std::numbers::ln2 - 1e-9;
}

// A candidate ln(x) / k (k > 0), if `valid`, with a lower bound of its value: -inf where x is not
// a positive normal number (0, subnormal, infinite, NaN), which leaves it to be taken exactly.
struct LogCandidate {
  bool valid = false;
  double x = 0.0, k = 1.0, lower = 0.0;
  LogCandidate() = default;
  LogCandidate(bool v, double x_in, double k_in) : valid(v), x(x_in), k(k_in) {
    lower = v && std::isnormal(x) && x > 0.0 ? rough_ln_below(x) / k
                                             : -std::numeric_limits<double>::infinity();
  }
  // least = min(least, ln(x) / k), exactly as std::min gives it, without the logarithm when the
  // lower bound already exceeds `least` (the minimum is `least` either way then).
  void lower_into(double& least) const {
    if (valid && !(lower > least)) least = std::min(least, std::log(x) / k);
  }
};

// least = min(least, both candidates' values), the one with the lower bound first: the second's
// logarithm is then mostly not needed.
inline void lower_into(double& least, const LogCandidate& a, const LogCandidate& b) {
  const bool a_first = !(b.lower < a.lower);
  (a_first ? a : b).lower_into(least);
  (a_first ? b : a).lower_into(least);
}

}  // namespace fragsim
