#pragma once
// The PTN density field of a finished run as JSON (fragsimd GET /v1/jobs/{id}/ptn), read back from
// its results.h5:
//   {"job_id", "triangles", "threshold_per_m2", "density_per_m2": [...], "std_error_per_m2": [...]}
// or as a GeoJSON FeatureCollection with one Polygon per terrain triangle (vertices [x, y, z] in
// the site's input coordinates) and properties {triangle, density_per_m2, std_error_per_m2}; the
// site's origin (CRS and offsets), when it has one, is the foreign member "fragsim_origin".
#include <filesystem>
#include <optional>
#include <string>

namespace fragsim::api {

// Throws std::runtime_error when the file lacks a dataset.
std::string render_ptn_json(const std::filesystem::path& results_h5, const std::string& job_id);
// Triangles with density < min_density_per_m2 are left out when it is given.
std::string render_ptn_geojson(const std::filesystem::path& results_h5, const std::string& job_id,
                               std::optional<double> min_density_per_m2);

}  // namespace fragsim::api
