#pragma once
// A fragment's bounce off a terrain triangle (paper eqs. 6-36): the contact point of the oriented
// body (core/fragments/support.h), the restitution for the normal approach speed (the surface
// material's e(v_n) table, paper Fig. 2), and the Mirtich/Stronge impulse (collision.h).
#include "core/common/types.h"
#include "core/fragments/support.h"
#include "core/impact/collision.h"
#include "core/scene/site.h"

namespace fragsim::impact {

struct TerrainBounce {
  CollisionResult collision;
  Vec3 r_m{0, 0, 0};              // contact point - centre of mass, site axes
  double normal_speed_mps = 0.0;  // approach speed of the contact point along the normal (>= 0)
  double restitution = 0.0;       // e used
};

// `q` body -> site attitude at contact, `omega_radps` in site axes, `normal` the triangle's unit
// upward normal. A face or edge within `flat_tol_m` of lying flat touches at its centre.
TerrainBounce bounce_on_terrain(const fragments::ContactBody& body, double mass_kg, const Quat& q,
                                const Vec3& velocity_mps, const Vec3& omega_radps,
                                const Vec3& normal, const scene::Material& material,
                                double flat_tol_m);

}  // namespace fragsim::impact
