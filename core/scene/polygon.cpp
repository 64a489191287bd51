#include "core/scene/polygon.h"

#include <algorithm>
#include <cmath>
#include <limits>
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

namespace {

using Triangles = std::vector<std::array<std::uint32_t, 3>>;

// Doubly linked ring of positions in `ring`, each naming a vertex of `pts`.
struct Ring {
  const std::vector<Vec2>& pts;
  const std::vector<std::uint32_t>& ring;
  std::vector<std::uint32_t> prev, next;
  const Vec2& at(std::uint32_t pos) const { return pts[ring[pos]]; }
};

// Position b (with neighbours a, c) is an ear when it is strictly convex and no other remaining
// vertex lies in the closed triangle a-b-c. Collinear vertices (orientation exactly 0) are never
// clipped themselves, so no zero-area triangle is emitted; they are absorbed as neighbours of
// later ears. Points on the ear's boundary block it, which keeps the result a valid partition.
// A bridged polygon visits each bridge end twice; the second visit of a, b or c sits on the
// ear's corner, and in a weakly simple polygon its edges cannot enter the ear without a vertex
// inside it, so it does not block (for a simple polygon this never applies).
bool is_ear(const Ring& r, std::uint32_t b) {
  const std::uint32_t a = r.prev[b], c = r.next[b];
  const Vec2 &pa = r.at(a), &pb = r.at(b), &pc = r.at(c);
  if (!(orient2d(pa, pb, pc) > 0)) return false;
  for (std::uint32_t p = r.next[c]; p != a; p = r.next[p]) {
    const Vec2& pp = r.at(p);
    if (orient2d(pa, pb, pp) >= 0 && orient2d(pb, pc, pp) >= 0 && orient2d(pc, pa, pp) >= 0 &&
        pp != pa && pp != pb && pp != pc)
      return false;
  }
  return true;
}

// Ear clipping of the counter-clockwise weakly simple polygon visiting pts[ring[0]],
// pts[ring[1]], ... (Meisters 1975, "two ears" theorem); triangles index `pts`.
Triangles clip_ears(const std::vector<Vec2>& pts, const std::vector<std::uint32_t>& ring) {
  const std::size_t n = ring.size();
  Triangles out;
  if (n < 3) return out;
  out.reserve(n - 2);
  Ring r{pts, ring, std::vector<std::uint32_t>(n), std::vector<std::uint32_t>(n)};
  for (std::size_t k = 0; k < n; ++k) {
    r.prev[k] = static_cast<std::uint32_t>((k + n - 1) % n);
    r.next[k] = static_cast<std::uint32_t>((k + 1) % n);
  }
  std::size_t remaining = n;
  std::uint32_t v = 0;
  std::size_t misses = 0;  // consecutive vertices tried without finding an ear
  while (remaining > 3) {
    if (is_ear(r, v)) {
      const std::uint32_t a = r.prev[v], c = r.next[v];
      out.push_back({ring[a], ring[v], ring[c]});
      r.next[a] = c;
      r.prev[c] = a;
      --remaining;
      misses = 0;
      v = c;  // continue around the polygon: keeps ears spread out (fewer slivers)
    } else {
      if (++misses > remaining) throw std::runtime_error("ear clipping found no ear");
      v = r.next[v];
    }
  }
  const std::uint32_t a = r.prev[v], c = r.next[v];
  if (orient2d(r.at(a), r.at(v), r.at(c)) > 0) out.push_back({ring[a], ring[v], ring[c]});
  return out;
}

}  // namespace

std::vector<std::array<std::uint32_t, 3>> triangulate_polygon(const std::vector<Vec2>& poly) {
  std::vector<std::uint32_t> ring(poly.size());
  for (std::size_t k = 0; k < ring.size(); ++k) ring[k] = static_cast<std::uint32_t>(k);
  return clip_ears(poly, ring);
}

