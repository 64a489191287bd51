#pragma once
// The edges of a terrain triangle's xy-projection, as the ground phase walks across them
// (ground_phase.cpp): from the cell arithmetic on a plane or grid terrain (no vertex loads), from
// the vertices on a general mesh. Internal to core/impact.
#include <cstdint>
#include <utility>

#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::impact::ground {

// The three edges of a triangle's xy-projection: outward unit normals, offsets (phi_k(p) =
// N_k . p_xy - c_k, in metres, <= 0 inside), the triangle across each edge when known from the
// lattice (-1: off the terrain; -2: look it up) and each edge's vertex indices.
struct TriangleEdges {
  Vec2 normal[3];
  double offset[3];
  std::int64_t across[3];
  std::uint32_t from[3], to[3];

  double phi_k(int k, const Vec3& p) const {
    return normal[k].x() * p.x() + normal[k].y() * p.y() - offset[k];
  }
  // d phi_k / dt for a velocity v.
  double rate_k(int k, const Vec3& v) const {
    return normal[k].x() * v.x() + normal[k].y() * v.y();
  }
};

inline void set_edge(TriangleEdges& te, int k, const Vec2& u, const Vec2& w, std::uint32_t iu,
                     std::uint32_t iw, std::int64_t across) {
  const Vec2 d = w - u;
  const Vec2 nrm = Vec2(d.y(), -d.x()) / d.norm();  // outward for a counter-clockwise triangle
  te.normal[k] = nrm;
  te.offset[k] = nrm.dot(u);
  te.across[k] = across;
  te.from[k] = iu;
  te.to[k] = iw;
}

// Lattice (plane or grid terrain): from the cell arithmetic, no vertex loads (the builder's
// layout, terrain_builder.cpp: cell (i, j) holds (v00, v10, v11) and (v00, v11, v01)).
inline TriangleEdges lattice_edges(const scene::TerrainIndex2D& g, std::uint32_t tri) {
  const std::int64_t cell = tri / 2, nx = g.nx, ny = g.ny;
  const std::int64_t i = cell % nx, j = cell / nx;
  const double x0 = g.origin.x() + static_cast<double>(i) * g.cell.x();
  const double y0 = g.origin.y() + static_cast<double>(j) * g.cell.y();
  const Vec2 p00(x0, y0), p10(x0 + g.cell.x(), y0), p01(x0, y0 + g.cell.y()),
      p11(x0 + g.cell.x(), y0 + g.cell.y());
  const auto vid = [&](std::int64_t ii, std::int64_t jj) {
    return static_cast<std::uint32_t>(jj * (nx + 1) + ii);
  };
  TriangleEdges te;
  if (tri % 2 == 0) {  // (v00, v10, v11)
    set_edge(te, 0, p00, p10, vid(i, j), vid(i + 1, j), j > 0 ? 2 * (cell - nx) + 1 : -1);
    set_edge(te, 1, p10, p11, vid(i + 1, j), vid(i + 1, j + 1),
             i + 1 < nx ? 2 * (cell + 1) + 1 : -1);
    set_edge(te, 2, p11, p00, vid(i + 1, j + 1), vid(i, j), 2 * cell + 1);
  } else {  // (v00, v11, v01)
    set_edge(te, 0, p00, p11, vid(i, j), vid(i + 1, j + 1), 2 * cell);
    set_edge(te, 1, p11, p01, vid(i + 1, j + 1), vid(i, j + 1), j + 1 < ny ? 2 * (cell + nx) : -1);
    set_edge(te, 2, p01, p00, vid(i, j + 1), vid(i, j), i > 0 ? 2 * (cell - 1) : -1);
  }
  return te;
}

inline TriangleEdges mesh_edges(const scene::Site& site, std::uint32_t tri) {
  const auto& ids = site.terrain_triangles()[tri];
  const auto& vs = site.terrain_vertices();
  std::uint32_t a = ids[0], b = ids[1], c = ids[2];
  const auto xy = [&](std::uint32_t v) { return Vec2(vs[v].x(), vs[v].y()); };
  const double orient =
      (xy(b) - xy(a)).x() * (xy(c) - xy(a)).y() - (xy(b) - xy(a)).y() * (xy(c) - xy(a)).x();
  if (orient < 0.0) std::swap(b, c);  // counter-clockwise seen from above
  TriangleEdges te;
  set_edge(te, 0, xy(a), xy(b), a, b, -2);
  set_edge(te, 1, xy(b), xy(c), b, c, -2);
  set_edge(te, 2, xy(c), xy(a), c, a, -2);
  return te;
}

// The edges of triangle `tri` of `site`.
inline TriangleEdges edges_of(const scene::Site& site, std::uint32_t tri) {
  return site.terrain_is_lattice() ? lattice_edges(site.terrain_index(), tri)
                                   : mesh_edges(site, tri);
}

}  // namespace fragsim::impact::ground
