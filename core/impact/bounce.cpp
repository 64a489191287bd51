#include "core/impact/bounce.h"

#include <algorithm>

namespace fragsim::impact {

TerrainBounce bounce_on_terrain(const fragments::ContactBody& body, double mass_kg, const Quat& q,
                                const Vec3& velocity_mps, const Vec3& omega_radps,
                                const Vec3& normal, const scene::Material& material,
                                double flat_tol_m) {
  TerrainBounce b;
  b.r_m = fragments::contact_point(body, q, normal, flat_tol_m);
  const Vec3 u = velocity_mps + omega_radps.cross(b.r_m);  // paper eq. 16
  b.normal_speed_mps = std::max(0.0, -u.dot(normal));
  b.restitution = material.restitution_at(b.normal_speed_mps);

  // World inverse inertia I_w^-1 = R diag(1/I) R^T (principal axes rotated by the attitude).
  const Mat3 rot = q.normalized().toRotationMatrix();
  const Vec3 inv_i = body.inertia_kg_m2.cwiseInverse();
  CollisionInput in;
  in.mass_kg = mass_kg;
  in.inv_inertia_world = rot * inv_i.asDiagonal() * rot.transpose();
  in.r_m = b.r_m;
  in.normal = normal;
  in.velocity_mps = velocity_mps;
  in.omega_radps = omega_radps;
  in.restitution = b.restitution;
  in.friction = material.friction;
  b.collision = resolve_collision(in);
  return b;
}

}  // namespace fragsim::impact
