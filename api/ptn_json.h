#pragma once
// The PTN density field of a finished run as JSON (fragsimd GET /v1/jobs/{id}/ptn), read back from
// its results.h5:
//   {"job_id", "triangles", "threshold_per_m2", "density_per_m2": [...], "std_error_per_m2": [...]}
// or as a GeoJSON FeatureCollection with one Polygon per terrain triangle and properties
// {triangle, density_per_m2, std_error_per_m2}. With a Wgs84Factory that knows the site's CRS, it
// is RFC 7946: vertices [longitude, latitude, z] (WGS 84; z the site's elevation, m); otherwise
// the vertices are [x, y, z] in the site's input coordinates, m, and the document says so. The
// foreign members "fragsim_coordinates" (which of the two) and "fragsim_origin" (the site's
// origin: CRS and offsets) are always there.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace fragsim::api {

// Throws std::runtime_error when the file lacks a dataset.
std::string render_ptn_json(const std::filesystem::path& results_h5, const std::string& job_id);

// Converts site coordinates (the CRS's own: input + origin offset) to WGS 84 longitude and
// latitude, in place; false when it cannot. Made by gis/ (api links no PROJ).
using ToWgs84 = std::function<bool(std::vector<double>& x, std::vector<double>& y)>;
// The converter for a site's CRS string, or an empty function when the CRS is not one PROJ
// knows (a label such as "local").
using Wgs84Factory = std::function<ToWgs84(const std::string& crs)>;

// The GeoJSON written piece by piece, so that a daemon can stream it: the whole text of the demo
// job is 20.7 MB, and building it as a JSON tree cost ~150 MB per request. The constructor reads
// and checks the datasets (throws std::runtime_error), so that nothing is sent for a bad file.
// Triangles with density < min_density_per_m2 are left out when it is given. Each feature's
// properties: triangle, density_per_m2, std_error_per_m2 and, from a results.h5 of format 4 or
// later, material (the triangle's material name).
class PtnGeoJsonWriter {
 public:
  PtnGeoJsonWriter(const std::filesystem::path& results_h5, const std::string& job_id,
                   std::optional<double> min_density_per_m2, const Wgs84Factory& wgs84 = {});
  // Appends about `piece_bytes` (at least one feature) to `out`; false once all is written.
  bool next(std::string& out, std::size_t piece_bytes = 64 << 10);

 private:
  void append_feature(std::string& out, std::size_t t) const;
  void read_materials(const std::filesystem::path& h5);
  // Vertices to WGS 84 when the factory knows the CRS; returns the "fragsim_coordinates" text.
  std::string convert_vertices(const nlohmann::json& origin, const Wgs84Factory& wgs84);

  std::string head_;
  std::vector<double> density_, std_error_, vertices_;
  std::vector<std::int64_t> triangles_;
  // Per triangle, its material's name as JSON text (results.h5 format >= 4: /terrain/material);
  // empty for older files, whose features have no "material".
  std::vector<std::string> material_names_json_;
  std::vector<std::int64_t> material_;
  std::optional<double> min_density_;
  std::size_t next_ = 0;  // triangle
  bool started_ = false, first_feature_ = true, done_ = false;
};

std::string render_ptn_geojson(const std::filesystem::path& results_h5, const std::string& job_id,
                               std::optional<double> min_density_per_m2,
                               const Wgs84Factory& wgs84 = {});

}  // namespace fragsim::api
