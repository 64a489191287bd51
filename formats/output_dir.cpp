#include "formats/output_dir.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <random>
#include <stdexcept>
#include <system_error>

namespace fragsim::formats {

namespace {

[[noreturn]] void fail_errno(const std::string& what, const std::filesystem::path& path, int err,
                             std::int64_t bytes_needed = -1) {
  if (is_no_space(err)) throw StorageFullError(path, err, bytes_needed);
  throw std::runtime_error(what + " " + path.string() + ": " + std::strerror(err));
}

std::string storage_full_message(const std::filesystem::path& path, int err, std::int64_t bytes) {
  std::string m = std::strerror(err);
  m += " writing " + path.string();
  if (bytes >= 0) m += " (" + std::to_string(bytes) + " bytes needed)";
  return m;
}

// 64 random bits in hex (the kernel's generator through std::random_device).
std::string random_tag() {
  std::random_device rd;
  const unsigned long long v = (static_cast<unsigned long long>(rd()) << 32) ^ rd();
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", v);
  return buf;
}

}  // namespace

StorageFullError::StorageFullError(const std::filesystem::path& path, int err,
                                   std::int64_t bytes_needed)
    : std::runtime_error(storage_full_message(path, err, bytes_needed)),
      path_(path),
      error_(err),
      bytes_needed_(bytes_needed) {}

bool is_no_space(int err) {
  return err == ENOSPC || err == EDQUOT;
}

bool is_temporary_name(const std::string& name) {
  return name.size() > 1 && name[0] == '.' && name.find(".tmp.", 1) != std::string::npos;
}

void write_new_file(const std::filesystem::path& path, std::string_view bytes) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) fail_errno("cannot create", path, errno, static_cast<std::int64_t>(bytes.size()));
  // On a failure the file made here goes, so that the space it took is free again.
  const auto fail = [&](const char* what, int err, std::int64_t needed) {
    ::close(fd);
    ::unlink(path.c_str());
    fail_errno(what, path, err, needed);
  };
  if (!bytes.empty()) {
    // EINVAL/EOPNOTSUPP: a file system without it; the writes below then find a full disk.
    const int rc = ::posix_fallocate(fd, 0, static_cast<off_t>(bytes.size()));
    if (is_no_space(rc))
      fail("cannot reserve space for", rc, static_cast<std::int64_t>(bytes.size()));
  }
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("cannot write", errno, static_cast<std::int64_t>(bytes.size() - done));
    }
    done += static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(path.c_str());
    fail_errno("cannot close", path, err);
  }
}

void fsync_path(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) fail_errno("cannot open", path, errno);
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) fail_errno("cannot fsync", path, err);
}

std::size_t remove_stale_temporaries(const std::filesystem::path& dir) noexcept {
  std::size_t removed = 0;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec) || !is_temporary_name(it->path().filename().string())) continue;
    std::error_code rm;
    if (std::filesystem::remove(it->path(), rm)) ++removed;
  }
  return removed;
}

OutputDir::OutputDir(std::filesystem::path dir) : dir_(std::move(dir)), unique_(random_tag()) {
  std::error_code ec;
  if (std::filesystem::exists(dir_, ec)) {
    if (!std::filesystem::is_directory(dir_, ec))
      throw std::runtime_error(dir_.string() + ": exists and is not a directory");
    return;
  }
  // Create the missing chain outermost first, remembering each, so that discard() can take
  // back exactly what was made here.
  std::filesystem::path leaf = dir_.lexically_normal();
  if (leaf.has_parent_path() && leaf.filename().empty()) leaf = leaf.parent_path();  // "out/"
  std::vector<std::filesystem::path> missing;
  for (std::filesystem::path p = leaf; !p.empty() && !std::filesystem::exists(p, ec);
       p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  for (auto it = missing.rbegin(); it != missing.rend(); ++it) {
    if (!std::filesystem::create_directory(*it, ec) && ec) {
      discard();
      if (is_no_space(ec.value())) throw StorageFullError(*it, ec.value(), -1);
      throw std::runtime_error("cannot create directory " + it->string() + ": " + ec.message());
    }
    created_dirs_.push_back(*it);
  }
}

OutputDir::~OutputDir() {
  if (!committed_) discard();
}

void OutputDir::stage(const std::string& name,
                      const std::function<void(const std::filesystem::path&)>& write) {
  if (name.empty() || name.find('/') != std::string::npos)
    throw std::invalid_argument("OutputDir::stage: not a plain file name: \"" + name + "\"");
  const std::filesystem::path temporary =
      dir_ / ("." + name + ".tmp." + unique_ + "." + std::to_string(counter_++));
  std::error_code ec;
  try {
    write(temporary);
    fsync_path(temporary);
  } catch (const StorageFullError& e) {
    std::filesystem::remove(temporary, ec);
    throw StorageFullError(dir_ / name, e.error(), e.bytes_needed());  // the name a reader knows
  } catch (...) {
    std::filesystem::remove(temporary, ec);
    throw;
  }
  staged_.push_back({name, temporary});
}

void OutputDir::stage_text(const std::string& name, std::string_view contents) {
  stage(name, [&](const std::filesystem::path& path) { write_new_file(path, contents); });
}

void OutputDir::commit() {
  for (const Staged& s : staged_) {
    std::error_code ec;
    std::filesystem::rename(s.temporary, dir_ / s.name, ec);
    if (ec) fail_errno("cannot rename", s.temporary, ec.value());
  }
  committed_ = true;
  staged_.clear();
  fsync_path(dir_);  // make the renames durable
}

void OutputDir::discard() noexcept {
  std::error_code ec;
  for (const Staged& s : staged_) std::filesystem::remove(s.temporary, ec);
  staged_.clear();
  // Innermost first; remove() leaves a directory that is not empty (someone else's files).
  for (auto it = created_dirs_.rbegin(); it != created_dirs_.rend(); ++it)
    std::filesystem::remove(*it, ec);
  created_dirs_.clear();
}

}  // namespace fragsim::formats
