#pragma once
// Fast contact on a deformable ground (docs/physics.md, "Fast contact on soil", F1-F6; what data
// there are in docs/validation.md): a terrain contact at least the material's switch speed v_s
// fast is an impact on a deformable half-space. It embeds (at or above the critical angle, or
// when the soil's resistance takes all its speed) or ricochets along an arc through the soil,
// losing speed to a Poncelet resistance. Below v_s the caller uses the rigid impulse (bounce.h)
// and Coulomb friction.
#include "core/common/types.h"
#include "core/scene/site_spec.h"

namespace fragsim::impact {

enum class FastContactEnd {
  kSlow,      // slower than v_s: not this law's regime
  kEmbedded,  // at or above the critical angle (F2)
  kStopped,   // the soil's resistance took all its speed (F4): embedded too
  kRicochet,  // leaves with `velocity_mps`, `omega_radps`
};

struct FastContactOutcome {
  FastContactEnd end = FastContactEnd::kSlow;
  Vec3 velocity_mps{0, 0, 0};
  Vec3 omega_radps{0, 0, 0};
  double incidence_deg = 0.0;  // grazing angle into the surface (0: along it or leaving)
  double critical_deg = 0.0;   // theta_c (F2)
  double exit_deg = 0.0;       // theta_out (F5; raised to leave the ground while fast, F6)
  double speed_ratio = 1.0;    // |v_out| / |v_in|
};

// Theta_c in radians for a fragment of density rho_f: coefficient / sqrt(rho_f / rho_s), at most
// 90 degrees (F2).
double critical_angle_rad(const scene::FastContactSpec& law, double density_kg_m3);

// |v_out|^2 after the arc through the soil for a grazing angle theta (radians) (F3-F4); <= 0:
// stopped in it.
double ricochet_speed2(const scene::FastContactSpec& law, double speed_mps, double theta_rad);

// The contact of a body of density `density_kg_m3` moving with v (spin omega) against a surface
// of unit normal n. A ricochet that keeps at least v_s leaves at no less than the angle whose
// normal speed is `min_exit_normal_speed_mps` (the rebound floor): a fast body never slides (F6).
FastContactOutcome fast_contact(const scene::FastContactSpec& law, double density_kg_m3,
                                const Vec3& v, const Vec3& omega, const Vec3& n,
                                double min_exit_normal_speed_mps);

}  // namespace fragsim::impact
