// The ParaView files of `fragsim export`, read back by an independent reader: VTK's own
// vtkHDFReader (Debian's python3-vtk9, through tests/gis/check_vtkhdf.py), compared with
// results.h5.
#include "gis/vtkhdf_export.h"

#include <gtest/gtest.h>
#include <hdf5.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <numeric>

#include "api/run_outputs.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "formats/results_h5.h"
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

// The bounds [xmin, xmax, ymin, ymax, zmin, zmax] of results.h5's n x 3 `name`, x and y shifted
// by the site's CRS origin: what VTK must report for the file made of them.
std::vector<double> bounds_of(const fs::path& h5, const std::string& name, double e, double n) {
  const auto xyz = formats::read_dataset_double(h5, name);
  std::vector<double> b{1e300, -1e300, 1e300, -1e300, 1e300, -1e300};
  for (std::size_t k = 0; k < xyz.size(); ++k) {
    const double v = xyz[k] + (k % 3 == 0 ? e : k % 3 == 1 ? n : 0.0);
    b[2 * (k % 3)] = std::min(b[2 * (k % 3)], v);
    b[2 * (k % 3) + 1] = std::max(b[2 * (k % 3) + 1], v);
  }
  return b;
}

// The first values of a VTK array (check_vtkhdf.py lists up to 5) equal results.h5's.
void expect_first(const Json& array, const std::vector<double>& expected, const char* what) {
  ASSERT_GT(array["first"].size(), 0u) << what;
  for (std::size_t k = 0; k < array["first"].size(); ++k)
    EXPECT_EQ(array["first"][k].get<double>(), expected.at(k)) << what << " " << k;
}

