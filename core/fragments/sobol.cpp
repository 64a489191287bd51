#include "core/fragments/sobol.h"

namespace fragsim::fragments {
namespace {

// Joe & Kuo (2008), new-joe-kuo-6.21201, dimensions 2-8: degree s, coefficients a, initial m.
struct Primitive {
  int s;
  std::uint32_t a;
  std::array<std::uint32_t, 5> m;
};
constexpr std::array<Primitive, SobolPoints::kDimensions - 1> kJoeKuo = {{
    {1, 0, {1, 0, 0, 0, 0}},
    {2, 1, {1, 3, 0, 0, 0}},
    {3, 1, {1, 3, 1, 0, 0}},
    {3, 2, {1, 1, 1, 0, 0}},
    {4, 1, {1, 1, 3, 3, 0}},
    {4, 4, {1, 3, 5, 13, 0}},
    {5, 2, {1, 1, 5, 5, 17}},
}};

std::uint32_t reverse_bits(std::uint32_t x) {
  x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
  x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
  x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
  x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
  return (x >> 16) | (x << 16);
}

}  // namespace

SobolPoints::SobolPoints() {
  for (int k = 0; k < 32; ++k) v_[0][static_cast<std::size_t>(k)] = 1u << (31 - k);
  for (int d = 1; d < kDimensions; ++d) {
    const Primitive& p = kJoeKuo[static_cast<std::size_t>(d - 1)];
    auto& v = v_[static_cast<std::size_t>(d)];
    for (int k = 0; k < 32; ++k) {
      const auto uk = static_cast<std::size_t>(k);
      if (k < p.s) {
        v[uk] = p.m[uk] << (31 - k);
        continue;
      }
      const auto us = static_cast<std::size_t>(p.s);
      std::uint32_t x = v[uk - us] ^ (v[uk - us] >> p.s);
      for (int j = 1; j < p.s; ++j)
        if ((p.a >> (p.s - 1 - j)) & 1u) x ^= v[uk - static_cast<std::size_t>(j)];
      v[uk] = x;
    }
  }
}

std::uint32_t SobolPoints::raw(std::uint32_t i, int d) const {
  const auto& v = v_[static_cast<std::size_t>(d)];
  std::uint32_t x = 0;
  for (std::size_t k = 0; i != 0; ++k, i >>= 1)
    if (i & 1u) x ^= v[k];
  return x;
}

// Burley (2020), after Laine & Karras (2011): a hash in which every output bit depends only on
// the input bits below it (in the reversed order: above it), i.e. a nested uniform scramble of the
// binary digits.
std::uint32_t SobolPoints::scramble(std::uint32_t x, std::uint32_t seed) {
  x = reverse_bits(x);
  x += seed;
  x ^= x * 0x6c50b47cu;
  x ^= x * 0xb82f1e52u;
  x ^= x * 0xc7afe638u;
  x ^= x * 0x8d22f6e6u;
  return reverse_bits(x);
}

const SobolPoints& sobol_points() {
  static const SobolPoints points;
  return points;
}

}  // namespace fragsim::fragments
