// A site document as GIS files (site_to_gis.h).
#include "gis/site_to_gis.h"

#include <ogrsf_frmts.h>

#include <memory>

#include "core/common/error.h"
#include "formats/output_dir.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

struct Offset {
  double e = 0, n = 0;
};

// The grid's samples as the centres of the DEM's cells (what `site import` reads back).
void write_dem(const fs::path& path, const Json& grid, const OGRSpatialReference& srs, Offset o) {
  const int nx = grid.at("nx"), ny = grid.at("ny");
  const double s = grid.at("spacing_m");
  const double x0 = grid.at("origin_m")[0].get<double>() + o.e;
  const double y0 = grid.at("origin_m")[1].get<double>() + o.n;
  ensure_gdal_registered();
  const char* options[] = {"COMPRESS=DEFLATE", "PREDICTOR=3", nullptr};
  GDALDatasetUniquePtr ds(GetGDALDriverManager()->GetDriverByName("GTiff")->Create(
      path.c_str(), nx, ny, 1, GDT_Float64, const_cast<char**>(options)));
  if (!ds) throw std::runtime_error("cannot create " + path.string());
  double gt[6] = {x0 - 0.5 * s, s, 0, y0 + (ny - 1) * s + 0.5 * s, 0, -s};
  ds->SetGeoTransform(gt);
  ds->SetSpatialRef(&srs);
  const std::vector<double> z = grid.at("elevation_m").get<std::vector<double>>();
  std::vector<double> rows(z.size());
  for (int r = 0; r < ny; ++r)  // file row r is grid row ny - 1 - r (north first)
    std::copy_n(z.begin() + static_cast<long>(ny - 1 - r) * nx, nx,
                rows.begin() + static_cast<long>(r) * nx);
  GDALRasterBand* b = ds->GetRasterBand(1);
  b->SetUnitType("m");
  if (b->RasterIO(GF_Write, 0, 0, nx, ny, rows.data(), nx, ny, GDT_Float64, 0, 0) != CE_None)
    throw std::runtime_error("cannot write " + path.string());
}

OGRLinearRing* ring_of(const Json& points, Offset o) {
  auto* ring = new OGRLinearRing();
  for (const auto& p : points) ring->addPoint(p[0].get<double>() + o.e, p[1].get<double>() + o.n);
  ring->closeRings();
  return ring;
}

// Footprint buildings as polygons (with their courtyards); mesh buildings have no footprint.
void write_footprints(const fs::path& path, const Json& buildings, const OGRSpatialReference& srs,
                      Offset o, SiteGisReport& report) {
  ensure_gdal_registered();
  GDALDatasetUniquePtr ds(GetGDALDriverManager()->GetDriverByName("GPKG")->Create(
      path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  if (!ds) throw std::runtime_error("cannot create " + path.string());
  OGRLayer* l =
      ds->CreateLayer("buildings", const_cast<OGRSpatialReference*>(&srs), wkbPolygon, nullptr);
  for (const auto& [name, type] :
       std::vector<std::pair<const char*, OGRFieldType>>{{"name", OFTString},
                                                         {"height_m", OFTReal},
                                                         {"base_elevation_m", OFTReal},
                                                         {"wall", OFTString},
                                                         {"roof", OFTString},
                                                         {"window", OFTString}}) {
    OGRFieldDefn fd(name, type);
    l->CreateField(&fd);
  }
  for (const auto& b : buildings) {
    if (!b.contains("footprint_m")) {
      report.notes.push_back("building \"" + b.value("id", "") +
                             "\" is a mesh, not a footprint: not in the GeoPackage");
      continue;
    }
    OGRPolygon poly;
    poly.addRingDirectly(ring_of(b["footprint_m"], o));
    if (b.contains("holes_m"))
      for (const auto& h : b["holes_m"]) poly.addRingDirectly(ring_of(h, o));
    OGRFeature f(l->GetLayerDefn());
    f.SetGeometry(&poly);
    f.SetField("name", b.value("id", "").c_str());
    f.SetField("height_m", b.at("height_m").get<double>());
    if (b.contains("base_elevation_m"))
      f.SetField("base_elevation_m", b["base_elevation_m"].get<double>());
    for (const char* k : {"wall", "roof", "window"})
      if (b.contains(k)) f.SetField(k, b[k].get<std::string>().c_str());
    if (l->CreateFeature(&f) != OGRERR_NONE) throw std::runtime_error("cannot write a footprint");
  }
}

Json import_file_for(const Json& site, bool buildings) {
  Json j = {{"schema", "fragsim.site_import/1"},
            {"terrain", {{"path", "terrain.tif"}, {"material", site["terrain"].at("material")}}}};
  if (buildings)
    j["buildings"] = {{"path", "buildings.gpkg"},
                      {"layer", "buildings"},
                      {"id_attribute", "name"},
                      {"height_attribute", "height_m"},
                      {"base_elevation_attribute", "base_elevation_m"},
                      {"wall_attribute", "wall"},
                      {"roof_attribute", "roof"},
                      {"window_attribute", "window"}};
  j["materials"] = site.value("materials", Json::object());
  j["origin_elevation_m"] = site["origin"].value("elevation_m", 0.0);
  return j;
}

}  // namespace

SiteGisReport write_site_gis(const Json& site, const fs::path& out_dir) {
  const std::string crs = site.contains("origin") ? site["origin"].value("crs", "") : "";
  if (crs.empty()) throw InputError("site.origin.crs", "the site has no CRS: GIS files need one");
  const OGRSpatialReference srs = crs_from_text(crs, "site.origin.crs");
  const Json& terrain = site.at("terrain");
  if (!terrain.contains("grid"))
    throw InputError("site.terrain", "only a grid terrain is a raster (DEM)");
  const Offset o{site["origin"].value("easting_m", 0.0), site["origin"].value("northing_m", 0.0)};
  SiteGisReport report;
  formats::OutputDir out(out_dir);
  out.stage("terrain.tif", [&](const fs::path& p) { write_dem(p, terrain["grid"], srs, o); });
  report.files.push_back("terrain.tif");
  const bool buildings = site.contains("buildings") && !site["buildings"].empty();
  if (buildings) {
    GdalErrorCapture quiet;  // the GPKG driver's warning about the temporary name
    out.stage("buildings.gpkg",
              [&](const fs::path& p) { write_footprints(p, site["buildings"], srs, o, report); });
    report.files.push_back("buildings.gpkg");
  }
  out.stage_text("import.json", import_file_for(site, buildings).dump(2) + "\n");
  report.files.push_back("import.json");
  out.commit();
  return report;
}

}  // namespace fragsim::gis
