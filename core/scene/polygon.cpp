#include "core/scene/polygon.h"

#include <algorithm>
#include <stdexcept>

namespace fragsim::scene::detail {

double signed_area(const std::vector<Vec2>& poly) {
  // Shoelace about the first vertex: the products then involve coordinate differences, which
  // keeps the sum accurate when the polygon sits far from the coordinate origin.
  double twice = 0.0;
  for (std::size_t k = 1; k + 1 < poly.size(); ++k)
    twice += orient2d(poly[0], poly[k], poly[k + 1]);
  return 0.5 * twice;
}

namespace {

// p is on the closed segment a-b, given that the three points are collinear.
bool within_box(const Vec2& a, const Vec2& b, const Vec2& p) {
  return std::min(a.x(), b.x()) <= p.x() && p.x() <= std::max(a.x(), b.x()) &&
         std::min(a.y(), b.y()) <= p.y() && p.y() <= std::max(a.y(), b.y());
}

int sign(double v) {
  return (v > 0) - (v < 0);
}

}  // namespace

bool segments_intersect(const Vec2& p1, const Vec2& p2, const Vec2& q1, const Vec2& q2) {
  const int d1 = sign(orient2d(q1, q2, p1));
  const int d2 = sign(orient2d(q1, q2, p2));
  const int d3 = sign(orient2d(p1, p2, q1));
  const int d4 = sign(orient2d(p1, p2, q2));
  if (d1 * d2 < 0 && d3 * d4 < 0) return true;  // proper crossing
  // Touching or collinear overlap: an endpoint lies on the other segment.
  if (d1 == 0 && within_box(q1, q2, p1)) return true;
  if (d2 == 0 && within_box(q1, q2, p2)) return true;
  if (d3 == 0 && within_box(p1, p2, q1)) return true;
  if (d4 == 0 && within_box(p1, p2, q2)) return true;
  return false;
}

bool point_in_polygon(const std::vector<Vec2>& poly, const Vec2& p) {
  bool inside = false;
  const std::size_t n = poly.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = poly[i];
    const Vec2& b = poly[j];
    // Half-open rule on y so a vertex exactly at p.y is counted once.
    if ((a.y() > p.y()) != (b.y() > p.y())) {
      const double x_cross = a.x() + (p.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (p.x() < x_cross) inside = !inside;
    }
  }
  return inside;
}

std::vector<std::array<std::uint32_t, 3>> triangulate_polygon(const std::vector<Vec2>& poly) {
  const std::size_t n = poly.size();
  std::vector<std::array<std::uint32_t, 3>> out;
  if (n < 3) return out;
  out.reserve(n - 2);
  // Circular doubly linked list of the vertices still in the polygon.
  std::vector<std::uint32_t> prev(n), next(n);
  for (std::size_t k = 0; k < n; ++k) {
    prev[k] = static_cast<std::uint32_t>((k + n - 1) % n);
    next[k] = static_cast<std::uint32_t>((k + 1) % n);
  }
  // Vertex b (with neighbours a, c) is an ear when it is strictly convex and no other remaining
  // vertex lies in the closed triangle a-b-c. Collinear vertices (orientation exactly 0) are never
  // clipped themselves, so no zero-area triangle is emitted; they are absorbed as neighbours of
  // later ears. Points on the ear's boundary block it, which keeps the result a valid partition.
  const auto is_ear = [&](std::uint32_t b) {
    const std::uint32_t a = prev[b], c = next[b];
    if (!(orient2d(poly[a], poly[b], poly[c]) > 0)) return false;
    for (std::uint32_t p = next[c]; p != a; p = next[p]) {
      if (orient2d(poly[a], poly[b], poly[p]) >= 0 && orient2d(poly[b], poly[c], poly[p]) >= 0 &&
          orient2d(poly[c], poly[a], poly[p]) >= 0)
        return false;
    }
    return true;
  };
  std::size_t remaining = n;
  std::uint32_t v = 0;
  std::size_t misses = 0;  // consecutive vertices tried without finding an ear
  while (remaining > 3) {
    if (is_ear(v)) {
      const std::uint32_t a = prev[v], c = next[v];
      out.push_back({a, v, c});
      next[a] = c;
      prev[c] = a;
      --remaining;
      misses = 0;
      v = c;  // continue around the polygon: keeps ears spread out (fewer slivers)
    } else {
      if (++misses > remaining) throw std::runtime_error("ear clipping found no ear");
      v = next[v];
    }
  }
  const std::uint32_t a = prev[v], c = next[v];
  if (orient2d(poly[a], poly[v], poly[c]) > 0) out.push_back({a, v, c});
  return out;
}

}  // namespace fragsim::scene::detail
