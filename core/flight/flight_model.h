#pragma once
// Translational flight of one fragment: gravity + quadratic drag (paper eqs. 3-5).
//   m r'' = -m g e_z - 1/2 rho(z) Cd(Mach) A |v - w| (v - w)
#include <vector>

#include "core/common/types.h"
#include "core/flight/atmosphere.h"
#include "core/fragments/group.h"

namespace fragsim::flight {

// Cd as a constant or a piecewise-linear table in Mach (clamped at the ends).
class DragCoefficient {
 public:
  DragCoefficient() = default;
  explicit DragCoefficient(const fragments::CdSpec& spec);
  double at_mach(double mach) const;
  bool is_constant() const { return mach_.empty(); }

 private:
  double constant_ = 1.0;
  std::vector<double> mach_, cd_;
};

// A null atmosphere or Cd, or zero area, means no drag (vacuum flight).
struct FlightModel {
  const Atmosphere* atmosphere = nullptr;
  const DragCoefficient* cd = nullptr;
  double gravity_mps2 = kStandardGravity_mps2;
  double area_m2 = 0.0;
  double mass_kg = 1.0;
  double altitude_offset_m = 0.0;  // altitude = local z + offset

  // Acceleration at local position p with velocity v (time-independent: wind is uniform and
  // steady).
  Vec3 acceleration(const Vec3& p, const Vec3& v) const;
};

}  // namespace fragsim::flight
