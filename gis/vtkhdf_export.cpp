#include "gis/vtkhdf_export.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "formats/results_h5.h"

namespace fragsim::gis {

namespace fs = std::filesystem;

namespace {

// n x 3 coordinates with the CRS offset added to x and y.
std::vector<double> points_of(const fs::path& f, const std::string& name, const Vec2& offset) {
  std::vector<double> xyz = formats::read_dataset_double(f, name);
  for (std::size_t k = 0; k + 2 < xyz.size(); k += 3) {
    xyz[k] += offset.x();
    xyz[k + 1] += offset.y();
  }
  return xyz;
}

// Triangles (m x 3 indices) as VTK triangle cells.
void add_triangles(formats::VtkUnstructuredGrid& g, const std::vector<std::int64_t>& t) {
  g.connectivity.reserve(t.size());
  g.offsets.reserve(t.size() / 3 + 1);
  g.types.reserve(t.size() / 3);
  for (std::size_t k = 0; k + 2 < t.size(); k += 3)
    g.add_cell(formats::kVtkTriangle, {t[k], t[k + 1], t[k + 2]});
}

bool has_dataset(const fs::path& f, const std::string& name) {
  const auto all = formats::list_datasets(f);
  return std::find(all.begin(), all.end(), name) != all.end();
}

std::vector<double> as_double(const std::vector<std::int64_t>& v) {
  return {v.begin(), v.end()};
}

}  // namespace

formats::VtkUnstructuredGrid terrain_vtk(const fs::path& f, const Vec2& offset) {
  formats::VtkUnstructuredGrid g;
  g.points_xyz = points_of(f, "/terrain/vertices_m", offset);
  add_triangles(g, formats::read_dataset_int64(f, "/terrain/triangles"));
  std::vector<double> density = formats::read_dataset_double(f, "/ptn/density_per_m2");
  const double threshold = formats::read_dataset_double(f, "/hfd/threshold_per_m2").at(0);
  std::vector<double> hazardous(density.size());
  for (std::size_t k = 0; k < density.size(); ++k)
    hazardous[k] = density[k] >= threshold ? 1.0 : 0.0;
  g.cell_data.emplace_back("density_per_m2", std::move(density));
  g.cell_data.emplace_back("std_error_per_m2",
                           formats::read_dataset_double(f, "/ptn/std_error_per_m2"));
  g.cell_data.emplace_back("area_m2", formats::read_dataset_double(f, "/terrain/area_m2"));
  g.cell_data.emplace_back("hazardous", std::move(hazardous));
  return g;
}

std::optional<formats::VtkUnstructuredGrid> buildings_vtk(const fs::path& f, const Vec2& offset) {
  const auto owner = formats::read_dataset_int64(f, "/buildings/triangle_building");
  if (owner.empty()) return std::nullopt;
  formats::VtkUnstructuredGrid g;
  g.points_xyz = points_of(f, "/buildings/vertices_m", offset);
  add_triangles(g, formats::read_dataset_int64(f, "/buildings/triangles"));
  g.cell_data.emplace_back("building", as_double(owner));
  g.cell_data.emplace_back(
      "surface", as_double(formats::read_dataset_int64(f, "/buildings/triangle_surface")));
  for (const char* figure : {"expected_impacts", "impacts_std_error", "expected_penetrations",
                             "penetrations_std_error"}) {
    const auto per_building = formats::read_dataset_double(f, std::string("/buildings/") + figure);
    std::vector<double> per_triangle(owner.size());
    for (std::size_t k = 0; k < owner.size(); ++k)
      per_triangle[k] = per_building.at(static_cast<std::size_t>(owner[k]));
    g.cell_data.emplace_back(figure, std::move(per_triangle));
  }
  return g;
}

std::optional<formats::VtkUnstructuredGrid> trajectories_vtk(const fs::path& f,
                                                             const Vec2& offset) {
  if (!has_dataset(f, "/trajectories/offsets")) return std::nullopt;
  const auto offsets = formats::read_dataset_int64(f, "/trajectories/offsets");
  if (offsets.size() < 2) return std::nullopt;
  formats::VtkUnstructuredGrid g;
  g.points_xyz = points_of(f, "/trajectories/position_m", offset);
  g.connectivity.resize(static_cast<std::size_t>(offsets.back()));
  for (std::size_t k = 0; k < g.connectivity.size(); ++k)
    g.connectivity[k] = static_cast<std::int64_t>(k);
  g.offsets = offsets;
  g.types.assign(offsets.size() - 1, formats::kVtkPolyLine);
  const auto v = formats::read_dataset_double(f, "/trajectories/velocity_mps");
  std::vector<double> speed(v.size() / 3);
  for (std::size_t k = 0; k < speed.size(); ++k)
    speed[k] =
        std::sqrt(v[3 * k] * v[3 * k] + v[3 * k + 1] * v[3 * k + 1] + v[3 * k + 2] * v[3 * k + 2]);
  g.point_data.emplace_back("t_s", formats::read_dataset_double(f, "/trajectories/t_s"));
  g.point_data.emplace_back("speed_mps", std::move(speed));
  g.point_data.emplace_back("event",
                            as_double(formats::read_dataset_int64(f, "/trajectories/event")));
  g.cell_data.emplace_back("group",
                           as_double(formats::read_dataset_int64(f, "/trajectories/group")));
  g.cell_data.emplace_back("history",
                           as_double(formats::read_dataset_int64(f, "/trajectories/history")));
  return g;
}

}  // namespace fragsim::gis
