// Quickhull in 3-D (Barber, Dobkin & Huhdanpaa 1996) with a fixed tolerance relative to the size
// of the points, and the mass properties of a closed mesh by signed tetrahedra (Tonon 2004).
//
// The hull grows from a tetrahedron of four extreme points. Every point outside the current hull
// waits in the outside set of one face it lies above; the farthest point of a face is added by
// removing every face it sees (more than the tolerance above its plane) and joining the horizon,
// the boundary of the visible region, to it. A point no more than the tolerance above any face is
// dropped, so the hull keeps no vertex in the middle of a face or an edge, and faces are at most
// the tolerance from convex.
#include "core/fragments/convex_hull.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "core/common/error.h"

namespace fragsim::fragments {

namespace {

// The horizon of a new point is not a simple cycle, or a face's neighbour does not share its edge:
// points degenerate at the tolerance's level. Never seen in the tests (lattices, points on a
// sphere, random clouds, scanned boulders); refused rather than built wrong.
constexpr const char* kInconsistent =
    "the hull could not be built consistently (points degenerate at rounding level)";

struct Face {
  std::array<std::uint32_t, 3> v{};   // point indices, counter-clockwise from outside
  std::array<std::uint32_t, 3> nb{};  // face across edge (v[k], v[k+1])
  Vec3 n{0, 0, 0};                    // unit outward normal
  double d = 0.0;                     // plane: n.x = d
  std::vector<std::uint32_t> outside;
  bool alive = true;
};

// A horizon edge (a, b) as the visible face `visible` had it, and the face `across` that stays.
struct HorizonEdge {
  std::uint32_t a, b, across, visible;
};

class Quickhull {
 public:
  Quickhull(const std::vector<Vec3>& p, const std::string& field) : p_(p), field_(field) {}
  HullMesh build();

 private:
  double dist(const Face& f, std::uint32_t i) const { return f.n.dot(p_[i]) - f.d; }
  std::uint32_t add_face(std::uint32_t a, std::uint32_t b, std::uint32_t c, const Vec3& fallback_n);
  void initial_simplex();
  void assign(const std::vector<std::uint32_t>& points, const std::vector<std::uint32_t>& faces);
  void add_point(std::uint32_t f);
  void find_horizon(std::uint32_t start, std::uint32_t point);
  static int edge_to(const Face& f, std::uint32_t a, std::uint32_t b) {
    for (int k = 0; k < 3; ++k)
      if (f.v[k] == a && f.v[(k + 1) % 3] == b) return k;
    return -1;
  }
  [[noreturn]] void fail(const std::string& why) const { throw InputError(field_, why); }

  const std::vector<Vec3>& p_;
  const std::string& field_;
  double tol_ = 0.0;
  std::vector<Face> faces_;
  std::vector<std::uint32_t> stamp_;  // per face: == round_ when visible from the current point
  std::uint32_t round_ = 0;
  std::vector<std::uint32_t> visible_;
  std::vector<HorizonEdge> horizon_;
};

std::uint32_t Quickhull::add_face(std::uint32_t a, std::uint32_t b, std::uint32_t c,
                                  const Vec3& fallback_n) {
  Face f;
  f.v = {a, b, c};
  const Vec3 cr = (p_[b] - p_[a]).cross(p_[c] - p_[a]);
  const double len = cr.norm();
  // A sliver with no direction of its own (the new point on the horizon edge's line, within
  // the tolerance) takes the normal of the face it replaces.
  f.n = len > 0.0 ? Vec3(cr / len) : fallback_n;
  f.d = f.n.dot(p_[a] + p_[b] + p_[c]) / 3.0;
  faces_.push_back(std::move(f));
  stamp_.push_back(0);
  return static_cast<std::uint32_t>(faces_.size() - 1);
}

void Quickhull::initial_simplex() {
  const auto n = static_cast<std::uint32_t>(p_.size());
  Box3 box;
  double size = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (!p_[i].allFinite()) throw InputError(field_ + "[" + std::to_string(i) + "]", "not finite");
    box.extend(p_[i]);
  }
  for (int k = 0; k < 3; ++k) size += std::max(std::abs(box.lo[k]), std::abs(box.hi[k]));
  tol_ = kHullTolerance_rel * size;
  Eigen::Index axis = 0;
  const double extent = (box.hi - box.lo).maxCoeff(&axis);
  const double flat = std::max(kHullFlatness_rel * extent, tol_);
  if (!(extent > flat)) fail("all points coincide: a polyhedron needs volume");

