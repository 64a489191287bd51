// The PTN field as JSON and GeoJSON (fragsimd GET /v1/jobs/{id}/ptn), read back from the
// results.h5 of a real (small) run: values bit for bit, one closed ring per terrain triangle in
// input coordinates, the min_density filter, the site origin as a foreign member, each
// triangle's material (a zone), and none from a results.h5 older than format 4.
#include "api/ptn_json.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>

#include "api/run_outputs.h"
#include "core/run/run.h"
#include "formats/output_dir.h"
#include "test_support.h"

namespace fragsim::api {
namespace {

namespace fs = std::filesystem;
using testing::Json;

constexpr const char* kJobId = "j_0123456789abcdef";

// Bit patterns: "bit for bit" also tells -0.0 from 0.0.
std::vector<std::uint64_t> bits(const std::vector<double>& v) {
  std::vector<std::uint64_t> out;
  out.reserve(v.size());
  for (const double x : v) out.push_back(std::bit_cast<std::uint64_t>(x));
  return out;
}

// The minimal example, coarser (8 x 8 cells: 128 triangles), fewer samples, and moved away from
// the coordinate origin (x + 1000, y + 2000, z + 100) so that input and local coordinates differ.
// Without an origin, the plane's west half (x < 1000) is a zone of the built-in "hard".
Json small_scenario(bool with_origin) {
  Json j = testing::minimal_example();
  Json& site = j["site"];
  if (with_origin) {
    site["origin"] = {
        {"crs", "EPSG:32611"}, {"easting_m", 500000}, {"northing_m", 3800000}, {"elevation_m", 50}};
  } else {
    site.erase("origin");
    site["terrain"]["zones"] = {
        {{"material", "hard"},
         {"polygon_m", {{800, 1800}, {1000, 1800}, {1000, 2200}, {800, 2200}}}}};
  }
  site["terrain"]["plane"] = {
      {"elevation_m", 100}, {"extent_m", {800, 1800, 1200, 2200}}, {"cell_m", 50}};
  site["buildings"][0]["footprint_m"] = {{1060, 1990}, {1080, 1990}, {1080, 2010}, {1060, 2010}};
  Json& g = j["fragment_groups"][0];
  g["frame"]["origin_m"] = {1000, 2000, 101};
  g["samples"] = with_origin ? 600 : 100;
  j["settings"]["record_fragments"] = false;
  j["settings"]["threads"] = 1;
  return j;
}

struct RunFiles {
  fs::path dir;
  fs::path h5;
  ScenarioDocument doc;
  std::shared_ptr<const scene::Site> site;
  run::RunResult result;
};

std::unique_ptr<RunFiles> run_to_files(const Json& scenario, const fs::path& dir) {
  auto f = std::make_unique<RunFiles>();
  f->dir = dir;
  f->doc = parse_scenario_document(scenario);
  f->site = validate_scenario(f->doc.scenario);
  f->result = run::run(f->doc.scenario, f->site);
  formats::OutputDir out(dir);
  stage_run_outputs(out, f->result, *f->site, f->doc, build_provenance());
  out.commit();
  f->h5 = dir / kResultsFileName;
  return f;
}

class PtnJson : public ::testing::Test {
 protected:
  // One run per suite: the tests only read its files.
  static void SetUpTestSuite() {
    const fs::path base =
        fs::temp_directory_path() / ("fragsim_ptn_test_" + std::to_string(::getpid()));
    fs::remove_all(base);
    with_origin_ = run_to_files(small_scenario(true), base / "origin").release();
    without_origin_ = run_to_files(small_scenario(false), base / "no_origin").release();
    base_ = new fs::path(base);
  }
  static void TearDownTestSuite() {
    delete with_origin_;
    delete without_origin_;
    if (base_ != nullptr) fs::remove_all(*base_);
    delete base_;
    with_origin_ = without_origin_ = nullptr;
    base_ = nullptr;
  }

