#pragma once
// The energy audit of impacts (stats.energy_rises): an impulse from the terrain can only remove
// mechanical energy (Stronge's energetic restitution, W_z = (1 - e^2) W_c <= 0, and Coulomb
// friction, W_t <= 0: core/impact/collision.h), and the body does not move during it, so its
// energy E = m v^2 / 2 + omega . I omega / 2 + m g z after an impact never exceeds the energy
// before. A rise beyond rounding means the impact model is wrong.
#include <algorithm>
#include <cmath>

namespace fragsim::run {

struct BodyEnergy {
  double kinetic_j = 0.0;    // translational + rotational
  double potential_j = 0.0;  // m g z, z local (any zero: only differences at one z are compared)

  double total_j() const { return kinetic_j + potential_j; }
  // The size of the terms the total is rounded from.
  double magnitude_j() const { return kinetic_j + std::abs(potential_j); }
};

// Rounding allowance: relative to the terms' size (the rises seen in the tests, e = 1 bounces and
// random scenarios, are <= 5e-16 of it; an error of the model is of the order of the energy) ...
inline constexpr double kEnergyRiseRelative = 1e-9;
// ... and an absolute floor for a body nearly at rest at z = 0 (terms near 0).
inline constexpr double kEnergyRiseFloor_j = 1e-12;

// Did the energy rise from `before` to `after` beyond rounding?
inline bool energy_rose(const BodyEnergy& before, const BodyEnergy& after) {
  const double scale_j = std::max(before.magnitude_j(), after.magnitude_j());
  return after.total_j() - before.total_j() > kEnergyRiseRelative * scale_j + kEnergyRiseFloor_j;
}

}  // namespace fragsim::run
