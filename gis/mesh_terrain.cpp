// Mesh terrain (mesh_terrain.h): axis map, welding, the height-surface check, grid resampling.
#include "gis/mesh_terrain.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "api/json_fields.h"
#include "core/common/error.h"
#include "core/scene/validation.h"

namespace fragsim::gis {

namespace {

using Tri = std::array<std::uint32_t, 3>;
using Json = nlohmann::json;
using OJson = nlohmann::ordered_json;

const char* const kResampleHint =
    "; \"grid_spacing_m\" resamples such a mesh to a grid terrain of the highest surface (a "
    "cliff then becomes a steep slope one grid cell wide)";

std::string xy_text(double x, double y) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "(%.3f, %.3f)", x, y);
  return buf;
}

double orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

// All files' facets, mapped and welded; where each triangle came from.
struct Assembled {
  std::vector<Vec3> vertices;
  std::vector<Tri> triangles;
  std::vector<std::uint32_t> file, facet;  // per triangle
  std::vector<std::uint32_t> material;     // per triangle: index into names
  std::vector<std::string> names;          // materials; names[0] is the first file's
  std::size_t file_facets = 0;
};

// Vertices closer than `tol` share one id (the first one's position): a hash grid of cells of
// 4 tol, searching the neighbour cells a point is within tol of. tol = 0 merges equal positions.
class Welder {
 public:
  explicit Welder(double tol) : tol_(tol), cell_(tol > 0 ? 4 * tol : 1.0) {}
  std::uint32_t add(const Vec3& p, std::vector<Vec3>& out) {
    Key c{};
    std::array<std::array<std::int64_t, 2>, 3> steps{};  // per axis: 0 and maybe -1 or +1
    std::array<int, 3> nsteps{};
    for (int k = 0; k < 3; ++k) {
      const double f = std::floor(p[k] / cell_);
      c[k] = static_cast<std::int64_t>(f);
      const double in = p[k] - f * cell_;
      steps[k][0] = 0;
      nsteps[k] = 1;
      if (in <= tol_) steps[k][nsteps[k]++] = -1;
      if (in >= cell_ - tol_) steps[k][nsteps[k]++] = 1;
    }
    for (int a = 0; a < nsteps[0]; ++a)
      for (int b = 0; b < nsteps[1]; ++b)
        for (int d = 0; d < nsteps[2]; ++d) {
          const auto it = head_.find({c[0] + steps[0][a], c[1] + steps[1][b], c[2] + steps[2][d]});
          if (it == head_.end()) continue;
          for (std::uint32_t v = it->second; v != kNone; v = next_[v])
            if ((out[v] - p).norm() <= tol_) return v;
        }
    const auto id = static_cast<std::uint32_t>(out.size());
    out.push_back(p);
    auto [it, fresh] = head_.emplace(c, id);
    next_.push_back(fresh ? kNone : it->second);
    it->second = id;
    return id;
  }

 private:
  using Key = std::array<std::int64_t, 3>;
  struct Hash {  // splitmix64's finaliser over the three cell indices
    static std::uint64_t mix(std::uint64_t x) {
      x ^= x >> 30;
      x *= 0xbf58476d1ce4e5b9ULL;
      x ^= x >> 27;
      x *= 0x94d049bb133111ebULL;
      return x ^ (x >> 31);
    }
    std::size_t operator()(const Key& k) const {
      return static_cast<std::size_t>(
          mix(static_cast<std::uint64_t>(k[0]) ^
              mix(static_cast<std::uint64_t>(k[1]) ^ mix(static_cast<std::uint64_t>(k[2])))));
    }
  };
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  double tol_, cell_;
  std::unordered_map<Key, std::uint32_t, Hash> head_;
  std::vector<std::uint32_t> next_;
};

std::uint32_t name_index(std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  if (it != names.end()) return static_cast<std::uint32_t>(it - names.begin());
  names.push_back(name);
  return static_cast<std::uint32_t>(names.size() - 1);
}

