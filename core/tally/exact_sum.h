#pragma once
// An exact sum of doubles: a 320-bit two's-complement fixed-point number with its lowest bit
// worth 2^-160 (docs/cluster.md, "Exact sums"). Adding is exact (integer arithmetic), so a sum
// does not depend on the order of its terms: any split of the histories among threads, chunks,
// processes or machines, merged in any order, gives the same bits. value() rounds the exact sum
// to the nearest double (ties to even) once.
//
// Range: -2^158 <= sum < 2^158 (about 3.7e47). A term is placed exactly when it is a multiple of
// 2^-160, which every double >= 2^-107 (about 6e-33) is; a smaller one is rounded to the nearest
// multiple (ties to even) first, a deterministic rounding of at most 2^-161 (about 3e-49) per term.
// A sum that would leave the range throws std::overflow_error rather than wrap.
#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <stdexcept>

namespace fragsim::tally {

class ExactSum {
 public:
  static constexpr int kLowestBit = -160;  // the lowest bit is worth 2^kLowestBit
  static constexpr int kLimbs = 5;
  using Limbs = std::array<std::uint64_t, kLimbs>;  // little-endian limbs

  ExactSum() = default;

  void add(double x) {
    if (x == 0.0) return;
    if (!std::isfinite(x)) throw std::overflow_error("exact sum: a term is not finite");
    const std::uint64_t bits = std::bit_cast<std::uint64_t>(x);
    const int biased = static_cast<int>((bits >> 52) & 0x7ff);
    std::uint64_t m = bits & ((std::uint64_t{1} << 52) - 1);
    if (biased != 0) m |= std::uint64_t{1} << 52;
    // x = +-m 2^e: its lowest mantissa bit sits at position p of the fixed-point number.
    const int e = (biased == 0 ? 1 : biased) - 1075;
    int p = e - kLowestBit;
    if (p < 0) {
      m = shift_right_rounded(m, -p);
      p = 0;
      if (m == 0) return;
    }
    if (p + 53 > 64 * kLimbs - 2) throw std::overflow_error("exact sum: a term is too large");
    add_shifted(m, p, (bits >> 63) != 0);
  }

  // Throws std::overflow_error, leaving the sum as it was, when the result is out of range.
  void add(const ExactSum& o) {
    Limbs r = limbs_;
    bool carry = false;
    for (int i = 0; i < kLimbs; ++i) carry = add_carry(r[i], o.limbs_[i], carry);
    check_range(negative(), o.negative(), r);
    limbs_ = r;
  }

  bool zero() const {
    std::uint64_t any = 0;
    for (const std::uint64_t l : limbs_) any |= l;
    return any == 0;
  }
  bool negative() const { return (limbs_[kLimbs - 1] >> 63) != 0; }

  // The exact sum rounded to the nearest double, ties to even.
  double value() const {
    if (zero()) return 0.0;
    Limbs mag = limbs_;
    const bool neg = negative();
    if (neg) negate(mag);
    int top = kLimbs - 1;
    while (mag[static_cast<std::size_t>(top)] == 0) --top;
    const int high = 64 * top + 63 - std::countl_zero(mag[static_cast<std::size_t>(top)]);
    // Keep bits [high - 52, high]; round on the bits below.
    double v;
    if (high <= 52) {
      v = static_cast<double>(mag[0]);  // exact: fewer than 54 bits
    } else {
      const int low = high - 52;
      std::uint64_t kept = bits_at(mag, low, 53);
      const bool half = bit(mag, low - 1);
      const bool rest = any_below(mag, low - 1);
      if (half && (rest || (kept & 1) != 0)) ++kept;  // may carry to 2^53: still exact
      v = std::ldexp(static_cast<double>(kept), low);
    }
    v = std::ldexp(v, kLowestBit);
    return neg ? -v : v;
  }

  const Limbs& limbs() const { return limbs_; }
  // In range: the top two bits agree (what a sum of in-range terms always has).
  static bool in_range(const Limbs& l) {
    const std::uint64_t top = l[kLimbs - 1] >> 62;
    return top == 0 || top == 3;
  }
  static ExactSum from_limbs(const Limbs& l) {
    ExactSum s;
    s.limbs_ = l;
    return s;
  }
  friend bool operator==(const ExactSum& a, const ExactSum& b) { return a.limbs_ == b.limbs_; }

