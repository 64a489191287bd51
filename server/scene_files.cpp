#include "server/scene_files.h"

#include "formats/output_dir.h"

namespace fragsim::server {

std::filesystem::path SceneFiles::ensure(const std::filesystem::path& dir, const std::string& name,
                                         const std::function<formats::SceneArrays()>& build) {
  const std::filesystem::path file = dir / name;
  const std::lock_guard<std::mutex> lock(mutex_);
  std::error_code ec;
  if (std::filesystem::is_regular_file(file, ec)) return file;
  formats::OutputDir out(dir);
  out.stage_text(name, formats::encode_scene(build()));
  out.commit();
  return file;
}

std::string SceneFiles::encode_now(const std::function<formats::SceneArrays()>& build) {
  const std::lock_guard<std::mutex> lock(mutex_);
  return formats::encode_scene(build());
}

}  // namespace fragsim::server
