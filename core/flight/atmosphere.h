#pragma once
// Atmosphere models: air density and speed of sound against altitude above sea level, and wind.
#include "core/common/types.h"

namespace fragsim::flight {

struct AtmosphereSpec {
  enum class Model { kIsa, kConstant };
  Model model = Model::kIsa;
  double density_kg_m3 = 1.225;     // constant model
  double sound_speed_mps = 340.294;  // constant model
  Vec3 wind_mps{0, 0, 0};            // uniform wind, site axes
};

// ISA (ICAO Doc 7488 / ISO 2533) troposphere to 11 km, isothermal stratosphere above
// (physics notes). The ISA model is tabulated once at construction (cubic Hermite, 10 m nodes,
// -1 km .. 30 km; relative error < 1e-9 against the closed form) because pow() per right-hand-side
// evaluation would dominate flight cost. Outside the table the closed form is used.
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
  AtmosphereSpec spec_;
  // table: value and derivative at nodes
  double h0_ = 0.0, dh_ = 10.0;
  std::vector<double> rho_, drho_, a_, da_;
};

}  // namespace fragsim::flight
