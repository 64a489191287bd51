// The site-plan hazard boundary (plan_boundary.h; docs/gis.md, "Site-plan boundary").
#include "gis/plan_boundary.h"

#include <ogr_geometry.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/common/error.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

constexpr int kSectors = 36;
constexpr double kSectorDeg = 10.0;
constexpr int kArcSteps = 10;  // chords per sector: 1 degree each
constexpr double kPi = 3.14159265358979323846;

double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

Vec2 unit(double deg) {
  return Vec2(std::cos(deg * kPi / 180.0), std::sin(deg * kPi / 180.0));
}

// The part of `poly` where cross(u, p) >= 0 (left of the direction u through the origin):
// Sutherland-Hodgman against one half-plane.
std::vector<Vec2> clip_left_of(const std::vector<Vec2>& poly, const Vec2& u) {
  std::vector<Vec2> out;
  for (std::size_t i = 0; i < poly.size(); ++i) {
    const Vec2& a = poly[i];
    const Vec2& b = poly[(i + 1) % poly.size()];
    const double sa = cross(u, a), sb = cross(u, b);
    if (sa >= 0) out.push_back(a);
    if ((sa >= 0) != (sb >= 0)) out.push_back(a + (b - a) * (sa / (sa - sb)));
  }
  return out;
}

// The largest distance from the origin of a point of triangle `t` (relative to the origin) in
// sector k's closed wedge (azimuths [10k, 10k + 10] deg); -1 when none. Distance is convex, so
// the largest is at a vertex of the clipped polygon.
double reach_in_sector(const std::array<Vec2, 3>& t, int k) {
  const double a0 = kSectorDeg * k;
  std::vector<Vec2> p = clip_left_of({t[0], t[1], t[2]}, unit(a0));
  p = clip_left_of(p, -unit(a0 + kSectorDeg));  // right of the wedge's far ray
  double best = -1.0;
  for (const Vec2& v : p) best = std::max(best, v.norm());
  return best;
}

// Whether no point of the triangle lies in sector k's wedge: all its vertices on the outer side
// of one of the wedge's two half-planes (a quick test before clipping).
bool misses_sector(const std::array<Vec2, 3>& t, int k) {
  const Vec2 u0 = unit(kSectorDeg * k), u1 = unit(kSectorDeg * (k + 1));
  bool right_of_near = true, left_of_far = true;
  for (const Vec2& v : t) {
    right_of_near = right_of_near && cross(u0, v) < 0;
    left_of_far = left_of_far && cross(u1, v) > 0;
  }
  return right_of_near || left_of_far;
}

// R_k per sector over the triangles where density + s * se >= threshold.
std::vector<double> sector_reach(const ResultsFile& r, double s, const Vec2& origin) {
  std::vector<double> reach(kSectors, 0.0);
  for (std::size_t i = 0; i < r.triangles.size(); ++i) {
    if (!(r.density[i] + s * r.std_error[i] >= r.threshold)) continue;
    std::array<Vec2, 3> t;
    for (int c = 0; c < 3; ++c) t[c] = r.vertices[r.triangles[i][c]].head<2>() - origin;
    for (int k = 0; k < kSectors; ++k)
      if (!misses_sector(t, k)) reach[k] = std::max(reach[k], reach_in_sector(t, k));
  }
  return reach;
}

// Sector k's arc, from azimuth 10k to 10k + 10 deg, as a polyline whose chords all stay outside
// the circle of radius R (+ kMargin_m): its vertices lie at that radius / cos(half a step).
constexpr double kMargin_m = 1e-3;  // against rounding: the envelope is 1 mm outside each R_k

void append_arc(std::vector<Vec2>& ring, const Vec2& origin, double radius, int k) {
  const double step = kSectorDeg / kArcSteps;
  const double rv = (radius + kMargin_m) / std::cos(0.5 * step * kPi / 180.0);
  for (int j = 0; j <= kArcSteps; ++j) {
    const Vec2 p = origin + rv * unit(kSectorDeg * k + step * j);
    if (ring.empty() || (p - ring.back()).norm() > 1e-9) ring.push_back(p);
  }
}

