#pragma once
// An output directory whose files appear all at once or not at all.
//
// Each file is written under a temporary name in the target directory
// (".<name>.tmp.<random 64 bits>.<n>"), fsynced, and only renamed to its final name by commit(),
// which then fsyncs the directory. If commit() is never reached (an exception, a cancelled run),
// the destructor removes the temporaries, and the directories this object created if they are
// left empty: a failed run leaves no final-named file behind and no new directory. A process
// killed while staging leaves its temporaries: their names never collide with a later run's
// (they do not depend on the process id, which a restarted container gives again: PID 1), and
// remove_stale_temporaries() clears them where no other writer can be at work.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace fragsim::formats {

// A write the file system refused for want of space (ENOSPC, or EDQUOT: a quota), with the path
// written and, when known, the bytes the write needed (-1: unknown). fragsimd reports it as
// storage_full (docs/operations.md).
class StorageFullError : public std::runtime_error {
 public:
  StorageFullError(const std::filesystem::path& path, int err, std::int64_t bytes_needed);
  const std::filesystem::path& path() const { return path_; }
  int error() const { return error_; }
  std::int64_t bytes_needed() const { return bytes_needed_; }

 private:
  std::filesystem::path path_;
  int error_;
  std::int64_t bytes_needed_;
};

// True for the errno values that mean "no space": ENOSPC and EDQUOT.
bool is_no_space(int err);

// Creates `path` (which must not exist) holding `bytes`: the space is reserved first
// (posix_fallocate, where the file system has it), so a full disk is found before anything is
// written. Throws StorageFullError for want of space, std::runtime_error naming the path
// otherwise; on a throw the file may be left behind for the caller to remove.
void write_new_file(const std::filesystem::path& path, std::string_view bytes);

class OutputDir {
 public:
  // Uses `dir`, creating it (and missing parents) if needed. Throws std::runtime_error if it
  // cannot, or if `dir` exists and is not a directory.
  explicit OutputDir(std::filesystem::path dir);
  ~OutputDir();
  OutputDir(const OutputDir&) = delete;
  OutputDir& operator=(const OutputDir&) = delete;

  const std::filesystem::path& path() const { return dir_; }
  // True when this object created the directory.
  bool created() const { return !created_dirs_.empty(); }

  // Writes `name` (a plain file name) by calling `write(temporary_path)`, which must create the
  // file; then fsyncs it. If `write` throws, the temporary is removed and the exception passes.
  void stage(const std::string& name,
             const std::function<void(const std::filesystem::path&)>& write);
  void stage_text(const std::string& name, std::string_view contents);

  // Renames every staged file to its final name and fsyncs the directory.
  void commit();
  // Removes the temporaries (and the directories this object created, if empty). Idempotent;
  // the destructor calls it unless commit() succeeded.
  void discard() noexcept;

 private:
  struct Staged {
    std::string name;
    std::filesystem::path temporary;
  };
  std::filesystem::path dir_;
  std::vector<std::filesystem::path> created_dirs_;  // outermost first
  std::vector<Staged> staged_;
  bool committed_ = false;
  unsigned counter_ = 0;
  std::string unique_;  // random, per object: temporaries of different runs never collide
};

// Whether `name` is an OutputDir temporary (".<name>.tmp.<...>"): a write in progress, or one a
// killed process left.
bool is_temporary_name(const std::string& name);

// Removes the temporaries an OutputDir left in `dir` (files named ".<name>.tmp.<...>") when its
// process was killed while staging. Only for a directory no other process writes to (fragsimd
// holds its data directory's lock). Returns how many it removed; errors are ignored.
std::size_t remove_stale_temporaries(const std::filesystem::path& dir) noexcept;

// fsync of a file or directory by path; throws std::runtime_error naming it.
void fsync_path(const std::filesystem::path& path);

}  // namespace fragsim::formats
