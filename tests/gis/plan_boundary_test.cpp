// The site-plan hazard boundary (gis/plan_boundary.h; docs/gis.md "Site-plan boundary"): the
// sector envelope contains every hazardous triangle and is never inside its sector's HFD arc;
// the smoothed contour contains the exact area, so its HFD is never shorter. On a results.h5
// written from a chosen density field (a 400 m plane of 10 m cells in UTM 11N), read back as the
// exports read it.
#include "gis/plan_boundary.h"

#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>

#include "api/run_outputs.h"
#include "api/scenario_json.h"
#include "api/test_support.h"
#include "core/common/error.h"
#include "core/run/hfd.h"
#include "formats/results_h5.h"
#include "gis/gdal_support.h"
#include "gis/results_export.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// Density and standard error of a triangle from its centroid (input coordinates), in units of
// the threshold.
using Field = std::function<std::pair<double, double>(const Vec2&)>;

bool near(const Vec2& c, double x, double y, double r) {
  return (c - Vec2(x, y)).norm() < r;
}

// Far islands of one cell (two triangles) in sectors 5, 13 and 27 (2 t, se t), and one in
// sector 9 that only the upper end of the band reaches (0.5 t, se 0.6 t).
std::pair<double, double> islands(const Vec2& c) {
  for (const auto& [x, y] : {std::pair{105.0, 155.0}, {-125.0, 125.0}, {25.0, -175.0}})
    if (near(c, x, y, 4)) return {2.0, 1.0};
  if (near(c, -5, 175, 4)) return {0.5, 0.6};
  return {0.0, 0.0};
}

// A blob of radius 45 m round the HFD origin (5 t), a ring to 60 m only the band's upper end
// reaches (0.7 t, se 0.5 t), and the islands.
std::pair<double, double> blob_round_origin(const Vec2& c) {
  if (c.norm() < 45) return {5.0, 0.5};
  if (c.norm() < 60) return {0.7, 0.5};
  return islands(c);
}

// A blob east of the origin, not covering it (its sectors wrap round azimuth 0), and the islands.
std::pair<double, double> blob_east(const Vec2& c) {
  if (near(c, 70, 0, 25)) return {5.0, 0.5};
  return islands(c);
}

class PlanBoundaryTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_plan_boundary_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // results.h5 of the minimal example on a 400 m plane of 10 m cells with `field` as its PTN
  // density; its HFD figures computed as a run computes them (core/run/hfd.h).
  fs::path write_field(const std::string& name, const Field& field) {
    Json j = api::testing::on_small_plane(api::testing::minimal_example());
    j["site"]["origin"] = {
        {"crs", "EPSG:32611"}, {"easting_m", 452300}, {"northing_m", 3839800}, {"elevation_m", 0}};
    const run::Scenario sc = api::parse_scenario(j);
    const auto site = scene::Site::build(sc.site);
    const double t = sc.settings.hfd_threshold_per_m2;
    run::RunResult r;
    r.samples = r.histories_done = 1000;
    r.real_fragments = 1000;
    r.buildings.push_back(api::testing::example_building());  // the example's one building
    for (std::uint32_t k = 0; k < site->terrain_triangle_count(); ++k) {
      const auto [d, se] = field(site->to_input(site->terrain_triangle_centroid(k)).head<2>());
      r.ptn_density_per_m2.push_back(d * t);
      r.ptn_std_error_per_m2.push_back(se * t);
    }
    r.hfd_origin_m = run::hfd_origin_input(sc, *site);
    const run::HfdGeometry g(*site, site->to_local(r.hfd_origin_m));
    const run::HfdFigures f = g.figures(r.ptn_density_per_m2, r.ptn_std_error_per_m2, t);
    r.hazardous_fragment_distance_m = f.hfd_m;
    r.hfd_lower_m = f.lower_m;
    r.hfd_upper_m = f.upper_m;
    r.hfd_by_sector_m = f.by_sector_m;
    const fs::path path = dir_ / name;
    formats::write_results_h5(
        path, r, *site, sc,
        api::results_texts(r, sc, api::scenario_to_json(sc).dump(), api::build_provenance()));
    return path;
  }

  fs::path dir_;
};

