#include "server/backup.h"

#include <sqlite3.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <stdexcept>
#include <system_error>
#include <thread>

#include "formats/output_dir.h"
#include "server/job_maps.h"
#include "server/job_reports.h"

namespace fragsim::server {

namespace fs = std::filesystem;

namespace {

constexpr const char* kStoreName = "fragsimd.sqlite";

// An open SQLite connection, closed on scope exit.
class Db {
 public:
  Db(const fs::path& path, int flags) {
    if (sqlite3_open_v2(path.c_str(), &db_, flags, nullptr) != SQLITE_OK) {
      const std::string m = db_ ? sqlite3_errmsg(db_) : "out of memory";
      sqlite3_close(db_);
      throw std::runtime_error("cannot open " + path.string() + ": " + m);
    }
    sqlite3_busy_timeout(db_, 10000);
  }
  ~Db() { sqlite3_close(db_); }
  Db(const Db&) = delete;
  Db& operator=(const Db&) = delete;
  sqlite3* get() const { return db_; }

  void exec(const std::string& sql) {
    char* error = nullptr;
    if (sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, &error) != SQLITE_OK) {
      const std::string m = error ? error : sqlite3_errmsg(db_);
      sqlite3_free(error);
      throw std::runtime_error("backup: " + m);
    }
  }
  // The first column of every row of `sql`, paired with the second when there is one; `arg`
  // bound to ?1 when given.
  std::vector<std::pair<std::string, std::string>> rows(const char* sql,
                                                        const std::string* arg = nullptr) {
    sqlite3_stmt* st = nullptr;
    if (sqlite3_prepare_v2(db_, sql, -1, &st, nullptr) != SQLITE_OK)
      throw std::runtime_error(std::string("backup: ") + sqlite3_errmsg(db_));
    if (arg != nullptr) sqlite3_bind_text(st, 1, arg->c_str(), -1, SQLITE_TRANSIENT);
    std::vector<std::pair<std::string, std::string>> out;
    while (sqlite3_step(st) == SQLITE_ROW) {
      const auto text = [&](int c) {
        const auto* t = sqlite3_column_text(st, c);
        return t ? std::string(reinterpret_cast<const char*>(t)) : std::string();
      };
      out.emplace_back(text(0), sqlite3_column_count(st) > 1 ? text(1) : std::string());
    }
    sqlite3_finalize(st);
    return out;
  }