  static const RunFiles& run_a() { return *with_origin_; }
  static const RunFiles& run_b() { return *without_origin_; }

  static Json geojson(const RunFiles& f, std::optional<double> min_density) {
    return Json::parse(render_ptn_geojson(f.h5, kJobId, min_density));
  }

 private:
  static RunFiles* with_origin_;
  static RunFiles* without_origin_;
  static fs::path* base_;
};

RunFiles* PtnJson::with_origin_ = nullptr;
RunFiles* PtnJson::without_origin_ = nullptr;
fs::path* PtnJson::base_ = nullptr;

TEST_F(PtnJson, TheRunIsUsable) {
  // Preconditions of the other tests: a finished run with some triangles hit and some not.
  const run::RunResult& r = run_a().result;
  ASSERT_FALSE(r.cancelled);
  ASSERT_EQ(run_a().site->terrain_triangle_count(), 128u);
  const auto hit = std::count_if(r.ptn_density_per_m2.begin(), r.ptn_density_per_m2.end(),
                                 [](double d) { return d > 0; });
  EXPECT_GT(hit, 1);
  EXPECT_LT(hit, 128);
  ASSERT_TRUE(fs::is_regular_file(run_a().h5));
}

TEST_F(PtnJson, JsonArraysAreTheRunResultBitForBit) {
  const RunFiles& f = run_a();
  const Json j = Json::parse(render_ptn_json(f.h5, kJobId));
  EXPECT_EQ(j["job_id"], kJobId);
  EXPECT_EQ(j["triangles"].get<std::size_t>(), f.site->terrain_triangle_count());
  EXPECT_EQ(j["threshold_per_m2"].get<double>(), f.doc.scenario.settings.hfd_threshold_per_m2);
  const auto density = j["density_per_m2"].get<std::vector<double>>();
  const auto std_error = j["std_error_per_m2"].get<std::vector<double>>();
  ASSERT_EQ(density.size(), f.result.ptn_density_per_m2.size());
  ASSERT_EQ(std_error.size(), f.result.ptn_std_error_per_m2.size());
  for (std::size_t t = 0; t < density.size(); ++t) {
    EXPECT_EQ(density[t], f.result.ptn_density_per_m2[t]) << "triangle " << t;
    EXPECT_EQ(std_error[t], f.result.ptn_std_error_per_m2[t]) << "triangle " << t;
  }
  EXPECT_EQ(bits(density), bits(f.result.ptn_density_per_m2));
  EXPECT_EQ(bits(std_error), bits(f.result.ptn_std_error_per_m2));
}

TEST_F(PtnJson, GeoJsonHasOneClosedRingPerTerrainTriangleInInputCoordinates) {
  const RunFiles& f = run_a();
  const Json j = geojson(f, std::nullopt);
  EXPECT_EQ(j["type"], "FeatureCollection");
  EXPECT_EQ(j["fragsim_job_id"], kJobId);
  EXPECT_EQ(j["fragsim_threshold_per_m2"].get<double>(),
            f.doc.scenario.settings.hfd_threshold_per_m2);
  const Json& features = j["features"];
  const scene::Site& site = *f.site;
  ASSERT_EQ(features.size(), site.terrain_triangle_count());
  for (std::size_t t = 0; t < features.size(); ++t) {
    SCOPED_TRACE("triangle " + std::to_string(t));
    const Json& feature = features[t];
    EXPECT_EQ(feature["type"], "Feature");
    EXPECT_EQ(feature["geometry"]["type"], "Polygon");
    const Json& rings = feature["geometry"]["coordinates"];
    ASSERT_EQ(rings.size(), 1u);
    const Json& ring = rings[0];
    ASSERT_EQ(ring.size(), 4u);
    EXPECT_EQ(ring[0], ring[3]);
    const auto& tri = site.terrain_triangles()[t];
    for (std::size_t c = 0; c < 3; ++c) {
      const Vec3 v = site.to_input(site.terrain_vertices()[tri[c]]);
      ASSERT_EQ(ring[c].size(), 3u);
      EXPECT_EQ(ring[c][0].get<double>(), v.x());
      EXPECT_EQ(ring[c][1].get<double>(), v.y());
      EXPECT_EQ(ring[c][2].get<double>(), v.z());
      // Input coordinates: inside the plane's extent, at its elevation.
      EXPECT_GE(v.x(), 800.0);
      EXPECT_LE(v.x(), 1200.0);
      EXPECT_GE(v.y(), 1800.0);
      EXPECT_LE(v.y(), 2200.0);
      EXPECT_DOUBLE_EQ(v.z(), 100.0);
    }
    // Counter-clockwise seen from above (docs/http-api.md).
    const double x0 = ring[0][0], y0 = ring[0][1], x1 = ring[1][0], y1 = ring[1][1],
                 x2 = ring[2][0], y2 = ring[2][1];
    EXPECT_GT((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0), 0.0);
    const Json& p = feature["properties"];
    EXPECT_EQ(p["triangle"].get<std::size_t>(), t);
    EXPECT_EQ(p["density_per_m2"].get<double>(), f.result.ptn_density_per_m2[t]);
    EXPECT_EQ(p["std_error_per_m2"].get<double>(), f.result.ptn_std_error_per_m2[t]);
  }
}

TEST_F(PtnJson, GeoJsonTrianglesCoverTheSitePlane) {
  // Two triangles per 50 m cell: together they cover the plane's 400 m x 400 m extent.
  const Json j = geojson(run_a(), std::nullopt);
  double area = 0.0;
  for (const Json& feature : j["features"]) {
    const Json& ring = feature["geometry"]["coordinates"][0];
    const double x0 = ring[0][0], y0 = ring[0][1], x1 = ring[1][0], y1 = ring[1][1],
                 x2 = ring[2][0], y2 = ring[2][1];
    area += 0.5 * std::abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0));
  }
  EXPECT_NEAR(area, 400.0 * 400.0, 1e-6);
}