  // Two extreme points along the longest side, the farthest from their line, the farthest from
  // the plane of the three.
  std::uint32_t i0 = 0, i1 = 0;
  for (std::uint32_t i = 0; i < n; ++i) {
    if (p_[i][axis] < p_[i0][axis]) i0 = i;
    if (p_[i][axis] > p_[i1][axis]) i1 = i;
  }
  const Vec3 u = (p_[i1] - p_[i0]).normalized();
  std::uint32_t i2 = i0;
  double best = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const double dl = (p_[i] - p_[i0]).cross(u).norm();
    if (dl > best) best = dl, i2 = i;
  }
  if (!(best > flat)) fail("the points are (nearly) collinear: a polyhedron needs volume");
  const Vec3 pn = (p_[i1] - p_[i0]).cross(p_[i2] - p_[i0]).normalized();
  std::uint32_t i3 = i0;
  best = 0.0;
  for (std::uint32_t i = 0; i < n; ++i) {
    const double dp = std::abs(pn.dot(p_[i] - p_[i0]));
    if (dp > best) best = dp, i3 = i;
  }
  if (!(best > flat)) fail("the points are (nearly) coplanar: a polyhedron needs volume");

  // Orient (i0, i1, i2) so that i3 lies below it; the other faces follow.
  if (pn.dot(p_[i3] - p_[i0]) > 0.0) std::swap(i1, i2);
  const std::array<std::array<std::uint32_t, 3>, 4> tri = {
      {{i0, i1, i2}, {i0, i3, i1}, {i1, i3, i2}, {i2, i3, i0}}};
  for (const auto& t : tri) add_face(t[0], t[1], t[2], Vec3::UnitZ());
  for (std::uint32_t f = 0; f < 4; ++f) {
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = faces_[f].v[k], b = faces_[f].v[(k + 1) % 3];
      for (std::uint32_t g = 0; g < 4; ++g)
        if (g != f && edge_to(faces_[g], b, a) >= 0) faces_[f].nb[k] = g;
    }
  }
  std::vector<std::uint32_t> rest;
  for (std::uint32_t i = 0; i < n; ++i)
    if (i != i0 && i != i1 && i != i2 && i != i3) rest.push_back(i);
  assign(rest, {0, 1, 2, 3});
}

// Each point goes to the outside set of the face it lies farthest above; no such face: inside.
void Quickhull::assign(const std::vector<std::uint32_t>& points,
                       const std::vector<std::uint32_t>& faces) {
  for (const std::uint32_t i : points) {
    double best = tol_;
    std::uint32_t to = 0;
    bool found = false;
    for (const std::uint32_t f : faces) {
      const double h = dist(faces_[f], i);
      if (h > best) best = h, to = f, found = true;
    }
    if (found) faces_[to].outside.push_back(i);
  }
}

// The faces `point` sees, flooded from `start`, and the horizon as the edges from a visible to a
// non-visible face. Each visible face's edges are taken in turn from the one it was entered by
// (the order of a depth-first walk around the visible region).
void Quickhull::find_horizon(std::uint32_t start, std::uint32_t point) {
  ++round_;
  visible_.clear();
  horizon_.clear();
  struct Frame {
    std::uint32_t face;
    int first, done;
  };
  std::vector<Frame> stack{{start, 0, 0}};
  stamp_[start] = round_;
  visible_.push_back(start);
  while (!stack.empty()) {
    Frame& fr = stack.back();
    if (fr.done == 3) {
      stack.pop_back();
      continue;
    }
    const int k = (fr.first + fr.done++) % 3;
    const Face& f = faces_[fr.face];
    const std::uint32_t g = f.nb[k];
    if (stamp_[g] == round_) continue;
    if (dist(faces_[g], point) > tol_) {
      stamp_[g] = round_;
      visible_.push_back(g);
      const int back = edge_to(faces_[g], f.v[(k + 1) % 3], f.v[k]);
      if (back < 0) fail(kInconsistent);
      stack.push_back({g, back, 1});
    } else {
      horizon_.push_back({f.v[k], f.v[(k + 1) % 3], g, fr.face});
    }
  }
}

