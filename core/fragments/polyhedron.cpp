// The polyhedron fragment's body: hull, principal frame, adjacency for the support queries.
#include "core/fragments/polyhedron.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace fragsim::fragments {

Mat3 principal_axes(const Mat3& inertia, Vec3& moments) {
  Mat3 t = 0.5 * (inertia + inertia.transpose());
  const double tiny = 1e-12 * std::abs(t.trace());
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (i != j && std::abs(t(i, j)) <= tiny) t(i, j) = 0.0;
  if (t.isDiagonal(0.0)) {
    moments = t.diagonal();
    return Mat3::Identity();
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> es(t);
  const Mat3 e = es.eigenvectors();
  // Greedy matching: the largest |e(i, k)| pairs input axis i with eigenvector k, and so on.
  std::array<int, 3> axis_of{-1, -1, -1};  // eigenvector for input axis i
  std::array<bool, 3> row_used{}, col_used{};
  for (int round = 0; round < 3; ++round) {
    int bi = 0, bk = 0;
    double best = -1.0;
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        if (!row_used[i] && !col_used[k] && std::abs(e(i, k)) > best)
          best = std::abs(e(i, k)), bi = i, bk = k;
    row_used[bi] = col_used[bk] = true;
    axis_of[bi] = bk;
  }
  Mat3 r;
  for (int i = 0; i < 3; ++i) {
    r.col(i) = e.col(axis_of[i]);
    if (r(i, i) < 0.0) r.col(i) = -r.col(i);
    moments[i] = es.eigenvalues()[axis_of[i]];
  }
  if (r.determinant() < 0.0) {  // flip the axis least aligned with its input axis
    int worst = 0;
    for (int i = 1; i < 3; ++i)
      if (std::abs(r(i, i)) < std::abs(r(worst, worst))) worst = i;
    r.col(worst) = -r.col(worst);
  }
  return r;
}

std::shared_ptr<const Polyhedron> Polyhedron::from_points(const std::vector<Vec3>& points,
                                                          const std::string& field) {
  auto p = std::make_shared<Polyhedron>();
  HullMesh hull = convex_hull(points, field);
  const MeshMass mm = mesh_mass(hull);
  p->rotation_ = principal_axes(mm.inertia_m5, p->inertia_m5_);
  p->centre_m_ = mm.centroid_m;
  p->volume_m3_ = mm.volume_m3;
  p->surface_m2_ = mm.surface_m2;
  for (Vec3& v : hull.vertices) v = p->rotation_.transpose() * (v - mm.centroid_m);
  p->mesh_ = std::move(hull);

  const auto& verts = p->mesh_.vertices;
  for (const Vec3& v : verts) {
    p->bounding_radius_m_ = std::max(p->bounding_radius_m_, v.norm());
    p->half_extent_m_ = p->half_extent_m_.cwiseMax(v.cwiseAbs());
  }
  for (int k = 0; k < 6; ++k) {
    const Vec3 d = (k % 2 == 0 ? 1.0 : -1.0) * Vec3::Unit(k / 2);
    std::uint32_t best = 0;
    for (std::uint32_t i = 1; i < verts.size(); ++i)
      if (d.dot(verts[i]) > d.dot(verts[best])) best = i;
    p->extreme_[static_cast<std::size_t>(k)] = best;
  }

  // Face planes in body axes, and the vertex adjacency (each edge once per direction: a closed
  // surface has every edge (a, b) in exactly one triangle as (a, b)).
  std::vector<std::vector<std::uint32_t>> nb(verts.size());
  for (const auto& t : p->mesh_.triangles) {
    const Vec3 cr = (verts[t[1]] - verts[t[0]]).cross(verts[t[2]] - verts[t[0]]);
    const double len = cr.norm();
    const Vec3 n = len > 0.0 ? Vec3(cr / len) : Vec3::UnitZ();
    p->normals_.push_back(n);
    p->offsets_.push_back(n.dot(verts[t[0]] + verts[t[1]] + verts[t[2]]) / 3.0);
    p->areas_.push_back(0.5 * len);
    for (int k = 0; k < 3; ++k) nb[t[k]].push_back(t[(k + 1) % 3]);
  }
  p->adj_start_.push_back(0);
  for (auto& list : nb) {
    std::sort(list.begin(), list.end());
    p->adj_.insert(p->adj_.end(), list.begin(), list.end());
    p->adj_start_.push_back(static_cast<std::uint32_t>(p->adj_.size()));
  }
  return p;
}

std::uint32_t Polyhedron::support_vertex(const Vec3& d) const {
  const auto& v = mesh_.vertices;
  std::uint32_t cur = extreme_[0];
  double best = d.dot(v[cur]);
  for (std::size_t k = 1; k < 6; ++k) {
    const double h = d.dot(v[extreme_[k]]);
    if (h > best) best = h, cur = extreme_[k];
  }
  for (;;) {
    std::uint32_t next = cur;
    for (const std::uint32_t* it = neighbours_begin(cur); it != neighbours_end(cur); ++it) {
      const double h = d.dot(v[*it]);
      if (h > best) best = h, next = *it;
    }
    if (next == cur) return cur;
    cur = next;
  }
}

}  // namespace fragsim::fragments