 private:
  sqlite3* db_ = nullptr;
};

// The store, one consistent snapshot (SQLite's online backup API: a read transaction on the
// source; the daemon goes on committing meanwhile). Then checkpointed into one file.
void copy_store(const fs::path& from, const fs::path& to) {
  Db src(from, SQLITE_OPEN_READONLY);
  Db dst(to, SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE);
  sqlite3_backup* b = sqlite3_backup_init(dst.get(), "main", src.get(), "main");
  if (b == nullptr) throw std::runtime_error(std::string("backup: ") + sqlite3_errmsg(dst.get()));
  int rc = SQLITE_OK;
  for (int tries = 0; tries < 200; ++tries) {
    rc = sqlite3_backup_step(b, -1);  // all pages in one step: one snapshot
    if (rc != SQLITE_BUSY && rc != SQLITE_LOCKED) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  sqlite3_backup_finish(b);
  if (rc != SQLITE_DONE) {
    if (sqlite3_errcode(dst.get()) == SQLITE_FULL) throw formats::StorageFullError(to, ENOSPC, -1);
    throw std::runtime_error(std::string("backup of the store: ") + sqlite3_errstr(rc));
  }
  dst.exec("PRAGMA journal_mode = DELETE");  // one file, no -wal beside it
}

// A job directory's own files: not temporaries, not caches (maps, report, scene: remade on
// request), not a backend run's work directory. Relative paths.
std::vector<fs::path> job_files(const fs::path& dir) {
  std::vector<fs::path> out;
  for (fs::recursive_directory_iterator it(dir), end; it != end; ++it) {
    const std::string name = it->path().filename().string();
    const bool top = it.depth() == 0;
    if (it->is_directory()) {
      if (top && (name == JobMaps::kDirName || name == JobReports::kDirName ||
                  name.rfind("backend-", 0) == 0))
        it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file() || formats::is_temporary_name(name)) continue;
    if (top && name.rfind("scene", 0) == 0 && name.size() > 4 &&
        name.compare(name.size() - 4, 4, ".bin") == 0)
      continue;
    out.push_back(fs::relative(it->path(), dir));
  }
  return out;
}

// Copies `from` to `to` (a new file), fsynced; false when `from` is gone (purged meanwhile). The
// kernel copies (copy_file_range): a results.h5 of gigabytes is never held in memory.
bool copy_file(const fs::path& from, const fs::path& to, std::int64_t& bytes) {
  std::error_code ec;
  fs::create_directories(to.parent_path());
  fs::copy_file(from, to, fs::copy_options::none, ec);
  if (ec == std::errc::no_such_file_or_directory) return false;
  if (ec) {
    const std::error_code failed = ec;
    fs::remove(to, ec);
    if (formats::is_no_space(failed.value()))
      throw formats::StorageFullError(to, failed.value(), -1);
    throw std::runtime_error("backup: cannot copy " + from.string() + ": " + failed.message());
  }
  formats::fsync_path(to);
  bytes += static_cast<std::int64_t>(fs::file_size(to));
  return true;
}

// A done job's files; false when the job went (purged) while they were copied.
bool copy_job(const fs::path& from, const fs::path& to, std::int64_t& bytes) {
  std::error_code ec;
  if (!fs::is_directory(from, ec)) return false;
  std::vector<fs::path> files;
  try {
    files = job_files(from);
  } catch (const fs::filesystem_error&) {
    return false;  // removed while listed
  }
  for (const fs::path& f : files)
    if (!copy_file(from / f, to / f, bytes)) return false;
  return !files.empty();
}

}  // namespace

BackupReport backup_data_dir(const fs::path& data_dir, const fs::path& target) {
  std::error_code ec;
  if (fs::exists(target, ec)) throw std::runtime_error("backup: " + target.string() + " exists");
  const fs::path store = data_dir / kStoreName;
  if (!fs::is_regular_file(store, ec))
    throw std::runtime_error("backup: no store in " + data_dir.string() + " (" + kStoreName + ")");
  fs::path partial = target;
  partial += ".partial";
  fs::remove_all(partial, ec);  // an earlier backup that did not finish
  fs::create_directories(partial / "jobs");
  fs::create_directories(partial / "sites");
  BackupReport r;
  try {
    copy_store(store, partial / kStoreName);
    Db db(partial / kStoreName, SQLITE_OPEN_READWRITE);
    for (const auto& [v, unused] : db.rows("SELECT value FROM meta WHERE key = 'schema_version'"))
      r.schema_version = std::atoi(v.c_str());
    for (const auto& [site, unused] : db.rows("SELECT site_id FROM sites")) {
      const std::string name = site + ".json";
      if (copy_file(data_dir / "sites" / name, partial / "sites" / name, r.bytes)) {
        ++r.sites;
      } else {
        db.rows("DELETE FROM sites WHERE site_id = ?1", &site);  // deleted after the snapshot
      }
    }
    db.exec("PRAGMA foreign_keys = ON");  // a job's building rows go with it
    for (const auto& [job, state] : db.rows("SELECT job_id, state FROM jobs")) {
      if (state != "done") continue;
      if (copy_job(data_dir / "jobs" / job, partial / "jobs" / job, r.bytes)) {
        ++r.done_jobs;
        continue;
      }
      r.gone.push_back(job);  // purged after the snapshot: it leaves the backup too
      fs::remove_all(partial / "jobs" / job, ec);
      db.rows("DELETE FROM jobs WHERE job_id = ?1", &job);
    }
    r.jobs = std::stoll(db.rows("SELECT count(*) FROM jobs").at(0).first);
    r.bytes += static_cast<std::int64_t>(fs::file_size(partial / kStoreName));
  } catch (...) {
    fs::remove_all(partial, ec);
    throw;
  }
  formats::fsync_path(partial / kStoreName);
  fs::rename(partial, target);
  formats::fsync_path(target.parent_path().empty() ? fs::path(".") : target.parent_path());
  return r;
}

}  // namespace fragsim::server
