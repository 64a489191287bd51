// GIS outputs of a run (results_export.h).
#include "gis/results_export.h"

#include <ogrsf_frmts.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "core/common/error.h"
#include "formats/output_dir.h"
#include "formats/results_h5.h"
#include "gis/gdal_support.h"
#include "gis/plan_boundary.h"
#include "gis/plan_raster.h"
#include "gis/results_file.h"
#include "gis/vtkhdf_export.h"

namespace fragsim::gis {

namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

constexpr double kNoData = -1.0;  // densities and errors are >= 0

// ---- Rasters ----

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

// Value sets 0 and 1 of `pr` as two float64 bands named `names`, `nodata` where nothing covers a
// cell. Row r of the file is raster row rows-1-r (GeoTIFF rows run north to south).
void write_two_bands(GDALDataset& ds, const fs::path& path, const PlanRaster& pr,
                     const std::array<const char*, 2>& names, double nodata) {
  for (int b = 0; b < 2; ++b) {
    std::vector<double> v(static_cast<std::size_t>(pr.cols) * pr.rows);
    for (int row = 0; row < pr.rows; ++row)
      for (int col = 0; col < pr.cols; ++col) {
        const double m = pr.mean(static_cast<std::size_t>(b), col, pr.rows - 1 - row);
        v[static_cast<std::size_t>(row) * pr.cols + col] = std::isnan(m) ? nodata : m;
      }
    GDALRasterBand* band = ds.GetRasterBand(b + 1);
    band->SetNoDataValue(nodata);
    band->SetDescription(names[static_cast<std::size_t>(b)]);
    if (band->RasterIO(GF_Write, 0, 0, pr.cols, pr.rows, v.data(), pr.cols, pr.rows, GDT_Float64, 0,
                       0) != CE_None)
      throw std::runtime_error("cannot write " + path.string());
  }
}

void write_density_tif(const fs::path& path, const PlanRaster& pr, const ResultsFile& res,
                       const OGRSpatialReference* srs) {
  const NoAuxXml no_aux;
  GDALDatasetUniquePtr ds = create_tif(path, pr, 2, GDT_Float64, srs);
  write_two_bands(*ds, path, pr,
                  {"PTN hazardous fragment density (1/m2)",
                   "standard error of the density (1/m2; area-weighted, an upper bound)"},
                  kNoData);
  ds->SetMetadataItem("FRAGSIM_THRESHOLD_PER_M2", std::to_string(res.threshold).c_str());
  ds->SetMetadataItem("FRAGSIM_CELL_VALUE",
                      "mean of the terrain triangles' values weighted by their plan area in the "
                      "cell");
}

// The paired difference (band 1) and its se (band 2); NaN where nothing covers a cell (a
// difference can be negative, so no sentinel value).
void write_difference_tif(const fs::path& path, const PlanRaster& pr,
                          const OGRSpatialReference* srs) {
  const NoAuxXml no_aux;
  GDALDatasetUniquePtr ds = create_tif(path, pr, 2, GDT_Float64, srs);
  write_two_bands(*ds, path, pr,
                  {"PTN density difference, variant - base (1/m2)",
                   "paired standard error of the difference (1/m2; area-weighted)"},
                  std::numeric_limits<double>::quiet_NaN());
  ds->SetMetadataItem("FRAGSIM_CELL_VALUE",
                      "mean of the terrain triangles' values weighted by their plan area in the "
                      "cell (docs/comparison.md)");
}

// The results with compare.h5's difference and se in place of the density and its se; nullopt
// when compare.h5 has none (the terrains differ).
std::optional<ResultsFile> with_difference(ResultsFile r, const fs::path& compare_h5) {
  const auto names = formats::list_datasets(compare_h5);
  if (std::find(names.begin(), names.end(), "/density/difference_per_m2") == names.end())
    return std::nullopt;
  r.density = formats::read_dataset_double(compare_h5, "/density/difference_per_m2");
  r.std_error = formats::read_dataset_double(compare_h5, "/density/paired_std_error_per_m2");
  if (r.density.size() != r.triangles.size() || r.std_error.size() != r.triangles.size())
    throw InputError(compare_h5.string(),
                     "its density difference has " + std::to_string(r.density.size()) +
                         " triangles, the results' terrain " + std::to_string(r.triangles.size()));
  return r;
}

std::optional<OGRSpatialReference> site_crs(const ResultsFile& r) {
  if (r.crs.empty()) return std::nullopt;
  try {
    return crs_from_text(r.crs, "site.origin.crs");
  } catch (const InputError&) {
    return std::nullopt;  // a label PROJ does not know: local metres, as export_results reads it
  }
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

// ---- US customary fields (docs/units.md): beside the SI ones, never instead of them ----

using Fields = std::vector<std::pair<const char*, OGRFieldType>>;

Fields with_us(Fields si, const Fields& us, api::UnitSystem u) {
  if (u == api::UnitSystem::kUs) si.insert(si.end(), us.begin(), us.end());
  return si;
}

// "138.8 m" / "455.4 ft", "≥ " first when the site boundary cuts it.
std::string bounded_length(double m, const std::string& bound, api::UnitSystem u) {
  return (bound == "lower" ? "≥ " : "") + api::format_length(m, u);
}

// "estimate: density >= threshold (1 per 600 ft²); reaches the site boundary".
void set_us_hazard_fields(OGRFeature& f, const ResultsFile& r, const char* band, const char* rule,
                          const std::string& bound, api::UnitSystem u) {
  if (u != api::UnitSystem::kUs) return;
  f.SetField("threshold_per_600ft2", api::present_areal_density(r.threshold, u).value);
  f.SetField("description",
             (std::string(band) + ": " + rule + " (" + api::format_areal_density(r.threshold, u) +
              ")" + (bound == "lower" ? "; reaches the site boundary" : ""))
                 .c_str());
}

void set_us_hfd_fields(OGRFeature& f, const ResultsFile& r, api::UnitSystem u) {
  if (u != api::UnitSystem::kUs) return;
  f.SetField("hfd_ft", api::present_length(r.hfd_m, u).value);
  f.SetField("band_lower_ft", api::present_length(r.band_lo, u).value);
  f.SetField("band_upper_ft", api::present_length(r.band_hi, u).value);
  f.SetField("threshold_per_600ft2", api::present_areal_density(r.threshold, u).value);
  f.SetField("description",
             ("HFD " + bounded_length(r.hfd_m, r.hfd_bound, u) + " (±1 se band " +
              bounded_length(r.band_lo, r.band_lower_bound, u) + " .. " +
              bounded_length(r.band_hi, r.band_upper_bound, u) + "), threshold " +
              api::format_areal_density(r.threshold, u) +
              (r.hfd_bound == "lower" ? "; a lower bound: the site boundary cuts it" : ""))
                 .c_str());
}

void set_us_sector_fields(OGRFeature& f, const ResultsFile& r, std::size_t k, api::UnitSystem u) {
  if (u != api::UnitSystem::kUs) return;
  const int sector = static_cast<int>(k);
  const std::string range = api::sector_bearing_range(sector);
  f.SetField("hfd_ft", api::present_length(r.by_sector[k], u).value);
  f.SetField("bearing_from_deg", api::bearing_deg(10.0 * sector + 10.0));
  f.SetField("bearing_to_deg",
             api::bearing_deg(10.0 * sector) == 0.0 ? 360.0 : api::bearing_deg(10.0 * sector));
  f.SetField("bearing_range", range.c_str());
  f.SetField("description",
             ("bearing " + range + ": HFD " + bounded_length(r.by_sector[k], r.sector_bound[k], u))
                 .c_str());
}

void write_hazard_layer(GDALDataset& ds, const ResultsFile& r, const LayerSet& g,
                        const OGRSpatialReference* srs, OGRCoordinateTransformation* tr,
                        api::UnitSystem u) {
  OGRLayer* l =
      new_layer(ds, "hazardous_area", srs, wkbMultiPolygon,
                with_us({{"band", OFTString},
                         {"threshold_per_m2", OFTReal},
                         {"rule", OFTString},
                         {"extent_bound", OFTString}},
                        {{"threshold_per_600ft2", OFTReal}, {"description", OFTString}}, u));
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
          set_us_hazard_fields(f, r, band, rule, *bound, u);
        },
        tr);
}