// The material of each of the file's groups: material_by_group of its usemtl, g or o name (in
// that order), else the file's material. A material_by_group key that names no group is refused.
std::vector<std::uint32_t> group_materials(const MeshData& m, const MeshSource& src,
                                           const std::string& field,
                                           std::vector<std::string>& names) {
  std::vector<std::uint32_t> out;
  for (const FaceGroup& g : m.groups) {
    std::string mat = src.material;
    for (const std::string* n : {&g.material, &g.group, &g.object}) {
      const auto it = src.material_by_group.find(*n);
      if (!n->empty() && it != src.material_by_group.end()) {
        mat = it->second;
        break;
      }
    }
    out.push_back(name_index(names, mat));
  }
  for (const auto& entry : src.material_by_group) {
    const std::string& group = entry.first;
    const bool found = std::any_of(m.groups.begin(), m.groups.end(), [&](const FaceGroup& g) {
      return g.material == group || g.group == group || g.object == group;
    });
    if (found) continue;
    std::string have;
    for (const FaceGroup& g : m.groups)
      for (const std::string* n : {&g.material, &g.group, &g.object})
        if (!n->empty() && have.find("\"" + *n + "\"") == std::string::npos)
          have += (have.empty() ? "" : ", ") + ("\"" + *n + "\"");
    throw InputError(api::child_path(field + ".material_by_group", group),
                     file_label(src.path) + " has no group of that name (its groups: " +
                         (have.empty() ? "none" : have) + ")");
  }
  return out;
}

Assembled assemble(const MeshTerrainImport& spec) {
  Assembled a;
  a.names.push_back(spec.meshes.at(0).material);
  Welder welder(spec.weld_m);
  for (std::size_t f = 0; f < spec.meshes.size(); ++f) {
    const MeshSource& src = spec.meshes[f];
    const std::string field = api::index_path(spec.field + ".meshes", f);
    const MeshData m = read_mesh_file(src.path, field);
    const std::vector<std::uint32_t> mats = group_materials(m, src, field, a.names);
    std::vector<std::uint32_t> id(m.vertices.size(), std::numeric_limits<std::uint32_t>::max());
    a.file_facets += m.triangles.size();
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      Tri tri{};
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t v = m.triangles[t][k];
        if (id[v] == std::numeric_limits<std::uint32_t>::max())
          id[v] = welder.add(spec.axes.apply(m.vertices[v]), a.vertices);
        tri[k] = id[v];
      }
      const bool merged = tri[0] == tri[1] || tri[1] == tri[2] || tri[0] == tri[2];
      if (merged ||
          scene::detail::is_zero_area(a.vertices[tri[0]], a.vertices[tri[1]], a.vertices[tri[2]]))
        throw InputError(field, file_label(src.path) + ": facet " + std::to_string(m.facet[t]) +
                                    ": welding (weld_m = " + api::format_number(spec.weld_m) +
                                    " m) leaves it without area" +
                                    (merged ? " (two of its vertices merge)" : "") +
                                    "; give a smaller weld_m");
      a.triangles.push_back(tri);
      a.file.push_back(static_cast<std::uint32_t>(f));
      a.facet.push_back(m.facet[t]);
      a.material.push_back(mats[m.group[t]]);
    }
  }
  return a;
}

// The triangles' plan (x, y) bounding boxes in a bucket grid of about one triangle per cell:
// each triangle listed in every cell its box touches (compressed rows).
class PlanIndex {
 public:
  PlanIndex(const std::vector<Vec3>& v, const std::vector<Tri>& tris,
            const std::vector<std::uint32_t>& members)
      : v_(v), tris_(tris) {
    double sx = 0, sy = 0;
    for (const auto t : members) {
      const auto b = box(t);
      lo_ = lo_.cwiseMin(Vec2(b[0], b[1]));
      hi_ = hi_.cwiseMax(Vec2(b[2], b[3]));
      sx += b[2] - b[0];
      sy += b[3] - b[1];
    }
    const double n = std::max<double>(1.0, static_cast<double>(members.size()));
    const Vec2 ext = (hi_ - lo_).cwiseMax(Vec2(1e-9, 1e-9));
    cell_ = std::max({std::sqrt(ext.x() * ext.y() / n), sx / n, sy / n, 1e-9});
    while ((ext.x() / cell_ + 1) * (ext.y() / cell_ + 1) > 4 * n + 16) cell_ *= 1.5;
    ncx_ = static_cast<int>(ext.x() / cell_) + 1;
    ncy_ = static_cast<int>(ext.y() / cell_) + 1;
    start_.assign(static_cast<std::size_t>(ncx_) * ncy_ + 1, 0);
    for (const auto t : members) each_cell(t, [&](std::size_t c) { ++start_[c + 1]; });
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    items_.resize(start_.back());
    std::vector<std::size_t> fill(start_.begin(), start_.end() - 1);
    for (const auto t : members) each_cell(t, [&](std::size_t c) { items_[fill[c]++] = t; });
  }

