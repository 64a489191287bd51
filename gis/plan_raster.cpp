// Per-triangle values onto a raster by exact plan-area weights (plan_raster.h).
#include "gis/plan_raster.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace fragsim::gis {

namespace {

// A convex polygon of at most 7 vertices: a triangle clipped by the 4 sides of a cell (each
// clip adds at most one vertex). Fixed storage: the export clips millions of triangles.
struct SmallPolygon {
  std::array<Vec2, 8> v;
  std::size_t n = 0;
  void push(const Vec2& p) { v[n++] = p; }
};

// Keeps the part of `poly` where s * (p[axis] - bound) >= 0.
SmallPolygon clip(const SmallPolygon& poly, int axis, double bound, double s) {
  SmallPolygon out;
  const std::size_t n = poly.n;
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& p = poly.v[k];
    const Vec2& q = poly.v[(k + 1) % n];
    const double dp = s * (p[axis] - bound), dq = s * (q[axis] - bound);
    if (dp >= 0) out.push(p);
    if ((dp >= 0) != (dq >= 0)) out.push(p + (q - p) * (dp / (dp - dq)));
  }
  return out;
}

double polygon_area(const SmallPolygon& p) {
  double a2 = 0;
  for (std::size_t k = 0; k < p.n; ++k) {
    const Vec2& u = p.v[k];
    const Vec2& v = p.v[(k + 1) % p.n];
    a2 += u.x() * v.y() - v.x() * u.y();
  }
  return 0.5 * std::abs(a2);
}

}  // namespace

double PlanRaster::mean(std::size_t k, int col, int row) const {
  const std::size_t i = index(col, row);
  return covered_m2[i] > 0 ? weighted[k][i] / covered_m2[i]
                           : std::numeric_limits<double>::quiet_NaN();
}

PlanRaster make_plan_raster_at(double x0, double y0, double cell_m, int cols, int rows,
                               std::size_t value_sets) {
  PlanRaster r;
  r.x0 = x0;
  r.y0 = y0;
  r.cell_m = cell_m;
  r.cols = cols;
  r.rows = rows;
  const std::size_t n = static_cast<std::size_t>(cols) * static_cast<std::size_t>(rows);
  r.covered_m2.assign(n, 0.0);
  r.weighted.assign(value_sets, std::vector<double>(n, 0.0));
  return r;
}

PlanRaster make_plan_raster(const std::vector<Vec3>& vertices, double cell_m,
                            std::size_t value_sets) {
  Vec2 lo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity());
  Vec2 hi = -lo;
  for (const Vec3& v : vertices) {
    lo = lo.cwiseMin(v.head<2>());
    hi = hi.cwiseMax(v.head<2>());
  }
  // A whole number of cells to within 1e-9 of a cell counts as whole (grid spacings).
  const auto cells = [&](double span) {
    return std::max(1, static_cast<int>(std::ceil(span / cell_m - 1e-9)));
  };
  return make_plan_raster_at(lo.x(), lo.y(), cell_m, cells(hi.x() - lo.x()), cells(hi.y() - lo.y()),
                             value_sets);
}

double clipped_area(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& lo, const Vec2& hi) {
  SmallPolygon p;
  p.push(a);
  p.push(b);
  p.push(c);
  p = clip(p, 0, lo.x(), 1.0);
  if (p.n > 0) p = clip(p, 0, hi.x(), -1.0);
  if (p.n > 0) p = clip(p, 1, lo.y(), 1.0);
  if (p.n > 0) p = clip(p, 1, hi.y(), -1.0);
  return p.n < 3 ? 0.0 : polygon_area(p);
}

void add_triangle(PlanRaster& r, const Vec2& a, const Vec2& b, const Vec2& c,
                  const std::vector<double>& values) {
  const Vec2 tlo = a.cwiseMin(b).cwiseMin(c), thi = a.cwiseMax(b).cwiseMax(c);
  const auto cell_of = [&](double v, double origin, int n) {
    return std::clamp(static_cast<int>(std::floor((v - origin) / r.cell_m)), 0, n - 1);
  };
  const int i0 = cell_of(tlo.x(), r.x0, r.cols), i1 = cell_of(thi.x(), r.x0, r.cols);
  const int j0 = cell_of(tlo.y(), r.y0, r.rows), j1 = cell_of(thi.y(), r.y0, r.rows);
  for (int j = j0; j <= j1; ++j)
    for (int i = i0; i <= i1; ++i) {
      const Vec2 lo(r.x0 + i * r.cell_m, r.y0 + j * r.cell_m);
      const double area = clipped_area(a, b, c, lo, lo + Vec2(r.cell_m, r.cell_m));
      if (area <= 0) continue;
      const std::size_t k = r.index(i, j);
      r.covered_m2[k] += area;
      for (std::size_t s = 0; s < values.size(); ++s) r.weighted[s][k] += values[s] * area;
    }
}

}  // namespace fragsim::gis
