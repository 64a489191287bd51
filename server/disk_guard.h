#pragma once
// The free-space guard (docs/operations.md, "Disk space"): while the file system of the data
// directory has less than min_free_bytes available, new jobs and sites are refused (507
// storage_full) and queued jobs wait instead of starting; nothing is dropped. The figure is
// statvfs's f_bavail (what an unprivileged writer may still use), read at each check: a
// syscall, no cache, so freeing space takes effect at once.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

namespace fragsim::server {

struct DiskSpace {
  std::int64_t free_bytes = 0;   // available to an unprivileged writer
  std::int64_t total_bytes = 0;  // the file system's size
};

// The space of the file system holding `path`; nullopt when statvfs fails.
std::optional<DiskSpace> disk_space(const std::filesystem::path& path);

class DiskGuard {
 public:
  // min_free_bytes 0: the guard is off.
  DiskGuard(std::filesystem::path dir, std::int64_t min_free_bytes)
      : dir_(std::move(dir)), min_free_bytes_(min_free_bytes) {}

  // The space found when it is short; nullopt when there is room, the guard is off, or the
  // file system cannot be asked (then writes report a full disk themselves).
  std::optional<DiskSpace> short_of_space() const;
  // What a refusal says: the free and required bytes, and what to do.
  std::string refusal(const DiskSpace& found) const;

  std::int64_t min_free_bytes() const { return min_free_bytes_; }
  const std::filesystem::path& dir() const { return dir_; }

 private:
  std::filesystem::path dir_;
  std::int64_t min_free_bytes_;
};

// Whether a queued job may start: not while the guard finds the data directory short of space
// (queued jobs wait). Logged once when the wait starts and once when it ends. Called by one
// thread only (the scheduler's worker, or the backend runner's monitor).
class StartGate {
 public:
  explicit StartGate(const DiskGuard* disk) : disk_(disk) {}  // null: always room
  bool room();

 private:
  const DiskGuard* disk_;
  bool short_ = false;  // at the last call
};

}  // namespace fragsim::server