void write_buildings_layer(GDALDataset& ds, const ResultsFile& r, const LayerSet& g,
                           const OGRSpatialReference* srs, OGRCoordinateTransformation* tr) {
  OGRLayer* l = new_layer(ds, "buildings", srs, wkbMultiPolygon,
                          {{"id", OFTString},
                           {"expected_impacts", OFTReal},
                           {"impacts_std_error", OFTReal},
                           {"expected_penetrations", OFTReal},
                           {"penetrations_std_error", OFTReal}});
  for (std::size_t k = 0; k < r.buildings.size(); ++k) {
    const ResultsBuilding& b = r.buildings[k];
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

void write_hfd_layers(GDALDataset& ds, const ResultsFile& r, const OGRSpatialReference* srs,
                      OGRCoordinateTransformation* tr, api::UnitSystem u) {
  OGRLayer* p = new_layer(ds, "hfd", srs, wkbPoint,
                          with_us({{"hfd_m", OFTReal},
                                   {"hfd_bound", OFTString},
                                   {"band_lower_m", OFTReal},
                                   {"band_upper_m", OFTReal},
                                   {"band_lower_bound", OFTString},
                                   {"band_upper_bound", OFTString},
                                   {"threshold_per_m2", OFTReal},
                                   {"note", OFTString},
                                   {"left_site_hazardous", OFTReal},
                                   {"left_site_hazardous_se", OFTReal}},
                                  {{"hfd_ft", OFTReal},
                                   {"band_lower_ft", OFTReal},
                                   {"band_upper_ft", OFTReal},
                                   {"threshold_per_600ft2", OFTReal},
                                   {"description", OFTString}},
                                  u));
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
        set_us_hfd_fields(f, r, u);
      },
      tr);
  OGRLayer* s = new_layer(ds, "hfd_sectors", srs, wkbLineString,
                          with_us({{"azimuth_from_deg", OFTReal},
                                   {"azimuth_to_deg", OFTReal},
                                   {"hfd_m", OFTReal},
                                   {"hfd_bound", OFTString},
                                   {"left_site_hazardous", OFTReal}},
                                  {{"hfd_ft", OFTReal},
                                   {"bearing_from_deg", OFTReal},
                                   {"bearing_to_deg", OFTReal},
                                   {"bearing_range", OFTString},
                                   {"description", OFTString}},
                                  u));
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
          set_us_sector_fields(f, r, k, u);
        },
        tr);
  }
}

