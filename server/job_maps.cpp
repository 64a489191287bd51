#include "server/job_maps.h"

#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "api/compare_json.h"
#include "api/run_outputs.h"
#include "formats/output_dir.h"
#include "gis/results_export.h"

namespace fragsim::server {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

std::string map_content_type(const std::string& name) {
  static const std::map<std::string, std::string> kTypes = {
      {".tif", "image/tiff"},
      {".gpkg", "application/geopackage+sqlite3"},
      {".geojson", "application/geo+json"},
      {".kml", "application/vnd.google-earth.kml+xml"},
      {".vtkhdf", "application/x-hdf5"},
      {".json", "application/json"},
  };
  const auto it = kTypes.find(fs::path(name).extension().string());
  return it == kTypes.end() ? "application/octet-stream" : it->second;
}

namespace {

Json to_json(const MapSet& m) {
  Json files = Json::array();
  for (const auto& f : m.files)
    files.push_back({{"name", f.name}, {"content_type", f.content_type}, {"bytes", f.bytes}});
  return {{"crs", m.crs.empty() ? Json(nullptr) : Json(m.crs)},
          {"pixel_m", m.pixel_m},
          {"raster_cols", m.raster_cols},
          {"raster_rows", m.raster_rows},
          {"hazardous_triangles", m.hazardous_triangles},
          {"files", std::move(files)},
          {"notes", m.notes}};
}

MapSet from_json(const Json& j) {
  MapSet m;
  if (!j.at("crs").is_null()) m.crs = j.at("crs").get<std::string>();
  m.pixel_m = j.at("pixel_m").get<double>();
  m.raster_cols = j.at("raster_cols").get<int>();
  m.raster_rows = j.at("raster_rows").get<int>();
  m.hazardous_triangles = j.at("hazardous_triangles").get<std::size_t>();
  for (const auto& f : j.at("files"))
    m.files.push_back({f.at("name").get<std::string>(), f.at("content_type").get<std::string>(),
                       f.at("bytes").get<std::uintmax_t>()});
  m.notes = j.at("notes").get<std::vector<std::string>>();
  return m;
}

}  // namespace

std::optional<MapSet> JobMaps::read_index(const fs::path& dir) {
  std::ifstream in(dir / kIndexName);
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  try {
    MapSet m = from_json(Json::parse(text.str()));
    for (const auto& f : m.files) {
      std::error_code ec;
      if (!fs::is_regular_file(dir / f.name, ec)) return std::nullopt;  // made again
    }
    return m;
  } catch (const std::exception&) {
    return std::nullopt;  // unreadable: made again
  }
}

MapSet JobMaps::make(const fs::path& job_dir) {
  const fs::path dir = job_dir / kDirName;
  std::error_code ec;
  if (fs::is_directory(dir, ec)) {
    formats::remove_stale_temporaries(dir);
    fs::remove(dir / kIndexName, ec);  // the old listing must not outlive a new file set
  }
  gis::ExportOptions options;
  options.results_h5 = job_dir / api::kResultsFileName;
  options.out_dir = dir;
  // A job with compare_with: its maps include the density difference (docs/comparison.md).
  if (std::error_code no; fs::exists(job_dir / api::kCompareH5FileName, no))
    options.compare_h5 = job_dir / api::kCompareH5FileName;
  const gis::ExportReport report = gis::export_results(options);
  MapSet m;
  m.crs = report.crs;
  m.pixel_m = report.pixel_m;
  m.raster_cols = report.raster_cols;
  m.raster_rows = report.raster_rows;
  m.hazardous_triangles = report.hazardous_triangles;
  m.notes = report.notes;
  for (const auto& name : report.files)
    m.files.push_back({name, map_content_type(name), fs::file_size(dir / name)});
  formats::OutputDir out(dir);
  out.stage_text(kIndexName, to_json(m).dump(2) + "\n");
  out.commit();
  return m;
}

MapSet JobMaps::ensure(const fs::path& job_dir) {
  if (auto m = read_index(job_dir / kDirName)) return *m;
  std::lock_guard<std::mutex> lock(mutex_);
  if (auto m = read_index(job_dir / kDirName)) return *m;  // made while this request waited
  return make(job_dir);
}

std::size_t JobMaps::remove_stale(const fs::path& job_dir) noexcept {
  return formats::remove_stale_temporaries(job_dir / kDirName);
}

}  // namespace fragsim::server
