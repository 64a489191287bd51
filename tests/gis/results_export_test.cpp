// GIS outputs of a run (gis/results_export.h; docs/gis.md "Outputs"): a run's results.h5 out as
// GeoTIFF, GeoPackage, RFC 7946 GeoJSON and KML; checked by reading the files back with GDAL.
#include "gis/results_export.h"

#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include <cmath>
#include <map>

#include "api/ptn_json.h"
#include "api/run_outputs.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "formats/h5_writer.h"
#include "formats/results_h5.h"
#include "gis/gdal_support.h"
#include "gis/run_fixture.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

class ResultsExport : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_export_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // The minimal example moved to UTM 11N (input (0, 0) at 452300 E, 3839800 N), with fragments
  // slow and steep enough to leave a hazardous area near the origin.
  fs::path run_minimal(const std::string& crs) {
    Json sc = api::testing::on_small_plane(api::testing::minimal_example());
    sc["site"]["origin"] = {
        {"crs", crs}, {"easting_m", 452300}, {"northing_m", 3839800}, {"elevation_m", 0}};
    auto& g = sc["fragment_groups"][0];
    g["speed_mps"] = {{"dist", "normal"}, {"mean", 60}, {"sigma", 5}};
    g["direction"]["elevation_deg"] = {40, 80};
    g["count"] = 20000;
    return testing::write_run(sc, dir_ / "run");
  }

  fs::path dir_;
};

struct Terrain {
  std::vector<double> v;  // input coordinates
  std::vector<std::int64_t> t;
  std::vector<double> d, se;
  double threshold;
  Vec2 centroid(std::size_t k) const {
    Vec2 c(0, 0);
    for (int i = 0; i < 3; ++i) c += Vec2(v[3 * t[3 * k + i]], v[3 * t[3 * k + i] + 1]);
    return c / 3.0;
  }
};

Terrain read_terrain(const fs::path& h5) {
  return {formats::read_dataset_double(h5, "/terrain/vertices_m"),
          formats::read_dataset_int64(h5, "/terrain/triangles"),
          formats::read_dataset_double(h5, "/ptn/density_per_m2"),
          formats::read_dataset_double(h5, "/ptn/std_error_per_m2"),
          formats::read_dataset_double(h5, "/hfd/threshold_per_m2").at(0)};
}

TEST_F(ResultsExport, TheDensityGeoTiffHoldsTheCellMeansOfTheTrianglesInTheSiteCrs) {
  const fs::path h5 = run_minimal("EPSG:32611");
  const ExportReport rep = export_results({h5, dir_ / "gis", std::nullopt});
  EXPECT_EQ(rep.crs, "EPSG:32611");
  EXPECT_EQ(rep.pixel_m, 10.0);  // the plane's cells
  GDALDatasetUniquePtr ds(
      GDALDataset::Open((dir_ / "gis/ptn_density.tif").c_str(), GDAL_OF_RASTER));
  ASSERT_TRUE(ds);
  EXPECT_EQ(crs_name(*ds->GetSpatialRef()), "EPSG:32611");
  double gt[6];
  ds->GetGeoTransform(gt);
  // The plane spans input -200 ... 200: 40 x 40 cells of 10 m, north-up.
  EXPECT_EQ(std::vector<double>(gt, gt + 6), (std::vector<double>{452100, 10, 0, 3840000, 0, -10}));
  ASSERT_EQ(ds->GetRasterXSize(), 40);
  ASSERT_EQ(ds->GetRasterYSize(), 40);
  std::vector<double> band(1600), se(1600);
  ASSERT_EQ(
      ds->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, 40, 40, band.data(), 40, 40, GDT_Float64, 0, 0),
      CE_None);
  ASSERT_EQ(
      ds->GetRasterBand(2)->RasterIO(GF_Read, 0, 0, 40, 40, se.data(), 40, 40, GDT_Float64, 0, 0),
      CE_None);
  // Each cell: the mean of its two triangles (equal plan areas), independently from results.h5.
  const Terrain t = read_terrain(h5);
  std::vector<double> sum(1600, 0.0), sum_se(1600, 0.0);
  std::vector<int> n(1600, 0);
  for (std::size_t k = 0; k < t.d.size(); ++k) {
    const Vec2 c = t.centroid(k);
    const int col = static_cast<int>(std::floor((c.x() + 200) / 10));
    const int row = 39 - static_cast<int>(std::floor((c.y() + 200) / 10));  // north first
    sum[row * 40 + col] += t.d[k];
    sum_se[row * 40 + col] += t.se[k];
    ++n[row * 40 + col];
  }
  double total = 0;
  for (std::size_t p = 0; p < 1600; ++p) {
    ASSERT_EQ(n[p], 2);
    EXPECT_NEAR(band[p], sum[p] / 2, 1e-12 * std::max(1e-12, sum[p])) << p;
    EXPECT_NEAR(se[p], sum_se[p] / 2, 1e-12 * std::max(1e-12, sum_se[p])) << p;
    total += band[p];
  }
  EXPECT_GT(total, 0.0);
}