// The envelope of the radii: one polygon per run of consecutive non-empty sectors, from the
// origin (the parts may touch there); all 36 non-empty: one polygon round the origin.
PlanMultiPolygon envelope_polygon(const std::vector<double>& reach, const Vec2& origin) {
  PlanMultiPolygon out;
  const auto empty = [&](int k) { return reach[static_cast<std::size_t>(k % kSectors)] <= 0; };
  int start = 0;
  while (start < kSectors && !empty(start)) ++start;
  if (start == kSectors) {  // no gap: a closed ring without the origin
    std::vector<Vec2> ring;
    for (int k = 0; k < kSectors; ++k) append_arc(ring, origin, reach[k], k);
    if ((ring.back() - ring.front()).norm() <= 1e-9) ring.pop_back();  // 360 deg = 0 deg
    out.push_back({{ring}});
    return out;
  }
  for (int k = start + 1; k <= start + kSectors; ++k) {
    if (empty(k)) continue;
    std::vector<Vec2> ring{origin};
    for (; !empty(k); ++k) append_arc(ring, origin, reach[k % kSectors], k % kSectors);
    out.push_back({{ring}});
  }
  return out;
}

SectorEnvelope sector_envelope(const ResultsFile& r, double s, const Vec2& origin) {
  SectorEnvelope e;
  e.radius_m = sector_reach(r, s, origin);
  e.max_radius_m = *std::max_element(e.radius_m.begin(), e.radius_m.end());
  e.polygon = envelope_polygon(e.radius_m, origin);
  return e;
}

double signed_area(const std::vector<Vec2>& ring) {
  double a = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) a += cross(ring[i], ring[(i + 1) % ring.size()]);
  return 0.5 * a;
}

std::vector<Vec2> ring_of(const OGRLinearRing& ring, bool ccw) {
  std::vector<Vec2> out;
  for (int i = 0; i + 1 < ring.getNumPoints(); ++i)  // the closing point is not repeated
    out.emplace_back(ring.getX(i), ring.getY(i));
  if ((signed_area(out) > 0) != ccw) std::reverse(out.begin(), out.end());
  return out;
}

void add_polygons(const OGRGeometry& g, bool with_holes, PlanMultiPolygon& out) {
  if (const auto* p = dynamic_cast<const OGRPolygon*>(&g)) {
    if (p->IsEmpty()) return;
    PlanPolygon poly{{ring_of(*p->getExteriorRing(), true)}};
    for (int h = 0; with_holes && h < p->getNumInteriorRings(); ++h)
      poly.rings.push_back(ring_of(*p->getInteriorRing(h), false));
    out.push_back(std::move(poly));
  } else if (const auto* c = dynamic_cast<const OGRGeometryCollection*>(&g)) {
    for (const OGRGeometry* part : *c) add_polygons(*part, with_holes, out);
  }  // points and lines (degenerate pieces of a union) have no area
}

double max_distance(const PlanMultiPolygon& m, const Vec2& origin) {
  double d = 0;
  for (const PlanPolygon& p : m)
    for (const Vec2& v : p.rings.at(0)) d = std::max(d, (v - origin).norm());
  return d;
}

double area_of(const OGRGeometry& g) {
  if (const auto* s = dynamic_cast<const OGRSurface*>(&g)) return s->get_Area();
  if (const auto* m = dynamic_cast<const OGRMultiSurface*>(&g)) return m->get_Area();
  if (const auto* c = dynamic_cast<const OGRGeometryCollection*>(&g)) return c->get_Area();
  return 0.0;
}

// Closing (dilate by rho, erode by rho) with holes dropped, united with the exact area: GEOS
// approximates the discs by polygons, so the union is what guarantees containment.
std::unique_ptr<OGRGeometry> smooth(const OGRGeometry& exact, double rho) {
  constexpr int kQuadrantSegments = 8;  // GEOS's default: 8 chords per quarter circle
  std::unique_ptr<OGRGeometry> dilated(exact.Buffer(rho, kQuadrantSegments));
  if (!dilated) throw std::runtime_error("buffer failed (GEOS)");
  std::unique_ptr<OGRGeometry> closed(dilated->Buffer(-rho, kQuadrantSegments));
  if (!closed) throw std::runtime_error("buffer failed (GEOS)");
  PlanMultiPolygon filled;
  add_polygons(*closed, false, filled);
  const auto filled_ogr = to_ogr(filled);
  std::unique_ptr<OGRGeometry> u(filled_ogr->Union(&exact));
  if (!u) throw std::runtime_error("polygon union failed (GEOS)");
  PlanMultiPolygon again;
  add_polygons(*u, false, again);  // a piece of the exact area can close a ring: no holes
  return to_ogr(again);
}

