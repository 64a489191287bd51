// A done job's study reports (server/job_reports.h): made once and kept; while one is being
// made (a slow PDF), another request waits at most JobReports::kWait and is then told to retry
// (Busy), so report requests cannot tie up the daemon's workers; a failed PDF leaves nothing.
#include "server/job_reports.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <chrono>
#include <fstream>
#include <future>

#include "api/run_outputs.h"
#include "api/test_support.h"
#include "core/run/run.h"
#include "formats/output_dir.h"

namespace fragsim::server {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

class JobReportsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = api::testing::fresh_test_dir("fragsim_job_reports_");
    const api::ScenarioDocument doc = api::parse_scenario_document(api::testing::minimal_example());
    const auto site = api::validate_scenario(doc.scenario);
    formats::OutputDir out(dir_ / "job");
    api::stage_run_outputs(out, run::run(doc.scenario), *site, doc, api::build_provenance());
    out.commit();
  }
  void TearDown() override {
    unsetenv("CHROMIUM");
    fs::remove_all(dir_);
  }
  // A stand-in browser that takes `seconds` and prints no PDF.
  void slow_browser(int seconds) {
    const fs::path script = dir_ / "slow-chromium";
    std::ofstream(script) << "#!/bin/sh\nsleep " << seconds << "\nexit 1\n";
    fs::permissions(script, fs::perms::owner_all);
    setenv("CHROMIUM", script.c_str(), 1);
  }
  fs::path dir_;
};

TEST_F(JobReportsTest, MadeOnceThenServedFromTheKeptFile) {
  JobReports reports;
  const fs::path f = reports.ensure(dir_ / "job", api::UnitSystem::kUs, false);
  EXPECT_EQ(f, dir_ / "job" / "report" / "report-us.html");
  const auto written = fs::last_write_time(f);
  EXPECT_EQ(reports.ensure(dir_ / "job", api::UnitSystem::kUs, false), f);
  EXPECT_EQ(fs::last_write_time(f), written);
}

TEST_F(JobReportsTest, AnotherRequestWaitsAtMostKWaitWhileASlowPdfIsMade) {
  slow_browser(static_cast<int>(JobReports::kWait.count()) + 2);
  JobReports reports;
  auto pdf = std::async(std::launch::async,
                        [&] { return reports.ensure(dir_ / "job", api::UnitSystem::kSi, true); });
  std::this_thread::sleep_for(std::chrono::milliseconds(500));  // the PDF holds the lock
  const auto t0 = Clock::now();
  EXPECT_THROW(reports.ensure(dir_ / "job", api::UnitSystem::kSi, false), JobReports::Busy);
  const double waited = std::chrono::duration<double>(Clock::now() - t0).count();
  EXPECT_GE(waited, static_cast<double>(JobReports::kWait.count()) - 0.6);
  EXPECT_LT(waited, static_cast<double>(JobReports::kWait.count()) + 1.5);
  EXPECT_ANY_THROW(pdf.get());  // the stand-in printed nothing
  // Nothing of the failed PDF (nor its HTML) is left: no file, no temporary, not even the
  // report/ folder it created.
  EXPECT_FALSE(fs::exists(dir_ / "job" / "report"));
}

}  // namespace
}  // namespace fragsim::server