// ---- The site-plan boundary (gis/plan_boundary.h) ----

// A polygon feature and its attributes; a layer's fields are its features' attributes, in order.
using Attribute = std::pair<const char*, std::variant<double, std::string>>;
struct PlanFeature {
  const PlanMultiPolygon* polygon;
  std::vector<Attribute> attributes;
};

// "143.2 m" / "469.8 ft".
std::string length_text(double m, api::UnitSystem u) {
  return api::format_length(m, u, 1);
}

// With US units, the figures again in ft beside the SI fields (docs/units.md).
void add_feet(std::vector<Attribute>& a, api::UnitSystem u,
              std::initializer_list<std::pair<const char*, double>> figures_m) {
  if (u != api::UnitSystem::kUs) return;
  for (const auto& figure : figures_m) {
    Attribute& added = a.emplace_back();
    added.first = figure.first;
    added.second.emplace<double>(api::present_length(figure.second, u).value);
  }
}

// The two sector envelopes: of the estimate and of the upper end of the +-1 se band.
std::vector<PlanFeature> envelope_features(const ResultsFile& r, const PlanBoundary& b,
                                           api::UnitSystem u) {
  const auto one = [&](const SectorEnvelope& e, const char* band, const char* rule, double hfd) {
    PlanFeature f{
        &e.polygon,
        {{"name", std::string("HFD sector envelope (") + band + ")"},
         {"band", std::string(band)},
         {"rule", std::string(rule)},
         {"max_radius_m", e.max_radius_m},
         {"exact_hfd_m", hfd},
         {"description",
          "Per 10-degree HFD sector, an arc through the farthest point of the sector's triangles "
          "where " +
              std::string(rule) +
              ", joined radially: it contains every such triangle and "
              "is never inside the sector's HFD arc. Largest radius " +
              length_text(e.max_radius_m, u) + " (HFD " + length_text(hfd, u) + ")."}}};
    add_feet(f.attributes, u, {{"max_radius_ft", e.max_radius_m}, {"exact_hfd_ft", hfd}});
    return f;
  };
  return {one(b.envelope, "estimate", "density >= threshold", r.hfd_m),
          one(b.envelope_upper, "upper_1se", "density + 1 standard error >= threshold", r.band_hi)};
}

