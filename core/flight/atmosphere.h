#pragma once
// Atmosphere models: air density and speed of sound against altitude above sea level, and wind.
#include <vector>

#include "core/common/types.h"

namespace fragsim::flight {

struct AtmosphereSpec {
  enum class Model { kIsa, kConstant };
  Model model = Model::kIsa;
  double density_kg_m3 = 1.225;      // constant model
  double sound_speed_mps = 340.294;  // constant model
  Vec3 wind_mps{0, 0, 0};            // uniform wind, site axes
};

// ISA (ICAO Doc 7488 / ISO 2533) troposphere to 11 km, isothermal stratosphere above
// (docs/physics.md, "Reference formulas"). The ISA model is tabulated once at construction (cubic
// Hermite, 10 m nodes, -1 km .. 30 km; relative error < 1e-9 against the closed form) because pow()
// per right-hand-side evaluation would dominate flight cost. Outside the table the closed form is
// used.
class Atmosphere {
 public:
  explicit Atmosphere(const AtmosphereSpec& spec);
  double density(double altitude_m) const;
  double sound_speed(double altitude_m) const;
  const Vec3& wind() const { return spec_.wind_mps; }
  bool is_constant() const { return spec_.model == AtmosphereSpec::Model::kConstant; }
  // Closed-form ISA (for tests and outside the table).
  static double isa_density(double altitude_m);
  static double isa_sound_speed(double altitude_m);

 private:
  // Private Members
  AtmosphereSpec spec_;
  // Table: for each 10 m interval [h0 + i dh, h0 + (i+1) dh] the cubic in s = (h - h_i)/dh in
  // power form c0 + s (c1 + s (c2 + s c3)), built from the closed-form value and analytic
  // derivative at both ends of the interval. Per-interval (not per-node) storage keeps the
  // tropopause (11 km, a node) exact: T' jumps there, so rho' and a' have one-sided values.
  double h0_ = -1000.0, dh_ = 10.0, inv_dh_ = 0.1;
  int intervals_ = 0;
  std::vector<double> rho_, a_;  // 4 * intervals_ coefficients each
};

// The table lookups are inline: they are called on every right-hand-side evaluation.
inline double Atmosphere::density(double altitude_m) const {
  if (is_constant()) return spec_.density_kg_m3;
  const double x = (altitude_m - h0_) * inv_dh_;
  // `!(x < n)` also sends NaN to the closed form, which propagates it.
  if (!(x >= 0.0 && x < static_cast<double>(intervals_))) return isa_density(altitude_m);
  const int i = static_cast<int>(x);
  const double s = x - i;
  const double* c = &rho_[4 * static_cast<std::size_t>(i)];
  return c[0] + s * (c[1] + s * (c[2] + s * c[3]));
}

inline double Atmosphere::sound_speed(double altitude_m) const {
  if (is_constant()) return spec_.sound_speed_mps;
  const double x = (altitude_m - h0_) * inv_dh_;
  if (!(x >= 0.0 && x < static_cast<double>(intervals_))) return isa_sound_speed(altitude_m);
  const int i = static_cast<int>(x);
  const double s = x - i;
  const double* c = &a_[4 * static_cast<std::size_t>(i)];
  return c[0] + s * (c[1] + s * (c[2] + s * c[3]));
}

}  // namespace fragsim::flight
