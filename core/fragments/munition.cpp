// Gurney launch speeds and Mott mass scales of a cased charge (munition.h).
#include "core/fragments/munition.h"

#include <cmath>
#include <numbers>

namespace fragsim::fragments {

double gurney_constant(CaseGeometry geometry) {
  switch (geometry) {
    case CaseGeometry::kCylinder: return 0.5;
    case CaseGeometry::kSphere: return 0.6;
    case CaseGeometry::kSandwich: return 1.0 / 3.0;
  }
  return 0.5;
}

double gurney_velocity(double sqrt_2e_mps, double charge_to_metal, CaseGeometry geometry) {
  return sqrt_2e_mps / std::sqrt(1.0 / charge_to_metal + gurney_constant(geometry));
}

double mott_scale_kg(double b_si, double wall_thickness_m, double inner_diameter_m) {
  const double t = wall_thickness_m, d = inner_diameter_m;
  const double m_a = b_si * std::pow(t, 5.0 / 6.0) * std::cbrt(d) * (1.0 + t / d);
  return m_a * m_a;
}

double mott_constant_si_from_us(double b_oz_in) {
  return b_oz_in * kMottUsToSi;
}

double cylinder_wall_mass_kg(double density_kg_m3, double inner_diameter_m, double wall_thickness_m,
                             double length_m) {
  const double d = inner_diameter_m, t = wall_thickness_m;
  // (d + 2t)^2 - d^2 = 4t (d + t), free of cancellation for thin walls.
  return std::numbers::pi * t * (d + t) * length_m * density_kg_m3;
}

double sphere_shell_mass_kg(double density_kg_m3, double inner_diameter_m,
                            double wall_thickness_m) {
  const double d = inner_diameter_m, t = wall_thickness_m;
  // (d + 2t)^3 - d^3 = 2t (3d^2 + 6dt + 4t^2).
  return std::numbers::pi / 6.0 * 2.0 * t * (3.0 * d * d + 6.0 * d * t + 4.0 * t * t) *
         density_kg_m3;
}

double mott_fragment_count(double case_mass_kg, double mu_kg) {
  return case_mass_kg / (2.0 * mu_kg);
}

}  // namespace fragsim::fragments