double area_of(OGRLayer& l, const char* band) {
  l.ResetReading();
  for (auto& f : l)
    if (std::string(f->GetFieldAsString("band")) == band) {
      const OGRGeometry* g = f->GetGeometryRef();
      return g->IsEmpty() ? 0.0
             : dynamic_cast<const OGRSurface*>(g)
                 ? dynamic_cast<const OGRSurface*>(g)->get_Area()
                 : dynamic_cast<const OGRMultiSurface*>(g)->get_Area();
    }
  ADD_FAILURE() << "no feature " << band;
  return -1;
}

TEST_F(ResultsExport, TheHazardousAreaIsExactlyTheTrianglesAtOrAboveTheThreshold) {
  const fs::path h5 = run_minimal("EPSG:32611");
  const ExportReport rep = export_results({h5, dir_ / "gis", std::nullopt});
  const Terrain t = read_terrain(h5);
  ASSERT_GT(rep.hazardous_triangles, 0u) << "the scenario leaves no hazardous area";
  GDALDatasetUniquePtr ds(GDALDataset::Open((dir_ / "gis/hazard.gpkg").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(ds);
  OGRLayer* l = ds->GetLayerByName("hazardous_area");
  ASSERT_NE(l, nullptr);
  EXPECT_EQ(l->GetFeatureCount(), 3);
  EXPECT_EQ(crs_name(*l->GetSpatialRef()), "EPSG:32611");
  // Plan area: 50 m2 per triangle of the 10 m plane.
  int above = 0, lower = 0, upper = 0;
  for (std::size_t k = 0; k < t.d.size(); ++k) {
    above += t.d[k] >= t.threshold;
    lower += t.d[k] - t.se[k] >= t.threshold;
    upper += t.d[k] + t.se[k] >= t.threshold;
  }
  EXPECT_EQ(static_cast<std::size_t>(above), rep.hazardous_triangles);
  EXPECT_NEAR(area_of(*l, "estimate"), 50.0 * above, 1e-6);
  EXPECT_NEAR(area_of(*l, "lower_1se"), 50.0 * lower, 1e-6);
  EXPECT_NEAR(area_of(*l, "upper_1se"), 50.0 * upper, 1e-6);
  // Every triangle's centroid is inside the estimate iff its density reaches the threshold.
  l->ResetReading();
  std::unique_ptr<OGRGeometry> estimate;
  for (auto& f : *l)
    if (std::string(f->GetFieldAsString("band")) == "estimate")
      estimate.reset(f->GetGeometryRef()->clone());
  ASSERT_TRUE(estimate);
  for (std::size_t k = 0; k < t.d.size(); ++k) {
    const Vec2 c = t.centroid(k);
    const OGRPoint p(c.x() + 452300, c.y() + 3839800);
    EXPECT_EQ(p.Within(estimate.get()), t.d[k] >= t.threshold) << k;
  }
  // The HFD point and its 36 sectors.
  EXPECT_EQ(ds->GetLayerByName("hfd")->GetFeatureCount(), 1);
  EXPECT_EQ(ds->GetLayerByName("hfd_sectors")->GetFeatureCount(), 36);
}

// Issue 22: the HFD, its band, its sectors and the hazardous area say whether the terrain's
// boundary cuts them, as results.h5 does, in the GeoPackage and the KML; the export's first note
// says so. On the small plane the area runs off the site; on the minimal example's own 3 km plane
// it does not.
std::map<std::string, std::string> hfd_fields(const fs::path& gpkg) {
  GDALDatasetUniquePtr ds(GDALDataset::Open(gpkg.c_str(), GDAL_OF_VECTOR));
  std::map<std::string, std::string> out;
  if (!ds) return out;
  OGRLayer* hfd = ds->GetLayerByName("hfd");
  for (auto& f : *hfd)
    for (const char* k : {"hfd_bound", "band_lower_bound", "band_upper_bound", "note"})
      out[k] = f->GetFieldAsString(k);
  for (auto& f : *ds->GetLayerByName("hazardous_area"))
    out[std::string("area_") + f->GetFieldAsString("band")] = f->GetFieldAsString("extent_bound");
  int k = 0;
  for (auto& f : *ds->GetLayerByName("hfd_sectors"))
    out["sector_" + std::to_string(k++)] = f->GetFieldAsString("hfd_bound");
  return out;
}

TEST_F(ResultsExport, TheHfdLayersSayWhereTheSiteBoundaryCutsThem) {
  const fs::path h5 = run_minimal("EPSG:32611");
  const ExportReport rep = export_results({h5, dir_ / "gis", std::nullopt});
  ASSERT_EQ(formats::read_dataset_double(h5, "/hfd/bound").at(0), 1.0) << "the small plane is cut";
  auto f = hfd_fields(dir_ / "gis/hazard.gpkg");
  EXPECT_EQ(f["hfd_bound"], "lower");
  EXPECT_EQ(f["area_estimate"], "lower");
  const std::string note = formats::read_attribute_string(h5, "/hfd", "note");
  EXPECT_EQ(note.rfind("HFD ≥ ", 0), 0u) << note;
  EXPECT_EQ(f["note"], note);
  ASSERT_FALSE(rep.notes.empty());
  EXPECT_EQ(rep.notes[0], note);
  const auto band = formats::read_dataset_double(h5, "/hfd/band_bound");
  EXPECT_EQ(f["band_lower_bound"], band[0] != 0 ? "lower" : "none");
  EXPECT_EQ(f["band_upper_bound"], band[1] != 0 ? "lower" : "none");
  EXPECT_EQ(f["area_lower_1se"], f["band_lower_bound"]);
  EXPECT_EQ(f["area_upper_1se"], f["band_upper_bound"]);
  const auto sectors = formats::read_dataset_double(h5, "/hfd/by_sector_bound");
  int cut = 0;
  for (std::size_t k = 0; k < 36; ++k) {
    EXPECT_EQ(f["sector_" + std::to_string(k)], sectors[k] != 0 ? "lower" : "none") << k;
    cut += sectors[k] != 0;
  }
  EXPECT_GT(cut, 0);
  EXPECT_NE(api::testing::read_text(dir_ / "gis/hazard.kml").find("hfd_bound"), std::string::npos);

  Json sc = api::testing::minimal_example();  // its own 3 km plane
  sc["fragment_groups"][0]["samples"] = 200;
  const fs::path big = testing::write_run(sc, dir_ / "big");
  const ExportReport big_rep = export_results({big, dir_ / "big_gis", std::nullopt});
  f = hfd_fields(dir_ / "big_gis/hazard.gpkg");
  EXPECT_EQ(f["hfd_bound"], "none");
  EXPECT_EQ(f["note"], "");
  EXPECT_EQ(f["area_estimate"], "none");
  for (int k = 0; k < 36; ++k) EXPECT_EQ(f["sector_" + std::to_string(k)], "none") << k;
  for (const auto& n : big_rep.notes) EXPECT_EQ(n.find("HFD ≥"), std::string::npos) << n;
}

TEST_F(ResultsExport, BuildingsCarryTheirFiguresAndGeoJsonIsRfc7946) {
  const fs::path h5 = run_minimal("EPSG:32611");
  export_results({h5, dir_ / "gis", std::nullopt});
  const auto ids = formats::read_dataset_strings(h5, "/buildings/id");
  const auto impacts = formats::read_dataset_double(h5, "/buildings/expected_impacts");
  GDALDatasetUniquePtr ds(
      GDALDataset::Open((dir_ / "gis/buildings.geojson").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(ds);
  OGRLayer* l = ds->GetLayer(0);
  ASSERT_EQ(l->GetFeatureCount(), static_cast<GIntBig>(ids.size()));
  std::size_t k = 0;
  for (auto& f : *l) {
    EXPECT_EQ(f->GetFieldAsString("id"), ids[k]);
    EXPECT_EQ(f->GetFieldAsDouble("expected_impacts"), impacts[k]);
    OGREnvelope e;
    f->GetGeometryRef()->getEnvelope(&e);
    // WGS 84 longitude, latitude near the site (117.5 W, 34.7 N).
    EXPECT_GT(e.MinX, -118.0);
    EXPECT_LT(e.MaxX, -117.0);
    EXPECT_GT(e.MinY, 34.0);
    EXPECT_LT(e.MaxY, 35.0);
    ++k;
  }
  const std::string text = api::testing::read_text(dir_ / "gis/hazardous_area.geojson");
  EXPECT_EQ(text.find("\"crs\""), std::string::npos) << "RFC 7946 has no crs member";
  const std::string kml = api::testing::read_text(dir_ / "gis/hazard.kml");
  EXPECT_NE(kml.find("<Placemark>"), std::string::npos);
  EXPECT_NE(kml.find("hfd_sectors"), std::string::npos);
  for (const auto& e : fs::directory_iterator(dir_ / "gis"))
    EXPECT_NE(e.path().filename().string()[0], '.') << "left behind: " << e.path();
}

// --units us (docs/units.md): the vector layers carry US fields beside the unchanged SI ones
// (ft = m / 0.3048, per 600 ft² = per m² × 55.741824, sectors by bearing) and a description in
// US units, which KML shows as the placemark's balloon; an SI export has none of them.
TEST_F(ResultsExport, UsUnitsAddFeetBearingsAndDescriptionsBesideTheSiFields) {
  const fs::path h5 = run_minimal("EPSG:32611");
  export_results({h5, dir_ / "si", std::nullopt});
  export_results({h5, dir_ / "us", std::nullopt, api::UnitSystem::kUs});
  GDALDatasetUniquePtr si(GDALDataset::Open((dir_ / "si/hazard.gpkg").c_str(), GDAL_OF_VECTOR));
  GDALDatasetUniquePtr us(GDALDataset::Open((dir_ / "us/hazard.gpkg").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(si && us);
  for (const char* layer : {"hfd", "hfd_sectors", "hazardous_area"})
    EXPECT_LT(si->GetLayerByName(layer)->GetLayerDefn()->GetFieldIndex("description"), 0) << layer;

  std::unique_ptr<OGRFeature> p(us->GetLayerByName("hfd")->GetNextFeature());
  std::unique_ptr<OGRFeature> p_si(si->GetLayerByName("hfd")->GetNextFeature());
  ASSERT_TRUE(p && p_si);
  const double hfd_m = p->GetFieldAsDouble("hfd_m");
  EXPECT_EQ(hfd_m, p_si->GetFieldAsDouble("hfd_m"));  // the SI field stays
  EXPECT_GT(hfd_m, 0.0);
  EXPECT_DOUBLE_EQ(p->GetFieldAsDouble("hfd_ft"), hfd_m / 0.3048);
  EXPECT_DOUBLE_EQ(p->GetFieldAsDouble("band_lower_ft"),
                   p->GetFieldAsDouble("band_lower_m") / 0.3048);
  EXPECT_DOUBLE_EQ(p->GetFieldAsDouble("band_upper_ft"),
                   p->GetFieldAsDouble("band_upper_m") / 0.3048);
  const double threshold = p->GetFieldAsDouble("threshold_per_m2");
  EXPECT_DOUBLE_EQ(p->GetFieldAsDouble("threshold_per_600ft2"), threshold * 55.741824);
  const std::string description = p->GetFieldAsString("description");
  EXPECT_EQ(description.rfind("HFD ≥ " + api::format_length(hfd_m, api::UnitSystem::kUs), 0), 0u)
      << description;  // the small plane cuts it
  EXPECT_NE(description.find("threshold 1 per 600 ft²"), std::string::npos) << description;

  OGRLayer* sectors = us->GetLayerByName("hfd_sectors");
  ASSERT_EQ(sectors->GetFeatureCount(), 36);
  int k = 0;
  for (auto& f : *sectors) {
    EXPECT_DOUBLE_EQ(f->GetFieldAsDouble("hfd_ft"), f->GetFieldAsDouble("hfd_m") / 0.3048) << k;
    EXPECT_EQ(std::string(f->GetFieldAsString("bearing_range")), api::sector_bearing_range(k));
    EXPECT_EQ(f->GetFieldAsDouble("bearing_to_deg") - f->GetFieldAsDouble("bearing_from_deg"), 10.0)
        << k;
    ++k;
  }
  sectors->ResetReading();
  std::unique_ptr<OGRFeature> east(sectors->GetNextFeature());  // azimuth 0–10° from +x
  EXPECT_STREQ(east->GetFieldAsString("bearing_range"), "080°–090°");
  EXPECT_EQ(east->GetFieldAsDouble("bearing_from_deg"), 80.0);

  GDALDatasetUniquePtr area(
      GDALDataset::Open((dir_ / "us/hazardous_area.geojson").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(area);
  for (auto& f : *area->GetLayer(0)) {
    EXPECT_DOUBLE_EQ(f->GetFieldAsDouble("threshold_per_600ft2"), threshold * 55.741824);
    EXPECT_NE(std::string(f->GetFieldAsString("description")).find("1 per 600 ft²"),
              std::string::npos);
  }
  // KML: the description is the placemark's balloon text.
  const std::string kml = api::testing::read_text(dir_ / "us/hazard.kml");
  EXPECT_NE(kml.find("<description>HFD ≥ "), std::string::npos);
  EXPECT_NE(kml.find("<description>bearing 080°–090°: HFD "), std::string::npos);
  // The site-plan boundary's descriptions follow the units too, with ft fields beside the SI.
  EXPECT_NE(kml.find(" ft (HFD "), std::string::npos);
  EXPECT_NE(kml.find("max_radius_ft"), std::string::npos);
  // SI: no US field and no figure in ft anywhere.
  const std::string si_kml = api::testing::read_text(dir_ / "si/hazard.kml");
  EXPECT_EQ(si_kml.find(" ft"), std::string::npos);
  EXPECT_EQ(si_kml.find("_ft"), std::string::npos);
  EXPECT_NE(si_kml.find(" m (HFD "), std::string::npos);
}

TEST_F(ResultsExport, WithoutACrsOnlyLocalFilesAreWrittenAndSaid) {
  const fs::path h5 = run_minimal("");
  const ExportReport rep = export_results({h5, dir_ / "gis", std::nullopt});
  EXPECT_EQ(rep.files,
            (std::vector<std::string>{"ptn_density.tif", "ptn_classes.tif", "hazard.gpkg",
                                      "terrain.vtkhdf", "buildings.vtkhdf"}));
  // The HFD is a lower bound (the small plane), no trajectories were recorded, no CRS.
  ASSERT_EQ(rep.notes.size(), 3u);
  EXPECT_EQ(rep.notes[0].rfind("HFD ≥ ", 0), 0u);
  EXPECT_NE(rep.notes[2].find("no CRS"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir_ / "gis/hazard.kml"));
}

// site.origin.crs is informational: a label PROJ does not know ("local") is read as no CRS and
// said, not a reason to refuse the export.
TEST_F(ResultsExport, ACrsLabelPROJDoesNotKnowIsReadAsNoCrs) {
  const fs::path h5 = run_minimal("local");
  const ExportReport rep = export_results({h5, dir_ / "gis", std::nullopt});
  EXPECT_EQ(rep.crs, "");
  EXPECT_EQ(rep.files,
            (std::vector<std::string>{"ptn_density.tif", "ptn_classes.tif", "hazard.gpkg",
                                      "terrain.vtkhdf", "buildings.vtkhdf"}));
  ASSERT_EQ(rep.notes.size(), 4u);  // the HFD a lower bound, the label, no trajectories, no CRS
  EXPECT_NE(rep.notes[1].find("\"local\" is not a CRS PROJ knows"), std::string::npos);
}

// A paired comparison's map (docs/comparison.md): compare.h5's per-triangle difference and se
// rasterised as ptn_density.tif is. With the difference set to minus the run's density, every
// cell is minus ptn_density.tif's and the se band equals its; the CRS is the site's. A compare.h5
// without a difference (other terrains) writes nothing; one of another terrain is refused.
TEST_F(ResultsExport, TheDifferenceMapIsThePairedDifferenceRasterisedAsTheDensity) {
  const fs::path h5 = run_minimal("EPSG:32611");
  const Terrain t = read_terrain(h5);
  auto write_compare = [&](const fs::path& p, bool with_density, std::size_t drop) {
    std::vector<double> minus(t.d.begin(), t.d.end() - static_cast<long>(drop));
    for (double& x : minus) x = -x;
    const std::lock_guard<std::mutex> lock(formats::h5::hdf5_mutex());
    formats::h5::Writer w(p);
    if (with_density) {
      const auto g = w.group("/density");
      w.dataset("/density/difference_per_m2", minus);
      w.dataset("/density/paired_std_error_per_m2",
                std::vector<double>(t.se.begin(), t.se.end() - static_cast<long>(drop)));
    }
    w.close();
  };
  write_compare(dir_ / "compare.h5", true, 0);
  ASSERT_TRUE(write_difference_map(h5, dir_ / "compare.h5", dir_ / "d.tif"));
  const ExportReport rep = export_results(
      {h5, dir_ / "gis", std::nullopt, api::UnitSystem::kSi, std::nullopt, dir_ / "compare.h5"});
  EXPECT_NE(std::find(rep.files.begin(), rep.files.end(), kDifferenceMapName), rep.files.end());
  auto bands = [](const fs::path& tif) {
    GDALDatasetUniquePtr ds(GDALDataset::Open(tif.c_str(), GDAL_OF_RASTER));
    EXPECT_TRUE(ds);
    EXPECT_EQ(crs_name(*ds->GetSpatialRef()), "EPSG:32611");
    std::vector<double> b(3200);
    for (int k = 0; k < 2; ++k)
      EXPECT_EQ(ds->GetRasterBand(k + 1)->RasterIO(GF_Read, 0, 0, 40, 40, b.data() + 1600 * k, 40,
                                                   40, GDT_Float64, 0, 0),
                CE_None);
    return b;
  };
  const auto density = bands(dir_ / "gis/ptn_density.tif"), d = bands(dir_ / "d.tif"),
             in_export = bands(dir_ / "gis" / kDifferenceMapName);
  double total = 0;
  for (std::size_t p = 0; p < 1600; ++p) {
    EXPECT_EQ(d[p], -density[p]) << p;
    EXPECT_EQ(d[1600 + p], density[1600 + p]) << p;
    EXPECT_EQ(in_export[p], d[p]) << p;
    total += density[p];
  }
  EXPECT_GT(total, 0.0);

  write_compare(dir_ / "other.h5", false, 0);
  EXPECT_FALSE(write_difference_map(h5, dir_ / "other.h5", dir_ / "none.tif"));
  EXPECT_FALSE(fs::exists(dir_ / "none.tif"));
  write_compare(dir_ / "short.h5", true, 2);
  EXPECT_THROW(write_difference_map(h5, dir_ / "short.h5", dir_ / "bad.tif"), InputError);
  EXPECT_FALSE(fs::exists(dir_ / "bad.tif"));
}

TEST_F(ResultsExport, NotAResultsFileIsAnInputErrorNamingIt) {
  std::ofstream(dir_ / "x.h5") << "nothing";
  try {
    export_results({dir_ / "x.h5", dir_ / "gis", std::nullopt});
    FAIL();
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "RESULTS.h5");
    EXPECT_NE(e.message().find((dir_ / "x.h5").string()), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(dir_ / "gis"));
}

TEST_F(ResultsExport, ThePtnGeoJsonRouteIsRfc7946WhenTheSiteHasACrs) {
  // What fragsimd serves at GET /v1/jobs/{id}/ptn?format=geojson (api/ptn_json.h with gis's
  // converter): WGS 84 longitude/latitude, back to the site's UTM coordinates to 1 mm.
  const fs::path h5 = run_minimal("EPSG:32611");
  const Json g = Json::parse(api::render_ptn_geojson(h5, "j_1", std::nullopt, wgs84_converter));
  EXPECT_EQ(g["fragsim_coordinates"].get<std::string>().rfind("RFC 7946: WGS 84", 0), 0u);
  EXPECT_FALSE(g.contains("crs"));
  const auto v = formats::read_dataset_double(h5, "/terrain/vertices_m");
  const auto t = formats::read_dataset_int64(h5, "/terrain/triangles");
  const OGRSpatialReference wgs = crs_from_text("EPSG:4326", "x");
  const OGRSpatialReference utm = crs_from_text("EPSG:32611", "x");
  std::unique_ptr<OGRCoordinateTransformation> back(OGRCreateCoordinateTransformation(&wgs, &utm));
  for (const std::size_t f : {std::size_t{0}, std::size_t{1234}, std::size_t{3199}}) {
    const auto& ring = g["features"][f]["geometry"]["coordinates"][0];
    ASSERT_EQ(g["features"][f]["properties"]["triangle"], f);
    for (std::size_t c = 0; c < 3; ++c) {
      double lon = ring[c][0], lat = ring[c][1];
      EXPECT_GT(lon, -118.0);
      EXPECT_LT(lon, -117.0);
      ASSERT_TRUE(back->Transform(1, &lon, &lat));
      const auto k = static_cast<std::size_t>(3 * t[3 * f + c]);
      EXPECT_NEAR(lon, v[k] + 452300, 1e-3);
      EXPECT_NEAR(lat, v[k + 1] + 3839800, 1e-3);
      EXPECT_EQ(ring[c][2].get<double>(), v[k + 2]);
    }
  }
}

TEST_F(ResultsExport, ThePtnGeoJsonSaysSoWhenTheCrsIsOnlyALabel) {
  const fs::path h5 = run_minimal("local");
  const Json g = Json::parse(api::render_ptn_geojson(h5, "j_1", std::nullopt, wgs84_converter));
  EXPECT_EQ(g["fragsim_coordinates"],
            "site input coordinates [x, y, z] in metres: the site has no CRS PROJ knows "
            "(\"local\"), so this is not RFC 7946 GeoJSON");
  const auto v = formats::read_dataset_double(h5, "/terrain/vertices_m");
  const auto t = formats::read_dataset_int64(h5, "/terrain/triangles");
  EXPECT_EQ(g["features"][0]["geometry"]["coordinates"][0][0][0].get<double>(),
            v[static_cast<std::size_t>(3 * t[0])]);
}

}  // namespace
}  // namespace fragsim::gis
