#pragma once
// An independent reference for the tests of tally/exact_sum.h: the exact sum of any finite
// doubles, correctly rounded (to nearest, ties to even) once.
//
// Every finite double is an integer multiple of 2^-1074, so the sum is kept as two unsigned big
// integers in units of 2^-1074 (32-bit limbs), one for the positive terms and one for the
// magnitudes of the negative ones (sign-magnitude, unlike ExactSum's two's complement, and with
// no range limit for doubles). rounded() subtracts the two and rounds the difference bit by bit.
// Deliberately simple rather than fast.
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <vector>

namespace fragsim::tally::testing {

class ReferenceSum {
 public:
  // Bits 0 .. 32 kWords - 1, bit 0 worth 2^-1074: doubles reach bit 2097; 2^80 headroom.
  static constexpr int kWords = 70;
  using Big = std::vector<std::uint32_t>;

  ReferenceSum() : pos_(kWords, 0), neg_(kWords, 0) {}

  void add(double x) {
    if (!std::isfinite(x)) throw std::invalid_argument("reference sum: not finite");
    if (x == 0.0) return;
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(x);
    const unsigned biased = static_cast<unsigned>((bits >> 52) & 0x7ffu);
    std::uint64_t m = bits & ((std::uint64_t{1} << 52) - 1);
    if (biased != 0) m |= std::uint64_t{1} << 52;
    // x = m 2^(biased - 1075) (normal) or m 2^-1074 (subnormal): m shifted from 2^-1074.
    const unsigned shift = biased == 0 ? 0u : biased - 1u;
    add_shifted((bits >> 63) != 0 ? neg_ : pos_, m, shift);
  }

  double rounded() const {
    const int c = compare(pos_, neg_);
    if (c == 0) return 0.0;
    const bool negative = c < 0;
    const Big d = negative ? subtract(neg_, pos_) : subtract(pos_, neg_);
    int word = kWords - 1;
    while (d[static_cast<std::size_t>(word)] == 0) --word;
    int high = 32 * word + 31;  // the highest set bit
    while (!bit(d, high)) --high;
    double v;
    if (high <= 52) {
      std::uint64_t m = 0;
      for (int i = high; i >= 0; --i) m = (m << 1) | (bit(d, i) ? 1u : 0u);
      v = std::ldexp(static_cast<double>(m), -1074);  // exact (subnormal or the lowest binade)
    } else {
      const int low = high - 52;
      std::uint64_t kept = 0;
      for (int i = high; i >= low; --i) kept = (kept << 1) | (bit(d, i) ? 1u : 0u);
      const bool half = bit(d, low - 1);
      bool sticky = false;  // any of bits [0, low - 1)
      for (int i = 0; i < low - 1 && !sticky;) {
        if (i % 32 == 0 && i + 32 <= low - 1) {  // a whole word
          sticky = d[static_cast<std::size_t>(i / 32)] != 0;
          i += 32;
        } else {
          sticky = bit(d, i++);
        }
      }
      if (half && (sticky || (kept & 1u) != 0)) ++kept;
      v = std::ldexp(static_cast<double>(kept), low - 1074);  // kept <= 2^53: exact
    }
    return negative ? -v : v;
  }

 private:
  static bool bit(const Big& b, int i) {
    return ((b[static_cast<std::size_t>(i / 32)] >> (i % 32)) & 1u) != 0;
  }
  static void add_shifted(Big& b, std::uint64_t m, unsigned shift) {
    // m < 2^53 shifted by shift % 32 < 32: three 32-bit words.
    const unsigned off = shift % 32;
    const std::uint64_t lo = m << off, hi = off == 0 ? 0 : m >> (64 - off);
    const std::uint64_t words[3] = {lo & 0xffffffffu, lo >> 32, hi};
    std::uint64_t carry = 0;
    for (std::size_t w = shift / 32, k = 0; k < 3 || carry != 0; ++w, ++k) {
      if (w >= b.size()) throw std::overflow_error("reference sum: out of headroom");
      const std::uint64_t t = std::uint64_t{b[w]} + (k < 3 ? words[k] : 0) + carry;
      b[w] = static_cast<std::uint32_t>(t);
      carry = t >> 32;
    }
  }
  static int compare(const Big& a, const Big& b) {
    for (std::size_t i = a.size(); i-- > 0;)
      if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
    return 0;
  }
  static Big subtract(const Big& a, const Big& b) {  // a - b, a >= b
    Big d(a.size());
    std::int64_t borrow = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      std::int64_t t = static_cast<std::int64_t>(a[i]) - static_cast<std::int64_t>(b[i]) - borrow;
      borrow = t < 0 ? 1 : 0;
      if (t < 0) t += std::int64_t{1} << 32;
      d[i] = static_cast<std::uint32_t>(t);
    }
    return d;
  }

  Big pos_, neg_;
};

template <class Range>
double reference_sum(const Range& terms) {
  ReferenceSum s;
  for (const double x : terms) s.add(x);
  return s.rounded();
}

}  // namespace fragsim::tally::testing