TEST_F(PtnJson, MinDensityKeepsExactlyTheTrianglesAtOrAboveIt) {
  const RunFiles& f = run_a();
  const std::vector<double>& density = f.result.ptn_density_per_m2;
  std::vector<double> positive;
  for (const double d : density)
    if (d > 0) positive.push_back(d);
  ASSERT_GE(positive.size(), 2u);
  std::sort(positive.begin(), positive.end());
  // A value that occurs in the field: triangles equal to it must be kept.
  for (const double x : {positive[positive.size() / 2], positive.front(), positive.back()}) {
    SCOPED_TRACE("min_density " + std::to_string(x));
    const Json j = geojson(f, x);
    std::vector<std::size_t> expected;
    for (std::size_t t = 0; t < density.size(); ++t)
      if (density[t] >= x) expected.push_back(t);
    std::vector<std::size_t> got;
    for (const Json& feature : j["features"]) {
      const auto t = feature["properties"]["triangle"].get<std::size_t>();
      got.push_back(t);
      EXPECT_EQ(feature["properties"]["density_per_m2"].get<double>(), density[t]);
    }
    EXPECT_EQ(got, expected);
    EXPECT_FALSE(got.empty());
  }
}

TEST_F(PtnJson, MinDensityZeroKeepsAllAndAboveTheMaximumKeepsNone) {
  const RunFiles& f = run_a();
  EXPECT_EQ(geojson(f, 0.0)["features"].size(), f.site->terrain_triangle_count());
  const double max =
      *std::max_element(f.result.ptn_density_per_m2.begin(), f.result.ptn_density_per_m2.end());
  const Json none = geojson(f, std::nextafter(max, 1e300));
  ASSERT_TRUE(none["features"].is_array());
  EXPECT_TRUE(none["features"].empty());
  EXPECT_EQ(geojson(f, max)["features"].size(),
            static_cast<std::size_t>(std::count(f.result.ptn_density_per_m2.begin(),
                                                f.result.ptn_density_per_m2.end(), max)));
}

