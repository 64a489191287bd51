#pragma once
// Scrambled Sobol points for randomized quasi-Monte Carlo launch sampling. Point i of dimension d
// of the Sobol sequence (Sobol 1967) with the direction numbers of Joe & Kuo (2008,
// "Constructing Sobol sequences with better two-dimensional projections", SIAM J. Sci. Comput.
// 30, 2635-2654; file new-joe-kuo-6.21201, dimensions 2-8), in natural (not Gray-code) order,
// then Owen-scrambled (nested uniform scrambling, Owen 1995) by the hash of Burley (2020,
// "Practical Hash-based Owen Scrambling", JCGT 9(4)): every scrambled point is uniform on the unit
// cube, and the points of one scramble keep the net's stratification.
#include <array>
#include <cstdint>

namespace fragsim::fragments {

class SobolPoints {
 public:
  static constexpr int kDimensions = 8;
  SobolPoints();
  // The 32-bit coordinate d of point i, unscrambled.
  std::uint32_t raw(std::uint32_t i, int d) const;
  // Owen-scrambled by `seed` (a different seed per dimension and randomisation).
  static std::uint32_t scramble(std::uint32_t x, std::uint32_t seed);

 private:
  std::array<std::array<std::uint32_t, 32>, kDimensions> v_{};  // direction numbers
};

const SobolPoints& sobol_points();

}  // namespace fragsim::fragments
