#include "core/scene/terrain_index.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace fragsim::scene::detail {

namespace {

// Nearest float not below z, so max_z stays an upper bound after the conversion.
float float_at_least(double z) {
  float f = static_cast<float>(z);
  if (static_cast<double>(f) < z) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

double triangle_max_z(const std::vector<Vec3>& v, const std::array<std::uint32_t, 3>& t) {
  return std::max({v[t[0]].z(), v[t[1]].z(), v[t[2]].z()});
}

// Separating-axis test of a 2-D triangle against an axis-aligned rectangle [lo, hi]: the boxes'
// axes are checked by the caller (bucket range from the triangle's bounding box); here the three
// edge normals remain (Eberly, "Intersection of convex objects: the method of separating axes").
bool triangle_overlaps_rect(const Vec2 (&p)[3], const Vec2& lo, const Vec2& hi) {
  for (int k = 0; k < 3; ++k) {
    const Vec2& a = p[k];
    const Vec2& b = p[(k + 1) % 3];
    const Vec2& c = p[(k + 2) % 3];
    const Vec2 n(a.y() - b.y(), b.x() - a.x());  // normal of edge a-b
    const double edge = n.dot(a);
    const double third = n.dot(c);
    const double tri_lo = std::min(edge, third), tri_hi = std::max(edge, third);
    const double r0 = n.x() * lo.x() + n.y() * lo.y(), r1 = n.x() * hi.x() + n.y() * lo.y();
    const double r2 = n.x() * lo.x() + n.y() * hi.y(), r3 = n.x() * hi.x() + n.y() * hi.y();
    const double rect_lo = std::min({r0, r1, r2, r3}), rect_hi = std::max({r0, r1, r2, r3});
    if (rect_hi < tri_lo || rect_lo > tri_hi) return false;
  }
  return true;
}

}  // namespace

TerrainIndex2D make_cell_index(const Vec2& origin, const Vec2& cell, int ncx, int ncy,
                               const std::vector<Vec3>& vertices,
                               const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  TerrainIndex2D index;
  index.origin = origin;
  index.cell = cell;
  index.nx = ncx;
  index.ny = ncy;
  const std::size_t buckets = static_cast<std::size_t>(ncx) * static_cast<std::size_t>(ncy);
  if (triangles.size() != 2 * buckets) throw std::logic_error("cell index: triangle count");
  index.start.resize(buckets + 1);
  index.triangles.resize(triangles.size());
  index.max_z.resize(buckets);
  for (std::size_t b = 0; b <= buckets; ++b) index.start[b] = static_cast<std::uint32_t>(2 * b);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    index.triangles[t] = static_cast<std::uint32_t>(t);
  for (std::size_t b = 0; b < buckets; ++b)
    index.max_z[b] = float_at_least(std::max(triangle_max_z(vertices, triangles[2 * b]),
                                             triangle_max_z(vertices, triangles[2 * b + 1])));
  return index;
}

TerrainIndex2D make_mesh_index(const std::vector<Vec3>& vertices,
                               const std::vector<std::array<std::uint32_t, 3>>& triangles) {
  TerrainIndex2D index;
  if (triangles.empty()) return index;
  Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  double projected_area = 0.0;
  for (const auto& t : triangles) {
    const Vec2 a = vertices[t[0]].head<2>(), b = vertices[t[1]].head<2>(),
               c = vertices[t[2]].head<2>();
    lo = lo.cwiseMin(a).cwiseMin(b).cwiseMin(c);
    hi = hi.cwiseMax(a).cwiseMax(b).cwiseMax(c);
    projected_area += 0.5 * std::abs((b - a).x() * (c - a).y() - (b - a).y() * (c - a).x());
  }
  const Vec2 size = hi - lo;
  // Site::build refuses terrains this wide (site_limits.h); called directly with vertices near
  // the largest doubles, the size overflows and no bucket size would make the loop below end.
  if (!size.allFinite()) throw std::length_error("terrain index: terrain extent not finite");
  const double tri_count = static_cast<double>(triangles.size());
  // Bucket side 0.7 sqrt(mean projected triangle area): about two buckets per triangle. A
  // triangle is listed in every bucket it overlaps, so the mean list length cannot fall to one;
  // measured on an irregular mesh it is 3.5 at this size (2.8 at 0.5, 4.8 at 1.0), and halving
  // the side again would double the index memory for little gain.
  double s = 0.7 * std::sqrt(projected_area / tri_count);
  if (!(s > 0)) s = std::max(size.x(), size.y());
  if (!(s > 0)) s = 1.0;
  // Cap the bucket count (a few large triangles among tiny ones, or a sparse mesh over a large
  // box, would otherwise ask for far more buckets than triangles).
  // Also at most 2^30 buckets per side, so that bucket indices fit an int. Each pass grows s by
  // at least 1.0001 while the count is too high; the side cap ends it whatever the sizes.
  const double max_buckets = 4.0 * tri_count + 64.0;
  constexpr double kMaxSide = 1073741824.0;  // 2^30
  s = std::max(s, std::max(size.x(), size.y()) / kMaxSide);
  for (int pass = 0; pass < 100000; ++pass) {
    const double cells = std::ceil(size.x() / s) * std::ceil(size.y() / s);
    if (cells <= max_buckets) break;
    s *= std::sqrt(cells / max_buckets) * 1.0001;
  }
  index.origin = lo;
  index.cell = Vec2(s, s);
  index.nx = static_cast<int>(std::clamp(std::ceil(size.x() / s), 1.0, kMaxSide));
  index.ny = static_cast<int>(std::clamp(std::ceil(size.y() / s), 1.0, kMaxSide));
  const std::size_t buckets =
      static_cast<std::size_t>(index.nx) * static_cast<std::size_t>(index.ny);

  const double pad = 1e-9;  // in bucket units
  // Calls f(bucket) for each bucket triangle t overlaps.
  const auto for_each_bucket = [&](const std::array<std::uint32_t, 3>& t, auto&& f) {
    Vec2 p[3];
    for (int k = 0; k < 3; ++k) p[k] = (vertices[t[k]].head<2>() - lo) / s;  // bucket units
    const Vec2 tlo = p[0].cwiseMin(p[1]).cwiseMin(p[2]), thi = p[0].cwiseMax(p[1]).cwiseMax(p[2]);
    const int i0 = clamped_bucket(tlo.x() - pad, index.nx);
    const int i1 = clamped_bucket(thi.x() + pad, index.nx);
    const int j0 = clamped_bucket(tlo.y() - pad, index.ny);
    const int j1 = clamped_bucket(thi.y() + pad, index.ny);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const Vec2 blo(i - pad, j - pad), bhi(i + 1 + pad, j + 1 + pad);
        if (triangle_overlaps_rect(p, blo, bhi))
          f(static_cast<std::size_t>(j) * static_cast<std::size_t>(index.nx) +
            static_cast<std::size_t>(i));
      }
    }
  };
  // Two passes, CSR: count, prefix sum, fill.
  std::vector<std::size_t> count(buckets + 1, 0);
  for (const auto& t : triangles) for_each_bucket(t, [&](std::size_t b) { ++count[b + 1]; });
  for (std::size_t b = 0; b < buckets; ++b) count[b + 1] += count[b];
  if (count[buckets] >= std::numeric_limits<std::uint32_t>::max())
    throw std::length_error("terrain index: too many bucket entries");
  index.start.resize(buckets + 1);
  for (std::size_t b = 0; b <= buckets; ++b) index.start[b] = static_cast<std::uint32_t>(count[b]);
  index.triangles.resize(count[buckets]);
  index.max_z.assign(buckets, -std::numeric_limits<float>::infinity());
  std::vector<std::size_t> fill(count.begin(), count.end() - 1);
  for (std::size_t ti = 0; ti < triangles.size(); ++ti) {
    const float zmax = float_at_least(triangle_max_z(vertices, triangles[ti]));
    for_each_bucket(triangles[ti], [&](std::size_t b) {
      index.triangles[fill[b]++] = static_cast<std::uint32_t>(ti);
      index.max_z[b] = std::max(index.max_z[b], zmax);
    });
  }
  return index;
}

double mean_bucket_occupancy(const TerrainIndex2D& index) {
  std::size_t non_empty = 0;
  for (std::size_t b = 0; b + 1 < index.start.size(); ++b)
    if (index.start[b + 1] > index.start[b]) ++non_empty;
  return non_empty == 0
             ? 0.0
             : static_cast<double>(index.triangles.size()) / static_cast<double>(non_empty);
}

}  // namespace fragsim::scene::detail
