#pragma once
// VTKHDF files (VTK's HDF5 format, version 1.0, type UnstructuredGrid), which ParaView (5.10 and
// later) and VTK's vtkHDFReader open directly. Layout, as VTK's "VTKHDF format specification":
//   /VTKHDF                 attributes Version = [1, 0], Type = "UnstructuredGrid" (ASCII)
//   /VTKHDF/NumberOfPoints, NumberOfCells, NumberOfConnectivityIds   one entry (one partition)
//   /VTKHDF/Points          n x 3 float64
//   /VTKHDF/Connectivity    point indices of every cell, one after another (int64)
//   /VTKHDF/Offsets         cells + 1 (int64): cell k is Connectivity[Offsets[k] .. Offsets[k+1])
//   /VTKHDF/Types           VTK cell type per cell (uint8: 5 triangle, 4 poly-line)
//   /VTKHDF/CellData/<name>, /VTKHDF/PointData/<name>   one value per cell / point (float64)
#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

namespace fragsim::formats {

inline constexpr std::uint8_t kVtkPolyLine = 4;
inline constexpr std::uint8_t kVtkTriangle = 5;

struct VtkUnstructuredGrid {
  std::vector<double> points_xyz;  // 3 per point
  std::vector<std::int64_t> connectivity;
  std::vector<std::int64_t> offsets{0};  // cells + 1, starting at 0
  std::vector<std::uint8_t> types;       // one per cell
  std::vector<std::pair<std::string, std::vector<double>>> cell_data, point_data;

  std::size_t points() const { return points_xyz.size() / 3; }
  std::size_t cells() const { return types.size(); }
  // Appends a cell of `type` over the given point indices.
  void add_cell(std::uint8_t type, std::initializer_list<std::int64_t> point_ids);
};

// Writes a new file at `path` (fails if it exists). Throws std::logic_error when the arrays do not
// fit together (sizes, offsets, indices) and std::runtime_error on HDF5 errors.
void write_vtkhdf(const std::filesystem::path& path, const VtkUnstructuredGrid& grid);

}  // namespace fragsim::formats