namespace {

constexpr std::size_t kNone = static_cast<std::size_t>(-1);

// The point q lies strictly inside the angle the ring makes at position i (the polygon's side:
// left of the incoming and outgoing edges for a counter-clockwise ring). Picks, among the visits
// of a bridge end, the one facing q.
bool locally_inside(const std::vector<Vec2>& pts, const std::vector<std::uint32_t>& ring,
                    std::size_t i, const Vec2& q) {
  const std::size_t n = ring.size();
  const Vec2& a = pts[ring[(i + n - 1) % n]];
  const Vec2& b = pts[ring[i]];
  const Vec2& c = pts[ring[(i + 1) % n]];
  const double turn = orient2d(a, b, c);
  if (turn < 0) return orient2d(a, b, q) > 0 || orient2d(b, c, q) > 0;  // reflex
  if (turn == 0 && (b - a).dot(c - b) <= 0) return false;               // folds back
  return orient2d(a, b, q) > 0 && orient2d(b, c, q) > 0;
}

// The open segment m-p meets none of the closed edges of `loop` (the ring so far, or a hole),
// edges ending at m or p aside: those are the bridge's own neighbours, checked by locally_inside.
bool clear_of(const Vec2& m, const Vec2& p, const std::vector<Vec2>& pts,
              const std::vector<std::uint32_t>& loop) {
  const std::size_t n = loop.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& u = pts[loop[k]];
    const Vec2& w = pts[loop[(k + 1) % n]];
    if (u == m || u == p || w == m || w == p) continue;
    if (segments_intersect(m, p, u, w)) return false;
  }
  return true;
}

// Eberly's bridge end for the hole vertex m of largest x: cast the ray m + t (1, 0); the first
// edge it meets is an upward one (the ring is counter-clockwise and m inside). If it meets that
// edge at a vertex, that vertex is visible. Otherwise the edge's end of larger x, p, is visible
// unless ring vertices lie in the triangle (m, hit, p); then the one among them at the smallest
// angle to the ray (the nearest on a tie) is. Returns its position in `ring`, or kNone.
std::size_t eberly_bridge(const std::vector<Vec2>& pts, const std::vector<std::uint32_t>& ring,
                          const Vec2& m) {
  const std::size_t n = ring.size();
  double hit_x = std::numeric_limits<double>::infinity();
  std::size_t best = kNone;
  bool at_vertex = false;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t i1 = (i + 1) % n;
    const Vec2& a = pts[ring[i]];
    const Vec2& b = pts[ring[i1]];
    if (!(a.y() <= m.y() && m.y() <= b.y() && a.y() < b.y())) continue;
    // Exact at the ends, so that a hit on a vertex is recognised as one.
    const double x = a.y() == m.y()   ? a.x()
                     : b.y() == m.y() ? b.x()
                                      : a.x() + (m.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
    if (!(x > m.x() && x < hit_x)) continue;
    hit_x = x;
    at_vertex = a.y() == m.y() || b.y() == m.y();
    best = a.y() == m.y() ? i : b.y() == m.y() ? i1 : (a.x() > b.x() ? i : i1);
  }
  if (best == kNone || at_vertex) return best;
  const Vec2 hit(hit_x, m.y());
  const Vec2 p = pts[ring[best]];
  // Candidates: vertices in the closed triangle (m, hit, p), m itself aside, facing m.
  const auto tangent = [&](const Vec2& q) { return std::abs(q.y() - m.y()) / (q.x() - m.x()); };
  double best_tan = tangent(p), best_dx = p.x() - m.x();
  const double side = orient2d(m, hit, p);
  for (std::size_t j = 0; j < n; ++j) {
    const Vec2& q = pts[ring[j]];
    if (q == p || !(q.x() > m.x())) continue;
    const bool in_triangle =
        side > 0 ? orient2d(m, hit, q) >= 0 && orient2d(hit, p, q) >= 0 && orient2d(p, m, q) >= 0
                 : orient2d(m, hit, q) <= 0 && orient2d(hit, p, q) <= 0 && orient2d(p, m, q) <= 0;
    if (!in_triangle || !locally_inside(pts, ring, j, m)) continue;
    const double t = tangent(q), dx = q.x() - m.x();
    if (t < best_tan || (t == best_tan && dx < best_dx)) {
      best_tan = t;
      best_dx = dx;
      best = j;
    }
  }
  return best;
}