 private:
  static std::uint64_t shift_right_rounded(std::uint64_t m, int s) {
    if (s >= 64) return 0;  // m < 2^53 <= 2^63: less than half of the lowest bit
    const std::uint64_t kept = m >> s;
    const std::uint64_t rem = m & ((std::uint64_t{1} << s) - 1);
    const std::uint64_t half = std::uint64_t{1} << (s - 1);
    return (rem > half || (rem == half && (kept & 1) != 0)) ? kept + 1 : kept;
  }

  // Adds (or subtracts) m 2^p in place: the two limbs the term covers, then the carry (borrow)
  // up only as far as it goes. The same bits and range check as adding the term's 320-bit two's
  // complement (whose sign is `subtract`: m > 0), without building and negating it.
  void add_shifted(std::uint64_t m, int p, bool subtract) {
    const int limb = p / 64, off = p % 64;
    const std::uint64_t lo = m << off, hi = off != 0 ? m >> (64 - off) : 0;
    Limbs r = limbs_;
    bool carry = false;
    for (int i = limb; i < kLimbs; ++i) {
      const std::uint64_t term = i == limb ? lo : (i == limb + 1 ? hi : 0);
      auto& x = r[static_cast<std::size_t>(i)];
      carry = subtract ? sub_borrow(x, term, carry) : add_carry(x, term, carry);
      if (!carry && i > limb) break;  // the rest of the term is zero
    }
    check_range(negative(), subtract, r);
    limbs_ = r;
  }

  // a += b + carry; returns the carry out.
  static bool add_carry(std::uint64_t& a, std::uint64_t b, bool carry) {
    const bool c1 = __builtin_add_overflow(a, b, &a);
    const bool c2 = __builtin_add_overflow(a, std::uint64_t{carry}, &a);
    return c1 || c2;
  }
  // a -= b + borrow; returns the borrow out.
  static bool sub_borrow(std::uint64_t& a, std::uint64_t b, bool borrow) {
    const bool b1 = __builtin_sub_overflow(a, b, &a);
    const bool b2 = __builtin_sub_overflow(a, std::uint64_t{borrow}, &a);
    return b1 || b2;
  }
  static void negate(Limbs& l) {
    bool carry = true;
    for (auto& x : l) {
      x = ~x;
      carry = add_carry(x, 0, carry);
    }
  }

  // Two's-complement overflow: both terms of one sign and the sum of the other. The range is
  // kept two bits short of the 320 so that a sum of in-range terms never wraps silently.
  static void check_range(bool sa, bool sb, const Limbs& r) {
    const bool s = (r[kLimbs - 1] >> 63) != 0;
    const std::uint64_t top = r[kLimbs - 1] >> 62;
    if ((sa == sb && s != sa) || (top != 0 && top != 3))
      throw std::overflow_error("exact sum: the sum left the range of 2^158");
  }

  static bool bit(const Limbs& l, int i) {
    if (i < 0) return false;
    return ((l[static_cast<std::size_t>(i / 64)] >> (i % 64)) & 1) != 0;
  }
  static bool any_below(const Limbs& l, int i) {  // any of bits [0, i)
    for (int k = 0; k < kLimbs && 64 * k < i; ++k) {
      const int n = std::min(64, i - 64 * k);
      const std::uint64_t mask = n == 64 ? ~std::uint64_t{0} : ((std::uint64_t{1} << n) - 1);
      if ((l[static_cast<std::size_t>(k)] & mask) != 0) return true;
    }
    return false;
  }
  static std::uint64_t bits_at(const Limbs& l, int low, int n) {  // bits [low, low + n), n <= 64
    const int limb = low / 64, off = low % 64;
    std::uint64_t v = l[static_cast<std::size_t>(limb)] >> off;
    if (off != 0 && limb + 1 < kLimbs) v |= l[static_cast<std::size_t>(limb) + 1] << (64 - off);
    return n == 64 ? v : (v & ((std::uint64_t{1} << n) - 1));
  }

  Limbs limbs_{};
};

}  // namespace fragsim::tally
