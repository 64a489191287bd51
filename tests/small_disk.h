#pragma once
// A small file system for full-disk tests: a tmpfs of a given size mounted on a directory, in a
// mount namespace of this test process's own (unshare(CLONE_NEWNS), mounts made private), so the
// host never sees it and it goes with the process. Needs root (CAP_SYS_ADMIN); where it cannot be
// had, make() returns null and says why, and the test skips. Call it before the test starts a
// thread: threads made afterwards (and child processes, e.g. fragsimd) see the mount.
#include <sched.h>
#include <sys/mount.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

namespace fragsim::testing {

class SmallDisk {
 public:
  static std::unique_ptr<SmallDisk> make(const std::filesystem::path& dir, std::int64_t bytes,
                                         std::string* why) {
    std::filesystem::create_directories(dir);
    if (::unshare(CLONE_NEWNS) != 0) return fail(why, "unshare(CLONE_NEWNS)");
    if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0)
      return fail(why, "making mounts private");
    const std::string options = "size=" + std::to_string(bytes) + ",mode=0755";
    if (::mount("fragsim-test", dir.c_str(), "tmpfs", MS_NOSUID | MS_NODEV, options.c_str()) != 0)
      return fail(why, "mount -t tmpfs");
    return std::unique_ptr<SmallDisk>(new SmallDisk(dir));
  }
  ~SmallDisk() { ::umount2(dir_.c_str(), MNT_DETACH); }
  SmallDisk(const SmallDisk&) = delete;
  SmallDisk& operator=(const SmallDisk&) = delete;

  // Fills the disk with a file until `leave` bytes are free (about: tmpfs counts whole pages).
  void fill_leaving(std::int64_t leave) {
    const auto free_now = static_cast<std::int64_t>(std::filesystem::space(dir_).available);
    std::int64_t n = free_now - leave;
    if (n <= 0) return;
    std::ofstream out(filler(), std::ios::binary | std::ios::app);
    const std::vector<char> block(1 << 16, 'x');
    while (n > 0 && out) {
      const auto k = std::min<std::int64_t>(n, static_cast<std::int64_t>(block.size()));
      out.write(block.data(), k);
      n -= k;
    }
  }
  void free_filler() { std::filesystem::remove(filler()); }
  std::int64_t available() const {
    return static_cast<std::int64_t>(std::filesystem::space(dir_).available);
  }

 private:
  explicit SmallDisk(std::filesystem::path dir) : dir_(std::move(dir)) {}
  std::filesystem::path filler() const { return dir_ / "filler"; }
  static std::unique_ptr<SmallDisk> fail(std::string* why, const char* what) {
    if (why != nullptr) *why = std::string(what) + ": " + std::strerror(errno);
    return nullptr;
  }
  std::filesystem::path dir_;
};

}  // namespace fragsim::testing
