#pragma once
// The PTN density field of a finished run as JSON (fragsimd GET /v1/jobs/{id}/ptn), read back from
// its results.h5:
//   {"job_id", "triangles", "threshold_per_m2", "density_per_m2": [...], "std_error_per_m2": [...]}
// or as a GeoJSON FeatureCollection with one Polygon per terrain triangle (vertices [x, y, z] in
// the site's input coordinates) and properties {triangle, density_per_m2, std_error_per_m2}; the
// site's origin (CRS and offsets), when it has one, is the foreign member "fragsim_origin".
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace fragsim::api {

// Throws std::runtime_error when the file lacks a dataset.
std::string render_ptn_json(const std::filesystem::path& results_h5, const std::string& job_id);

// The GeoJSON written piece by piece, so that a daemon can stream it: the whole text of the demo
// job is 20.7 MB, and building it as a JSON tree cost ~150 MB per request. The constructor reads
// and checks the datasets (throws std::runtime_error), so that nothing is sent for a bad file.
// Triangles with density < min_density_per_m2 are left out when it is given.
class PtnGeoJsonWriter {
 public:
  PtnGeoJsonWriter(const std::filesystem::path& results_h5, const std::string& job_id,
                   std::optional<double> min_density_per_m2);
  // Appends about `piece_bytes` (at least one feature) to `out`; false once all is written.
  bool next(std::string& out, std::size_t piece_bytes = 64 << 10);

 private:
  void append_feature(std::string& out, std::size_t t) const;

  std::string head_;
  std::vector<double> density_, std_error_, vertices_;
  std::vector<std::int64_t> triangles_;
  std::optional<double> min_density_;
  std::size_t next_ = 0;  // triangle
  bool started_ = false, first_feature_ = true, done_ = false;
};

std::string render_ptn_geojson(const std::filesystem::path& results_h5, const std::string& job_id,
                               std::optional<double> min_density_per_m2);

}  // namespace fragsim::api
