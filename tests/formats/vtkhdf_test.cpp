// formats/vtkhdf: the layout VTK's format specification asks for, read back with HDF5, and arrays
// that do not fit together refused before anything is written.
#include "formats/vtkhdf.h"

#include <gtest/gtest.h>

#include "api/test_support.h"
#include "formats/results_h5.h"

namespace fragsim::formats {
namespace {

namespace fs = std::filesystem;

VtkUnstructuredGrid two_triangles() {
  VtkUnstructuredGrid g;
  g.points_xyz = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
  g.add_cell(kVtkTriangle, {0, 1, 2});
  g.add_cell(kVtkTriangle, {0, 2, 3});
  g.cell_data.emplace_back("value", std::vector<double>{1.5, 2.5});
  g.point_data.emplace_back("z", std::vector<double>{0, 0, 0, 0});
  return g;
}

TEST(Vtkhdf, LayoutOfTheSpecification) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_vtkhdf_api_");
  const fs::path f = dir / "g.vtkhdf";
  write_vtkhdf(f, two_triangles());
  EXPECT_EQ(read_attribute_string(f, "/VTKHDF", "Type"), "UnstructuredGrid");
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/NumberOfPoints"), std::vector<std::int64_t>{4});
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/NumberOfCells"), std::vector<std::int64_t>{2});
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/NumberOfConnectivityIds"), std::vector<std::int64_t>{6});
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/Offsets"), (std::vector<std::int64_t>{0, 3, 6}));
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/Connectivity"),
            (std::vector<std::int64_t>{0, 1, 2, 0, 2, 3}));
  EXPECT_EQ(read_dataset_int64(f, "/VTKHDF/Types"), (std::vector<std::int64_t>{5, 5}));
  EXPECT_EQ(dataset_shape(f, "/VTKHDF/Points"), (std::vector<std::uint64_t>{4, 3}));
  EXPECT_EQ(read_dataset_double(f, "/VTKHDF/CellData/value"), (std::vector<double>{1.5, 2.5}));
  EXPECT_EQ(dataset_shape(f, "/VTKHDF/PointData/z"), (std::vector<std::uint64_t>{4}));
  fs::remove_all(dir);
}

TEST(Vtkhdf, ArraysThatDoNotFitAreRefusedAndNothingIsWritten) {
  const fs::path dir = api::testing::fresh_test_dir("fragsim_vtkhdf_api_");
  const auto refused = [&](VtkUnstructuredGrid g) {
    EXPECT_THROW(write_vtkhdf(dir / "bad.vtkhdf", g), std::logic_error);
    EXPECT_FALSE(fs::exists(dir / "bad.vtkhdf"));
  };
  VtkUnstructuredGrid g = two_triangles();
  g.connectivity[5] = 4;  // no point 4
  refused(g);
  g = two_triangles();
  g.cell_data[0].second.pop_back();
  refused(g);
  g = two_triangles();
  g.point_data[0].second.push_back(1.0);
  refused(g);
  g = two_triangles();
  g.offsets[1] = 7;  // decreasing
  refused(g);
  g = two_triangles();
  g.points_xyz.pop_back();
  refused(g);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fragsim::formats
