#pragma once
// The GIS maps of a finished job (GET /v1/jobs/{id}/maps[/{name}]; docs/http-api.md): the files
// `fragsim export` writes (gis::export_results, the same code), made on the first request and kept
// in jobs/<id>/maps/ beside results.h5.
//
// The set appears all at once: the export stages every file and renames them together, then
// index.json (the listing served) is written last; a directory without index.json is not
// served and is made again. One export runs at a time (a mutex): a second request for the same
// job waits and finds the maps made. A daemon killed while exporting leaves temporaries that
// the next export (and the next start) removes.
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace fragsim::server {

struct MapFile {
  std::string name;          // e.g. "ptn_density.tif"
  std::string content_type;  // e.g. "image/tiff"
  std::uintmax_t bytes = 0;
};

struct MapSet {
  std::string crs;  // "EPSG:32611", or "" when the site has none
  double pixel_m = 0.0;
  int raster_cols = 0, raster_rows = 0;
  std::size_t hazardous_triangles = 0;
  std::vector<MapFile> files;
  std::vector<std::string> notes;  // what was not written and why
};

// The media type of a map file by its extension (application/octet-stream if unknown).
std::string map_content_type(const std::string& name);

class JobMaps {
 public:
  static constexpr const char* kDirName = "maps";
  static constexpr const char* kIndexName = "index.json";

  // The maps of the job whose directory is `job_dir` (holding results.h5), made if missing.
  // Throws std::runtime_error if the export fails (nothing is then left under a final name).
  MapSet ensure(const std::filesystem::path& job_dir);

  // Removes an interrupted export's temporaries in `job_dir`/maps; for use at start-up, when no
  // export can be running. Returns how many files it removed.
  static std::size_t remove_stale(const std::filesystem::path& job_dir) noexcept;

 private:
  static std::optional<MapSet> read_index(const std::filesystem::path& dir);
  static MapSet make(const std::filesystem::path& job_dir);

  std::mutex mutex_;  // one export at a time
};

}  // namespace fragsim::server
