#pragma once
// The study reports of a finished job (GET /v1/jobs/{id}/report.html|.pdf?units=si|us;
// docs/http-api.md): the page `fragsim report` writes (report::write_report, the same code),
// made on the first request and kept in jobs/<id>/report/ beside results.h5, one per format and
// unit system. Each file appears complete or not at all (staged and renamed); one report is
// made at a time (the PDF runs a headless chromium for seconds): a request that finds another
// being made waits up to kWait, then gets Busy (503, retry), so that many clients asking for
// reports cannot tie up the daemon's workers. A kept report is served without waiting. A daemon
// killed while making one leaves temporaries that the next start removes.
#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>

#include "api/units.h"

namespace fragsim::server {

class JobReports {
 public:
  static constexpr const char* kDirName = "report";
  static constexpr std::chrono::seconds kWait{5};

  // Another report is being made and did not finish within kWait.
  struct Busy : std::runtime_error {
    using std::runtime_error::runtime_error;
  };

  // The report file of the job whose directory is `job_dir` (holding results.h5), made if
  // missing. Throws InputError("RESULTS.h5", ...) when the results cannot be reported (an older
  // results format) and std::runtime_error / InputError("--pdf", ...) when the PDF cannot be
  // printed (no chromium); nothing is then left under a final name.
  std::filesystem::path ensure(const std::filesystem::path& job_dir, api::UnitSystem units,
                               bool pdf);

  // Removes an interrupted report's temporaries in `job_dir`/report (start-up only).
  static std::size_t remove_stale(const std::filesystem::path& job_dir) noexcept;

  // "report-si.html", "report-us.pdf", ...
  static std::string file_name(api::UnitSystem units, bool pdf);

 private:
  // One report at a time: `making_` under `mutex_`, waited for on `done_` (a condition variable
  // rather than a timed mutex, whose clock-based lock TSan's interceptors do not see).
  std::mutex mutex_;
  std::condition_variable done_;
  bool making_ = false;
};

}  // namespace fragsim::server
