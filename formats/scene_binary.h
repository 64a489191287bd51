#pragma once
// The compact scene a browser draws (docs/http-api.md, "The scene format"): terrain, PTN density,
// buildings and a sample of trajectories as little-endian typed arrays behind a small JSON
// header, so that a WebGL page reads a million triangles without parsing JSON numbers.
//
//   bytes 0..7     "FSSCENE1"
//   bytes 8..11    uint32 H: header length, spaces included, so that 12 + H is a multiple of 8
//   bytes 12..     header JSON {"format": "fragsim.scene/1", "offset_m": [x, y, z],
//                  "arrays": {name: {"type", "shape", "offset", "bytes"}}, "building_ids": [...],
//                  "material_names": [...], "trajectories": {"recorded", "sent"} (jobs)}
//   then the data block; each array starts at 12 + H + offset, offset a multiple of 8.
//
// Positions are float32 relative to offset_m (float64, the centre of the terrain's bounding box
// rounded to whole metres): input coordinates = position + offset_m. Float32 keeps 0.1 mm over
// a 2 km site wherever the site lies on the map.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/scene/site.h"

namespace fragsim::formats {

inline constexpr const char* kSceneContentType = "application/vnd.fragsim.scene";
inline constexpr std::int64_t kDefaultSceneTrajectories = 200;
inline constexpr std::int64_t kMaxSceneTrajectories = 10'000;

struct SceneArrays {
  Vec3 offset_m{0, 0, 0};
  std::vector<float> terrain_vertices;  // 3 per vertex, relative to offset_m
  std::vector<std::uint32_t> terrain_triangles;
  // Per terrain triangle: its material, an index into material_names (docs/scenario.md,
  // "Materials by zone"). Empty for a results.h5 older than format 4 (no /terrain/material).
  // Sent as u8 when there are at most 256 names, else u16.
  std::vector<std::uint16_t> terrain_material;
  std::vector<std::string> material_names;              // the site's materials, index order
  std::vector<float> density_per_m2, std_error_per_m2;  // per terrain triangle (jobs)
  std::vector<float> building_vertices;
  std::vector<std::uint32_t> building_triangles;
  std::vector<std::uint32_t> triangle_building;
  std::vector<std::uint8_t> triangle_surface;  // 1 wall, 2 roof, 3 window
  std::vector<std::string> building_ids;
  bool has_trajectories = false;  // a job's scene: say how many were recorded and sent
  std::int64_t trajectories_recorded = 0;
  std::vector<std::uint32_t> trajectory_offsets;  // k + 1
  std::vector<float> trajectory_points;           // 3 per point
  std::vector<float> trajectory_speed;            // per point, m/s
  std::vector<std::uint32_t> trajectory_group;    // per trajectory
};

// A registered site's terrain and buildings (no densities).
SceneArrays scene_from_site(const scene::Site& site);

// A finished run's scene from its results.h5: terrain, density, buildings, and up to
// `max_trajectories` of the recorded trajectories, evenly spaced among them. Throws
// std::runtime_error naming what is missing.
SceneArrays scene_from_results(const std::filesystem::path& results_h5,
                               std::int64_t max_trajectories);

std::string encode_scene(const SceneArrays& scene);

}  // namespace fragsim::formats
