// The ParaView files of `fragsim export`, read back by an independent reader: VTK's own
// vtkHDFReader (Debian's python3-vtk9, through tests/gis/check_vtkhdf.py), compared with
// results.h5.
#include "gis/vtkhdf_export.h"

#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>

#include "api/results_h5.h"
#include "api/run_outputs.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "gis/results_export.h"
#include "gis/run_fixture.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// What VTK sees in `files` (JSON from check_vtkhdf.py); fails the test if the script fails.
Json vtk_view(const std::vector<fs::path>& files) {
  std::string cmd = "/usr/bin/python3 " FRAGSIM_SOURCE_DIR "/tests/gis/check_vtkhdf.py";
  for (const auto& f : files) cmd += " '" + f.string() + "'";
  cmd += " 2>&1";
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (p == nullptr) return Json();
  std::array<char, 4096> buf;
  for (std::size_t n; (n = fread(buf.data(), 1, buf.size(), p)) > 0;) out.append(buf.data(), n);
  const int rc = pclose(p);
  EXPECT_EQ(rc, 0) << out;
  try {
    return Json::parse(out);
  } catch (const std::exception&) {
    ADD_FAILURE() << "check_vtkhdf.py: " << out;
    return Json();
  }
}

double sum(const std::vector<double>& v) {
  return std::accumulate(v.begin(), v.end(), 0.0);
}

class VtkhdfExport : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_vtkhdf_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // The minimal example with a CRS offset and 5 recorded trajectories.
  fs::path run_minimal() {
    Json sc = api::testing::minimal_example();
    sc["site"]["origin"] = {
        {"crs", "EPSG:32611"}, {"easting_m", 452300}, {"northing_m", 3839800}, {"elevation_m", 0}};
    auto& g = sc["fragment_groups"][0];  // slow and many: some triangles are hazardous
    g["speed_mps"] = {{"dist", "normal"}, {"mean", 60}, {"sigma", 5}};
    g["direction"]["elevation_deg"] = {40, 80};
    g["count"] = 20000;
    g["samples"] = 2000;
    sc["settings"]["record_trajectories"] = true;
    sc["settings"]["max_recorded_trajectories"] = 5;
    return testing::write_run(sc, dir_ / "run");
  }
  fs::path dir_;
};

TEST_F(VtkhdfExport, VtkReadsTerrainBuildingsAndTrajectoriesAsInResultsH5) {
  const fs::path h5 = run_minimal();
  const ExportReport rep = export_results({h5, dir_ / "maps", std::nullopt});
  for (const char* name : {"terrain.vtkhdf", "buildings.vtkhdf", "trajectories.vtkhdf"})
    EXPECT_NE(std::find(rep.files.begin(), rep.files.end(), name), rep.files.end()) << name;
  const fs::path t = dir_ / "maps/terrain.vtkhdf", b = dir_ / "maps/buildings.vtkhdf",
                 tr = dir_ / "maps/trajectories.vtkhdf";
  const Json v = vtk_view({t, b, tr});
  ASSERT_TRUE(v.is_object());

  // Terrain: counts, CRS coordinates (input + origin), cell values, the hazardous flag.
  const Json& tv = v[t.string()];
  EXPECT_EQ(tv["class"], "vtkUnstructuredGrid");
  EXPECT_EQ(tv["points"], api::dataset_shape(h5, "/terrain/vertices_m")[0]);
  EXPECT_EQ(tv["cells"], 3200);
  EXPECT_EQ(tv["cell_types"], Json::array({5}));
  const auto tri = api::read_dataset_int64(h5, "/terrain/triangles");
  EXPECT_EQ(tv["first_cell"], Json::array({tri[0], tri[1], tri[2]}));
  EXPECT_DOUBLE_EQ(tv["bounds"][0].get<double>(), 452300.0 - 200.0);
  EXPECT_DOUBLE_EQ(tv["bounds"][3].get<double>(), 3839800.0 + 200.0);
  const auto density = api::read_dataset_double(h5, "/ptn/density_per_m2");
  const double threshold = api::read_dataset_double(h5, "/hfd/threshold_per_m2")[0];
  const Json& cd = tv["cell_data"];
  EXPECT_DOUBLE_EQ(cd["density_per_m2"]["sum"].get<double>(), sum(density));
  EXPECT_EQ(cd["density_per_m2"]["first"][0].get<double>(), density[0]);
  EXPECT_DOUBLE_EQ(cd["std_error_per_m2"]["sum"].get<double>(),
                   sum(api::read_dataset_double(h5, "/ptn/std_error_per_m2")));
  EXPECT_DOUBLE_EQ(cd["area_m2"]["sum"].get<double>(), 400.0 * 400.0);
  const auto hazardous = static_cast<double>(
      std::count_if(density.begin(), density.end(), [&](double d) { return d >= threshold; }));
  EXPECT_GT(hazardous, 0.0);
  EXPECT_EQ(cd["hazardous"]["sum"].get<double>(), hazardous);

  // Buildings: the building's figures on each of its triangles.
  const Json& bv = v[b.string()];
  const auto owner = api::read_dataset_int64(h5, "/buildings/triangle_building");
  EXPECT_EQ(bv["cells"], owner.size());
  const double pen = api::read_dataset_double(h5, "/buildings/expected_penetrations")[0];
  EXPECT_DOUBLE_EQ(bv["cell_data"]["expected_penetrations"]["sum"].get<double>(),
                   pen * static_cast<double>(owner.size()));  // one building
  EXPECT_EQ(bv["cell_data"]["surface"]["count"], owner.size());

  // Trajectories: one poly-line per recorded history, its points and times.
  const Json& rv = v[tr.string()];
  EXPECT_EQ(rv["cells"], 5);
  EXPECT_EQ(rv["cell_types"], Json::array({4}));
  EXPECT_EQ(rv["points"], api::dataset_shape(h5, "/trajectories/t_s")[0]);
  EXPECT_DOUBLE_EQ(rv["point_data"]["t_s"]["sum"].get<double>(),
                   sum(api::read_dataset_double(h5, "/trajectories/t_s")));
  EXPECT_GT(rv["point_data"]["speed_mps"]["first"][0].get<double>(), 30.0);  // the launch
  EXPECT_EQ(rv["cell_data"]["history"]["first"], Json::array({0, 1, 2, 3, 4}));
}

TEST_F(VtkhdfExport, NoTrajectoriesNoFileAndSaid) {
  Json sc = api::testing::minimal_example();
  sc["fragment_groups"][0]["samples"] = 200;
  testing::write_run(sc, dir_ / "run");
  const ExportReport rep = export_results({dir_ / "run/results.h5", dir_ / "maps", std::nullopt});
  EXPECT_TRUE(fs::is_regular_file(dir_ / "maps/terrain.vtkhdf"));
  EXPECT_FALSE(fs::exists(dir_ / "maps/trajectories.vtkhdf"));
  bool said = false;
  for (const auto& n : rep.notes) said = said || n.find("trajectories.vtkhdf") != std::string::npos;
  EXPECT_TRUE(said);
}

}  // namespace
}  // namespace fragsim::gis
