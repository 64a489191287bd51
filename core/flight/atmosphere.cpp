#include "core/flight/atmosphere.h"

#include <cmath>

#include "core/common/error.h"

namespace fragsim::flight {

namespace {

// ISA constants (ICAO Doc 7488, ISO 2533; docs/physics.md, "Reference formulas"). Altitudes are
// geopotential metres.
constexpr double kT0_K = 288.15;        // sea-level temperature
constexpr double kP0_Pa = 101325.0;     // sea-level pressure
constexpr double kLapse_K_m = -0.0065;  // troposphere temperature gradient
constexpr double kTropopause_m = 11000.0;
constexpr double kT11_K = 216.65;     // isothermal layer temperature
constexpr double kP11_Pa = 22632.0;   // pressure at 11 km (docs/physics.md, "Reference formulas")
constexpr double kR_J_kgK = 287.053;  // specific gas constant of dry air
constexpr double kGamma = 1.4;
constexpr double kExponent = 5.25588;  // g0 / (R |L|), as printed in the standard
constexpr double kG0_mps2 = kStandardGravity_mps2;

// Table extent: -1 km .. 30 km at 10 m (header contract). 11 km is a node (index 1200), so no
// interval straddles the tropopause kink.
constexpr double kTableLo_m = -1000.0;
constexpr double kTableHi_m = 30000.0;
constexpr double kTableStep_m = 10.0;

struct ValueSlope {
  double value, slope;  // f and df/dh
};

// Closed form with analytic derivative. `upper` selects the branch at exactly 11 km, so the
// interval below the tropopause uses the troposphere's one-sided values and the one above the
// stratosphere's.
ValueSlope isa_rho(double h, bool upper) {
  if (h < kTropopause_m || (h == kTropopause_m && !upper)) {
    // rho = p / (R T) = (p0 / (R T0)) (T/T0)^(n-1), drho/dh = rho (n-1) L / T
    const double t = kT0_K + kLapse_K_m * h;
    const double rho = kP0_Pa / (kR_J_kgK * kT0_K) * std::pow(t / kT0_K, kExponent - 1.0);
    return {rho, rho * (kExponent - 1.0) * kLapse_K_m / t};
  }
  // Isothermal: p = p11 exp(-g (h - 11 km) / (R T11)), drho/dh = -rho g / (R T11)
  const double scale = kG0_mps2 / (kR_J_kgK * kT11_K);
  const double rho = kP11_Pa / (kR_J_kgK * kT11_K) * std::exp(-scale * (h - kTropopause_m));
  return {rho, -rho * scale};
}

ValueSlope isa_a(double h, bool upper) {
  if (h < kTropopause_m || (h == kTropopause_m && !upper)) {
    // a = sqrt(gamma R T), da/dh = a L / (2 T)
    const double t = kT0_K + kLapse_K_m * h;
    const double a = std::sqrt(kGamma * kR_J_kgK * t);
    return {a, a * kLapse_K_m / (2.0 * t)};
  }
  return {std::sqrt(kGamma * kR_J_kgK * kT11_K), 0.0};
}

// Power-form coefficients of the cubic Hermite interpolant on one interval, in s = (h - h_i)/dh:
// p(0) = f0, p(1) = f1, p'(0) = dh f0', p'(1) = dh f1'.
void append_hermite(std::vector<double>& out, ValueSlope lo, ValueSlope hi, double dh) {
  const double m0 = dh * lo.slope, m1 = dh * hi.slope;
  out.push_back(lo.value);
  out.push_back(m0);
  out.push_back(3.0 * (hi.value - lo.value) - 2.0 * m0 - m1);
  out.push_back(2.0 * (lo.value - hi.value) + m0 + m1);
}

}  // namespace

Atmosphere::Atmosphere(const AtmosphereSpec& spec) : spec_(spec) {
  if (spec_.model == AtmosphereSpec::Model::kConstant) {
    if (!(spec_.density_kg_m3 >= 0.0) || !std::isfinite(spec_.density_kg_m3))
      throw InputError("atmosphere.density_kg_m3", "must be finite and >= 0");
    if (!(spec_.sound_speed_mps > 0.0) || !std::isfinite(spec_.sound_speed_mps))
      throw InputError("atmosphere.sound_speed_mps", "must be finite and > 0");
  }
  if (!spec_.wind_mps.allFinite()) throw InputError("atmosphere.wind_mps", "must be finite");
  if (spec_.model != AtmosphereSpec::Model::kIsa) return;

  h0_ = kTableLo_m;
  dh_ = kTableStep_m;
  inv_dh_ = 1.0 / dh_;
  intervals_ = static_cast<int>(std::lround((kTableHi_m - kTableLo_m) / kTableStep_m));
  rho_.reserve(4 * static_cast<std::size_t>(intervals_));
  a_.reserve(4 * static_cast<std::size_t>(intervals_));
  for (int i = 0; i < intervals_; ++i) {
    // Node altitudes from the index (not by accumulation) so that 11 km is hit exactly.
    const double lo = h0_ + dh_ * i, hi = h0_ + dh_ * (i + 1);
    append_hermite(rho_, isa_rho(lo, true), isa_rho(hi, false), dh_);
    append_hermite(a_, isa_a(lo, true), isa_a(hi, false), dh_);
  }
}

double Atmosphere::isa_density(double altitude_m) {
  return isa_rho(altitude_m, true).value;
}

double Atmosphere::isa_sound_speed(double altitude_m) {
  return isa_a(altitude_m, true).value;
}

}  // namespace fragsim::flight