PlanFeature smoothed_feature(const PlanBoundary& b, api::UnitSystem u) {
  const double longer = b.smoothed_hfd_m - b.exact_hfd_m;
  PlanFeature f{
      &b.smoothed,
      {{"name", std::string("hazard boundary (smoothed)")},
       {"band", std::string("estimate")},
       {"smoothing_m", b.smoothing_m},
       {"hfd_m", b.smoothed_hfd_m},
       {"exact_hfd_m", b.exact_hfd_m},
       {"area_m2", b.smoothed_area_m2},
       {"exact_area_m2", b.exact_area_m2},
       {"description",
        "The hazardous area (density >= threshold) closed with a disc of radius " +
            length_text(b.smoothing_m, u) +
            " (dilated, then eroded), holes filled, united with the exact area: it contains "
            "every hazardous triangle. Its farthest point is " +
            length_text(b.smoothed_hfd_m, u) + " from the HFD origin, " + length_text(longer, u) +
            " beyond the HFD (" + length_text(b.exact_hfd_m, u) + ")."}}};
  add_feet(f.attributes, u,
           {{"smoothing_ft", b.smoothing_m},
            {"hfd_ft", b.smoothed_hfd_m},
            {"exact_hfd_ft", b.exact_hfd_m}});
  return f;
}

// A layer of plan features (those with no polygon are left out: an empty layer).
void write_plan_layer(GDALDataset& ds, const char* name, const std::vector<PlanFeature>& features,
                      const OGRSpatialReference* srs, OGRCoordinateTransformation* tr) {
  std::vector<std::pair<const char*, OGRFieldType>> fields;
  for (const auto& f : features)
    for (const auto& [field, value] : f.attributes) {
      const auto same = [&, field = field](const auto& x) { return std::string(x.first) == field; };
      if (std::none_of(fields.begin(), fields.end(), same))
        fields.emplace_back(field, value.index() == 0 ? OFTReal : OFTString);
    }
  OGRLayer* l = new_layer(ds, name, srs, wkbMultiPolygon, fields);
  for (const auto& pf : features) {
    if (pf.polygon->empty()) continue;
    add_feature(
        *l, *to_ogr(*pf.polygon),
        [&](OGRFeature& f) {
          for (const auto& [field, value] : pf.attributes) {
            if (const double* x = std::get_if<double>(&value))
              f.SetField(field, *x);
            else
              f.SetField(field, std::get<std::string>(value).c_str());
          }
        },
        tr);
  }
}

void write_boundary_layers(GDALDataset& ds, const ResultsFile& r, const PlanBoundary& b,
                           const OGRSpatialReference* srs, OGRCoordinateTransformation* tr,
                           api::UnitSystem u) {
  write_plan_layer(ds, "hfd_envelope", envelope_features(r, b, u), srs, tr);
  write_plan_layer(ds, "hazard_boundary", {smoothed_feature(b, u)}, srs, tr);
}

