#include "formats/scene_binary.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "formats/results_h5.h"

namespace fragsim::formats {

namespace {

// The centre of the points' bounding box in whole metres (zero for no points).
Vec3 rounded_centre(const std::vector<Vec3>& points) {
  Box3 box;
  for (const Vec3& p : points) box.extend(p);
  if (box.empty()) return Vec3::Zero();
  const Vec3 c = 0.5 * (box.lo + box.hi);
  return {std::round(c.x()), std::round(c.y()), std::round(c.z())};
}

void append_relative(std::vector<float>& out, const Vec3& p, const Vec3& offset) {
  const Vec3 d = p - offset;
  out.insert(out.end(),
             {static_cast<float>(d.x()), static_cast<float>(d.y()), static_cast<float>(d.z())});
}

std::vector<Vec3> points_of(const std::vector<double>& xyz) {
  std::vector<Vec3> out(xyz.size() / 3);
  for (std::size_t k = 0; k < out.size(); ++k)
    out[k] = {xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]};
  return out;
}

template <class T>
std::vector<T> narrowed(const std::vector<std::int64_t>& v) {
  std::vector<T> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(), [](std::int64_t x) { return static_cast<T>(x); });
  return out;
}

std::vector<std::uint8_t> narrowed_u8(const std::vector<std::uint16_t>& v) {
  std::vector<std::uint8_t> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(),
                 [](std::uint16_t x) { return static_cast<std::uint8_t>(x); });
  return out;
}

std::vector<float> to_float(const std::vector<double>& v) {
  std::vector<float> out(v.size());
  std::transform(v.begin(), v.end(), out.begin(), [](double x) { return static_cast<float>(x); });
  return out;
}

bool has_dataset(const std::vector<std::string>& names, const std::string& name) {
  return std::binary_search(names.begin(), names.end(), name);
}

// Trajectories k0 < k1 < ... evenly spaced among `recorded`, at most `max` of them.
std::vector<std::size_t> spread(std::size_t recorded, std::size_t max) {
  const std::size_t k = std::min(recorded, max);
  std::vector<std::size_t> out(k);
  for (std::size_t j = 0; j < k; ++j) out[j] = j * recorded / k;
  return out;
}

void read_trajectories(const std::filesystem::path& f, std::int64_t max, SceneArrays& s) {
  const auto offsets = read_dataset_int64(f, "/trajectories/offsets");
  const auto groups = read_dataset_int64(f, "/trajectories/group");
  const auto xyz = read_dataset_double(f, "/trajectories/position_m");
  const auto vel = read_dataset_double(f, "/trajectories/velocity_mps");
  if (offsets.empty() || groups.size() + 1 != offsets.size())
    throw std::runtime_error(f.string() +
                             ": /trajectories/offsets does not fit /trajectories/group");
  s.trajectories_recorded = static_cast<std::int64_t>(groups.size());
  s.trajectory_offsets.push_back(0);
  for (const std::size_t i : spread(groups.size(), static_cast<std::size_t>(max))) {
    const auto lo = static_cast<std::size_t>(offsets[i]);
    const auto hi = static_cast<std::size_t>(offsets[i + 1]);
    if (hi < lo || 3 * hi > xyz.size() || 3 * hi > vel.size())
      throw std::runtime_error(f.string() + ": /trajectories/offsets out of range");
    for (std::size_t p = lo; p < hi; ++p) {
      append_relative(s.trajectory_points, {xyz[3 * p], xyz[3 * p + 1], xyz[3 * p + 2]},
                      s.offset_m);
      const Vec3 v{vel[3 * p], vel[3 * p + 1], vel[3 * p + 2]};
      s.trajectory_speed.push_back(static_cast<float>(v.norm()));
    }
    s.trajectory_offsets.push_back(static_cast<std::uint32_t>(s.trajectory_speed.size()));
    s.trajectory_group.push_back(static_cast<std::uint32_t>(groups[i]));
  }
}

// /terrain/material and /terrain/material_names (results.h5 format 4), checked against the
// triangles.
void read_terrain_material(const std::filesystem::path& f, SceneArrays& s) {
  const auto material = read_dataset_int64(f, "/terrain/material");
  s.material_names = read_dataset_strings(f, "/terrain/material_names");
  if (3 * material.size() != s.terrain_triangles.size())
    throw std::runtime_error(f.string() + ": /terrain/material does not fit /terrain/triangles");
  for (const std::int64_t k : material)
    if (k < 0 || static_cast<std::size_t>(k) >= s.material_names.size())
      throw std::runtime_error(f.string() + ": /terrain/material holds " + std::to_string(k) +
                               ", beyond /terrain/material_names");
  s.terrain_material = narrowed<std::uint16_t>(material);
}

// Appends one array's bytes at the next multiple of 8 and describes it in `arrays`.
template <class T>
void put_array(std::string& data, nlohmann::ordered_json& arrays, const char* name,
               const std::vector<T>& v, std::size_t columns) {
  if (v.empty()) return;
  static_assert(std::is_arithmetic_v<T>);
  data.resize((data.size() + 7) / 8 * 8, '\0');
  const char* type = std::is_same_v<T, float> ? "f32"
                     : sizeof(T) == 4         ? "u32"
                     : sizeof(T) == 2         ? "u16"
                                              : "u8";
  nlohmann::ordered_json shape = {v.size() / columns};
  if (columns > 1) shape.push_back(columns);
  arrays[name] = {
      {"type", type}, {"shape", shape}, {"offset", data.size()}, {"bytes", v.size() * sizeof(T)}};
  // The host is little-endian (x86-64, aarch64): the bytes are the format's.
  data.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

}  // namespace