TEST_F(PtnJson, OriginIsAForeignMemberIffTheSiteHasOne) {
  const Json a = geojson(run_a(), std::nullopt);
  ASSERT_TRUE(a.contains("fragsim_origin"));
  EXPECT_EQ(a["fragsim_origin"]["crs"], "EPSG:32611");
  EXPECT_EQ(a["fragsim_origin"]["easting_m"].get<double>(), 500000.0);
  EXPECT_EQ(a["fragsim_origin"]["northing_m"].get<double>(), 3800000.0);
  EXPECT_EQ(a["fragsim_origin"]["elevation_m"].get<double>(), 50.0);

  const Json b = geojson(run_b(), std::nullopt);
  EXPECT_FALSE(b.contains("fragsim_origin"));
  EXPECT_EQ(b["features"].size(), run_b().site->terrain_triangle_count());
}

// Each feature names its triangle's material: the base one's everywhere without zones, the
// zone's on the west half.
TEST_F(PtnJson, GeoJsonFeaturesNameTheirTrianglesMaterial) {
  for (const RunFiles* f : {&run_a(), &run_b()}) {
    const Json j = geojson(*f, std::nullopt);
    ASSERT_EQ(j["features"].size(), f->site->terrain_triangle_count());
    std::size_t hard = 0;
    for (const Json& feature : j["features"]) {
      const auto t = feature["properties"]["triangle"].get<std::uint32_t>();
      const std::string& want = f->site->materials()[f->site->terrain_triangle_material(t)].name;
      EXPECT_EQ(feature["properties"]["material"], want) << t;
      hard += want == "hard";
    }
    EXPECT_EQ(hard, f == &run_b() ? 64u : 0u);  // 4 of the 8 columns of 16 triangles
  }
}

// A results.h5 of format < 4 (no /terrain/material): features without "material".
TEST_F(PtnJson, GeoJsonOfAnOldFileHasNoMaterial) {
  const fs::path old = run_b().dir / "old.h5";
  fs::copy_file(run_b().h5, old, fs::copy_options::overwrite_existing);
  const hid_t file = H5Fopen(old.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  ASSERT_GE(file, 0);
  EXPECT_GE(H5Ldelete(file, "/terrain/material", H5P_DEFAULT), 0);
  EXPECT_GE(H5Ldelete(file, "/terrain/material_names", H5P_DEFAULT), 0);
  H5Fclose(file);
  const Json j = Json::parse(render_ptn_geojson(old, kJobId, std::nullopt));
  ASSERT_EQ(j["features"].size(), run_b().site->terrain_triangle_count());
  for (const Json& feature : j["features"])
    EXPECT_FALSE(feature["properties"].contains("material"));
}

TEST_F(PtnJson, JsonOfTheSecondRunMatchesItsResult) {
  const RunFiles& f = run_b();
  const Json j = Json::parse(render_ptn_json(f.h5, "j_fedcba9876543210"));
  EXPECT_EQ(j["job_id"], "j_fedcba9876543210");
  EXPECT_EQ(j["density_per_m2"].get<std::vector<double>>(), f.result.ptn_density_per_m2);
  EXPECT_EQ(j["std_error_per_m2"].get<std::vector<double>>(), f.result.ptn_std_error_per_m2);
}

TEST_F(PtnJson, AFileWithoutTheDatasetsThrows) {
  const fs::path dir = testing::fresh_test_dir("fragsim_ptn_missing_");
  EXPECT_THROW(render_ptn_json(dir / "missing.h5", kJobId), std::runtime_error);
  EXPECT_THROW(render_ptn_geojson(dir / "missing.h5", kJobId, std::nullopt), std::runtime_error);
  // summary.json is not an HDF5 file.
  EXPECT_THROW(render_ptn_json(run_a().dir / kSummaryFileName, kJobId), std::runtime_error);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fragsim::api
