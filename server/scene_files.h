#pragma once
// The scenes the web viewer fetches (GET /v1/sites/{id}/scene, GET /v1/jobs/{id}/scene;
// formats/scene_binary.h), written once to disk and then served as files: a site's and a job's
// results never change, and a file is sent in 1 MiB pieces, so that many clients fetching the
// scene of a large site (about 25 bytes per terrain triangle: 400 MB at 2^24) hold neither a
// copy per request nor a rebuild each.
//
//   sites/<site_id>.scene.v2.bin   removed with the site (SiteRegistry::remove)
//   jobs/<job_id>/scene.v2.bin     the default trajectory sample
//   (formats::kDefaultSceneTrajectories)
//
// The names carry the version of what a scene holds (v2: the terrain's materials, issue 24), so
// a daemon never serves a scene an older daemon cached without them: it builds the new one
// beside it. Older versions' files (scene.bin) are removed with their site or job.
// Files appear whole (formats::OutputDir: a temporary renamed; a killed daemon's temporaries are
// removed at the next start). One scene is built at a time (a mutex): a second request for the
// same scene waits and finds the file. A job scene with another max_trajectories is built per
// request, also one at a time, and not stored (any number of variants would fill the disk).
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "formats/scene_binary.h"

namespace fragsim::server {

class SceneFiles {
 public:
  // The file `dir/name`, made by encoding `build()` when it is not there yet.
  std::filesystem::path ensure(const std::filesystem::path& dir, const std::string& name,
                               const std::function<formats::SceneArrays()>& build);
  // An encoded scene built now, not stored.
  std::string encode_now(const std::function<formats::SceneArrays()>& build);

  static constexpr const char* kJobSceneName = "scene.v2.bin";
  static std::string site_scene_name(const std::string& site_id) {
    return site_id + ".scene.v2.bin";
  }
  // Every name a site's scene has had (removed with the site).
  static std::vector<std::string> site_scene_names(const std::string& site_id) {
    return {site_id + ".scene.bin", site_scene_name(site_id)};
  }

 private:
  std::mutex mutex_;
};

}  // namespace fragsim::server
