// The HDF5 writer's choice of layout (formats/h5_writer.h): a large field is deflated when a
// probe of its first values shows that it pays, stored as it is otherwise; read back exactly
// either way.
#include "formats/h5_writer.h"

#include <gtest/gtest.h>
#include <hdf5.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

namespace fragsim::formats::h5 {
namespace {

namespace fs = std::filesystem;

struct Stored {
  H5D_layout_t layout;
  int filters;
  std::vector<double> values;
};

Stored read_back(const fs::path& f, const char* name, std::size_t n) {
  const Handle file(H5Fopen(f.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose, "open");
  const Handle d(H5Dopen2(file, name, H5P_DEFAULT), H5Dclose, "dataset");
  const Handle dcpl(H5Dget_create_plist(d), H5Pclose, "dcpl");
  Stored s{H5Pget_layout(dcpl), H5Pget_nfilters(dcpl), std::vector<double>(n)};
  check(H5Dread(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, s.values.data()), "read");
  return s;
}

TEST(H5Writer, DeflatesAFieldOnlyWhenItsProbeShowsItPays) {
  const fs::path dir = fs::temp_directory_path() / ("fragsim_h5w_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path f = dir / "layout.h5";
  fs::remove(f);
  constexpr std::size_t n = 100000;  // above the size from which fields may be compressed
  std::mt19937_64 g(3);
  std::uniform_real_distribution<double> u(-500.0, 500.0);
  std::vector<double> random(n), smooth(n), sparse(n, 0.0), small_random(1000);
  for (double& x : random) x = u(g);  // a fragment's positions
  for (std::size_t i = 0; i < n; ++i) smooth[i] = 0.25 * static_cast<double>(i % 640);
  for (std::size_t i = 0; i < n; i += 97) sparse[i] = u(g);  // a density: mostly zero
  for (double& x : small_random) x = u(g);
  {
    Writer w(f);
    w.dataset("/random", random);
    w.dataset("/smooth", smooth);
    w.dataset("/sparse", sparse);
    w.dataset("/small", small_random);
    w.close();
  }
  const Stored r = read_back(f, "/random", n), s = read_back(f, "/smooth", n),
               z = read_back(f, "/sparse", n), small = read_back(f, "/small", 1000);
  EXPECT_EQ(r.layout, H5D_CONTIGUOUS);  // near-random doubles: deflate would not pay
  EXPECT_EQ(r.filters, 0);
  EXPECT_EQ(s.layout, H5D_CHUNKED);
  EXPECT_EQ(s.filters, 2);  // shuffle + deflate
  EXPECT_EQ(z.layout, H5D_CHUNKED);
  EXPECT_EQ(z.filters, 2);
  EXPECT_EQ(small.filters, 0);  // below the size from which fields may be compressed
  EXPECT_EQ(r.values, random);
  EXPECT_EQ(s.values, smooth);
  EXPECT_EQ(z.values, sparse);
  EXPECT_EQ(small.values, small_random);
  // The probe itself: at least a 20 % saving on the first 8,192 values.
  EXPECT_FALSE(worth_deflating(random.data(), n, sizeof(double)));
  EXPECT_TRUE(worth_deflating(smooth.data(), n, sizeof(double)));
  EXPECT_FALSE(worth_deflating(random.data(), 0, sizeof(double)));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace fragsim::formats::h5