// The plan triangles where density + s * se >= threshold.
std::vector<std::array<Vec2, 3>> hazardous(const ResultsFile& r, double s) {
  std::vector<std::array<Vec2, 3>> out;
  for (std::size_t k = 0; k < r.triangles.size(); ++k)
    if (r.density[k] + s * r.std_error[k] >= r.threshold)
      out.push_back({r.vertices[r.triangles[k][0]].head<2>(),
                     r.vertices[r.triangles[k][1]].head<2>(),
                     r.vertices[r.triangles[k][2]].head<2>()});
  return out;
}

// Tolerance of the containment checks: a point is in the envelope when its distance from it
// (0 inside) is at most 1 micrometre. A vertex of a hazardous triangle on a sector's radial edge
// lies on the boundary, where rounding (UTM coordinates of 4e6 m carry ~1e-9 m) may put it either
// side.
constexpr double kTol_m = 1e-6;

std::unique_ptr<OGRGeometry> checked(const PlanMultiPolygon& m) {
  auto g = to_ogr(m);
  EXPECT_TRUE(g->IsValid());
  return g;
}

void expect_envelope_holds(const ResultsFile& r, const SectorEnvelope& e, double s,
                           const std::vector<double>& sector_hfd, double hfd) {
  ASSERT_EQ(e.radius_m.size(), 36u);
  const auto tris = hazardous(r, s);
  ASSERT_FALSE(tris.empty());
  const auto env = checked(e.polygon);
  double farthest = 0;
  for (const auto& t : tris)
    for (const Vec2& v : t) {
      const OGRPoint p(v.x(), v.y());
      EXPECT_LE(env->Distance(&p), kTol_m) << "vertex (" << v.x() << ", " << v.y() << ") outside";
      farthest = std::max(farthest, (v - r.hfd_origin.head<2>()).norm());
    }
  // Never inside a sector's HFD arc: R_k >= the sector's HFD, and the arc itself (sampled every
  // 0.1 degree) lies in the envelope.
  const Vec2 o = r.hfd_origin.head<2>();
  for (int k = 0; k < 36; ++k) {
    // kTol_m: the HFD's distances come from local coordinates, R_k from the CRS's (rounding).
    EXPECT_GE(e.radius_m[k] + kTol_m, sector_hfd[k]) << "sector " << k;
    if (sector_hfd[k] <= 0) continue;
    for (int j = 0; j <= 100; ++j) {
      const double a = (10.0 * k + 0.1 * j) * M_PI / 180.0;
      const OGRPoint p(o.x() + sector_hfd[k] * std::cos(a), o.y() + sector_hfd[k] * std::sin(a));
      EXPECT_LE(env->Distance(&p), kTol_m) << "sector " << k << " arc at " << 10.0 * k + 0.1 * j;
    }
  }
  EXPECT_GE(e.max_radius_m + kTol_m, hfd);
  // ... and no farther than the farthest hazardous vertex (the envelope is tight).
  EXPECT_LE(e.max_radius_m, farthest + 1e-9);
}

TEST_F(PlanBoundaryTest, TheEnvelopeContainsEveryHazardousTriangleAndNoArcLiesOutsideIt) {
  for (const auto& [name, field] :
       {std::pair<const char*, Field>{"round.h5", blob_round_origin}, {"east.h5", blob_east}}) {
    SCOPED_TRACE(name);
    const ResultsFile r = read_results_file(write_field(name, field));
    const PlanBoundary b = plan_boundary(r);
    ASSERT_GT(r.hfd_m, 140.0);  // an island sets it
    // The band's upper end: the sector HFDs of density + se are not stored; their overall
    // HFD is, and each sector's is at least the estimate's.
    expect_envelope_holds(r, b.envelope, 0.0, r.by_sector, r.hfd_m);
    expect_envelope_holds(r, b.envelope_upper, 1.0, r.by_sector, r.band_hi);
    for (int k = 0; k < 36; ++k) EXPECT_GE(b.envelope_upper.radius_m[k], b.envelope.radius_m[k]);
    EXPECT_LT(b.envelope.radius_m[9], 61.0);  // the island only the band's upper end reaches
    EXPECT_GT(b.envelope_upper.radius_m[9], 175.0);
  }
}

