// Reading results.h5 for the GIS exports and the report (results_file.h).
#include "gis/results_file.h"

#include <ogr_geometry.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "core/common/error.h"
#include "formats/results_h5.h"

namespace fragsim::gis {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

std::vector<Vec3> read_points(const fs::path& f, const std::string& name, const Vec2& offset) {
  const auto v = formats::read_dataset_double(f, name);
  std::vector<Vec3> out(v.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = Vec3(v[3 * k] + offset.x(), v[3 * k + 1] + offset.y(), v[3 * k + 2]);
  return out;
}

std::vector<std::array<std::size_t, 3>> read_triangles(const fs::path& f, const std::string& name) {
  const auto t = formats::read_dataset_int64(f, name);
  std::vector<std::array<std::size_t, 3>> out(t.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k)
    for (std::size_t c = 0; c < 3; ++c) out[k][c] = static_cast<std::size_t>(t[3 * k + c]);
  return out;
}

void read_site_of_scenario(const fs::path& f, ResultsFile& r) {
  const Json sc = Json::parse(formats::read_attribute_string(f, "/", "scenario_json"));
  const Json& site = sc.at("site");
  if (const auto o = site.find("origin"); o != site.end()) {
    r.crs = o->value("crs", "");
    r.offset = Vec2(o->value("easting_m", 0.0), o->value("northing_m", 0.0));
  }
  const Json& terrain = site.at("terrain");
  if (terrain.contains("grid")) {
    const Json& g = terrain["grid"];
    r.terrain_cell_m = g.at("spacing_m").get<double>();
    r.grid_origin = std::array<double, 2>{g.at("origin_m")[0].get<double>() + r.offset.x(),
                                          g.at("origin_m")[1].get<double>() + r.offset.y()};
    r.grid_nx = g.at("nx").get<int>();
    r.grid_ny = g.at("ny").get<int>();
  }
  if (terrain.contains("plane")) r.terrain_cell_m = terrain["plane"].value("cell_m", 10.0);
}

void read_buildings(const fs::path& f, ResultsFile& r) {
  const auto ids = formats::read_dataset_strings(f, "/buildings/id");
  const auto imp = formats::read_dataset_double(f, "/buildings/expected_impacts");
  const auto imp_se = formats::read_dataset_double(f, "/buildings/impacts_std_error");
  const auto pen = formats::read_dataset_double(f, "/buildings/expected_penetrations");
  const auto pen_se = formats::read_dataset_double(f, "/buildings/penetrations_std_error");
  r.buildings.resize(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k)
    r.buildings[k] = {ids[k], imp[k], imp_se[k], pen[k], pen_se[k], {}};
  if (ids.empty()) return;
  const auto v = read_points(f, "/buildings/vertices_m", r.offset);
  const auto t = read_triangles(f, "/buildings/triangles");
  const auto owner = formats::read_dataset_int64(f, "/buildings/triangle_building");
  for (std::size_t k = 0; k < t.size(); ++k)
    r.buildings[static_cast<std::size_t>(owner[k])].plan.push_back(
        {v[t[k][0]].head<2>(), v[t[k][1]].head<2>(), v[t[k][2]].head<2>()});
}

const char* bound_name(double flag) {
  return flag != 0.0 ? "lower" : "none";
}

void read_hfd_bounds(const fs::path& f, ResultsFile& r) {
  if (formats::read_attribute_int64(f, "/", "format_version") < 2) return;
  r.hfd_bound = bound_name(formats::read_dataset_double(f, "/hfd/bound").at(0));
  const auto band = formats::read_dataset_double(f, "/hfd/band_bound");
  r.band_lower_bound = bound_name(band.at(0));
  r.band_upper_bound = bound_name(band.at(1));
  const auto sectors = formats::read_dataset_double(f, "/hfd/by_sector_bound");
  for (std::size_t k = 0; k < r.sector_bound.size() && k < sectors.size(); ++k)
    r.sector_bound[k] = bound_name(sectors[k]);
  r.hfd_note = formats::read_attribute_string(f, "/hfd", "note");
  r.left_hazardous = formats::read_dataset_double(f, "/hfd/left_site_hazardous_fragments").at(0);
  r.left_hazardous_se =
      formats::read_dataset_double(f, "/hfd/left_site_hazardous_fragments_std_error").at(0);
  r.left_hazardous_by_sector =
      formats::read_dataset_double(f, "/hfd/left_site_hazardous_by_sector");
  r.left_hazardous_by_sector.resize(36, 0.0);
}

}  // namespace

ResultsFile read_results_file(const fs::path& f) {
  ResultsFile r;
  try {
    if (formats::read_attribute_string(f, "/", "file_type") != formats::kResultsFileType)
      throw std::runtime_error("not a fragsim results file");
    read_site_of_scenario(f, r);
    r.vertices = read_points(f, "/terrain/vertices_m", r.offset);
    r.triangles = read_triangles(f, "/terrain/triangles");
    r.density = formats::read_dataset_double(f, "/ptn/density_per_m2");
    r.std_error = formats::read_dataset_double(f, "/ptn/std_error_per_m2");
    r.threshold = formats::read_dataset_double(f, "/hfd/threshold_per_m2").at(0);
    r.hfd_m = formats::read_dataset_double(f, "/hfd/hazardous_fragment_distance_m").at(0);
    const auto band = formats::read_dataset_double(f, "/hfd/band_m");
    r.band_lo = band.at(0);
    r.band_hi = band.at(1);
    r.by_sector = formats::read_dataset_double(f, "/hfd/by_sector_m");
    const auto o = formats::read_dataset_double(f, "/hfd/origin_m");
    r.hfd_origin = Vec3(o.at(0) + r.offset.x(), o.at(1) + r.offset.y(), o.at(2));
    read_hfd_bounds(f, r);
    read_buildings(f, r);
  } catch (const std::exception& e) {
    throw InputError("RESULTS.h5", f.string() + ": " + e.what());
  }
  return r;
}

double default_cell(const ResultsFile& r) {
  if (r.terrain_cell_m > 0) return r.terrain_cell_m;
  double area = 0;  // a mesh: cells about the size of a triangle pair
  for (const auto& t : r.triangles) {
    const Vec2 a = r.vertices[t[0]].head<2>(), b = r.vertices[t[1]].head<2>(),
               c = r.vertices[t[2]].head<2>();
    area += 0.5 * std::abs((b - a).x() * (c - a).y() - (c - a).x() * (b - a).y());
  }
  return std::sqrt(2.0 * area / static_cast<double>(std::max<std::size_t>(1, r.triangles.size())));
}

PlanRaster rasterise(const ResultsFile& r, double cell_m, bool on_grid_samples) {
  PlanRaster pr = on_grid_samples ? make_plan_raster_at((*r.grid_origin)[0] - 0.5 * cell_m,
                                                        (*r.grid_origin)[1] - 0.5 * cell_m, cell_m,
                                                        r.grid_nx, r.grid_ny, 2)
                                  : make_plan_raster(r.vertices, cell_m, 2);
  std::vector<double> values(2);
  for (std::size_t k = 0; k < r.triangles.size(); ++k) {
    const auto& t = r.triangles[k];
    values[0] = r.density[k];
    values[1] = r.std_error[k];
    add_triangle(pr, r.vertices[t[0]].head<2>(), r.vertices[t[1]].head<2>(),
                 r.vertices[t[2]].head<2>(), values);
  }
  return pr;
}

std::unique_ptr<OGRGeometry> union_of(const std::vector<std::array<Vec2, 3>>& triangles) {
  OGRMultiPolygon all;
  for (const auto& t : triangles) {
    const double a2 = (t[1] - t[0]).x() * (t[2] - t[0]).y() - (t[2] - t[0]).x() * (t[1] - t[0]).y();
    if (std::abs(a2) < 1e-9) continue;  // a wall seen from above
    auto ring = std::make_unique<OGRLinearRing>();
    for (int k = 0; k <= 3; ++k) ring->addPoint(t[k % 3].x(), t[k % 3].y());
    auto poly = std::make_unique<OGRPolygon>();
    poly->addRingDirectly(ring.release());
    all.addGeometryDirectly(poly.release());
  }
  if (all.IsEmpty()) return std::make_unique<OGRMultiPolygon>();
  std::unique_ptr<OGRGeometry> u(all.UnionCascaded());
  if (!u) throw std::runtime_error("polygon union failed (GEOS)");
  return u;
}

// Terrain triangles where density + s * std_error >= threshold, merged.
std::unique_ptr<OGRGeometry> hazard_area(const ResultsFile& r, double s, std::size_t* count) {
  std::vector<std::array<Vec2, 3>> tris;
  for (std::size_t k = 0; k < r.triangles.size(); ++k) {
    if (!(r.density[k] + s * r.std_error[k] >= r.threshold)) continue;
    const auto& t = r.triangles[k];
    tris.push_back(
        {r.vertices[t[0]].head<2>(), r.vertices[t[1]].head<2>(), r.vertices[t[2]].head<2>()});
  }
  if (count != nullptr) *count = tris.size();
  return union_of(tris);
}

}  // namespace fragsim::gis