SceneArrays scene_from_site(const scene::Site& site) {
  SceneArrays s;
  std::vector<Vec3> terrain;
  terrain.reserve(site.terrain_vertices().size());
  for (const Vec3& v : site.terrain_vertices()) terrain.push_back(site.to_input(v));
  s.offset_m = rounded_centre(terrain);
  s.terrain_vertices.reserve(3 * terrain.size());
  for (const Vec3& p : terrain) append_relative(s.terrain_vertices, p, s.offset_m);
  s.terrain_triangles.reserve(3 * site.terrain_triangle_count());
  for (const auto& t : site.terrain_triangles())
    s.terrain_triangles.insert(s.terrain_triangles.end(), t.begin(), t.end());
  s.terrain_material.resize(site.terrain_triangle_count());
  for (std::size_t t = 0; t < s.terrain_material.size(); ++t)
    s.terrain_material[t] = site.terrain_triangle_material(static_cast<std::uint32_t>(t));
  for (const scene::Material& m : site.materials()) s.material_names.push_back(m.name);
  for (const Vec3& v : site.building_vertices())
    append_relative(s.building_vertices, site.to_input(v), s.offset_m);
  for (const auto& t : site.building_triangles()) {
    s.building_triangles.insert(s.building_triangles.end(), t.v.begin(), t.v.end());
    s.triangle_building.push_back(t.building);
    s.triangle_surface.push_back(static_cast<std::uint8_t>(t.surface));
  }
  for (const auto& b : site.buildings()) s.building_ids.push_back(b.id);
  return s;
}

SceneArrays scene_from_results(const std::filesystem::path& f, std::int64_t max_trajectories) {
  SceneArrays s;
  const auto terrain = points_of(read_dataset_double(f, "/terrain/vertices_m"));
  s.offset_m = rounded_centre(terrain);
  s.terrain_vertices.reserve(3 * terrain.size());
  for (const Vec3& p : terrain) append_relative(s.terrain_vertices, p, s.offset_m);
  s.terrain_triangles = narrowed<std::uint32_t>(read_dataset_int64(f, "/terrain/triangles"));
  s.density_per_m2 = to_float(read_dataset_double(f, "/ptn/density_per_m2"));
  s.std_error_per_m2 = to_float(read_dataset_double(f, "/ptn/std_error_per_m2"));
  if (3 * s.density_per_m2.size() != s.terrain_triangles.size())
    throw std::runtime_error(f.string() + ": /ptn/density_per_m2 does not fit /terrain/triangles");
  const auto names = list_datasets(f);
  if (has_dataset(names, "/terrain/material")) read_terrain_material(f, s);
  s.building_ids = read_dataset_strings(f, "/buildings/id");
  if (has_dataset(names, "/buildings/vertices_m")) {
    for (const Vec3& p : points_of(read_dataset_double(f, "/buildings/vertices_m")))
      append_relative(s.building_vertices, p, s.offset_m);
    s.building_triangles = narrowed<std::uint32_t>(read_dataset_int64(f, "/buildings/triangles"));
    s.triangle_building =
        narrowed<std::uint32_t>(read_dataset_int64(f, "/buildings/triangle_building"));
    s.triangle_surface =
        narrowed<std::uint8_t>(read_dataset_int64(f, "/buildings/triangle_surface"));
  }
  s.has_trajectories = true;
  if (has_dataset(names, "/trajectories/offsets") && max_trajectories > 0)
    read_trajectories(f, max_trajectories, s);
  else if (has_dataset(names, "/trajectories/group"))
    s.trajectories_recorded =
        static_cast<std::int64_t>(dataset_shape(f, "/trajectories/group").at(0));
  return s;
}

std::string encode_scene(const SceneArrays& s) {
  std::string data;
  nlohmann::ordered_json arrays = nlohmann::ordered_json::object();
  put_array(data, arrays, "terrain_vertices", s.terrain_vertices, 3);
  put_array(data, arrays, "terrain_triangles", s.terrain_triangles, 3);
  if (s.material_names.size() <= 256)
    put_array(data, arrays, "terrain_material", narrowed_u8(s.terrain_material), 1);
  else
    put_array(data, arrays, "terrain_material", s.terrain_material, 1);
  put_array(data, arrays, "density_per_m2", s.density_per_m2, 1);
  put_array(data, arrays, "std_error_per_m2", s.std_error_per_m2, 1);
  put_array(data, arrays, "building_vertices", s.building_vertices, 3);
  put_array(data, arrays, "building_triangles", s.building_triangles, 3);
  put_array(data, arrays, "triangle_building", s.triangle_building, 1);
  put_array(data, arrays, "triangle_surface", s.triangle_surface, 1);
  put_array(data, arrays, "trajectory_offsets", s.trajectory_offsets, 1);
  put_array(data, arrays, "trajectory_points", s.trajectory_points, 3);
  put_array(data, arrays, "trajectory_speed", s.trajectory_speed, 1);
  put_array(data, arrays, "trajectory_group", s.trajectory_group, 1);

  nlohmann::ordered_json header;
  header["format"] = "fragsim.scene/1";
  header["offset_m"] = {s.offset_m.x(), s.offset_m.y(), s.offset_m.z()};
  header["arrays"] = std::move(arrays);
  header["building_ids"] = s.building_ids;
  if (!s.material_names.empty()) header["material_names"] = s.material_names;
  if (s.has_trajectories)
    header["trajectories"] = {{"recorded", s.trajectories_recorded},
                              {"sent", s.trajectory_group.size()}};
  std::string text = header.dump(-1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  text.resize((12 + text.size() + 7) / 8 * 8 - 12, ' ');
  const auto h = static_cast<std::uint32_t>(text.size());
  std::string out = "FSSCENE1";
  out.append(reinterpret_cast<const char*>(&h), 4);
  out += text;
  out += data;
  return out;
}

}  // namespace fragsim::formats