  std::array<double, 4> box(std::uint32_t t) const {
    const Vec3 &a = v_[tris_[t][0]], &b = v_[tris_[t][1]], &c = v_[tris_[t][2]];
    return {std::min({a.x(), b.x(), c.x()}), std::min({a.y(), b.y(), c.y()}),
            std::max({a.x(), b.x(), c.x()}), std::max({a.y(), b.y(), c.y()})};
  }
  // Cell ranges [i0, i1] x [j0, j1] of a triangle's box.
  std::array<int, 4> range(std::uint32_t t) const {
    const auto b = box(t);
    return {ci(b[0]), cj(b[1]), ci(b[2]), cj(b[3])};
  }
  int ncx() const { return ncx_; }
  std::size_t cells() const { return start_.size() - 1; }
  // The triangles listed in cell c.
  std::pair<const std::uint32_t*, const std::uint32_t*> in_cell(std::size_t c) const {
    return {items_.data() + start_[c], items_.data() + start_[c + 1]};
  }
  // The triangles whose boxes may hold the point.
  std::pair<const std::uint32_t*, const std::uint32_t*> at(double x, double y) const {
    const int i = ci(x), j = cj(y);
    if (i < 0 || j < 0 || i >= ncx_ || j >= ncy_) return {nullptr, nullptr};
    return in_cell(static_cast<std::size_t>(j) * ncx_ + i);
  }

 private:
  int ci(double x) const {
    return std::clamp(static_cast<int>(std::floor((x - lo_.x()) / cell_)), -1, ncx_);
  }
  int cj(double y) const {
    return std::clamp(static_cast<int>(std::floor((y - lo_.y()) / cell_)), -1, ncy_);
  }
  template <class F>
  void each_cell(std::uint32_t t, F&& f) const {
    const auto r = range(t);
    for (int j = std::max(r[1], 0); j <= std::min(r[3], ncy_ - 1); ++j)
      for (int i = std::max(r[0], 0); i <= std::min(r[2], ncx_ - 1); ++i)
        f(static_cast<std::size_t>(j) * ncx_ + i);
  }

