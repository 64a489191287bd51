#include "core/fragments/support.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

namespace fragsim::fragments {

ContactBody contact_body(ShapeType type, const MassProperties& mp) {
  ContactBody b;
  b.type = type;
  b.inertia_kg_m2 = mp.inertia_kg_m2;
  switch (type) {
    case ShapeType::kSphere: b.half_m.setConstant(0.5 * mp.dims_m[0]); break;
    case ShapeType::kCuboid:
    case ShapeType::kEllipsoid: b.half_m = 0.5 * mp.dims_m; break;
    case ShapeType::kCylinder:
      b.half_m = Vec3(0.5 * mp.dims_m[0], 0.5 * mp.dims_m[0], 0.5 * mp.dims_m[1]);
      break;
    case ShapeType::kPolyhedron:
      b.polyhedron = mp.polyhedron;
      b.scale = mp.scale;
      b.half_m = 0.5 * mp.dims_m;
      break;
    case ShapeType::kPoint: {
      // A small sphere of the same presented area (pi r^2 = A) and of the point's mass.
      const double r = std::sqrt(std::max(mp.presented_area_m2, 0.0) / kPi);
      b.type = ShapeType::kSphere;
      b.half_m.setConstant(r);
      b.inertia_kg_m2.setConstant(0.4 * mp.mass_kg * r * r);
      break;
    }
  }
  return b;
}

double body_volume(const ContactBody& b) {
  const Vec3& h = b.half_m;
  switch (b.type) {
    case ShapeType::kCuboid: return 8.0 * h.x() * h.y() * h.z();
    case ShapeType::kCylinder: return kPi * h.x() * h.x() * 2.0 * h.z();
    case ShapeType::kPolyhedron: return std::pow(b.scale, 3) * b.polyhedron->volume_m3();
    case ShapeType::kSphere:
    case ShapeType::kEllipsoid:
    case ShapeType::kPoint: break;
  }
  return 4.0 / 3.0 * kPi * h.x() * h.y() * h.z();
}

double bounding_radius(const ContactBody& b) {
  switch (b.type) {
    case ShapeType::kCuboid: return b.half_m.norm();                         // a corner
    case ShapeType::kCylinder: return std::hypot(b.half_m[0], b.half_m[2]);  // a rim point
    case ShapeType::kPolyhedron: return b.scale * b.polyhedron->bounding_radius_m();
    default: return b.half_m.maxCoeff();  // sphere, ellipsoid
  }
}

double support_extent(const ContactBody& b, const Quat& q, const Vec3& d) {
  const Vec3 db = q.conjugate() * d;  // direction in body axes
  const Vec3& a = b.half_m;
  switch (b.type) {
    case ShapeType::kCuboid: return a.cwiseProduct(db).cwiseAbs().sum();
    case ShapeType::kEllipsoid:
      return a.cwiseProduct(db).norm();  // sqrt(d^T A^2 d), A = diag(semi-axes)
    case ShapeType::kCylinder: {
      const double c = std::clamp(db.z(), -1.0, 1.0);
      return a.z() * std::abs(c) + a.x() * std::sqrt(std::max(0.0, 1.0 - c * c));
    }
    case ShapeType::kPolyhedron: {
      const Polyhedron& p = *b.polyhedron;
      return b.scale * db.dot(p.vertices()[p.support_vertex(db)]);
    }
    default: return a.x();
  }
}

namespace {

// Area centroid of the convex polygon spanned by `pts` (body axes) seen along the unit direction
// d: their 2-D hull in the plane across d (monotone chain), fanned into triangles whose projected
// areas weight their 3-D centroids. A set that spans no area: the midpoint of its two ends.
Vec3 contact_polygon_centroid(const std::vector<Vec3>& pts, const Vec3& d) {
  const Vec3 e1 = d.unitOrthogonal(), e2 = d.cross(e1);
  std::vector<std::pair<Vec2, std::size_t>> uv;
  for (std::size_t i = 0; i < pts.size(); ++i) uv.push_back({{e1.dot(pts[i]), e2.dot(pts[i])}, i});
  std::sort(uv.begin(), uv.end(), [](const auto& a, const auto& b) {
    return a.first.x() < b.first.x() || (a.first.x() == b.first.x() && a.first.y() < b.first.y());
  });
  const auto turn = [](const Vec2& o, const Vec2& a, const Vec2& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<std::size_t> ring;  // indices into uv, counter-clockwise
  for (int pass = 0; pass < 2; ++pass) {
    const std::size_t base = ring.size();
    for (std::size_t k = 0; k < uv.size(); ++k) {
      const std::size_t j = pass == 0 ? k : uv.size() - 1 - k;
      while (ring.size() >= base + 2 &&
             turn(uv[ring[ring.size() - 2]].first, uv[ring.back()].first, uv[j].first) <= 0.0)
        ring.pop_back();
      ring.push_back(j);
    }
    ring.pop_back();  // the last point starts the other chain
  }
  double area = 0.0;
  Vec3 sum = Vec3::Zero();
  for (std::size_t k = 1; k + 1 < ring.size(); ++k) {
    const double w = turn(uv[ring[0]].first, uv[ring[k]].first, uv[ring[k + 1]].first);
    area += w;
    sum += w * (pts[uv[ring[0]].second] + pts[uv[ring[k]].second] + pts[uv[ring[k + 1]].second]);
  }
  if (area > 0.0) return sum / (3.0 * area);
  return 0.5 * (pts[uv.front().second] + pts[uv.back().second]);
}

// Polyhedron: the vertices within `tol` (hull units) of the lowest along db, found by walking
// the hull's edges from a support vertex (they form a connected set: from each, an edge path of
// rising d . x leads to the support vertex), and their centroid.
Vec3 polyhedron_contact_point(const Polyhedron& p, const Vec3& db, double tol) {
  const auto& v = p.vertices();
  const std::uint32_t top = p.support_vertex(db);
  const double floor = db.dot(v[top]) - tol;
  std::vector<std::uint32_t> set{top};
  for (std::size_t k = 0; k < set.size(); ++k) {
    for (const std::uint32_t* it = p.neighbours_begin(set[k]); it != p.neighbours_end(set[k]);
         ++it) {
      if (db.dot(v[*it]) >= floor && std::find(set.begin(), set.end(), *it) == set.end())
        set.push_back(*it);
    }
  }
  if (set.size() == 1) return v[top];
  if (set.size() == 2) return 0.5 * (v[set[0]] + v[set[1]]);
  std::vector<Vec3> pts;
  for (const std::uint32_t i : set) pts.push_back(v[i]);
  return contact_polygon_centroid(pts, db);
}

}  // namespace

Vec3 contact_point(const ContactBody& b, const Quat& q, const Vec3& n, double flat_tol_m) {
  const Vec3 db = -(q.conjugate() * n);  // toward the plane, body axes
  const Vec3& a = b.half_m;
  Vec3 xb = Vec3::Zero();  // body axes
  switch (b.type) {
    case ShapeType::kCuboid:
      // The two corners along axis i differ in height by 2 a_i |db_i|: when that is within the
      // tolerance, both touch and the centroid lies on the mid-plane (coordinate 0).
      for (int i = 0; i < 3; ++i) {
        if (2.0 * a[i] * std::abs(db[i]) > flat_tol_m) xb[i] = std::copysign(a[i], db[i]);
      }
      break;
    case ShapeType::kEllipsoid: {
      // Strictly convex: one support point x = A^2 d / |A d|.
      const double h = a.cwiseProduct(db).norm();
      if (h > 0.0) xb = a.cwiseProduct(a).cwiseProduct(db) / h;
      break;
    }
    case ShapeType::kCylinder: {
      const double c = std::clamp(db.z(), -1.0, 1.0);
      const double s = std::sqrt(std::max(0.0, 1.0 - c * c));
      // End disks differ in height by 2 L |c|; the rim's lowest point is R s below the centre
      // line, and the whole disk touches when R s is within the tolerance.
      if (2.0 * a.z() * std::abs(c) > flat_tol_m) xb.z() = std::copysign(a.z(), c);
      if (a.x() * s > flat_tol_m && s > 0.0) {
        xb.x() = a.x() * db.x() / s;
        xb.y() = a.x() * db.y() / s;
      }
      break;
    }
    case ShapeType::kPolyhedron:
      xb = b.scale * polyhedron_contact_point(*b.polyhedron, db, flat_tol_m / b.scale);
      break;
    default:
      xb = a.x() * db;  // sphere: |db| = 1
      break;
  }
  return q * xb;
}

namespace {

// 1 - cos of the largest tilt taken as lying flat already (toppled_attitude).
constexpr double kFlatCos = 1e-15;

// The hull face the ray from the centre along unit d leaves through: the least
// t = offset_f / (n_f . d) (scale-free), ties to the lower face (smaller offset).
std::size_t polyhedron_exit_face(const Polyhedron& p, const Vec3& d, double& t_exit) {
  const auto& normals = p.normals();
  const auto& offsets = p.offsets();
  std::size_t best = normals.size();
  t_exit = std::numeric_limits<double>::infinity();
  for (std::size_t f = 0; f < normals.size(); ++f) {
    const double c = normals[f].dot(d);
    if (!(c > 0.0)) continue;
    const double t = offsets[f] / c;
    if (t < t_exit || (t == t_exit && offsets[f] < offsets[best])) t_exit = t, best = f;
  }
  return best;
}

// The face a polyhedron comes to rest on: the face the line from the centre along db leaves
// through; lying on it, the centre may stand outside it (unlike a cuboid's), and then it falls on
// to the face the line along that face's normal leaves through, until the line leaves through the
// face it lies on (or one coplanar with it, within 1e-12). Each fall lowers the centre (from
// offset_f to offset_g < t_g <= offset_f), so this ends, at most once per face.
Vec3 polyhedron_resting_normal(const Polyhedron& p, const Vec3& db) {
  double t = 0.0;
  std::size_t f = polyhedron_exit_face(p, db, t);
  if (f == p.normals().size()) return db;
  for (std::size_t k = 0; k < p.normals().size(); ++k) {
    const std::size_t g = polyhedron_exit_face(p, p.normals()[f], t);
    if (g == p.normals().size() || g == f || t >= p.offsets()[f] * (1.0 - 1e-12)) break;
    f = g;
  }
  return p.normals()[f];
}

// The unit direction, in body axes, that is to point along -n once the body has toppled: the
// projection of db (= -n in body axes) onto the span of the resting face's normal(s).
Vec3 resting_direction(const ContactBody& b, const Vec3& db) {
  const Vec3& a = b.half_m;
  Vec3 keep = Vec3::Zero();  // 1 for the body axes the direction keeps
  switch (b.type) {
    case ShapeType::kCuboid: {
      // The face the line from the centre along db leaves through: the first face plane it
      // meets, at distance a_i / |db_i|; ties go to the thinner axis (the lower rest).
      int best = 0;
      for (int i = 1; i < 3; ++i) {
        const double lhs = std::abs(db[i]) * a[best], rhs = std::abs(db[best]) * a[i];
        if (lhs > rhs || (lhs == rhs && a[i] < a[best])) best = i;
      }
      keep[best] = 1.0;
      break;
    }
    case ShapeType::kCylinder: {
      const double c = std::abs(db.z()), s = std::sqrt(std::max(0.0, 1.0 - c * c));
      if (c * a.x() > s * a.z()) {
        keep.z() = 1.0;  // on an end disk
      } else {
        keep.x() = keep.y() = 1.0;  // on its side: the axis perpendicular to n
      }
      break;
    }
    case ShapeType::kEllipsoid: {
      const double shortest = a.minCoeff();  // stable only on the shortest axis (or axes)
      for (int i = 0; i < 3; ++i) keep[i] = a[i] == shortest ? 1.0 : 0.0;
      break;
    }
    case ShapeType::kPolyhedron: return polyhedron_resting_normal(*b.polyhedron, db);
    case ShapeType::kSphere:
    case ShapeType::kPoint: return db;
  }
  const Vec3 f = keep.cwiseProduct(db);
  const double fn = f.norm();
  if (fn > 0.0) return f / fn;
  // db perpendicular to every resting normal (a tie of measure zero): the first kept axis.
  for (int i = 0; i < 3; ++i)
    if (keep[i] > 0.0) return Vec3::Unit(i);
  return db;
}

}  // namespace

Quat toppled_attitude(const ContactBody& b, const Quat& q, const Vec3& n) {
  const Vec3 db = -(q.conjugate() * n);
  const Vec3 f = resting_direction(b, db);
  // Already resting on that face (tilted by less than ~5e-8 rad, what rounding leaves in an
  // attitude turned with the terrain): q exactly, not a near-identity rotation of it.
  if (f.dot(db) >= 1.0 - kFlatCos) return q;
  return (Quat::FromTwoVectors(q * f, -n) * q).normalized();
}

double projected_area(const ContactBody& b, const Quat& q, const Vec3& d) {
  const Vec3 db = q.conjugate() * d;  // body axes
  const Vec3& h = b.half_m;
  switch (b.type) {
    case ShapeType::kCuboid:
      // Full sizes 2h: |d_x| (2h_y)(2h_z) + ...
      return 4.0 * (std::abs(db.x()) * h.y() * h.z() + std::abs(db.y()) * h.x() * h.z() +
                    std::abs(db.z()) * h.x() * h.y());
    case ShapeType::kEllipsoid: return kPi * h.x() * h.y() * h.z() * db.cwiseQuotient(h).norm();
    case ShapeType::kCylinder: {
      // sqrt(1 - d_z^2) as |(d_x, d_y)|: exact for a flow along the axis (1 - d_z^2 is not).
      const double r = h.x(), len = 2.0 * h.z();
      return kPi * r * r * std::abs(db.z()) + 2.0 * r * len * std::hypot(db.x(), db.y());
    }
    case ShapeType::kPolyhedron: {
      const Polyhedron& p = *b.polyhedron;
      double sum = 0.0;
      for (std::size_t f = 0; f < p.normals().size(); ++f)
        sum += p.areas()[f] * std::abs(p.normals()[f].dot(db));
      return 0.5 * b.scale * b.scale * sum;
    }
    case ShapeType::kSphere:
    case ShapeType::kPoint: break;
  }
  return kPi * h.x() * h.x();
}

}  // namespace fragsim::fragments