TEST_F(PlanBoundaryTest, EmptySectorsSplitTheEnvelopeIntoPartsFromTheOrigin) {
  const ResultsFile round = read_results_file(write_field("round.h5", blob_round_origin));
  const PlanBoundary a = plan_boundary(round);
  ASSERT_EQ(a.envelope.polygon.size(), 1u);  // every sector has some of the blob
  EXPECT_EQ(a.envelope.polygon[0].rings.size(), 1u);
  for (const Vec2& v : a.envelope.polygon[0].rings[0])
    EXPECT_GT((v - a.origin).norm(), 35.0);  // no origin vertex

  const ResultsFile east = read_results_file(write_field("east.h5", blob_east));
  const PlanBoundary b = plan_boundary(east);
  // The blob (sectors 33 to 2: one part across azimuth 0) and three islands.
  ASSERT_EQ(b.envelope.polygon.size(), 4u);
  int through_origin = 0;
  for (const PlanPolygon& p : b.envelope.polygon) through_origin += p.rings[0][0] == b.origin;
  EXPECT_EQ(through_origin, 4);
  EXPECT_EQ(b.envelope.radius_m[18], 0.0);  // due west: nothing
}

TEST_F(PlanBoundaryTest, TheSmoothedContourContainsTheExactAreaSoItsHfdIsNeverShorter) {
  const ResultsFile r = read_results_file(write_field("round.h5", blob_round_origin));
  const PlanBoundary b = plan_boundary(r);
  EXPECT_EQ(b.smoothing_m, 20.0);  // 2 cells of 10 m
  const auto exact = hazard_area(r, 0.0, nullptr);
  const auto smoothed = to_ogr(b.smoothed);
  EXPECT_TRUE(smoothed->IsValid());
  const std::unique_ptr<OGRGeometry> outside(exact->Difference(smoothed.get()));
  const double exact_area = dynamic_cast<const OGRMultiSurface&>(*exact).get_Area();
  EXPECT_NEAR(b.exact_area_m2, exact_area, 1e-9 * exact_area);
  EXPECT_LE(outside->IsEmpty() ? 0.0 : dynamic_cast<OGRMultiSurface*>(outside.get())->get_Area(),
            1e-6 * exact_area);
  EXPECT_GE(b.smoothed_area_m2, exact_area * (1 - 1e-9));
  EXPECT_GE(b.smoothed_hfd_m, b.exact_hfd_m);
  EXPECT_EQ(b.exact_hfd_m, r.hfd_m);
  for (const PlanPolygon& p : b.smoothed) EXPECT_EQ(p.rings.size(), 1u) << "a hole was kept";
  // The blob's stair-stepped edge is rounded, the far islands stay apart (150 m > 2 x 20 m).
  EXPECT_EQ(b.smoothed.size(), 4u);
  const PlanBoundary wide = plan_boundary(r, {200.0});
  EXPECT_EQ(wide.smoothing_m, 200.0);
  EXPECT_LT(wide.smoothed.size(), b.smoothed.size());  // islands bridged to the blob
  EXPECT_GE(wide.smoothed_hfd_m, b.exact_hfd_m);
  // A closing stays in the convex hull, whose farthest point is a hazardous triangle's vertex:
  // the smoothing lengthens the HFD only by the centroid-to-corner distance of the triangle that
  // sets it, up to GEOS's polygonal discs (chords of 1/32 of a turn: sagitta 0.5 % of the radius).
  double farthest = 0;
  for (const auto& t : hazardous(r, 0.0))
    for (const Vec2& v : t) farthest = std::max(farthest, (v - b.origin).norm());
  EXPECT_LE(b.smoothed_hfd_m, farthest + 0.005 * b.smoothing_m);
  EXPECT_LE(wide.smoothed_hfd_m, farthest + 0.005 * wide.smoothing_m);
}