  const std::vector<Vec3>& v_;
  const std::vector<Tri>& tris_;
  Vec2 lo_{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
  Vec2 hi_{-std::numeric_limits<double>::infinity(), -std::numeric_limits<double>::infinity()};
  double cell_ = 1;
  int ncx_ = 1, ncy_ = 1;
  std::vector<std::size_t> start_;
  std::vector<std::uint32_t> items_;
};

std::array<Vec2, 3> plan(const Assembled& a, std::uint32_t t) {
  return {a.vertices[a.triangles[t][0]].head<2>(), a.vertices[a.triangles[t][1]].head<2>(),
          a.vertices[a.triangles[t][2]].head<2>()};
}

// Whether two plan triangles' interiors overlap (more than 1e-9 of their size: triangles that
// share an edge or a vertex only touch). Separating axes: the six edge normals.
bool interiors_overlap(std::array<Vec2, 3> p, std::array<Vec2, 3> q) {
  const Vec2 o = p[0];  // relative to a vertex: projections of CRS-sized coordinates keep digits
  for (int k = 0; k < 3; ++k) {
    p[k] -= o;
    q[k] -= o;
  }
  double size = 0;
  for (int k = 0; k < 3; ++k)
    size = std::max({size, (p[(k + 1) % 3] - p[k]).norm(), (q[(k + 1) % 3] - q[k]).norm()});
  const double tol = 1e-9 * size;
  for (const auto* tri : {&p, &q})
    for (int k = 0; k < 3; ++k) {
      const Vec2 e = (*tri)[(k + 1) % 3] - (*tri)[k];
      const Vec2 n = Vec2(-e.y(), e.x()).normalized();
      double p0 = n.dot(p[0]), p1 = p0, q0 = n.dot(q[0]), q1 = q0;
      for (int i = 1; i < 3; ++i) {
        p0 = std::min(p0, n.dot(p[i]));
        p1 = std::max(p1, n.dot(p[i]));
        q0 = std::min(q0, n.dot(q[i]));
        q1 = std::max(q1, n.dot(q[i]));
      }
      if (p1 <= q0 + tol || q1 <= p0 + tol) return false;
    }
  return true;
}

std::string facet_name(const MeshTerrainImport& spec, const Assembled& a, std::uint32_t t) {
  return "facet " + std::to_string(a.facet[t]) + " of " + file_label(spec.meshes[a.file[t]].path);
}

[[noreturn]] void refuse(const MeshTerrainImport& spec, const Assembled& a, std::uint32_t t,
                         const std::string& reason) {
  throw InputError(api::index_path(spec.field + ".meshes", a.file[t]),
                   file_label(spec.meshes[a.file[t]].path) + ": facet " +
                       std::to_string(a.facet[t]) + ": " + reason);
}

bool is_vertical(const Assembled& a, std::uint32_t t) {
  const auto p = plan(a, t);
  return scene::detail::is_zero_area_2d(p[0], p[1], p[2]);
}

// A mesh terrain must be a height surface: no vertical facet, no two facets overlapping in plan.
void check_height_surface(const MeshTerrainImport& spec, const Assembled& a) {
  const auto nt = static_cast<std::uint32_t>(a.triangles.size());
  std::size_t vertical = 0;
  std::uint32_t first = nt;
  for (std::uint32_t t = 0; t < nt; ++t)
    if (is_vertical(a, t) && vertical++ == 0) first = t;
  if (vertical > 0)
    refuse(spec, a, first,
           "vertical (its plan projection has no area; " + std::to_string(vertical) +
               " vertical facets in all): the terrain must be a height surface" + kResampleHint);
  std::vector<std::uint32_t> all(nt);
  for (std::uint32_t t = 0; t < nt; ++t) all[t] = t;
  const PlanIndex index(a.vertices, a.triangles, all);
  std::size_t pairs = 0;
  std::pair<std::uint32_t, std::uint32_t> worst{nt, nt};
  for (std::size_t c = 0; c < index.cells(); ++c) {
    const auto [b, e] = index.in_cell(c);
    const int ci = static_cast<int>(c % index.ncx()), cj = static_cast<int>(c / index.ncx());
    for (const std::uint32_t* s = b; s != e; ++s)
      for (const std::uint32_t* u = s + 1; u != e; ++u) {
        const auto rs = index.range(*s), ru = index.range(*u);
        // Each pair once: in the first cell both boxes touch.
        if (std::max(rs[0], ru[0]) != ci || std::max(rs[1], ru[1]) != cj) continue;
        const auto bs = index.box(*s), bu = index.box(*u);
        if (bs[2] <= bu[0] || bu[2] <= bs[0] || bs[3] <= bu[1] || bu[3] <= bs[1]) continue;
        if (!interiors_overlap(plan(a, *s), plan(a, *u))) continue;
        ++pairs;
        worst = std::min(worst, std::make_pair(std::min(*s, *u), std::max(*s, *u)));
      }
  }
  if (pairs == 0) return;
  const Vec3 g =
      (a.vertices[a.triangles[worst.first][0]] + a.vertices[a.triangles[worst.first][1]] +
       a.vertices[a.triangles[worst.first][2]]) /
      3.0;
  refuse(spec, a, worst.first,
         "overlaps " + facet_name(spec, a, worst.second) + " in plan near " +
             xy_text(g.x(), g.y()) + " (an overhang or a fold; " + std::to_string(pairs) +
             " overlapping pairs in all): the terrain must be a height surface" + kResampleHint);
}

// The highest surface of the indexed triangles at (x, y), and its triangle; nullopt if none is
// above the point (its boundary included, to 1e-9 of a triangle).
std::optional<std::pair<double, std::uint32_t>> highest_at(const PlanIndex& index,
                                                           const Assembled& a, double x, double y) {
  std::optional<std::pair<double, std::uint32_t>> best;
  const Vec2 q(x, y);
  for (auto [b, e] = index.at(x, y); b != e; ++b) {
    const auto p = plan(a, *b);
    const double d = orient(p[0], p[1], p[2]);
    const double l0 = orient(q, p[1], p[2]) / d, l1 = orient(p[0], q, p[2]) / d,
                 l2 = orient(p[0], p[1], q) / d;
    if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
    const auto& t = a.triangles[*b];
    const double z =
        l0 * a.vertices[t[0]].z() + l1 * a.vertices[t[1]].z() + l2 * a.vertices[t[2]].z();
    if (!best || z > best->first) best = std::make_pair(z, *b);
  }
  return best;
}

OJson names_json(const std::vector<std::string>& names) {
  OJson j = OJson::array();
  for (const auto& n : names) j.push_back(n);
  return j;
}

// A lattice of nx x ny nodes, spacing s from (x0, y0): node (i, j) at k = j nx + i.
struct Lattice {
  int nx = 0, ny = 0;
  double x0 = 0, y0 = 0, s = 0;
  std::vector<double> z;           // the highest surface at each node
  std::vector<std::uint32_t> top;  // the facet it is on (valid where covered)
  std::vector<char> covered;       // some facet above the node
  std::size_t missing = 0, first_missing = 0;
};

// The highest surface at every node of the lattice over the facets' plan box.
Lattice sample_lattice(const MeshTerrainImport& spec, const Assembled& a, const PlanIndex& index,
                       const std::vector<std::uint32_t>& members) {
  const double s = *spec.grid_spacing_m;
  Vec2 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (const auto t : members)
    for (const auto v : a.triangles[t]) {
      lo = lo.cwiseMin(a.vertices[v].head<2>());
      hi = hi.cwiseMax(a.vertices[v].head<2>());
    }
  Lattice l;
  l.s = s;
  l.x0 = std::ceil(lo.x() / s - 1e-9) * s;
  l.y0 = std::ceil(lo.y() / s - 1e-9) * s;
  l.nx = static_cast<int>(std::floor((hi.x() - l.x0) / s + 1e-9)) + 1;
  l.ny = static_cast<int>(std::floor((hi.y() - l.y0) / s + 1e-9)) + 1;
  const std::string field = spec.field + ".grid_spacing_m";
  if (l.nx < 2 || l.ny < 2)
    throw InputError(field, "gives fewer than 2 x 2 nodes over the meshes' plan extent");
  if (static_cast<double>(l.nx) * l.ny > 4e8)
    throw InputError(field, "gives " + api::format_number(static_cast<double>(l.nx) * l.ny) +
                                " nodes: too fine for the meshes' extent");
  const std::size_t n = static_cast<std::size_t>(l.nx) * l.ny;
  l.z.assign(n, 0.0);
  l.top.assign(n, 0);
  l.covered.assign(n, 0);
  for (int j = 0; j < l.ny; ++j)
    for (int i = 0; i < l.nx; ++i) {
      const std::size_t k = static_cast<std::size_t>(j) * l.nx + i;
      const auto h = highest_at(index, a, l.x0 + i * s, l.y0 + j * s);
      if (!h && l.missing++ == 0) l.first_missing = k;
      if (h) std::tie(l.z[k], l.top[k]) = *h;
      l.covered[k] = h ? 1 : 0;
    }
  return l;
}

// The material of each lattice triangle: the facet highest under its centroid (or under the
// cell's first node when none is).
std::vector<std::uint32_t> lattice_materials(const Assembled& a, const PlanIndex& index,
                                             const Lattice& l) {
  std::vector<std::uint32_t> mat(2 * static_cast<std::size_t>(l.nx - 1) * (l.ny - 1));
  for (int j = 0; j + 1 < l.ny; ++j)
    for (int i = 0; i + 1 < l.nx; ++i) {
      const std::size_t k = static_cast<std::size_t>(j) * (l.nx - 1) + i;
      const double x = l.x0 + i * l.s, y = l.y0 + j * l.s;
      // Cell k: triangle 2k = (v00, v10, v11), 2k + 1 = (v00, v11, v01) (terrain_builder.cpp).
      const std::array<Vec2, 2> centroid{Vec2(x + 2 * l.s / 3, y + l.s / 3),
                                         Vec2(x + l.s / 3, y + 2 * l.s / 3)};
      for (int h = 0; h < 2; ++h) {
        const auto top = highest_at(index, a, centroid[h].x(), centroid[h].y());
        const std::uint32_t t = top ? top->second : l.top[static_cast<std::size_t>(j) * l.nx + i];
        mat[2 * k + h] = a.material[t];
      }
    }
  return mat;
}

// The lattice's cells whose four corners are covered, as a mesh terrain (the used nodes, the
// cells' two triangles in the lattice's order) and the kept triangles' materials.
std::pair<OJson, std::vector<std::uint32_t>> covered_mesh(const Lattice& l,
                                                          const std::vector<std::uint32_t>& mat) {
  std::vector<std::int64_t> id(l.z.size(), -1);
  OJson vertices = OJson::array(), triangles = OJson::array();
  std::vector<std::uint32_t> kept;
  const auto node = [&](int i, int j) {
    const std::size_t k = static_cast<std::size_t>(j) * l.nx + i;
    if (id[k] < 0) {
      id[k] = static_cast<std::int64_t>(vertices.size());
      vertices.push_back({l.x0 + i * l.s, l.y0 + j * l.s, l.z[k]});
    }
    return id[k];
  };
  for (int j = 0; j + 1 < l.ny; ++j)
    for (int i = 0; i + 1 < l.nx; ++i) {
      const auto c = [&](int di, int dj) {
        return l.covered[static_cast<std::size_t>(j + dj) * l.nx + i + di] != 0;
      };
      if (!(c(0, 0) && c(1, 0) && c(0, 1) && c(1, 1))) continue;
      const auto v00 = node(i, j), v10 = node(i + 1, j), v11 = node(i + 1, j + 1),
                 v01 = node(i, j + 1);
      const std::size_t k = static_cast<std::size_t>(j) * (l.nx - 1) + i;
      triangles.push_back({v00, v10, v11});
      triangles.push_back({v00, v11, v01});
      kept.push_back(mat[2 * k]);
      kept.push_back(mat[2 * k + 1]);
    }
  OJson mesh = {{"vertices_m", std::move(vertices)}, {"triangles", std::move(triangles)}};
  return {std::move(mesh), std::move(kept)};
}

// Resampled to the lattice of the highest surface: a grid terrain when the facets cover their
// plan box, else (a survey's outline) a mesh of the lattice cells with all four corners covered,
// whose boundary follows the covered area.
ImportedMeshTerrain resample(const MeshTerrainImport& spec, const Assembled& a) {
  std::vector<std::uint32_t> members;
  for (std::uint32_t t = 0; t < a.triangles.size(); ++t)
    if (!is_vertical(a, t)) members.push_back(t);
  const PlanIndex index(a.vertices, a.triangles, members);
  const Lattice l = sample_lattice(spec, a, index, members);
  const std::vector<std::uint32_t> mat = lattice_materials(a, index, l);
  ImportedMeshTerrain out;
  out.terrain["material"] = a.names[0];
  const double x1 = l.x0 + (l.nx - 1) * l.s, y1 = l.y0 + (l.ny - 1) * l.s;
  out.outline_m = {Vec2(l.x0, l.y0), Vec2(x1, l.y0), Vec2(x1, y1), Vec2(l.x0, y1)};
  out.uncovered_nodes = l.missing;
  if (l.missing == 0) {
    out.nx = l.nx;
    out.ny = l.ny;
    out.vertices = l.z.size();
    out.triangles = mat.size();
    out.terrain["grid"] = {{"origin_m", {l.x0, l.y0}},
                           {"spacing_m", l.s},
                           {"nx", l.nx},
                           {"ny", l.ny},
                           {"elevation_m", l.z}};
    out.terrain["triangle_materials"] = {{"names", names_json(a.names)}, {"index", mat}};
    return out;
  }
  auto [mesh, kept] = covered_mesh(l, mat);
  out.vertices = mesh["vertices_m"].size();
  out.triangles = kept.size();
  if (out.triangles == 0)
    throw InputError(spec.field + ".grid_spacing_m",
                     "no grid cell has mesh above all four corners (the first uncovered node at " +
                         xy_text(l.x0 + static_cast<double>(l.first_missing % l.nx) * l.s,
                                 l.y0 + static_cast<double>(l.first_missing / l.nx) * l.s) +
                         ")");
  out.terrain["mesh"] = std::move(mesh);
  out.terrain["triangle_materials"] = {{"names", names_json(a.names)}, {"index", kept}};
  return out;
}

ImportedMeshTerrain as_mesh(const Assembled& a) {
  ImportedMeshTerrain out;
  out.vertices = a.vertices.size();
  out.triangles = a.triangles.size();
  OJson vertices = OJson::array(), triangles = OJson::array();
  Vec2 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (const Vec3& v : a.vertices) {
    vertices.push_back({v.x(), v.y(), v.z()});
    lo = lo.cwiseMin(v.head<2>());
    hi = hi.cwiseMax(v.head<2>());
  }
  for (std::uint32_t t = 0; t < a.triangles.size(); ++t) {
    Tri tri = a.triangles[t];
    const auto p = plan(a, t);
    if (orient(p[0], p[1], p[2]) < 0) std::swap(tri[1], tri[2]);  // counter-clockwise from above
    triangles.push_back({tri[0], tri[1], tri[2]});
  }
  out.terrain["material"] = a.names[0];
  out.terrain["mesh"] = {{"vertices_m", std::move(vertices)}, {"triangles", std::move(triangles)}};
  out.terrain["triangle_materials"] = {{"names", names_json(a.names)}, {"index", a.material}};
  out.outline_m = {lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())};
  return out;
}

}  // namespace