// hazard_boundary.geojson: the three in one layer.
void write_boundary_geojson(GDALDataset& ds, const ResultsFile& r, const PlanBoundary& b,
                            const OGRSpatialReference* srs, api::UnitSystem u) {
  std::vector<PlanFeature> all = envelope_features(r, b, u);
  all.push_back(smoothed_feature(b, u));
  write_plan_layer(ds, "hazard_boundary", all, srs, nullptr);
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
// Stages one file of the export: its name and its writer (to a temporary path).
using Stage =
    std::function<void(const std::string& name, const std::function<void(const fs::path&)>& write)>;

void stage_paraview(const fs::path& h5, const Vec2& offset, const Stage& stage,
                    std::vector<std::string>& notes) {
  const formats::VtkUnstructuredGrid terrain = terrain_vtk(h5, offset);
  stage("terrain.vtkhdf", [&](const fs::path& p) { formats::write_vtkhdf(p, terrain); });
  if (const auto b = buildings_vtk(h5, offset))
    stage("buildings.vtkhdf", [&](const fs::path& p) { formats::write_vtkhdf(p, *b); });
  else
    notes.push_back("the site has no buildings: buildings.vtkhdf was not written");
  if (const auto t = trajectories_vtk(h5, offset))
    stage("trajectories.vtkhdf", [&](const fs::path& p) { formats::write_vtkhdf(p, *t); });
  else
    notes.push_back(
        "the run recorded no trajectories (settings.record_trajectories): trajectories.vtkhdf "
        "was not written");
}

}  // namespace

bool write_difference_map(const fs::path& results_h5, const fs::path& compare_h5,
                          const fs::path& out_tif, std::optional<double> pixel_m) {
  const ResultsFile base = read_results_file(results_h5);
  const std::optional<ResultsFile> d = with_difference(base, compare_h5);
  if (!d) return false;
  const PlanRaster pr =
      rasterise(*d, pixel_m.value_or(default_cell(*d)), d->grid_origin && !pixel_m);
  const std::optional<OGRSpatialReference> srs = site_crs(*d);
  GdalErrorCapture quiet;
  formats::OutputDir out(out_tif.parent_path());
  out.stage(out_tif.filename().string(),
            [&](const fs::path& p) { write_difference_tif(p, pr, srs ? &*srs : nullptr); });
  out.commit();
  return true;
}

