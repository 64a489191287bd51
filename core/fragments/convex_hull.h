#pragma once
// Convex hull of a 3-D point set (quickhull, Barber, Dobkin & Huhdanpaa 1996, ACM TOMS 22(4),
// 469-483; our own implementation) and the exact mass properties of a closed triangulated solid of
// uniform density by signed tetrahedra (Tonon 2004, J. Math. Stat. 1(1), 8-11; docs/physics.md,
// "Polyhedron fragments", eqs. P1-P4).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/types.h"

namespace fragsim::fragments {

// A closed triangulated surface: triangles counter-clockwise seen from outside.
struct HullMesh {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::uint32_t, 3>> triangles;
};

// Tolerance the hull is built with: a point within it of a face's plane counts as on the face.
// Relative to the points' size (their largest |coordinate| summed over the axes), far above the
// rounding of a plane's offset (a few ulp of that size) and far below any physical detail.
inline constexpr double kHullTolerance_rel = 1e-12;
// Refused as flat: a set thinner than this fraction of its extent (a 1 m plate 1 nm thick).
inline constexpr double kHullFlatness_rel = 1e-9;

// Convex hull of `points` (at least 4, finite, not all (nearly) coplanar). Only hull vertices are
// kept; points within the tolerance of a face are left out. Throws InputError naming `field`
// (and the point, "field[12]", for a non-finite one).
HullMesh convex_hull(const std::vector<Vec3>& points, const std::string& field);

// Volume, centroid and second moments of the solid a closed mesh bounds (uniform unit density).
struct MeshMass {
  double volume_m3 = 0.0;
  Vec3 centroid_m{0, 0, 0};
  // Inertia tensor about the centroid per unit density, m^5: I = tr(C) 1 - C with
  // C = int (x - c)(x - c)^T dV (eq. P3).
  Mat3 inertia_m5 = Mat3::Zero();
  double surface_m2 = 0.0;
};
MeshMass mesh_mass(const HullMesh& mesh);

}  // namespace fragsim::fragments
