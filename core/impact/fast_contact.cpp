// Fast contact on a deformable ground (fast_contact.h; docs/physics.md, F1-F6).
#include "core/impact/fast_contact.h"

#include <algorithm>
#include <cmath>

namespace fragsim::impact {

double critical_angle_rad(const scene::FastContactSpec& law, double density_kg_m3) {
  const double sigma = density_kg_m3 / law.bulk_density_kg_m3;
  return std::min(0.5 * kPi, law.critical_angle_coefficient_deg * kDegToRad / std::sqrt(sigma));
}

// F4: in the soil the force A (s + c rho_s v^2) keeps the ratio D/L to its lift, so along the
// arc d(v^2 + v_s^2) = -2 (D/L) (v^2 + v_s^2) d(phi), turned through 2 theta_e.
double ricochet_speed2(const scene::FastContactSpec& law, double speed_mps, double theta_rad) {
  const double vs2 = law.switch_speed_mps * law.switch_speed_mps;
  const double theta_e = theta_rad + law.roughness_deg * kDegToRad;
  return (speed_mps * speed_mps + vs2) * std::exp(-4.0 * law.drag_to_lift_ratio * theta_e) - vs2;
}

namespace {

// A unit vector in the surface along v's tangential part (any tangent if v has none).
Vec3 along_surface(const Vec3& v, const Vec3& n) {
  const Vec3 t = v - v.dot(n) * n;
  const double s = t.norm();
  if (s > 0.0) return t / s;
  const Vec3 a = std::abs(n.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  return n.cross(a).normalized();
}

}  // namespace

FastContactOutcome fast_contact(const scene::FastContactSpec& law, double density_kg_m3,
                                const Vec3& v, const Vec3& omega, const Vec3& n,
                                double min_exit_normal_speed_mps) {
  FastContactOutcome out;
  const double speed = v.norm();
  if (!(speed >= law.switch_speed_mps) || !(density_kg_m3 > 0.0)) return out;
  const double theta = std::asin(std::clamp(-v.dot(n) / speed, 0.0, 1.0));
  const double theta_c = critical_angle_rad(law, density_kg_m3);
  out.incidence_deg = theta / kDegToRad;
  out.critical_deg = theta_c / kDegToRad;
  if (theta >= theta_c) {
    out.end = FastContactEnd::kEmbedded;
    return out;
  }
  const double out2 = ricochet_speed2(law, speed, theta);
  if (!(out2 > 0.0)) {
    out.end = FastContactEnd::kStopped;
    return out;
  }
  const double speed_out = std::sqrt(out2);
  double exit = law.exit_angle_ratio * (theta + law.roughness_deg * kDegToRad);  // F5
  // Still fast: it leaves the ground (F6). The margin keeps the normal speed at or above the
  // floor after rounding (exactly at it, the caller's `>= floor` test could see it a hair below
  // and let the body slide at v_out); it changes the angle by 1e-9 relative, not the speed.
  if (speed_out >= law.switch_speed_mps)
    exit = std::max(exit,
                    std::asin(std::min(1.0, min_exit_normal_speed_mps * (1.0 + 1e-9) / speed_out)));
  exit = std::min(exit, 0.5 * kPi);
  out.end = FastContactEnd::kRicochet;
  out.exit_deg = exit / kDegToRad;
  out.speed_ratio = speed_out / speed;
  out.velocity_mps = speed_out * (std::cos(exit) * along_surface(v, n) + std::sin(exit) * n);
  out.omega_radps = out.speed_ratio * omega;  // rotational energy falls with the speed's (F5)
  return out;
}

}  // namespace fragsim::impact
