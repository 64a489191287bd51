#include "formats/vtkhdf.h"

#include <stdexcept>

#include "formats/h5_writer.h"

namespace fragsim::formats {

void VtkUnstructuredGrid::add_cell(std::uint8_t type, std::initializer_list<std::int64_t> ids) {
  connectivity.insert(connectivity.end(), ids.begin(), ids.end());
  offsets.push_back(static_cast<std::int64_t>(connectivity.size()));
  types.push_back(type);
}

namespace {

void check_consistent(const VtkUnstructuredGrid& g) {
  const auto fail = [](const std::string& what) { throw std::logic_error("VTKHDF: " + what); };
  if (g.points_xyz.size() % 3 != 0) fail("points are not triples");
  if (g.offsets.size() != g.cells() + 1 || g.offsets.front() != 0 ||
      g.offsets.back() != static_cast<std::int64_t>(g.connectivity.size()))
    fail("offsets do not match the cells and the connectivity");
  for (std::size_t k = 0; k + 1 < g.offsets.size(); ++k)
    if (g.offsets[k + 1] < g.offsets[k]) fail("offsets decrease");
  const auto n = static_cast<std::int64_t>(g.points());
  for (const std::int64_t id : g.connectivity)
    if (id < 0 || id >= n) fail("a cell refers to point " + std::to_string(id));
  for (const auto& [name, v] : g.cell_data)
    if (v.size() != g.cells()) fail("cell array " + name + " has the wrong size");
  for (const auto& [name, v] : g.point_data)
    if (v.size() != g.points()) fail("point array " + name + " has the wrong size");
}

}  // namespace

void write_vtkhdf(const std::filesystem::path& path, const VtkUnstructuredGrid& g) {
  check_consistent(g);
  const std::lock_guard<std::mutex> lock(h5::hdf5_mutex());
  const h5::QuietErrors quiet;
  h5::Writer w(path);
  {
    const h5::Handle root = w.group("/VTKHDF");
    w.attribute(root, "Version", std::vector<std::int64_t>{1, 0});
    w.ascii_attribute(root, "Type", "UnstructuredGrid");
  }
  const auto one = [&](const char* name, std::size_t n) {
    const std::vector<std::int64_t> v{static_cast<std::int64_t>(n)};
    w.dataset(std::string("/VTKHDF/") + name, v);
  };
  one("NumberOfPoints", g.points());
  one("NumberOfCells", g.cells());
  one("NumberOfConnectivityIds", g.connectivity.size());
  w.dataset("/VTKHDF/Points", g.points_xyz.data(), g.points(), 3);
  w.dataset("/VTKHDF/Connectivity", g.connectivity);
  w.dataset("/VTKHDF/Offsets", g.offsets);
  w.dataset("/VTKHDF/Types", g.types);
  w.group("/VTKHDF/CellData");
  for (const auto& [name, v] : g.cell_data) w.dataset("/VTKHDF/CellData/" + name, v);
  w.group("/VTKHDF/PointData");
  for (const auto& [name, v] : g.point_data) w.dataset("/VTKHDF/PointData/" + name, v);
  w.close();
}

}  // namespace fragsim::formats
