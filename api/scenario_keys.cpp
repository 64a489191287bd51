#include "api/scenario_keys.h"

#include <stdexcept>

namespace fragsim::api {

const std::map<std::string, std::vector<std::string>, std::less<>>& scenario_object_keys() {
  static const std::map<std::string, std::vector<std::string>, std::less<>> kKeys = {
      {"scenario",
       {"schema", "description", "site", "site_id", "atmosphere", "gravity_mps2", "fragment_groups",
        "settings"}},
      // Site
      {"site", {"origin", "terrain", "materials", "buildings"}},
      {"site_origin", {"crs", "easting_m", "northing_m", "elevation_m"}},
      {"terrain", {"plane", "grid", "mesh", "material", "triangle_materials", "zones"}},
      {"terrain_triangle_materials", {"names", "index"}},
      {"terrain_zone", {"material", "polygon_m"}},
      {"terrain_plane", {"elevation_m", "extent_m", "cell_m"}},
      {"terrain_grid", {"origin_m", "spacing_m", "nx", "ny", "elevation_m"}},
      {"terrain_mesh", {"vertices_m", "triangles"}},
      {"material",
       {"friction", "rolling_resistance", "restitution", "penetration", "embedment", "fast_contact",
        "ranges", "illustrative", "source"}},
      {"material_ranges",
       {"friction", "rolling_resistance", "restitution", "switch_speed_mps",
        "critical_angle_coefficient_deg", "drag_to_lift_ratio", "roughness_deg",
        "exit_angle_ratio"}},
      {"fast_contact",
       {"bulk_density_kg_m3", "switch_speed_mps", "critical_angle_coefficient_deg",
        "drag_to_lift_ratio", "roughness_deg", "exit_angle_ratio"}},
      {"embedment", {"model", "bulk_density_kg_m3", "coefficient_deg", "min_speed_mps"}},
      {"restitution_table", {"normal_speed_mps", "e"}},
      {"penetration", {"ke_per_area_j_per_m2"}},
      {"building_footprint",
       {"id", "footprint_m", "holes_m", "height_m", "base_elevation_m", "wall", "roof", "window"}},
      {"building_mesh", {"id", "mesh", "wall", "roof", "window"}},
      {"building_mesh_geometry", {"vertices_m", "triangles", "surface"}},
      // Atmosphere
      {"atmosphere", {"model", "density_kg_m3", "sound_speed_mps", "wind_mps"}},
      // Fragment groups
      {"fragment_group",
       {"name", "count", "samples", "frame", "shape", "mass_kg", "speed_mps", "direction", "cd",
        "area_m2", "spin_radps", "attitude"}},
      {"frame", {"origin_m", "yaw_deg", "pitch_deg", "roll_deg", "velocity_mps"}},
      {"attitude", {"yaw_deg", "pitch_deg", "roll_deg"}},
      {"shape", {"type", "dims_m", "density_kg_m3", "aspect", "vertices_m"}},
      {"direction", {"elevation_deg", "azimuth_deg"}},
      {"cd_table", {"mach", "cd"}},
      {"dist_fixed", {"dist", "value"}},
      {"dist_uniform", {"dist", "min", "max"}},
      {"dist_normal", {"dist", "mean", "sigma", "min", "max"}},
      {"dist_lognormal", {"dist", "median", "sigma_ln", "min", "max"}},
      {"dist_table", {"dist", "values", "cdf"}},
      {"dist_mott", {"dist", "mu", "min", "max"}},
      // Settings
      {"settings",
       {"seed", "person_height_m", "hazardous_ke_j", "hfd_threshold_per_m2", "hfd_origin_m",
        "max_flight_time_s", "integrator", "bounce", "bounce_limits", "threads", "chunk_histories",
        "record_fragments", "record_trajectories", "max_recorded_trajectories", "profile",
        "precision", "stratified_launch", "ground_bracket"}},
      {"ground_bracket", {"samples_scale"}},
      {"stratified_launch", {"method", "histories_per_stratum", "speed", "replicates"}},
      {"precision",
       {"hfd_half_band_m", "hfd_half_band_rel", "building_rel_error", "building_abs_error",
        "buildings", "ptn_rel_error_at_hfd", "min_batches", "max_batches", "max_wall_s",
        "direction_importance"}},
      {"direction_importance",
       {"elevation_cells", "azimuth_cells", "speed_cells", "mass_cells", "defensive_fraction"}},
      {"integrator", {"rtol", "sagitta_m"}},
      {"bounce_limits", {"min_rebound_speed_mps", "max_bounces", "max_ground_steps"}},
  };
  return kKeys;
}

const std::vector<std::string>& object_keys(std::string_view kind) {
  const auto& table = scenario_object_keys();
  const auto it = table.find(kind);
  if (it == table.end())
    throw std::logic_error("no such scenario object kind: " + std::string(kind));
  return it->second;
}

}  // namespace fragsim::api
