#include "core/tally/ptn_prisms.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace fragsim::tally {

PtnPrisms::PtnPrisms(const scene::Site& site, double person_height_m)
    : vertices_(&site.terrain_vertices()),
      triangles_(&site.terrain_triangles()),
      count_(site.terrain_triangles().size()),
      h_(person_height_m) {
  double zmax = -std::numeric_limits<double>::infinity();
  for (const auto& t : *triangles_)
    zmax = std::max({zmax, (*vertices_)[t[0]].z(), (*vertices_)[t[1]].z(), (*vertices_)[t[2]].z()});
  top_z_ = zmax + h_;
}

PtnPrisms::Prism PtnPrisms::prism(std::uint32_t triangle) const {
  const auto& t = (*triangles_)[triangle];
  const Vec3& p0 = (*vertices_)[t[0]];
  const Vec3& p1 = (*vertices_)[t[1]];
  const Vec3& p2 = (*vertices_)[t[2]];
  Prism pr;
  const Vec3 cross = (p1 - p0).cross(p2 - p0);  // = 2 A n, sign by winding
  const Vec3 n_up = cross.z() >= 0 ? cross : Vec3(-cross);
  pr.area_normal = 0.5 * n_up;
  // Plane through p0 with normal n_up: n.x (x-x0) + n.y (y-y0) + n.z (z-z0) = 0.
  // The site guarantees terrain triangles are not vertical (n.z > 0).
  pr.gx = -n_up.x() / n_up.z();
  pr.gy = -n_up.y() / n_up.z();
  pr.gz = p0.z() - pr.gx * p0.x() - pr.gy * p0.y();
  // Counter-clockwise order in xy so that (dy, -dx) of each edge points outward.
  const bool ccw = cross.z() >= 0;
  const std::array<const Vec3*, 3> q = {&p0, ccw ? &p1 : &p2, ccw ? &p2 : &p1};
  for (int k = 0; k < 3; ++k) {
    const Vec3& u = *q[k];
    const Vec3& w = *q[(k + 1) % 3];
    const Vec2 nrm(w.y() - u.y(), -(w.x() - u.x()));
    pr.edge_normal[k] = nrm;
    pr.edge_c[k] = nrm.x() * u.x() + nrm.y() * u.y();
  }
  return pr;
}

double PtnPrisms::projected_area(std::uint32_t triangle, const Vec3& d) const {
  const Prism pr = prism(triangle);
  double a = std::abs(pr.area_normal.dot(d));  // top + bottom faces
  for (int k = 0; k < 3; ++k) {
    a += h_ * std::max(0.0, pr.edge_normal[k].x() * d.x() + pr.edge_normal[k].y() * d.y());
  }
  return a;
}

bool PtnPrisms::clip(std::uint32_t triangle, const Vec3& a, const Vec3& b, double& s_in,
                     double& s_out) const {
  const Prism pr = prism(triangle);
  const Vec3 d = b - a;
  double lo = 0.0, hi = 1.0;
  // Liang-Barsky/Cyrus-Beck against the three side half-planes.
  for (int k = 0; k < 3; ++k) {
    const double num =
        pr.edge_c[k] - (pr.edge_normal[k].x() * a.x() + pr.edge_normal[k].y() * a.y());
    const double den = pr.edge_normal[k].x() * d.x() + pr.edge_normal[k].y() * d.y();
    if (den == 0.0) {
      if (num < 0.0) return false;  // parallel and outside
    } else if (den > 0.0) {
      hi = std::min(hi, num / den);
    } else {
      lo = std::max(lo, num / den);
    }
    if (lo > hi) return false;
  }
  // Height above the ground plane is linear along the segment: h(s) = h0 + s dh; keep 0 <= h <= H.
  const double h0 = a.z() - (pr.gx * a.x() + pr.gy * a.y() + pr.gz);
  const double dh = d.z() - (pr.gx * d.x() + pr.gy * d.y());
  if (dh == 0.0) {
    if (h0 < 0.0 || h0 > h_) return false;
  } else {
    double s0 = (0.0 - h0) / dh, s1 = (h_ - h0) / dh;
    if (s0 > s1) std::swap(s0, s1);
    lo = std::max(lo, s0);
    hi = std::min(hi, s1);
  }
  if (lo > hi) return false;
  if (lo == hi && d.squaredNorm() > 0.0) return false;  // grazes an edge or corner only
  s_in = lo;
  s_out = hi;
  return true;
}

}  // namespace fragsim::tally