AxisMap parse_axes(const Json& j, const std::string& field) {
  std::vector<std::string> names;
  if (j.is_string()) {
    const std::string s = j.get<std::string>();
    if (s == "z_up") return AxisMap{};
    if (s != "y_up")
      throw InputError(field,
                       "must be \"z_up\", \"y_up\" or three axes such as [\"x\", \"-z\", "
                       "\"y\"] (got \"" +
                           s + "\")");
    names = {"x", "-z", "y"};
  } else {
    const Json& arr = api::read_array(j, field, 3);
    for (std::size_t k = 0; k < 3; ++k)
      names.push_back(api::read_string(arr[k], api::index_path(field, k)));
  }
  AxisMap m;
  std::array<bool, 3> used{false, false, false};
  for (std::size_t k = 0; k < 3; ++k) {
    std::string n = names[k];
    double sign = 1;
    if (!n.empty() && (n[0] == '-' || n[0] == '+')) {
      sign = n[0] == '-' ? -1 : 1;
      n.erase(0, 1);
    }
    if (n.size() != 1 || n[0] < 'x' || n[0] > 'z')
      throw InputError(api::index_path(field, k),
                       "must be one of \"x\", \"-x\", \"y\", \"-y\", "
                       "\"z\", \"-z\" (got \"" +
                           names[k] + "\")");
    const int from = n[0] - 'x';
    if (used[from])
      throw InputError(field, "names the file's " + n + " axis twice (each axis once)");
    used[from] = true;
    m.from[k] = from;
    m.sign[k] = sign;
  }
  // The determinant of the signed permutation: the permutation's parity times the signs.
  int inversions = 0;
  for (int p = 0; p < 3; ++p)
    for (int q = p + 1; q < 3; ++q) inversions += m.from[p] > m.from[q] ? 1 : 0;
  const double det = (inversions % 2 ? -1.0 : 1.0) * m.sign[0] * m.sign[1] * m.sign[2];
  if (det < 0)
    throw InputError(field,
                     "is a mirror (determinant -1), which would turn the terrain inside "
                     "out: flip the sign of one axis (e.g. \"y_up\" is [\"x\", \"-z\", "
                     "\"y\"])");
  return m;
}

