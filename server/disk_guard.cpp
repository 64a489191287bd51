#include "server/disk_guard.h"

#include <sys/statvfs.h>

#include <string>

#include "server/log.h"

namespace fragsim::server {

std::optional<DiskSpace> disk_space(const std::filesystem::path& path) {
  struct statvfs s {};
  if (::statvfs(path.c_str(), &s) != 0) return std::nullopt;
  DiskSpace d;
  d.free_bytes = static_cast<std::int64_t>(s.f_bavail) * static_cast<std::int64_t>(s.f_frsize);
  d.total_bytes = static_cast<std::int64_t>(s.f_blocks) * static_cast<std::int64_t>(s.f_frsize);
  return d;
}

std::optional<DiskSpace> DiskGuard::short_of_space() const {
  if (min_free_bytes_ <= 0) return std::nullopt;
  const auto d = disk_space(dir_);
  if (!d || d->free_bytes >= min_free_bytes_) return std::nullopt;
  return d;
}

std::string DiskGuard::refusal(const DiskSpace& found) const {
  return "the data directory's file system has " + std::to_string(found.free_bytes) +
         " bytes free, less than the " + std::to_string(min_free_bytes_) +
         " this daemon keeps free (--min-free-bytes); free space (purge finished jobs: DELETE "
         "/v1/jobs/{id}?purge=true, or --retain-bytes) and try again";
}

bool StartGate::room() {
  const auto found = disk_ != nullptr ? disk_->short_of_space() : std::nullopt;
  if (found.has_value() != short_) {
    short_ = found.has_value();
    if (found)
      log(LogLevel::kWarn, "queued jobs wait for disk space",
          {{"free_bytes", std::to_string(found->free_bytes)},
           {"min_free_bytes", std::to_string(disk_->min_free_bytes())}});
    else
      log(LogLevel::kInfo, "disk space back; queued jobs start");
  }
  return !found;
}

}  // namespace fragsim::server