TEST_F(PlanBoundaryTest, ABadSmoothingRadiusIsRefusedNamingTheOption) {
  const ResultsFile r = read_results_file(write_field("round.h5", blob_round_origin));
  for (const double bad : {-1.0, 0.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    try {
      plan_boundary(r, {bad});
      ADD_FAILURE() << bad << " accepted";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "smoothing_m");
    }
  }
}

TEST_F(PlanBoundaryTest, NoHazardousTriangleGivesEmptyPolygons) {
  const ResultsFile r = read_results_file(write_field("zero.h5", [](const Vec2&) {
    return std::pair{0.0, 0.0};
  }));
  const PlanBoundary b = plan_boundary(r);
  EXPECT_TRUE(b.envelope.polygon.empty());
  EXPECT_TRUE(b.envelope_upper.polygon.empty());
  EXPECT_TRUE(b.smoothed.empty());
  EXPECT_EQ(b.envelope.max_radius_m, 0.0);
  EXPECT_EQ(b.smoothed_hfd_m, 0.0);
  EXPECT_EQ(b.exact_area_m2, 0.0);
}

// ---- The exports (gis/results_export.h) ----

std::map<std::string, double> features_of(GDALDataset& ds, const char* layer, const char* key,
                                          const char* value) {
  std::map<std::string, double> out;
  OGRLayer* l = ds.GetLayerByName(layer);
  EXPECT_NE(l, nullptr) << layer;
  if (l == nullptr) return out;
  for (auto& f : *l) {
    EXPECT_FALSE(f->GetGeometryRef() == nullptr || f->GetGeometryRef()->IsEmpty());
    out[f->GetFieldAsString(key)] = f->GetFieldAsDouble(value);
  }
  return out;
}