namespace {

// Every layer, into one data set (GeoPackage in the site's CRS, KML in WGS 84 through `tr`).
void write_all_layers(GDALDataset& ds, const ResultsFile& r, const LayerSet& g,
                      const PlanBoundary& boundary, const OGRSpatialReference* srs,
                      OGRCoordinateTransformation* tr, api::UnitSystem units) {
  write_hazard_layer(ds, r, g, srs, tr, units);
  write_buildings_layer(ds, r, g, srs, tr);
  write_hfd_layers(ds, r, srs, tr, units);
  write_boundary_layers(ds, r, boundary, srs, tr, units);
}

// The site's CRS when PROJ knows it. site.origin.crs is informational in a scenario: a label PROJ
// does not know (e.g. "local") is treated as no CRS, as the PTN GeoJSON route does, rather than
// refusing the export.
std::optional<OGRSpatialReference> site_crs(const ResultsFile& r, ExportReport& report) {
  if (r.crs.empty()) return std::nullopt;
  try {
    auto srs = crs_from_text(r.crs, "site.origin.crs");
    report.crs = r.crs;
    return srs;
  } catch (const InputError&) {
    report.notes.push_back("site.origin.crs \"" + r.crs +
                           "\" is not a CRS PROJ knows: read as no CRS");
  }
  return std::nullopt;
}

// What every export holds: the hazard polygons (estimate and ±1 se) and the buildings' plans.
LayerSet layer_set(const ResultsFile& r, ExportReport& report) {
  LayerSet g;
  g.estimate = hazard_area(r, 0.0, &report.hazardous_triangles);
  g.lower = hazard_area(r, -1.0, nullptr);
  g.upper = hazard_area(r, 1.0, nullptr);
  for (const auto& b : r.buildings) g.buildings.push_back(union_of(b.plan));
  return g;
}

// A GeoJSON file (RFC 7946 coordinates while `write` runs).
std::function<void(const fs::path&)> geojson(const std::function<void(GDALDataset&)>& write) {
  return [write](const fs::path& p) {
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
}

// The files in WGS 84 (GeoJSON and KML), for a site whose CRS PROJ knows.
void stage_wgs84_files(const Stage& stage, const ResultsFile& r, const LayerSet& g,
                       const PlanBoundary& boundary, const OGRSpatialReference* site_srs,
                       api::UnitSystem units) {
  OGRSpatialReference wgs84 = crs_from_text("EPSG:4326", "wgs84");
  std::unique_ptr<OGRCoordinateTransformation> to_wgs(
      OGRCreateCoordinateTransformation(site_srs, &wgs84));
  if (!to_wgs) throw InputError("site.origin.crs", r.crs + ": no transformation to WGS 84");
  stage("hazardous_area.geojson",
        geojson([&](GDALDataset& ds) { write_hazard_layer(ds, r, g, site_srs, nullptr, units); }));
  stage("buildings.geojson",
        geojson([&](GDALDataset& ds) { write_buildings_layer(ds, r, g, site_srs, nullptr); }));
  stage("hazard_boundary.geojson", geojson([&](GDALDataset& ds) {
          write_boundary_geojson(ds, r, boundary, site_srs, units);
        }));
  stage("hazard.kml", [&](const fs::path& p) {
    auto ds = create_vector(p, "KML");
    write_all_layers(*ds, r, g, boundary, &wgs84, to_wgs.get(), units);
  });
}

}  // namespace

ExportReport export_results(const ExportOptions& o) {
  const ResultsFile r = read_results_file(o.results_h5);
  ExportReport report;
  if (r.hfd_bound == "lower") report.notes.push_back(r.hfd_note);  // on every export, first
  const std::optional<OGRSpatialReference> srs = site_crs(r, report);
  const OGRSpatialReference* site_srs = srs ? &*srs : nullptr;

  report.pixel_m = o.pixel_m.value_or(default_cell(r));
  const PlanRaster pr = rasterise(r, report.pixel_m, r.grid_origin && !o.pixel_m);
  report.raster_cols = pr.cols;
  report.raster_rows = pr.rows;
  const LayerSet g = layer_set(r, report);
  const PlanBoundary boundary = plan_boundary(r, {o.smoothing_m});
  if (boundary.smoothed.empty())
    report.notes.push_back(
        "no terrain triangle is at or above the threshold: the site-plan boundary layers "
        "(hfd_envelope, hazard_boundary) are empty");

  GdalErrorCapture quiet;  // drivers' warnings (temporary file names) are not the user's
  formats::OutputDir out(o.out_dir);
  const Stage stage = [&](const std::string& name,
                          const std::function<void(const fs::path&)>& write) {
    out.stage(name, write);
    report.files.push_back(name);
  };
  stage("ptn_density.tif", [&](const fs::path& p) { write_density_tif(p, pr, r, site_srs); });
  stage("ptn_classes.tif",
        [&](const fs::path& p) { write_classes_tif(p, pr, r.threshold, site_srs); });
  if (o.compare_h5) {
    if (const auto d = with_difference(r, *o.compare_h5)) {
      const PlanRaster dr = rasterise(*d, report.pixel_m, r.grid_origin && !o.pixel_m);
      stage(kDifferenceMapName, [&](const fs::path& p) { write_difference_tif(p, dr, site_srs); });
    }
  }
  stage("hazard.gpkg", [&](const fs::path& p) {
    auto ds = create_vector(p, "GPKG");
    write_all_layers(*ds, r, g, boundary, site_srs, nullptr, o.units);
  });
  stage_paraview(o.results_h5, r.offset, stage, report.notes);
  if (srs) {
    stage_wgs84_files(stage, r, g, boundary, site_srs, o.units);
  } else {
    report.notes.push_back(
        "the site has no CRS PROJ knows (site.origin.crs): GeoJSON (RFC 7946) and KML need WGS 84, "
        "so they were not written; the GeoTIFFs and the GeoPackage are in the site's local metres");
  }
  out.commit();
  return report;
}

}  // namespace fragsim::gis