double default_smoothing(const ResultsFile& r) {
  return std::max(1.0, 2.0 * default_cell(r));
}

}  // namespace

std::unique_ptr<OGRMultiPolygon> to_ogr(const PlanMultiPolygon& m) {
  auto out = std::make_unique<OGRMultiPolygon>();
  for (const PlanPolygon& p : m) {
    auto poly = std::make_unique<OGRPolygon>();
    for (const auto& ring : p.rings) {
      auto lr = std::make_unique<OGRLinearRing>();
      for (const Vec2& v : ring) lr->addPoint(v.x(), v.y());
      if (!ring.empty()) lr->addPoint(ring[0].x(), ring[0].y());
      poly->addRingDirectly(lr.release());
    }
    out->addGeometryDirectly(poly.release());
  }
  return out;
}

namespace {

nlohmann::ordered_json polygons_json(const PlanMultiPolygon& m, const Vec2& offset) {
  auto out = nlohmann::ordered_json::array();
  for (const PlanPolygon& p : m) {
    auto rings = nlohmann::ordered_json::array();
    for (const auto& ring : p.rings) {
      auto pts = nlohmann::ordered_json::array();
      for (const Vec2& v : ring) pts.push_back({v.x() - offset.x(), v.y() - offset.y()});
      rings.push_back(std::move(pts));
    }
    out.push_back(std::move(rings));
  }
  return out;
}

nlohmann::ordered_json envelope_json(const SectorEnvelope& e, const Vec2& offset) {
  return {{"max_radius_m", e.max_radius_m},
          {"radius_m", e.radius_m},
          {"polygons", polygons_json(e.polygon, offset)}};
}

}  // namespace

nlohmann::ordered_json plan_boundary_json(const PlanBoundary& b, const Vec2& offset) {
  return {{"origin_m", {b.origin.x() - offset.x(), b.origin.y() - offset.y()}},
          {"smoothing_m", b.smoothing_m},
          {"exact_hfd_m", b.exact_hfd_m},
          {"smoothed_hfd_m", b.smoothed_hfd_m},
          {"exact_area_m2", b.exact_area_m2},
          {"smoothed_area_m2", b.smoothed_area_m2},
          {"envelope", envelope_json(b.envelope, offset)},
          {"envelope_upper", envelope_json(b.envelope_upper, offset)},
          {"smoothed", {{"polygons", polygons_json(b.smoothed, offset)}}}};
}

PlanBoundary plan_boundary(const ResultsFile& r, const PlanBoundaryOptions& options) {
  if (options.smoothing_m && !(std::isfinite(*options.smoothing_m) && *options.smoothing_m > 0))
    throw InputError("smoothing_m", "must be a finite number of metres > 0, got " +
                                        std::to_string(*options.smoothing_m));
  ensure_gdal_registered();
  PlanBoundary b;
  b.origin = r.hfd_origin.head<2>();
  b.exact_hfd_m = r.hfd_m;
  b.envelope = sector_envelope(r, 0.0, b.origin);
  b.envelope_upper = sector_envelope(r, 1.0, b.origin);
  b.smoothing_m = options.smoothing_m.value_or(default_smoothing(r));
  const std::unique_ptr<OGRGeometry> exact = hazard_area(r, 0.0, nullptr);
  b.exact_area_m2 = area_of(*exact);
  if (exact->IsEmpty()) return b;
  const std::unique_ptr<OGRGeometry> smoothed = smooth(*exact, b.smoothing_m);
  add_polygons(*smoothed, false, b.smoothed);
  b.smoothed_area_m2 = area_of(*smoothed);
  b.smoothed_hfd_m = max_distance(b.smoothed, b.origin);
  return b;
}

}  // namespace fragsim::gis
