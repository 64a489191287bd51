// GIS outputs of a run (results_export.h).
#include "gis/results_export.h"

#include <ogrsf_frmts.h>

#include <cmath>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "api/output_dir.h"
#include "api/results_h5.h"
#include "core/common/error.h"
#include "gis/gdal_support.h"
#include "gis/plan_raster.h"
#include "gis/vtkhdf_export.h"

namespace fragsim::gis {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr double kNoData = -1.0;  // densities and errors are >= 0

struct Building {
  std::string id;
  double impacts = 0, impacts_se = 0, penetrations = 0, penetrations_se = 0;
  std::vector<std::array<Vec2, 3>> plan;  // its triangles seen from above
};

// What the exports need from results.h5, in the site's CRS (input + origin offset).
struct Results {
  std::vector<Vec3> vertices;
  std::vector<std::array<std::size_t, 3>> triangles;
  std::vector<double> density, std_error;
  double threshold = 0, hfd_m = 0, band_lo = 0, band_hi = 0;
  std::vector<double> by_sector;
  // Where the terrain's boundary cuts the HFD (results.h5 /hfd/*bound*, format 2): "lower" or
  // "none" each; "unknown" from a results.h5 of format 1, which does not say.
  std::string hfd_bound = "unknown", band_lower_bound = "unknown", band_upper_bound = "unknown";
  std::vector<std::string> sector_bound = std::vector<std::string>(36, "unknown");
  std::string hfd_note;
  double left_hazardous = 0, left_hazardous_se = 0;  // real fragments (format 2)
  std::vector<double> left_hazardous_by_sector = std::vector<double>(36, 0.0);
  Vec3 hfd_origin;
  std::vector<Building> buildings;
  std::string crs;            // "" when the site has none
  Vec2 offset{0, 0};          // site.origin easting, northing
  double terrain_cell_m = 0;  // grid spacing / plane cell; 0 for a mesh
  // A grid terrain: its vertices are the DEM's samples (docs/gis.md): the raster's cells are
  // centred on them, as the DEM's own cells were.
  std::optional<std::array<double, 2>> grid_origin;
  int grid_nx = 0, grid_ny = 0;
};

std::vector<Vec3> read_points(const fs::path& f, const std::string& name, const Vec2& offset) {
  const auto v = api::read_dataset_double(f, name);
  std::vector<Vec3> out(v.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = Vec3(v[3 * k] + offset.x(), v[3 * k + 1] + offset.y(), v[3 * k + 2]);
  return out;
}

std::vector<std::array<std::size_t, 3>> read_triangles(const fs::path& f, const std::string& name) {
  const auto t = api::read_dataset_int64(f, name);
  std::vector<std::array<std::size_t, 3>> out(t.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k)
    for (std::size_t c = 0; c < 3; ++c) out[k][c] = static_cast<std::size_t>(t[3 * k + c]);
  return out;
}

void read_site_of_scenario(const fs::path& f, Results& r) {
  const Json sc = Json::parse(api::read_attribute_string(f, "/", "scenario_json"));
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

void read_buildings(const fs::path& f, Results& r) {
  const auto ids = api::read_dataset_strings(f, "/buildings/id");
  const auto imp = api::read_dataset_double(f, "/buildings/expected_impacts");
  const auto imp_se = api::read_dataset_double(f, "/buildings/impacts_std_error");
  const auto pen = api::read_dataset_double(f, "/buildings/expected_penetrations");
  const auto pen_se = api::read_dataset_double(f, "/buildings/penetrations_std_error");
  r.buildings.resize(ids.size());
  for (std::size_t k = 0; k < ids.size(); ++k)
    r.buildings[k] = {ids[k], imp[k], imp_se[k], pen[k], pen_se[k], {}};
  if (ids.empty()) return;
  const auto v = read_points(f, "/buildings/vertices_m", r.offset);
  const auto t = read_triangles(f, "/buildings/triangles");
  const auto owner = api::read_dataset_int64(f, "/buildings/triangle_building");
  for (std::size_t k = 0; k < t.size(); ++k)
    r.buildings[static_cast<std::size_t>(owner[k])].plan.push_back(
        {v[t[k][0]].head<2>(), v[t[k][1]].head<2>(), v[t[k][2]].head<2>()});
}

const char* bound_name(double flag) {
  return flag != 0.0 ? "lower" : "none";
}

void read_hfd_bounds(const fs::path& f, Results& r) {
  if (api::read_attribute_int64(f, "/", "format_version") < 2) return;
  r.hfd_bound = bound_name(api::read_dataset_double(f, "/hfd/bound").at(0));
  const auto band = api::read_dataset_double(f, "/hfd/band_bound");
  r.band_lower_bound = bound_name(band.at(0));
  r.band_upper_bound = bound_name(band.at(1));
  const auto sectors = api::read_dataset_double(f, "/hfd/by_sector_bound");
  for (std::size_t k = 0; k < r.sector_bound.size() && k < sectors.size(); ++k)
    r.sector_bound[k] = bound_name(sectors[k]);
  r.hfd_note = api::read_attribute_string(f, "/hfd", "note");
  r.left_hazardous = api::read_dataset_double(f, "/hfd/left_site_hazardous_fragments").at(0);
  r.left_hazardous_se =
      api::read_dataset_double(f, "/hfd/left_site_hazardous_fragments_std_error").at(0);
  r.left_hazardous_by_sector = api::read_dataset_double(f, "/hfd/left_site_hazardous_by_sector");
  r.left_hazardous_by_sector.resize(36, 0.0);
}

Results read_results(const fs::path& f) {
  Results r;
  try {
    if (api::read_attribute_string(f, "/", "file_type") != api::kResultsFileType)
      throw std::runtime_error("not a fragsim results file");
    read_site_of_scenario(f, r);
    r.vertices = read_points(f, "/terrain/vertices_m", r.offset);
    r.triangles = read_triangles(f, "/terrain/triangles");
    r.density = api::read_dataset_double(f, "/ptn/density_per_m2");
    r.std_error = api::read_dataset_double(f, "/ptn/std_error_per_m2");
    r.threshold = api::read_dataset_double(f, "/hfd/threshold_per_m2").at(0);
    r.hfd_m = api::read_dataset_double(f, "/hfd/hazardous_fragment_distance_m").at(0);
    const auto band = api::read_dataset_double(f, "/hfd/band_m");
    r.band_lo = band.at(0);
    r.band_hi = band.at(1);
    r.by_sector = api::read_dataset_double(f, "/hfd/by_sector_m");
    const auto o = api::read_dataset_double(f, "/hfd/origin_m");
    r.hfd_origin = Vec3(o.at(0) + r.offset.x(), o.at(1) + r.offset.y(), o.at(2));
    read_hfd_bounds(f, r);
    read_buildings(f, r);
  } catch (const std::exception& e) {
    throw InputError("RESULTS.h5", f.string() + ": " + e.what());
  }
  return r;
}

// ---- Rasters ----

double default_cell(const Results& r) {
  if (r.terrain_cell_m > 0) return r.terrain_cell_m;
  double area = 0;  // a mesh: cells about the size of a triangle pair
  for (const auto& t : r.triangles) {
    const Vec2 a = r.vertices[t[0]].head<2>(), b = r.vertices[t[1]].head<2>(),
               c = r.vertices[t[2]].head<2>();
    area += 0.5 * std::abs((b - a).x() * (c - a).y() - (c - a).x() * (b - a).y());
  }
  return std::sqrt(2.0 * area / static_cast<double>(std::max<std::size_t>(1, r.triangles.size())));
}

PlanRaster rasterise(const Results& r, double cell_m, bool on_grid_samples) {
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

// While alive, GDAL keeps everything in the TIFF itself: no .aux.xml sidecar (it would be
// named after the temporary file and left behind by the rename).
struct NoAuxXml {
  NoAuxXml() { CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", "NO"); }
  ~NoAuxXml() { CPLSetThreadLocalConfigOption("GDAL_PAM_ENABLED", nullptr); }
};

GDALDatasetUniquePtr create_tif(const fs::path& path, const PlanRaster& pr, int bands,
                                GDALDataType type, const OGRSpatialReference* srs) {
  ensure_gdal_registered();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  const char* options[] = {"COMPRESS=DEFLATE", "TILED=YES", nullptr};
  GDALDatasetUniquePtr ds(
      drv->Create(path.c_str(), pr.cols, pr.rows, bands, type, const_cast<char**>(options)));
  if (!ds) throw std::runtime_error("cannot create " + path.string());
  double gt[6] = {pr.x0, pr.cell_m, 0, pr.y0 + pr.rows * pr.cell_m, 0, -pr.cell_m};
  ds->SetGeoTransform(gt);
  if (srs != nullptr) ds->SetSpatialRef(srs);
  return ds;
}

// Row r of the file is raster row rows-1-r (GeoTIFF rows run north to south).
void write_density_tif(const fs::path& path, const PlanRaster& pr, const Results& res,
                       const OGRSpatialReference* srs) {
  const NoAuxXml no_aux;
  GDALDatasetUniquePtr ds = create_tif(path, pr, 2, GDT_Float64, srs);
  const char* names[] = {"PTN hazardous fragment density (1/m2)",
                         "standard error of the density (1/m2; area-weighted, an upper bound)"};
  for (int b = 0; b < 2; ++b) {
    std::vector<double> v(static_cast<std::size_t>(pr.cols) * pr.rows);
    for (int row = 0; row < pr.rows; ++row)
      for (int col = 0; col < pr.cols; ++col) {
        const double m = pr.mean(static_cast<std::size_t>(b), col, pr.rows - 1 - row);
        v[static_cast<std::size_t>(row) * pr.cols + col] = std::isnan(m) ? kNoData : m;
      }
    GDALRasterBand* band = ds->GetRasterBand(b + 1);
    band->SetNoDataValue(kNoData);
    band->SetDescription(names[b]);
    if (band->RasterIO(GF_Write, 0, 0, pr.cols, pr.rows, v.data(), pr.cols, pr.rows, GDT_Float64, 0,
                       0) != CE_None)
      throw std::runtime_error("cannot write " + path.string());
  }
  ds->SetMetadataItem("FRAGSIM_THRESHOLD_PER_M2", std::to_string(res.threshold).c_str());
  ds->SetMetadataItem("FRAGSIM_CELL_VALUE",
                      "mean of the terrain triangles' values weighted by their plan area in the "
                      "cell");
}

// Classes relative to the threshold t: 0 no data, 1 no hazardous fragment, 2 < t/100,
// 3 [t/100, t/10), 4 [t/10, t), 5 [t, 10 t) hazardous, 6 >= 10 t.
unsigned char density_class(double d, double t) {
  if (std::isnan(d)) return 0;
  if (d <= 0) return 1;
  if (d < t / 100) return 2;
  if (d < t / 10) return 3;
  if (d < t) return 4;
  return d < 10 * t ? 5 : 6;
}

void write_classes_tif(const fs::path& path, const PlanRaster& pr, double t,
                       const OGRSpatialReference* srs) {
  const NoAuxXml no_aux;
  GDALDatasetUniquePtr ds = create_tif(path, pr, 1, GDT_Byte, srs);
  std::vector<unsigned char> v(static_cast<std::size_t>(pr.cols) * pr.rows);
  for (int row = 0; row < pr.rows; ++row)
    for (int col = 0; col < pr.cols; ++col)
      v[static_cast<std::size_t>(row) * pr.cols + col] =
          density_class(pr.mean(0, col, pr.rows - 1 - row), t);
  GDALRasterBand* band = ds->GetRasterBand(1);
  band->SetNoDataValue(0);
  GDALColorTable colours;
  const std::array<std::array<short, 4>, 7> rgba = {{{0, 0, 0, 0},
                                                     {255, 255, 255, 0},
                                                     {255, 255, 178, 255},
                                                     {254, 204, 92, 255},
                                                     {253, 141, 60, 255},
                                                     {227, 26, 28, 255},
                                                     {128, 0, 38, 255}}};
  for (int k = 0; k < 7; ++k) {
    const GDALColorEntry e{rgba[k][0], rgba[k][1], rgba[k][2], rgba[k][3]};
    colours.SetColorEntry(k, &e);
  }
  band->SetColorTable(&colours);
  // The legend as band metadata (kept in the TIFF itself; category names would need a
  // .aux.xml beside it).
  const char* names[] = {"no data",
                         "no hazardous fragment",
                         "below 1/100 of the threshold",
                         "1/100 to 1/10 of the threshold",
                         "1/10 of the threshold to the threshold",
                         "hazardous: the threshold to 10 times it",
                         "hazardous: 10 times the threshold or more"};
  for (int k = 0; k < 7; ++k)
    band->SetMetadataItem(("CLASS_" + std::to_string(k)).c_str(), names[k]);
  if (band->RasterIO(GF_Write, 0, 0, pr.cols, pr.rows, v.data(), pr.cols, pr.rows, GDT_Byte, 0,
                     0) != CE_None)
    throw std::runtime_error("cannot write " + path.string());
}

// ---- Vectors ----

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
std::unique_ptr<OGRGeometry> hazard_area(const Results& r, double s, std::size_t* count) {
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

struct LayerSet {
  std::unique_ptr<OGRGeometry> estimate, lower, upper;
  std::vector<std::unique_ptr<OGRGeometry>> buildings;
};

// RFC 7946 GeoJSON is a layer option of the GeoJSON driver (it then reprojects to WGS 84).
thread_local bool g_rfc7946 = false;

OGRLayer* new_layer(GDALDataset& ds, const char* name, const OGRSpatialReference* srs,
                    OGRwkbGeometryType type,
                    const std::vector<std::pair<const char*, OGRFieldType>>& fields) {
  const char* rfc[] = {"RFC7946=YES", nullptr};
  OGRLayer* l = ds.CreateLayer(name, const_cast<OGRSpatialReference*>(srs), type,
                               g_rfc7946 ? const_cast<char**>(rfc) : nullptr);
  if (l == nullptr) throw std::runtime_error(std::string("cannot create layer ") + name);
  for (const auto& [fname, ftype] : fields) {
    OGRFieldDefn fd(fname, ftype);
    if (l->CreateField(&fd) != OGRERR_NONE)
      throw std::runtime_error(std::string("cannot create field ") + fname);
  }
  return l;
}

void add_feature(OGRLayer& l, const OGRGeometry& g, const std::function<void(OGRFeature&)>& set,
                 OGRCoordinateTransformation* to_wgs84) {
  OGRFeature f(l.GetLayerDefn());
  std::unique_ptr<OGRGeometry> copy(g.clone());
  if (to_wgs84 != nullptr && copy->transform(to_wgs84) != OGRERR_NONE)
    throw std::runtime_error("cannot transform a geometry to WGS 84");
  f.SetGeometry(copy.get());
  set(f);
  if (l.CreateFeature(&f) != OGRERR_NONE) throw std::runtime_error("cannot write a feature");
}

void write_hazard_layer(GDALDataset& ds, const Results& r, const LayerSet& g,
                        const OGRSpatialReference* srs, OGRCoordinateTransformation* tr) {
  OGRLayer* l = new_layer(ds, "hazardous_area", srs, wkbMultiPolygon,
                          {{"band", OFTString},
                           {"threshold_per_m2", OFTReal},
                           {"rule", OFTString},
                           {"extent_bound", OFTString}});
  // extent_bound "lower": the area reaches the site boundary and goes on beyond the model.
  const std::array<std::tuple<const char*, const OGRGeometry*, const char*, const std::string*>, 3>
      rows = {{{"estimate", g.estimate.get(), "density >= threshold", &r.hfd_bound},
               {"lower_1se", g.lower.get(), "density - 1 standard error >= threshold",
                &r.band_lower_bound},
               {"upper_1se", g.upper.get(), "density + 1 standard error >= threshold",
                &r.band_upper_bound}}};
  for (const auto& [band, geom, rule, bound] : rows)
    add_feature(
        *l, *geom,
        [&, band = band, rule = rule, bound = bound](OGRFeature& f) {
          f.SetField("band", band);
          f.SetField("threshold_per_m2", r.threshold);
          f.SetField("rule", rule);
          f.SetField("extent_bound", bound->c_str());
        },
        tr);
}

void write_buildings_layer(GDALDataset& ds, const Results& r, const LayerSet& g,
                           const OGRSpatialReference* srs, OGRCoordinateTransformation* tr) {
  OGRLayer* l = new_layer(ds, "buildings", srs, wkbMultiPolygon,
                          {{"id", OFTString},
                           {"expected_impacts", OFTReal},
                           {"impacts_std_error", OFTReal},
                           {"expected_penetrations", OFTReal},
                           {"penetrations_std_error", OFTReal}});
  for (std::size_t k = 0; k < r.buildings.size(); ++k) {
    const Building& b = r.buildings[k];
    add_feature(
        *l, *g.buildings[k],
        [&](OGRFeature& f) {
          f.SetField("id", b.id.c_str());
          f.SetField("expected_impacts", b.impacts);
          f.SetField("impacts_std_error", b.impacts_se);
          f.SetField("expected_penetrations", b.penetrations);
          f.SetField("penetrations_std_error", b.penetrations_se);
        },
        tr);
  }
}

void write_hfd_layers(GDALDataset& ds, const Results& r, const OGRSpatialReference* srs,
                      OGRCoordinateTransformation* tr) {
  OGRLayer* p = new_layer(ds, "hfd", srs, wkbPoint,
                          {{"hfd_m", OFTReal},
                           {"hfd_bound", OFTString},
                           {"band_lower_m", OFTReal},
                           {"band_upper_m", OFTReal},
                           {"band_lower_bound", OFTString},
                           {"band_upper_bound", OFTString},
                           {"threshold_per_m2", OFTReal},
                           {"note", OFTString},
                           {"left_site_hazardous", OFTReal},
                           {"left_site_hazardous_se", OFTReal}});
  const OGRPoint origin(r.hfd_origin.x(), r.hfd_origin.y());
  add_feature(
      *p, origin,
      [&](OGRFeature& f) {
        f.SetField("hfd_m", r.hfd_m);
        f.SetField("hfd_bound", r.hfd_bound.c_str());
        f.SetField("band_lower_m", r.band_lo);
        f.SetField("band_upper_m", r.band_hi);
        f.SetField("band_lower_bound", r.band_lower_bound.c_str());
        f.SetField("band_upper_bound", r.band_upper_bound.c_str());
        f.SetField("threshold_per_m2", r.threshold);
        f.SetField("note", r.hfd_note.c_str());
        f.SetField("left_site_hazardous", r.left_hazardous);
        f.SetField("left_site_hazardous_se", r.left_hazardous_se);
      },
      tr);
  OGRLayer* s = new_layer(ds, "hfd_sectors", srs, wkbLineString,
                          {{"azimuth_from_deg", OFTReal},
                           {"azimuth_to_deg", OFTReal},
                           {"hfd_m", OFTReal},
                           {"hfd_bound", OFTString},
                           {"left_site_hazardous", OFTReal}});
  for (std::size_t k = 0; k < r.by_sector.size(); ++k) {
    const double a = (10.0 * static_cast<double>(k) + 5.0) * M_PI / 180.0;  // sector centre
    OGRLineString line;
    line.addPoint(origin.getX(), origin.getY());
    line.addPoint(origin.getX() + r.by_sector[k] * std::cos(a),
                  origin.getY() + r.by_sector[k] * std::sin(a));
    add_feature(
        *s, line,
        [&](OGRFeature& f) {
          f.SetField("azimuth_from_deg", 10.0 * static_cast<double>(k));
          f.SetField("azimuth_to_deg", 10.0 * static_cast<double>(k + 1));
          f.SetField("hfd_m", r.by_sector[k]);
          f.SetField("hfd_bound", r.sector_bound[k].c_str());
          f.SetField("left_site_hazardous", r.left_hazardous_by_sector[k]);
        },
        tr);
  }
}

GDALDatasetUniquePtr create_vector(const fs::path& path, const char* driver,
                                   const std::vector<std::string>& options = {}) {
  ensure_gdal_registered();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver);
  if (drv == nullptr) throw std::runtime_error(std::string("no GDAL driver ") + driver);
  std::vector<char*> opts;
  std::vector<std::string> keep = options;
  for (auto& o : keep) opts.push_back(o.data());
  opts.push_back(nullptr);
  GDALDatasetUniquePtr ds(drv->Create(path.c_str(), 0, 0, 0, GDT_Unknown, opts.data()));
  if (!ds) throw std::runtime_error("cannot create " + path.string());
  return ds;
}

}  // namespace

namespace {

// ParaView: terrain, buildings and trajectories as VTKHDF (gis/vtkhdf_export.h); a file with
// nothing to show is left out and said.
void stage_paraview(const fs::path& h5, const Vec2& offset,
                    const std::function<void(const std::string&,
                                             const std::function<void(const fs::path&)>&)>& stage,
                    std::vector<std::string>& notes) {
  const api::VtkUnstructuredGrid terrain = terrain_vtk(h5, offset);
  stage("terrain.vtkhdf", [&](const fs::path& p) { api::write_vtkhdf(p, terrain); });
  if (const auto b = buildings_vtk(h5, offset))
    stage("buildings.vtkhdf", [&](const fs::path& p) { api::write_vtkhdf(p, *b); });
  else
    notes.push_back("the site has no buildings: buildings.vtkhdf was not written");
  if (const auto t = trajectories_vtk(h5, offset))
    stage("trajectories.vtkhdf", [&](const fs::path& p) { api::write_vtkhdf(p, *t); });
  else
    notes.push_back(
        "the run recorded no trajectories (settings.record_trajectories): trajectories.vtkhdf "
        "was not written");
}

}  // namespace

ExportReport export_results(const ExportOptions& o) {
  const Results r = read_results(o.results_h5);
  ExportReport report;
  if (r.hfd_bound == "lower") report.notes.push_back(r.hfd_note);  // on every export, first
  // site.origin.crs is informational in a scenario: a label PROJ does not know (e.g. "local")
  // is treated as no CRS, as the PTN GeoJSON route does, rather than refusing the export.
  std::optional<OGRSpatialReference> srs;
  if (!r.crs.empty()) {
    try {
      srs = crs_from_text(r.crs, "site.origin.crs");
      report.crs = r.crs;
    } catch (const InputError&) {
      report.notes.push_back("site.origin.crs \"" + r.crs +
                             "\" is not a CRS PROJ knows: read as no CRS");
    }
  }
  const OGRSpatialReference* site_srs = srs ? &*srs : nullptr;

  report.pixel_m = o.pixel_m.value_or(default_cell(r));
  const PlanRaster pr = rasterise(r, report.pixel_m, r.grid_origin && !o.pixel_m);
  report.raster_cols = pr.cols;
  report.raster_rows = pr.rows;

  LayerSet g;
  g.estimate = hazard_area(r, 0.0, &report.hazardous_triangles);
  g.lower = hazard_area(r, -1.0, nullptr);
  g.upper = hazard_area(r, 1.0, nullptr);
  for (const auto& b : r.buildings) g.buildings.push_back(union_of(b.plan));

  GdalErrorCapture quiet;  // drivers' warnings (temporary file names) are not the user's
  api::OutputDir out(o.out_dir);
  const auto stage = [&](const std::string& name, const std::function<void(const fs::path&)>& w) {
    out.stage(name, w);
    report.files.push_back(name);
  };
  stage("ptn_density.tif", [&](const fs::path& p) { write_density_tif(p, pr, r, site_srs); });
  stage("ptn_classes.tif",
        [&](const fs::path& p) { write_classes_tif(p, pr, r.threshold, site_srs); });
  const auto all_layers = [&](GDALDataset& ds, const OGRSpatialReference* s,
                              OGRCoordinateTransformation* tr) {
    write_hazard_layer(ds, r, g, s, tr);
    write_buildings_layer(ds, r, g, s, tr);
    write_hfd_layers(ds, r, s, tr);
  };
  stage("hazard.gpkg", [&](const fs::path& p) {
    auto ds = create_vector(p, "GPKG");
    all_layers(*ds, site_srs, nullptr);
  });
  stage_paraview(o.results_h5, r.offset, stage, report.notes);
  if (!srs) {
    report.notes.push_back(
        "the site has no CRS PROJ knows (site.origin.crs): GeoJSON (RFC 7946) and KML need WGS 84, "
        "so "
        "they were not written; the GeoTIFFs and the GeoPackage are in the site's local metres");
    out.commit();
    return report;
  }
  OGRSpatialReference wgs84 = crs_from_text("EPSG:4326", "wgs84");
  std::unique_ptr<OGRCoordinateTransformation> to_wgs(
      OGRCreateCoordinateTransformation(site_srs, &wgs84));
  if (!to_wgs) throw InputError("site.origin.crs", r.crs + ": no transformation to WGS 84");
  const auto geojson = [&](const std::function<void(GDALDataset&)>& write) {
    return [&, write](const fs::path& p) {
      auto ds = create_vector(p, "GeoJSON");
      g_rfc7946 = true;
      try {
        write(*ds);
      } catch (...) {
        g_rfc7946 = false;
        throw;
      }
      g_rfc7946 = false;
    };
  };
  stage("hazardous_area.geojson",
        geojson([&](GDALDataset& ds) { write_hazard_layer(ds, r, g, site_srs, nullptr); }));
  stage("buildings.geojson",
        geojson([&](GDALDataset& ds) { write_buildings_layer(ds, r, g, site_srs, nullptr); }));
  stage("hazard.kml", [&](const fs::path& p) {
    auto ds = create_vector(p, "KML");
    all_layers(*ds, &wgs84, to_wgs.get());
  });
  out.commit();
  return report;
}

}  // namespace fragsim::gis