// A 1-D integer attribute (the VTKHDF Version), read with the HDF5 C API.
std::vector<std::int64_t> int_array_attribute(const fs::path& f, const char* object,
                                              const char* name) {
  const hid_t file = H5Fopen(f.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  const hid_t obj = H5Oopen(file, object, H5P_DEFAULT);
  const hid_t attr = H5Aopen(obj, name, H5P_DEFAULT);
  const hid_t space = H5Aget_space(attr);
  std::vector<std::int64_t> v(static_cast<std::size_t>(H5Sget_simple_extent_npoints(space)));
  const herr_t rc = H5Aread(attr, H5T_NATIVE_INT64, v.data());
  H5Sclose(space);
  H5Aclose(attr);
  H5Oclose(obj);
  H5Fclose(file);
  if (rc < 0) v.clear();
  return v;
}

// What every VTKHDF 1.0 unstructured grid must hold, read back with HDF5; returns the cell types.
std::vector<std::int64_t> expect_vtkhdf_layout(const fs::path& f) {
  SCOPED_TRACE(f.filename().string());
  EXPECT_EQ(int_array_attribute(f, "/VTKHDF", "Version"), (std::vector<std::int64_t>{1, 0}));
  EXPECT_EQ(formats::read_attribute_string(f, "/VTKHDF", "Type"), "UnstructuredGrid");
  const auto n = static_cast<std::int64_t>(formats::dataset_shape(f, "/VTKHDF/Points").at(0));
  EXPECT_EQ(formats::dataset_shape(f, "/VTKHDF/Points")[1], 3u);
  const auto offsets = formats::read_dataset_int64(f, "/VTKHDF/Offsets");
  const auto connectivity = formats::read_dataset_int64(f, "/VTKHDF/Connectivity");
  const auto types = formats::read_dataset_int64(f, "/VTKHDF/Types");
  EXPECT_EQ(formats::read_dataset_raw(f, "/VTKHDF/Types").size(), types.size());  // uint8
  EXPECT_EQ(formats::read_dataset_int64(f, "/VTKHDF/NumberOfPoints"), std::vector<std::int64_t>{n});
  EXPECT_EQ(formats::read_dataset_int64(f, "/VTKHDF/NumberOfCells"),
            std::vector<std::int64_t>{static_cast<std::int64_t>(types.size())});
  EXPECT_EQ(formats::read_dataset_int64(f, "/VTKHDF/NumberOfConnectivityIds"),
            std::vector<std::int64_t>{static_cast<std::int64_t>(connectivity.size())});
  EXPECT_EQ(offsets.size(), types.size() + 1);
  EXPECT_EQ(offsets.front(), 0);
  EXPECT_EQ(offsets.back(), static_cast<std::int64_t>(connectivity.size()));
  EXPECT_TRUE(std::is_sorted(offsets.begin(), offsets.end()));
  EXPECT_TRUE(std::all_of(connectivity.begin(), connectivity.end(),
                          [&](std::int64_t id) { return id >= 0 && id < n; }));
  return types;
}

class VtkhdfExport : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_vtkhdf_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // The minimal example with a CRS offset and 5 recorded trajectories. With the default count
  // one sample crossing a triangle gives about 10 times the threshold; with count 1000 about half
  // of it, so that densities lie on both sides of the threshold.
  fs::path run_minimal(int count = 20000) {
    Json sc = api::testing::on_small_plane(api::testing::minimal_example());
    sc["site"]["origin"] = {
        {"crs", "EPSG:32611"}, {"easting_m", 452300}, {"northing_m", 3839800}, {"elevation_m", 0}};
    auto& g = sc["fragment_groups"][0];  // slow and many: some triangles are hazardous
    g["speed_mps"] = {{"dist", "normal"}, {"mean", 60}, {"sigma", 5}};
    g["direction"]["elevation_deg"] = {40, 80};
    g["count"] = count;
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
  EXPECT_EQ(tv["points"], formats::dataset_shape(h5, "/terrain/vertices_m")[0]);
  EXPECT_EQ(tv["cells"], 3200);
  EXPECT_EQ(tv["cell_types"], Json::array({5}));
  const auto tri = formats::read_dataset_int64(h5, "/terrain/triangles");
  EXPECT_EQ(tv["first_cell"], Json::array({tri[0], tri[1], tri[2]}));
  EXPECT_DOUBLE_EQ(tv["bounds"][0].get<double>(), 452300.0 - 200.0);
  EXPECT_DOUBLE_EQ(tv["bounds"][3].get<double>(), 3839800.0 + 200.0);
  EXPECT_EQ(tv["bounds"].get<std::vector<double>>(),
            bounds_of(h5, "/terrain/vertices_m", 452300.0, 3839800.0));
  const auto density = formats::read_dataset_double(h5, "/ptn/density_per_m2");
  const double threshold = formats::read_dataset_double(h5, "/hfd/threshold_per_m2")[0];
  const Json& cd = tv["cell_data"];
  EXPECT_DOUBLE_EQ(cd["density_per_m2"]["sum"].get<double>(), sum(density));
  EXPECT_EQ(cd["density_per_m2"]["first"][0].get<double>(), density[0]);
  EXPECT_DOUBLE_EQ(cd["std_error_per_m2"]["sum"].get<double>(),
                   sum(formats::read_dataset_double(h5, "/ptn/std_error_per_m2")));
  EXPECT_DOUBLE_EQ(cd["area_m2"]["sum"].get<double>(), 400.0 * 400.0);
  const auto hazardous = static_cast<double>(
      std::count_if(density.begin(), density.end(), [&](double d) { return d >= threshold; }));
  EXPECT_GT(hazardous, 0.0);
  EXPECT_EQ(cd["hazardous"]["sum"].get<double>(), hazardous);
  expect_first(cd["density_per_m2"], density, "density_per_m2");
  expect_first(cd["std_error_per_m2"], formats::read_dataset_double(h5, "/ptn/std_error_per_m2"),
               "std_error_per_m2");
  expect_first(cd["area_m2"], formats::read_dataset_double(h5, "/terrain/area_m2"), "area_m2");

  // Buildings: the building's figures on each of its triangles.
  const Json& bv = v[b.string()];
  const auto owner = formats::read_dataset_int64(h5, "/buildings/triangle_building");
  EXPECT_EQ(bv["cells"], owner.size());
  const double pen = formats::read_dataset_double(h5, "/buildings/expected_penetrations")[0];
  EXPECT_DOUBLE_EQ(bv["cell_data"]["expected_penetrations"]["sum"].get<double>(),
                   pen * static_cast<double>(owner.size()));  // one building
  EXPECT_EQ(bv["cell_data"]["surface"]["count"], owner.size());
  EXPECT_EQ(bv["points"], formats::dataset_shape(h5, "/buildings/vertices_m")[0]);
  EXPECT_EQ(bv["bounds"].get<std::vector<double>>(),
            bounds_of(h5, "/buildings/vertices_m", 452300.0, 3839800.0));
  expect_first(
      bv["cell_data"]["surface"],
      [&] {
        const auto s = formats::read_dataset_int64(h5, "/buildings/triangle_surface");
        return std::vector<double>(s.begin(), s.end());
      }(),
      "surface");

  // Trajectories: one poly-line per recorded history, its points and times.
  const Json& rv = v[tr.string()];
  EXPECT_EQ(rv["cells"], 5);
  EXPECT_EQ(rv["cell_types"], Json::array({4}));
  EXPECT_EQ(rv["points"], formats::dataset_shape(h5, "/trajectories/t_s")[0]);
  EXPECT_DOUBLE_EQ(rv["point_data"]["t_s"]["sum"].get<double>(),
                   sum(formats::read_dataset_double(h5, "/trajectories/t_s")));
  EXPECT_GT(rv["point_data"]["speed_mps"]["first"][0].get<double>(), 30.0);  // the launch
  EXPECT_EQ(rv["cell_data"]["history"]["first"], Json::array({0, 1, 2, 3, 4}));
  EXPECT_EQ(rv["bounds"].get<std::vector<double>>(),
            bounds_of(h5, "/trajectories/position_m", 452300.0, 3839800.0));
  expect_first(rv["point_data"]["t_s"], formats::read_dataset_double(h5, "/trajectories/t_s"),
               "t_s");
}

TEST_F(VtkhdfExport, FilesReadBackWithHdf5HoldTheLayoutAndTheHazardousFlagPerTriangle) {
  const fs::path h5 = run_minimal(1000);
  export_results({h5, dir_ / "maps", std::nullopt});
  const fs::path t = dir_ / "maps/terrain.vtkhdf", b = dir_ / "maps/buildings.vtkhdf",
                 tr = dir_ / "maps/trajectories.vtkhdf";

  // Terrain: one triangle cell per results.h5 triangle; hazardous exactly where density >= t.
  auto types = expect_vtkhdf_layout(t);
  const auto tri = formats::read_dataset_int64(h5, "/terrain/triangles");
  EXPECT_EQ(types, std::vector<std::int64_t>(tri.size() / 3, 5));
  EXPECT_EQ(formats::read_dataset_int64(t, "/VTKHDF/Connectivity"), tri);
  const auto density = formats::read_dataset_double(h5, "/ptn/density_per_m2");
  const double threshold = formats::read_dataset_double(h5, "/hfd/threshold_per_m2").at(0);
  const auto flag = formats::read_dataset_double(t, "/VTKHDF/CellData/hazardous");
  ASSERT_EQ(flag.size(), density.size());
  std::size_t below = 0, just_above = 0;  // 0 < density < t, t <= density < 2 t
  for (std::size_t k = 0; k < density.size(); ++k) {
    EXPECT_EQ(flag[k], density[k] >= threshold ? 1.0 : 0.0) << "triangle " << k;
    below += density[k] > 0.0 && density[k] < threshold ? 1 : 0;
    just_above += density[k] >= threshold && density[k] < 2.0 * threshold ? 1 : 0;
  }
  EXPECT_GT(below, 0u);  // so that the flag is not merely density > 0
  EXPECT_GT(just_above, 0u);
  EXPECT_EQ(formats::read_dataset_double(t, "/VTKHDF/CellData/density_per_m2"), density);

  // Buildings: each triangle carries its building's figures.
  types = expect_vtkhdf_layout(b);
  const auto owner = formats::read_dataset_int64(h5, "/buildings/triangle_building");
  EXPECT_EQ(types, std::vector<std::int64_t>(owner.size(), 5));
  const auto impacts = formats::read_dataset_double(h5, "/buildings/expected_impacts");
  const auto per_cell = formats::read_dataset_double(b, "/VTKHDF/CellData/expected_impacts");
  ASSERT_EQ(per_cell.size(), owner.size());
  for (std::size_t k = 0; k < owner.size(); ++k)
    EXPECT_EQ(per_cell[k], impacts.at(static_cast<std::size_t>(owner[k])));

  // Trajectories: poly-lines over results.h5's own offsets.
  types = expect_vtkhdf_layout(tr);
  EXPECT_EQ(types, std::vector<std::int64_t>(5, 4));
  EXPECT_EQ(formats::read_dataset_int64(tr, "/VTKHDF/Offsets"),
            formats::read_dataset_int64(h5, "/trajectories/offsets"));
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

TEST_F(VtkhdfExport, NoBuildingsNoFileAndSaid) {
  Json sc = api::testing::minimal_example();
  sc["site"]["buildings"] = Json::array();
  sc["fragment_groups"][0]["samples"] = 200;
  testing::write_run(sc, dir_ / "run");
  const ExportReport rep = export_results({dir_ / "run/results.h5", dir_ / "maps", std::nullopt});
  EXPECT_TRUE(fs::is_regular_file(dir_ / "maps/terrain.vtkhdf"));
  EXPECT_FALSE(fs::exists(dir_ / "maps/buildings.vtkhdf"));
  EXPECT_EQ(std::count(rep.files.begin(), rep.files.end(), "buildings.vtkhdf"), 0);
  bool said = false;
  for (const auto& n : rep.notes) said = said || n.find("buildings.vtkhdf") != std::string::npos;
  EXPECT_TRUE(said);
}

}  // namespace
}  // namespace fragsim::gis
