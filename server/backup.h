#pragma once
// An online backup of a data directory (docs/operations.md, "Backups"): `fragsimd backup TARGET`,
// taken while the daemon runs and serves, from another process (the daemon's lock on the data
// directory is not needed: nothing in it is written).
//
// Consistent: the store is copied with SQLite's online backup API (one snapshot, whatever the
// daemon commits meanwhile); then the files of the snapshot's sites and done jobs, which never
// change once their row says so (results are renamed into place before the job is marked done).
// A job purged between the snapshot and its copy leaves the backup whole (its rows go too); a job
// running or queued in the snapshot is queued again, and rerun, by a daemon started on the
// backup. Caches are left out (site and job scenes, maps, reports: rebuilt on request), and so are
// the work directories of backend runs. The backup is a data directory: restore by starting
// fragsimd on it (or a copy). It appears whole: written under TARGET.partial, renamed to TARGET
// at the end.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace fragsim::server {

struct BackupReport {
  std::int64_t sites = 0;
  std::int64_t jobs = 0;          // rows in the backup
  std::int64_t done_jobs = 0;     // of which done, with their files
  std::int64_t bytes = 0;         // of the files copied, the store included
  std::vector<std::string> gone;  // jobs purged while the backup ran (left out)
  int schema_version = 0;
};

// Throws std::runtime_error naming the problem (TARGET exists, no store in data_dir, a copy
// failed; formats::StorageFullError for a full disk); TARGET is then not made.
BackupReport backup_data_dir(const std::filesystem::path& data_dir,
                             const std::filesystem::path& target);

}  // namespace fragsim::server