void Quickhull::add_point(std::uint32_t f) {
  const auto& out = faces_[f].outside;
  std::uint32_t point = out.front();
  for (const std::uint32_t i : out)
    if (dist(faces_[f], i) > dist(faces_[f], point)) point = i;
  find_horizon(f, point);

  // The cone of new faces (a, b, point) over the horizon, linked to the faces that stay and to
  // each other: the horizon is a simple cycle, each vertex starts one edge and ends one.
  std::unordered_map<std::uint32_t, std::uint32_t> starting_at, ending_at;
  std::vector<std::uint32_t> cone;
  for (const HorizonEdge& e : horizon_) {
    const std::uint32_t nf = add_face(e.a, e.b, point, faces_[e.visible].n);
    cone.push_back(nf);
    faces_[nf].nb[0] = e.across;
    Face& across = faces_[e.across];
    const int k = edge_to(across, e.b, e.a);
    if (k < 0 || !starting_at.emplace(e.a, nf).second || !ending_at.emplace(e.b, nf).second)
      fail(kInconsistent);
    across.nb[static_cast<std::size_t>(k)] = nf;
  }
  for (const std::uint32_t nf : cone) {
    Face& face = faces_[nf];
    const auto s = starting_at.find(face.v[1]), e = ending_at.find(face.v[0]);
    if (s == starting_at.end() || e == ending_at.end()) fail(kInconsistent);
    face.nb[1] = s->second;  // edge (b, point) borders the new face over the edge from b
    face.nb[2] = e->second;  // edge (point, a) borders the new face over the edge into a
  }
  std::vector<std::uint32_t> orphans;
  for (const std::uint32_t vf : visible_) {
    for (const std::uint32_t i : faces_[vf].outside)
      if (i != point) orphans.push_back(i);
    faces_[vf].outside.clear();
    faces_[vf].outside.shrink_to_fit();
    faces_[vf].alive = false;
  }
  assign(orphans, cone);
}

HullMesh Quickhull::build() {
  if (p_.size() < 4)
    fail("a polyhedron needs at least 4 points (got " + std::to_string(p_.size()) + ")");
  initial_simplex();
  // Faces are processed in the order they were made: deterministic, whatever the machine.
  for (std::uint32_t f = 0; f < faces_.size(); ++f)
    if (faces_[f].alive && !faces_[f].outside.empty()) add_point(f);

  HullMesh mesh;
  std::vector<std::uint32_t> index(p_.size(), UINT32_MAX);
  std::size_t edges2 = 0;
  for (const Face& f : faces_) {
    if (!f.alive) continue;
    std::array<std::uint32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      std::uint32_t& id = index[f.v[k]];
      if (id == UINT32_MAX) {
        id = static_cast<std::uint32_t>(mesh.vertices.size());
        mesh.vertices.push_back(p_[f.v[k]]);
      }
      t[k] = id;
    }
    mesh.triangles.push_back(t);
    edges2 += 3;
  }
  // Euler's formula for a closed surface of genus 0: V - E + F = 2.
  const auto v = static_cast<long>(mesh.vertices.size()), e = static_cast<long>(edges2 / 2),
             fc = static_cast<long>(mesh.triangles.size());
  if (v - e + fc != 2) fail("the hull could not be built consistently (Euler characteristic)");
  return mesh;
}

}  // namespace

HullMesh convex_hull(const std::vector<Vec3>& points, const std::string& field) {
  return Quickhull(points, field).build();
}

MeshMass mesh_mass(const HullMesh& mesh) {
  // Signed tetrahedra from a reference point o inside (the mean vertex, which keeps the
  // coordinates small): with a, b, c a triangle's vertices relative to o, the tetrahedron
  // (o, a, b, c) has volume V = a.(b x c) / 6 (eq. P1), centroid (a + b + c) / 4 (eq. P2) and
  // int x x^T dV = V / 20 (a a^T + b b^T + c c^T + s s^T), s = a + b + c (eq. P3; Tonon 2004,
  // eqs. 2-3 written as one tensor). Summed with signs they give the solid's moments exactly.
  MeshMass m;
  Vec3 o = Vec3::Zero();
  for (const Vec3& v : mesh.vertices) o += v;
  o /= static_cast<double>(mesh.vertices.size());
  Vec3 first = Vec3::Zero();
  Mat3 second = Mat3::Zero();
  for (const auto& t : mesh.triangles) {
    const Vec3 a = mesh.vertices[t[0]] - o, b = mesh.vertices[t[1]] - o,
               c = mesh.vertices[t[2]] - o;
    const Vec3 cr = (b - a).cross(c - a);
    m.surface_m2 += 0.5 * cr.norm();
    const double vol = a.dot(b.cross(c)) / 6.0;
    const Vec3 s = a + b + c;
    m.volume_m3 += vol;
    first += vol * s / 4.0;
    second += vol / 20.0 *
              (a * a.transpose() + b * b.transpose() + c * c.transpose() + s * s.transpose());
  }
  const Vec3 g = first / m.volume_m3;  // centroid relative to o
  m.centroid_m = o + g;
  // Parallel axes to the centroid (eq. P4): C_c = C_o - V g g^T, then I = tr(C) 1 - C.
  const Mat3 c = second - m.volume_m3 * g * g.transpose();
  m.inertia_m5 = c.trace() * Mat3::Identity() - c;
  return m;
}

}  // namespace fragsim::fragments
