#pragma once
// ParaView files of a run (docs/gis.md, "ParaView"): results.h5 as three VTKHDF unstructured
// grids (formats/vtkhdf.h), in the same coordinates as the GIS files (the site's CRS: input
// coordinates + site.origin easting/northing):
//   terrain        its triangles; cell data density_per_m2, std_error_per_m2, area_m2, and
//                  hazardous (1 where density >= the threshold, else 0)
//   buildings      their triangles; cell data building (index in results.h5), surface (1 wall,
//                  2 roof, 3 window), and the building's expected_impacts, impacts_std_error,
//                  expected_penetrations, penetrations_std_error on each of its triangles
//   trajectories   the recorded trajectories as poly-lines; point data t_s, speed_mps, event
//                  (results.h5 /trajectories/event codes); cell data group, history
#include <filesystem>
#include <optional>

#include "core/common/types.h"
#include "formats/vtkhdf.h"

namespace fragsim::gis {

// Each reads what it needs from results.h5 (throws std::runtime_error naming what is missing).
formats::VtkUnstructuredGrid terrain_vtk(const std::filesystem::path& results_h5,
                                         const Vec2& offset);
// nullopt when the site has no buildings, or the run recorded no trajectories.
std::optional<formats::VtkUnstructuredGrid> buildings_vtk(const std::filesystem::path& results_h5,
                                                          const Vec2& offset);
std::optional<formats::VtkUnstructuredGrid> trajectories_vtk(
    const std::filesystem::path& results_h5, const Vec2& offset);

}  // namespace fragsim::gis