// The visit of the ring vertex at `pos` (or of another vertex, if need be) that m can be joined
// to: the bridge m-p must leave p into the polygon and m out of the hole (loops[0], rotated to
// start at m), and cross no edge of the ring, of the hole, or of the holes still to join
// (loops[1..]). The fallback tries every ring vertex, nearest first; Eberly's choice is visible
// in exact arithmetic, so only rounding can call for it.
std::size_t visible_end(const std::vector<Vec2>& pts, const std::vector<std::uint32_t>& ring,
                        std::size_t pos, const Vec2& m,
                        const std::vector<std::vector<std::uint32_t>>& loops) {
  const auto usable = [&](std::size_t i) {
    const Vec2& p = pts[ring[i]];
    // A clockwise hole has the solid on its left, as the ring has: the same test applies.
    if (!locally_inside(pts, ring, i, m) || !locally_inside(pts, loops[0], 0, p)) return false;
    if (!clear_of(m, p, pts, ring)) return false;
    for (const auto& loop : loops)
      if (!clear_of(m, p, pts, loop)) return false;
    return true;
  };
  if (pos != kNone) {
    for (std::size_t i = 0; i < ring.size(); ++i)
      if (pts[ring[i]] == pts[ring[pos]] && usable(i)) return i;
  }
  std::vector<std::size_t> order(ring.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](std::size_t l, std::size_t r) {
    return (pts[ring[l]] - m).squaredNorm() < (pts[ring[r]] - m).squaredNorm();
  });
  for (const std::size_t i : order)
    if (usable(i)) return i;
  throw std::runtime_error("no bridge to a hole");
}

}  // namespace

std::vector<std::array<std::uint32_t, 3>> triangulate_polygon_with_holes(
    const std::vector<Vec2>& outer, const std::vector<std::vector<Vec2>>& holes) {
  // All rings in one vertex list; each ring as indices into it.
  std::vector<Vec2> pts = outer;
  std::vector<std::uint32_t> ring(outer.size());
  for (std::size_t k = 0; k < ring.size(); ++k) ring[k] = static_cast<std::uint32_t>(k);
  std::vector<std::vector<std::uint32_t>> loops(holes.size());
  for (std::size_t h = 0; h < holes.size(); ++h) {
    for (const Vec2& p : holes[h]) {
      loops[h].push_back(static_cast<std::uint32_t>(pts.size()));
      pts.push_back(p);
    }
  }
  // Rightmost vertex of each hole; holes joined from right to left, so that no hole still to
  // join lies right of the one being joined (its bridge runs rightwards).
  std::vector<std::size_t> rightmost(holes.size(), 0), order(holes.size());
  for (std::size_t h = 0; h < holes.size(); ++h) {
    order[h] = h;
    for (std::size_t k = 1; k < loops[h].size(); ++k)
      if (pts[loops[h][k]].x() > pts[loops[h][rightmost[h]]].x()) rightmost[h] = k;
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t l, std::size_t r) {
    return pts[loops[l][rightmost[l]]].x() > pts[loops[r][rightmost[r]]].x();
  });
  for (std::size_t done = 0; done < order.size(); ++done) {
    const std::size_t h = order[done];
    std::vector<std::uint32_t> hole = std::move(loops[h]);
    loops[h].clear();
    std::rotate(hole.begin(), hole.begin() + static_cast<std::ptrdiff_t>(rightmost[h]), hole.end());
    const Vec2 m = pts[hole[0]];
    std::vector<std::vector<std::uint32_t>> hole_and_rest = {hole};
    for (std::size_t k = done + 1; k < order.size(); ++k) hole_and_rest.push_back(loops[order[k]]);
    const std::size_t p = visible_end(pts, ring, eberly_bridge(pts, ring, m), m, hole_and_rest);
    // ... p, m, hole..., m, p, ...: the bridge is walked both ways.
    std::vector<std::uint32_t> splice = hole;
    splice.push_back(hole[0]);
    splice.push_back(ring[p]);
    ring.insert(ring.begin() + static_cast<std::ptrdiff_t>(p + 1), splice.begin(), splice.end());
  }
  return clip_ears(pts, ring);
}

}  // namespace fragsim::scene::detail
