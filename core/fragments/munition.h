#pragma once
// Fragments of a cased high-explosive charge from plain inputs: Gurney's launch speed and Mott's
// mass scale (docs/scenario.md, "Fragment groups from a munition"). Pure functions, SI units.
namespace fragsim::fragments {

enum class CaseGeometry { kCylinder, kSphere, kSandwich };

// Gurney's geometry constant k in V = sqrt(2E) (M/C + k)^(-1/2): 1/2 for a long cylinder, 3/5 for
// a sphere, 1/3 for a symmetric flat sandwich (Gurney 1943, BRL-405; the general form with
// k = n/(n+2), n = 1, 2, 3 for plane, cylinder, sphere, after Jacobs 1974, NOLTR 74-86).
double gurney_constant(CaseGeometry geometry);

// Launch speed of the case metal, m/s, from the explosive's Gurney velocity sqrt(2E) (m/s) and
// the charge-to-metal mass ratio C/M (> 0). Equivalent to sqrt(2E) (C/M / (1 + k C/M))^(1/2).
double gurney_velocity(double sqrt_2e_mps, double charge_to_metal, CaseGeometry geometry);

// Mott's parameter for a cylindrical steel case, M_A = B t^(5/6) d^(1/3) (1 + t/d) (kg^(1/2)), and
// the scale of the Mott mass law mu = M_A^2 (kg): B in kg^(1/2) m^(-7/6), t the wall thickness
// and d the inner diameter (m). The form used by DDESB TP-16 and TM 5-1300 / UFC 3-340-02.
double mott_scale_kg(double b_si, double wall_thickness_m, double inner_diameter_m);

// A Mott constant tabulated in oz^(1/2) in^(-7/6) in kg^(1/2) m^(-7/6): times
// sqrt(0.028349523125) * 0.0254^(-7/6) = 12.2264 (international ounce and inch).
double mott_constant_si_from_us(double b_oz_in);
inline constexpr double kMottUsToSi = 12.226445310107716;

// Case (wall) mass from its density and geometry, kg: a cylinder's wall, ends excluded,
// pi/4 ((d + 2t)^2 - d^2) L rho; a spherical shell pi/6 ((d + 2t)^3 - d^3) rho.
double cylinder_wall_mass_kg(double density_kg_m3, double inner_diameter_m, double wall_thickness_m,
                             double length_m);
double sphere_shell_mass_kg(double density_kg_m3, double inner_diameter_m, double wall_thickness_m);

// Number of fragments of a case of mass M under Mott's law: N0 = M / (2 mu), the mean mass 2 mu.
double mott_fragment_count(double case_mass_kg, double mu_kg);

}  // namespace fragsim::fragments
