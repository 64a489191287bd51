// Reports of finished jobs, made once and kept (job_reports.h).
#include "server/job_reports.h"

#include "api/compare_json.h"
#include "api/run_outputs.h"
#include "formats/output_dir.h"
#include "report/report.h"

namespace fragsim::server {

namespace fs = std::filesystem;

std::string JobReports::file_name(api::UnitSystem units, bool pdf) {
  return std::string("report-") + api::unit_system_name(units) + (pdf ? ".pdf" : ".html");
}

fs::path JobReports::ensure(const fs::path& job_dir, api::UnitSystem units, bool pdf) {
  const fs::path dir = job_dir / kDirName;
  const fs::path target = dir / file_name(units, pdf);
  std::error_code ec;
  if (fs::is_regular_file(target, ec)) return target;  // kept: no need to wait
  {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!done_.wait_for(lock, kWait, [&] { return !making_; }))
      throw Busy("another report is being made; try again in a few seconds");
    if (fs::is_regular_file(target, ec)) return target;  // made while we waited
    making_ = true;
  }
  struct Release {  // the next waiter may go, however this one ends
    JobReports& r;
    ~Release() {
      {
        const std::lock_guard<std::mutex> lock(r.mutex_);
        r.making_ = false;
      }
      r.done_.notify_one();
    }
  } release{*this};
  report::ReportOptions o;
  o.results_h5 = job_dir / api::kResultsFileName;
  o.units = units;
  // A job with compare_with: its report shows the comparison (docs/comparison.md).
  if (std::error_code missing; std::filesystem::exists(job_dir / api::kCompareFileName, missing))
    o.compare_json = job_dir / api::kCompareFileName;
  if (pdf) {
    // The HTML of the same units is written too (kept: a later request for it is served).
    o.out_html = dir / file_name(units, false);
    o.out_pdf = target;
  } else {
    o.out_html = target;
  }
  report::write_report(o);
  return target;
}

std::size_t JobReports::remove_stale(const fs::path& job_dir) noexcept {
  return formats::remove_stale_temporaries(job_dir / kDirName);
}

}  // namespace fragsim::server
