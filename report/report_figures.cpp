// Figure data of the report (report_figures.h).
#include "report/report_figures.h"

#include <algorithm>
#include <cmath>

namespace fragsim::report {

namespace {

using Json = nlohmann::json;

struct Frame {
  Vec2 origin;  // the HFD origin, CRS
  api::UnitSystem units;
  double len(double m) const { return api::present_length(m, units).value; }
  Json point(const Vec2& p) const {
    return Json::array({len(p.x() - origin.x()), len(p.y() - origin.y())});
  }
};

Json rings_json(const gis::PlanMultiPolygon& mp, const Frame& f) {
  Json out = Json::array();
  for (const auto& poly : mp)
    for (const auto& ring : poly.rings) {
      Json r = Json::array();
      for (const Vec2& p : ring) r.push_back(f.point(p));
      if (!ring.empty()) r.push_back(f.point(ring.front()));  // closed for drawing
      out.push_back(std::move(r));
    }
  return out;
}

Vec2 centroid2(const gis::ResultsFile& r, std::size_t t) {
  const auto& tri = r.triangles[t];
  return (r.vertices[tri[0]].head<2>() + r.vertices[tri[1]].head<2>() +
          r.vertices[tri[2]].head<2>()) /
         3.0;
}

double triangle_area(const gis::ResultsFile& r, std::size_t t) {
  const auto& tri = r.triangles[t];
  const Vec2 a = r.vertices[tri[0]].head<2>(), b = r.vertices[tri[1]].head<2>(),
             c = r.vertices[tri[2]].head<2>();
  return 0.5 * std::abs((b - a).x() * (c - a).y() - (c - a).x() * (b - a).y());
}

// The farthest extent of the terrain from the origin along x or y (the overview's half-width).
double terrain_reach(const ReportInputs& in, const Frame& f) {
  double reach = 0.0;
  for (const Vec3& v : in.results.vertices)
    reach = std::max(reach, (v.head<2>() - f.origin).cwiseAbs().maxCoeff());
  return reach;
}

// The close-up's half-width (m): the +1 se envelope, the smoothed contour and the HFD band with
// a margin, within the terrain.
double closeup_half_width(const ReportInputs& in, const Frame& f) {
  const double r = std::max({in.boundary.envelope_upper.max_radius_m, in.results.band_hi,
                             in.boundary.smoothed_hfd_m, 20.0});
  return std::min(1.2 * r, terrain_reach(in, f));
}

// Density classes relative to the threshold (as ptn_classes.tif: 1 none ... 6 >= 10x) on a
// raster of at most kMapMaxCells per side; null where no fragment (or no terrain).
Json map_raster(const ReportInputs& in, const Frame& f, double half) {
  const gis::ResultsFile& r = in.results;
  const double cell = 2.0 * half / kMapMaxCells;  // finer than the triangles: their edges show
  const int n = std::max(1, static_cast<int>(std::ceil(2.0 * half / cell)));
  gis::PlanRaster pr =
      gis::make_plan_raster_at(f.origin.x() - half, f.origin.y() - half, cell, n, n, 1);
  std::vector<double> value(1);
  const Vec2 lo = f.origin.array() - half, hi = f.origin.array() + half;
  for (std::size_t k = 0; k < r.triangles.size(); ++k) {
    const auto& t = r.triangles[k];
    const Vec2 a = r.vertices[t[0]].head<2>(), b = r.vertices[t[1]].head<2>(),
               c = r.vertices[t[2]].head<2>();
    if (std::max({a.x(), b.x(), c.x()}) < lo.x() || std::min({a.x(), b.x(), c.x()}) > hi.x() ||
        std::max({a.y(), b.y(), c.y()}) < lo.y() || std::min({a.y(), b.y(), c.y()}) > hi.y())
      continue;
    value[0] = r.density[k];
    gis::add_triangle(pr, a, b, c, value);
  }
  // One digit per cell, row 0 at the top (north), as Plot's raster expects; '0': no fragment.
  std::string classes;
  classes.reserve(static_cast<std::size_t>(n) * static_cast<std::size_t>(n));
  const double t = r.threshold;
  for (int row = n - 1; row >= 0; --row)
    for (int col = 0; col < n; ++col) {
      const double d = pr.mean(0, col, row);
      classes += !(d > 0)      ? '0'
                 : d < t / 100 ? '2'
                 : d < t / 10  ? '3'
                 : d < t       ? '4'
                 : d < 10 * t  ? '5'
                               : '6';
    }
  const double h = f.len(half);
  return {{"x1", -h},
          {"x2", h},
          {"y1", -h},
          {"y2", h},
          {"width", n},
          {"height", n},
          {"cell", f.len(cell)},
          {"classes", std::move(classes)}};
}

Json buildings_json(const ReportInputs& in, const Frame& f) {
  Json out = Json::array();
  for (std::size_t k = 0; k < in.results.buildings.size(); ++k) {
    const auto& b = in.results.buildings[k];
    Json tris = Json::array();
    Vec2 sum(0, 0);
    for (const auto& t : b.plan) {
      tris.push_back({f.point(t[0]), f.point(t[1]), f.point(t[2]), f.point(t[0])});
      sum += (t[0] + t[1] + t[2]) / 3.0;
    }
    const Vec2 c = b.plan.empty() ? f.origin : Vec2(sum / static_cast<double>(b.plan.size()));
    out.push_back({{"id", b.id},
                   {"index", k},
                   {"triangles", std::move(tris)},
                   {"label_at", f.point(c)},
                   {"impacts", b.impacts}});
  }
  return out;
}

bool sector_cut(const nlohmann::ordered_json& s, std::size_t k) {
  const auto it = s.find("hfd_by_sector_bound");
  return it != s.end() && it->is_array() && k < it->size() && (*it)[k] == "lower";
}

Json rose_json(const ReportInputs& in, const Frame& f) {
  Json sectors = Json::array();
  const auto& s = in.summary;
  for (int k = 0; k < 36; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    sectors.push_back({{"sector", k},
                       {"hfd", f.len(s.at("hfd_by_sector_m").at(uk).get<double>())},
                       {"envelope", f.len(in.boundary.envelope.radius_m.at(uk))},
                       {"upper", f.len(in.boundary.envelope_upper.radius_m.at(uk))},
                       {"cut", sector_cut(s, uk)},
                       {"bearings", api::sector_bearing_range(k)}});
  }
  return sectors;
}

Json profile_json(const ReportInputs& in, const Frame& f) {
  const double range = std::max({1.5 * in.results.band_hi, 1.2 * in.boundary.smoothed_hfd_m, 50.0});
  const DensityProfile p = density_profile(in.results, range, 80);
  Json r = Json::array(), mx = Json::array(), mean = Json::array();
  for (std::size_t k = 0; k < p.max_per_m2.size(); ++k) {
    r.push_back(f.len((static_cast<double>(k) + 0.5) * p.bin_m));
    mx.push_back(p.max_per_m2[k] > 0
                     ? Json(api::present_areal_density(p.max_per_m2[k], f.units).value)
                     : Json(nullptr));
    mean.push_back(p.mean_per_m2[k] > 0
                       ? Json(api::present_areal_density(p.mean_per_m2[k], f.units).value)
                       : Json(nullptr));
  }
  return {{"distance", std::move(r)},
          {"max", std::move(mx)},
          {"mean", std::move(mean)},
          {"bin", f.len(p.bin_m)}};
}

}  // namespace

DensityProfile density_profile(const gis::ResultsFile& r, double range_m, int bins) {
  DensityProfile p;
  p.bin_m = range_m / std::max(1, bins);
  const Vec2 o = r.hfd_origin.head<2>();
  const auto n = static_cast<std::size_t>(std::max(1, bins));
  p.max_per_m2.assign(n, 0.0);
  p.mean_per_m2.assign(n, 0.0);
  std::vector<double> area(n, 0.0);
  for (std::size_t t = 0; t < r.triangles.size(); ++t) {
    const double d = (centroid2(r, t) - o).norm();
    const auto k = static_cast<std::size_t>(d / p.bin_m);
    if (k >= n) continue;
    const double a = triangle_area(r, t);
    p.max_per_m2[k] = std::max(p.max_per_m2[k], r.density[t]);
    p.mean_per_m2[k] += a * r.density[t];
    area[k] += a;
  }
  for (std::size_t k = 0; k < n; ++k)
    p.mean_per_m2[k] = area[k] > 0 ? p.mean_per_m2[k] / area[k] : 0.0;
  return p;
}

Json figure_data(const ReportInputs& in, api::UnitSystem units) {
  const Frame f{in.results.hfd_origin.head<2>(), units};
  const double closeup = closeup_half_width(in, f), overview = terrain_reach(in, f);
  const auto& b = in.boundary;
  return {
      {"units",
       {{"length", api::present_length(1, units).unit},
        {"density", api::present_areal_density(1, units).unit}}},
      {"threshold", api::present_areal_density(in.results.threshold, units).value},
      {"hfd", f.len(in.results.hfd_m)},
      {"band", {f.len(in.results.band_lo), f.len(in.results.band_hi)}},
      {"overview", {{"raster", map_raster(in, f, overview)}, {"buildings", buildings_json(in, f)}}},
      {"map",
       {{"raster", map_raster(in, f, closeup)},
        {"envelope", rings_json(b.envelope.polygon, f)},
        {"envelope_upper", rings_json(b.envelope_upper.polygon, f)},
        {"smoothed", rings_json(b.smoothed, f)},
        {"buildings", buildings_json(in, f)}}},
      {"rose", rose_json(in, f)},
      {"profile", profile_json(in, f)}};
}

}  // namespace fragsim::report
