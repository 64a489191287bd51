#include "api/ptn_json.h"

#include <nlohmann/json.hpp>
#include <stdexcept>

#include "api/results_h5.h"

namespace fragsim::api {

namespace {

using OJson = nlohmann::ordered_json;

struct PtnField {
  std::vector<double> density;
  std::vector<double> std_error;
  double threshold = 0.0;
};

PtnField read_field(const std::filesystem::path& h5) {
  PtnField f;
  f.density = read_dataset_double(h5, "/ptn/density_per_m2");
  f.std_error = read_dataset_double(h5, "/ptn/std_error_per_m2");
  const auto threshold = read_dataset_double(h5, "/hfd/threshold_per_m2");
  if (f.density.size() != f.std_error.size() || threshold.size() != 1)
    throw std::runtime_error(h5.string() + ": inconsistent /ptn datasets");
  f.threshold = threshold[0];
  return f;
}

}  // namespace

std::string render_ptn_json(const std::filesystem::path& results_h5, const std::string& job_id) {
  const PtnField f = read_field(results_h5);
  OJson j;
  j["job_id"] = job_id;
  j["triangles"] = f.density.size();
  j["threshold_per_m2"] = f.threshold;
  j["density_per_m2"] = f.density;
  j["std_error_per_m2"] = f.std_error;
  return j.dump();
}

std::string render_ptn_geojson(const std::filesystem::path& results_h5, const std::string& job_id,
                               std::optional<double> min_density_per_m2) {
  const PtnField f = read_field(results_h5);
  const std::vector<double> vertices = read_dataset_double(results_h5, "/terrain/vertices_m");
  const std::vector<std::int64_t> triangles = read_dataset_int64(results_h5, "/terrain/triangles");
  if (triangles.size() != 3 * f.density.size() || vertices.size() % 3 != 0)
    throw std::runtime_error(results_h5.string() + ": terrain does not match the PTN field");
  const auto vertex_count = static_cast<std::int64_t>(vertices.size() / 3);

  OJson j;
  j["type"] = "FeatureCollection";
  j["fragsim_job_id"] = job_id;
  j["fragsim_threshold_per_m2"] = f.threshold;
  const nlohmann::json scenario =
      nlohmann::json::parse(read_attribute_string(results_h5, "/", "scenario_json"));
  if (const auto site = scenario.find("site"); site != scenario.end()) {
    if (const auto origin = site->find("origin"); origin != site->end())
      j["fragsim_origin"] = *origin;
  }
  auto features = OJson::array();
  for (std::size_t t = 0; t < f.density.size(); ++t) {
    if (min_density_per_m2 && !(f.density[t] >= *min_density_per_m2)) continue;
    auto ring = OJson::array();
    for (int c = 0; c <= 3; ++c) {
      const std::int64_t v = triangles[3 * t + static_cast<std::size_t>(c % 3)];
      if (v < 0 || v >= vertex_count)
        throw std::runtime_error(results_h5.string() + ": triangle index out of range");
      const auto k = static_cast<std::size_t>(3 * v);
      ring.push_back({vertices[k], vertices[k + 1], vertices[k + 2]});
    }
    OJson feature;
    feature["type"] = "Feature";
    feature["geometry"] = {{"type", "Polygon"}, {"coordinates", OJson::array({std::move(ring)})}};
    feature["properties"] = {{"triangle", t},
                             {"density_per_m2", f.density[t]},
                             {"std_error_per_m2", f.std_error[t]}};
    features.push_back(std::move(feature));
  }
  j["features"] = std::move(features);
  return j.dump();
}

}  // namespace fragsim::api