ImportedMeshTerrain import_mesh_terrain(const MeshTerrainImport& spec) {
  const Assembled a = assemble(spec);
  ImportedMeshTerrain out;
  if (spec.grid_spacing_m) {
    out = resample(spec, a);
  } else {
    check_height_surface(spec, a);
    out = as_mesh(a);
  }
  out.file_facets = a.file_facets;
  return out;
}

OJson shape_from_mesh_file(const std::string& path, const AxisMap& axes, double weld_m) {
  const MeshData m = read_mesh_file(path, "FILE");
  std::vector<Vec3> vertices;
  Welder welder(weld_m);
  std::vector<bool> used(m.vertices.size(), false);
  for (const auto& t : m.triangles)
    for (const auto v : t) used[v] = true;
  for (std::size_t v = 0; v < m.vertices.size(); ++v)
    if (used[v]) welder.add(axes.apply(m.vertices[v]), vertices);
  Vec3 mean = Vec3::Zero();
  for (const Vec3& v : vertices) mean += v;
  mean /= static_cast<double>(vertices.size());
  OJson list = OJson::array();
  for (const Vec3& v : vertices)
    list.push_back({v.x() - mean.x(), v.y() - mean.y(), v.z() - mean.z()});
  OJson shape;
  shape["type"] = "polyhedron";
  shape["vertices_m"] = std::move(list);
  return shape;
}

}  // namespace fragsim::gis
