#include "api/ptn_json.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "formats/results_h5.h"

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
  f.density = formats::read_dataset_double(h5, "/ptn/density_per_m2");
  f.std_error = formats::read_dataset_double(h5, "/ptn/std_error_per_m2");
  const auto threshold = formats::read_dataset_double(h5, "/hfd/threshold_per_m2");
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

namespace {

// Shortest text that reads back as the same double (as nlohmann::json writes them); null for
// what JSON cannot hold.
void append_number(std::string& out, double v) {
  if (!std::isfinite(v)) {
    out += "null";
    return;
  }
  char buf[32];
  const auto [end, ec] = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, ec == std::errc() ? static_cast<std::size_t>(end - buf) : 0);
}

}  // namespace

PtnGeoJsonWriter::PtnGeoJsonWriter(const std::filesystem::path& results_h5,
                                   const std::string& job_id,
                                   std::optional<double> min_density_per_m2,
                                   const Wgs84Factory& wgs84)
    : min_density_(min_density_per_m2) {
  PtnField f = read_field(results_h5);
  density_ = std::move(f.density);
  std_error_ = std::move(f.std_error);
  vertices_ = formats::read_dataset_double(results_h5, "/terrain/vertices_m");
  triangles_ = formats::read_dataset_int64(results_h5, "/terrain/triangles");
  if (triangles_.size() != 3 * density_.size() || vertices_.size() % 3 != 0)
    throw std::runtime_error(results_h5.string() + ": terrain does not match the PTN field");
  const auto vertex_count = static_cast<std::int64_t>(vertices_.size() / 3);
  for (const std::int64_t v : triangles_)
    if (v < 0 || v >= vertex_count)
      throw std::runtime_error(results_h5.string() + ": triangle index out of range");
  read_materials(results_h5);

  OJson head;
  head["type"] = "FeatureCollection";
  head["fragsim_job_id"] = job_id;
  head["fragsim_threshold_per_m2"] = f.threshold;
  const nlohmann::json scenario =
      nlohmann::json::parse(formats::read_attribute_string(results_h5, "/", "scenario_json"));
  nlohmann::json origin;
  if (const auto site = scenario.find("site"); site != scenario.end()) {
    if (const auto o = site->find("origin"); o != site->end()) origin = *o;
  }
  head["fragsim_coordinates"] = convert_vertices(origin, wgs84);
  if (!origin.is_null()) head["fragsim_origin"] = origin;
  head_ = head.dump();
  head_.pop_back();  // the closing brace: the features follow
  head_ += ",\"features\":[";
}

void PtnGeoJsonWriter::read_materials(const std::filesystem::path& h5) {
  const auto names = formats::list_datasets(h5);
  if (!std::binary_search(names.begin(), names.end(), std::string("/terrain/material"))) return;
  material_ = formats::read_dataset_int64(h5, "/terrain/material");
  for (const std::string& name : formats::read_dataset_strings(h5, "/terrain/material_names"))
    material_names_json_.push_back(nlohmann::json(name).dump());
  if (material_.size() != density_.size())
    throw std::runtime_error(h5.string() + ": /terrain/material does not match the PTN field");
  for (const std::int64_t k : material_)
    if (k < 0 || static_cast<std::size_t>(k) >= material_names_json_.size())
      throw std::runtime_error(h5.string() + ": /terrain/material index out of range");
}

std::string PtnGeoJsonWriter::convert_vertices(const nlohmann::json& origin,
                                               const Wgs84Factory& wgs84) {
  const std::string crs = origin.is_object() ? origin.value("crs", "") : "";
  const ToWgs84 to_wgs84 = wgs84 && !crs.empty() ? wgs84(crs) : ToWgs84();
  if (!to_wgs84)
    return "site input coordinates [x, y, z] in metres: the site has " +
           (crs.empty() ? std::string("no CRS") : "no CRS PROJ knows (\"" + crs + "\")") +
           ", so this is not RFC 7946 GeoJSON";
  const std::size_t n = vertices_.size() / 3;
  std::vector<double> x(n), y(n);
  for (std::size_t k = 0; k < n; ++k) {
    x[k] = vertices_[3 * k] + origin.value("easting_m", 0.0);
    y[k] = vertices_[3 * k + 1] + origin.value("northing_m", 0.0);
  }
  if (!to_wgs84(x, y)) throw std::runtime_error("the terrain cannot be transformed to WGS 84");
  for (std::size_t k = 0; k < n; ++k) {
    vertices_[3 * k] = x[k];
    vertices_[3 * k + 1] = y[k];
  }
  return "RFC 7946: WGS 84 [longitude, latitude, z], z the site's elevation in metres (from " +
         crs + ")";
}

void PtnGeoJsonWriter::append_feature(std::string& out, std::size_t t) const {
  out += first_feature_ ? "" : ",";
  out += R"({"type":"Feature","geometry":{"type":"Polygon","coordinates":[[)";
  for (int c = 0; c <= 3; ++c) {
    const auto k =
        static_cast<std::size_t>(3 * triangles_[3 * t + static_cast<std::size_t>(c % 3)]);
    out += c == 0 ? "[" : ",[";
    append_number(out, vertices_[k]);
    out += ',';
    append_number(out, vertices_[k + 1]);
    out += ',';
    append_number(out, vertices_[k + 2]);
    out += ']';
  }
  out += R"(]]},"properties":{"triangle":)";
  out += std::to_string(t);
  out += R"(,"density_per_m2":)";
  append_number(out, density_[t]);
  out += R"(,"std_error_per_m2":)";
  append_number(out, std_error_[t]);
  if (!material_.empty()) {
    out += R"(,"material":)";
    out += material_names_json_[static_cast<std::size_t>(material_[t])];
  }
  out += "}}";
}

bool PtnGeoJsonWriter::next(std::string& out, std::size_t piece_bytes) {
  if (done_) return false;
  const std::size_t limit = out.size() + piece_bytes;
  if (!started_) {
    out += head_;
    started_ = true;
  }
  for (; next_ < density_.size() && out.size() < limit; ++next_) {
    if (min_density_ && !(density_[next_] >= *min_density_)) continue;
    append_feature(out, next_);
    first_feature_ = false;
  }
  if (next_ < density_.size()) return true;
  out += "]}";
  done_ = true;
  return false;
}

std::string render_ptn_geojson(const std::filesystem::path& results_h5, const std::string& job_id,
                               std::optional<double> min_density_per_m2,
                               const Wgs84Factory& wgs84) {
  PtnGeoJsonWriter writer(results_h5, job_id, min_density_per_m2, wgs84);
  std::string out;
  while (writer.next(out)) {
  }
  return out;
}

}  // namespace fragsim::api
