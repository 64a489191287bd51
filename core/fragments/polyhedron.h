#pragma once
// The body of a polyhedron fragment: the convex hull of the given points, in its principal frame
// at its centre of mass (docs/physics.md, "Polyhedron fragments"). Built once per fragment group
// and shared, read-only, by every history (std::shared_ptr<const Polyhedron>); a history's body
// is this hull scaled by a factor (ContactBody::scale).
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/fragments/convex_hull.h"

namespace fragsim::fragments {

class Polyhedron {
 public:
  // Hull of `points` (input axes, metres), its mass properties and principal frame. Throws
  // InputError naming `field` for fewer than 4 points, a non-finite one, or a flat set.
  static std::shared_ptr<const Polyhedron> from_points(const std::vector<Vec3>& points,
                                                       const std::string& field);

  // Hull vertices in body axes (principal axes, centre of mass at the origin).
  const std::vector<Vec3>& vertices() const { return mesh_.vertices; }
  const std::vector<std::array<std::uint32_t, 3>>& triangles() const { return mesh_.triangles; }
  // Per triangle: unit outward normal, distance of its plane from the centre (> 0), area.
  const std::vector<Vec3>& normals() const { return normals_; }
  const std::vector<double>& offsets() const { return offsets_; }
  const std::vector<double>& areas() const { return areas_; }

  double volume_m3() const { return volume_m3_; }
  double surface_m2() const { return surface_m2_; }
  // Principal moments of inertia per unit density (m^5), about body x, y, z.
  const Vec3& inertia_m5() const { return inertia_m5_; }
  // Where the body frame sits in the input axes: x_input = centre_m + rotation * x_body.
  const Vec3& centre_m() const { return centre_m_; }
  const Mat3& rotation() const { return rotation_; }
  // Largest distance of a vertex from the centre; largest |coordinate| of a vertex per body axis.
  double bounding_radius_m() const { return bounding_radius_m_; }
  const Vec3& half_extent_m() const { return half_extent_m_; }

  // A vertex maximising d . x (body axes; d need not be unit): steepest ascent over the hull's
  // edges from the best of the six axis-extreme vertices. On a convex polytope a vertex no
  // neighbour improves on is a global maximum.
  std::uint32_t support_vertex(const Vec3& d) const;
  // Vertices joined to vertex v by a hull edge.
  const std::uint32_t* neighbours_begin(std::uint32_t v) const { return &adj_[adj_start_[v]]; }
  const std::uint32_t* neighbours_end(std::uint32_t v) const { return &adj_[adj_start_[v + 1]]; }

 private:
  HullMesh mesh_;
  std::vector<Vec3> normals_;
  std::vector<double> offsets_, areas_;
  std::vector<std::uint32_t> adj_start_, adj_;  // vertex adjacency, compressed rows
  std::array<std::uint32_t, 6> extreme_{};      // vertices extreme along +x, -x, +y, -y, +z, -z
  double volume_m3_ = 0.0, surface_m2_ = 0.0, bounding_radius_m_ = 0.0;
  Vec3 inertia_m5_{0, 0, 0}, centre_m_{0, 0, 0}, half_extent_m_{0, 0, 0};
  Mat3 rotation_ = Mat3::Identity();
};

// Principal axes of a symmetric inertia tensor as a rotation (columns = axes) chosen closest to
// the input axes: each axis matched to the input axis it is most nearly parallel to, pointing the
// same way, right-handed. Off-diagonal terms below 1e-12 of the trace are rounding: a tensor
// that is diagonal up to them keeps the input axes exactly (a cube, an aligned box).
Mat3 principal_axes(const Mat3& inertia, Vec3& moments);

}  // namespace fragsim::fragments