TEST_F(PlanBoundaryTest, TheExportsWriteTheEnvelopeAndTheSmoothedContour) {
  const fs::path h5 = write_field("round.h5", blob_round_origin);
  const ExportReport rep =
      export_results({h5, dir_ / "maps", std::nullopt, api::UnitSystem::kSi, 15.0});
  const PlanBoundary b = plan_boundary(read_results_file(h5), {15.0});
  GDALDatasetUniquePtr gpkg(GDALDataset::Open((dir_ / "maps/hazard.gpkg").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(gpkg);
  const auto env = features_of(*gpkg, "hfd_envelope", "band", "max_radius_m");
  EXPECT_EQ(env, (std::map<std::string, double>{{"estimate", b.envelope.max_radius_m},
                                                {"upper_1se", b.envelope_upper.max_radius_m}}));
  EXPECT_EQ(features_of(*gpkg, "hazard_boundary", "band", "hfd_m"),
            (std::map<std::string, double>{{"estimate", b.smoothed_hfd_m}}));
  EXPECT_EQ(features_of(*gpkg, "hazard_boundary", "band", "smoothing_m"),
            (std::map<std::string, double>{{"estimate", 15.0}}));
  GDALDatasetUniquePtr geojson(
      GDALDataset::Open((dir_ / "maps/hazard_boundary.geojson").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(geojson);
  EXPECT_EQ(geojson->GetLayer(0)->GetFeatureCount(), 3);
  GDALDatasetUniquePtr kml(GDALDataset::Open((dir_ / "maps/hazard.kml").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(kml);
  EXPECT_EQ(features_of(*kml, "hfd_envelope", "band", "max_radius_m").size(), 2u);
  EXPECT_EQ(features_of(*kml, "hazard_boundary", "band", "hfd_m").size(), 1u);
  EXPECT_NE(std::find(rep.files.begin(), rep.files.end(), "hazard_boundary.geojson"),
            rep.files.end());
}

TEST_F(PlanBoundaryTest, ASiteWithNothingHazardousGetsEmptyLayersAndANote) {
  const fs::path h5 = write_field("zero.h5", [](const Vec2&) { return std::pair{0.0, 0.0}; });
  const ExportReport rep = export_results({h5, dir_ / "maps", std::nullopt});
  GDALDatasetUniquePtr gpkg(GDALDataset::Open((dir_ / "maps/hazard.gpkg").c_str(), GDAL_OF_VECTOR));
  ASSERT_TRUE(gpkg);
  EXPECT_TRUE(features_of(*gpkg, "hfd_envelope", "band", "max_radius_m").empty());
  EXPECT_TRUE(features_of(*gpkg, "hazard_boundary", "band", "hfd_m").empty());
  bool noted = false;
  for (const auto& n : rep.notes) noted = noted || n.find("hfd_envelope") != std::string::npos;
  EXPECT_TRUE(noted);
}

// The cost on a Monte Carlo-like field of thousands of islands (docs/gis.md, "Site-plan
// boundary"): not run by default (--gtest_also_run_disabled_tests). A 1 km plane of 2 m cells
// (500,000 triangles), a solid blob of 100 m round the origin and, out to 400 m, each triangle
// hazardous with probability 0.02 (a fixed sequence).
TEST(PlanBoundaryCost, DISABLED_ThousandsOfIslands) {
  ResultsFile r;
  const int n = 500;
  const double cell = 2.0;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) r.vertices.emplace_back(-500 + cell * i, -500 + cell * j, 0);
  std::uint64_t state = 12345;
  const auto uniform = [&] {
    state = state * 6364136223846793005ull + 1442695040888963407ull;
    return static_cast<double>(state >> 11) / 9007199254740992.0;
  };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const std::size_t a = static_cast<std::size_t>(j * (n + 1) + i), b = a + 1,
                        c = a + static_cast<std::size_t>(n + 1), d = c + 1;
      for (const auto& t :
           {std::array<std::size_t, 3>{a, b, d}, std::array<std::size_t, 3>{a, d, c}}) {
        r.triangles.push_back(t);
        Vec2 centroid(0, 0);
        for (const std::size_t v : t) centroid += r.vertices[v].head<2>() / 3.0;
        const double dist = centroid.norm();
        const bool hot = dist < 100 || (dist < 400 && uniform() < 0.02);
        r.density.push_back(hot ? 2.0 : 0.0);
        r.std_error.push_back(0.5);
        if (hot) r.hfd_m = std::max(r.hfd_m, dist);
      }
    }
  r.threshold = 1.0;
  r.terrain_cell_m = cell;
  r.hfd_origin = Vec3(0, 0, 0);  // Eigen leaves it uninitialised
  const auto t0 = std::chrono::steady_clock::now();
  std::size_t count = 0;
  const auto exact = hazard_area(r, 0.0, &count);
  const auto t1 = std::chrono::steady_clock::now();
  const PlanBoundary b = plan_boundary(r);
  const auto t2 = std::chrono::steady_clock::now();
  const auto* m = dynamic_cast<const OGRGeometryCollection*>(exact.get());
  std::printf(
      "%zu hazardous triangles, exact area %d polygons: union %.2f s; plan_boundary %.2f s "
      "(smoothing %.1f m: %zu polygons; HFD %.1f m, smoothed %.1f m, envelope %.1f m)\n",
      count, m != nullptr ? m->getNumGeometries() : 1,
      std::chrono::duration<double>(t1 - t0).count(),
      std::chrono::duration<double>(t2 - t1).count(), b.smoothing_m, b.smoothed.size(), r.hfd_m,
      b.smoothed_hfd_m, b.envelope.max_radius_m);
  EXPECT_GE(b.smoothed_hfd_m, r.hfd_m);
}

}  // namespace
}  // namespace fragsim::gis
