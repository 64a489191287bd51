#pragma once
// Plane polygon geometry for building footprints (internal to core/scene): orientation
// predicates, segment crossing, point in polygon, and ear-clipping triangulation (with holes).
#include <array>
#include <cstdint>
#include <vector>

#include "core/common/types.h"

namespace fragsim::scene::detail {

// Twice the signed area of triangle (a, b, c): > 0 when counter-clockwise.
inline double orient2d(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

// Signed area of a polygon (shoelace formula): > 0 for counter-clockwise vertex order.
double signed_area(const std::vector<Vec2>& poly);

// True when the closed segments p1-p2 and q1-q2 share at least one point (crossing, touching,
// or collinear overlap). Exact sign tests on the double orientation values.
bool segments_intersect(const Vec2& p1, const Vec2& p2, const Vec2& q1, const Vec2& q2);

// Crossing-number point-in-polygon test (Shimrat 1962 / Haines 1994); points exactly on the
// boundary may go either way.
bool point_in_polygon(const std::vector<Vec2>& poly, const Vec2& p);

// Triangulates a simple counter-clockwise polygon (convex or concave, collinear vertices allowed)
// by ear clipping (Meisters 1975, "two ears" theorem): n - 2 counter-clockwise triangles indexing
// `poly`, whose areas sum to the polygon's. Throws std::runtime_error if no ear is found, which
// for a validated simple polygon only numerical near-degeneracy can cause.
std::vector<std::array<std::uint32_t, 3>> triangulate_polygon(const std::vector<Vec2>& poly);

// Triangulates a polygon with holes: `outer` counter-clockwise, each of `holes` clockwise, every
// hole strictly inside `outer` and the holes pairwise disjoint (validated footprints). Each hole,
// by decreasing largest x, is joined to a mutually visible vertex of the boundary built so far by
// a bridge (a zero-width cut traversed both ways; Eberly 2002, "Triangulation by ear clipping",
// §3-4), and the resulting weakly simple polygon is ear clipped. The triangles are counter-
// clockwise and index the rings concatenated: outer vertices 0..n0-1, then hole 0, hole 1, ...
// Their areas sum to area(outer) - sum of area(holes). With no holes, the same triangles as
// triangulate_polygon(outer). Throws std::runtime_error as triangulate_polygon does.
std::vector<std::array<std::uint32_t, 3>> triangulate_polygon_with_holes(
    const std::vector<Vec2>& outer, const std::vector<std::vector<Vec2>>& holes);

}  // namespace fragsim::scene::detail
