// `fragsim report` as a subprocess (report/report.h; docs/report.md): exit 2 naming the file on
// bad input with nothing left behind, and an HTML page and a PDF (headless chromium) from a run.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "cli/cli_process.h"

namespace {

namespace fs = std::filesystem;
using fragsim::cli::testing::CliResult;

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class ReportCli : public fragsim::cli::testing::CliDirTest {
 protected:
  ReportCli() : CliDirTest("fragsim_report_cli_test_") {}

  std::size_t entries(const fs::path& d) const {
    return static_cast<std::size_t>(
        std::distance(fs::directory_iterator(d), fs::directory_iterator()));
  }
};

TEST_F(ReportCli, BadInputExitsTwoNamingItAndWritesNothing) {
  std::ofstream(dir_ / "notes.txt") << "not a results file\n";
  const fs::path out = dir_ / "rep" / "report.html";
  CliResult r = run({"report", (dir_ / "notes.txt").string(), "--out", out.string()});
  EXPECT_EQ(r.exit_code, 2) << r.err;
  EXPECT_NE(r.err.find("notes.txt: not an HDF5 file"), std::string::npos) << r.err;
  EXPECT_FALSE(fs::exists(dir_ / "rep"));
  r = run({"report", (dir_ / "notes.txt").string(), "--out", out.string(), "--units", "imperial"});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--units: expected si or us, got \"imperial\""), std::string::npos) << r.err;
  r = run({"report", (dir_ / "notes.txt").string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("report needs --out REPORT.html"), std::string::npos) << r.err;
}

TEST_F(ReportCli, WritesTheHtmlAndThePdfOfARun) {
  const fs::path scenario = fs::path(FRAGSIM_SOURCE_DIR) / "examples/minimal/scenario.json";
  ASSERT_EQ(run({"run", scenario.string(), "--out", (dir_ / "run").string(), "-q"}).exit_code, 0);
  const fs::path h5 = dir_ / "run" / "results.h5";
  const fs::path unwritable = dir_ / "run" / "results.h5" / "r.html";  // under a file
  CliResult r = run({"report", h5.string(), "--out", unwritable.string()});
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--out: " + unwritable.string()), std::string::npos) << r.err;
  if (!fs::exists("/usr/bin/chromium") && std::getenv("CHROMIUM") == nullptr)
    GTEST_SKIP() << "no chromium: apt-get install chromium (the PDF is printed by it)";
  const fs::path html = dir_ / "rep" / "r.html", pdf = dir_ / "rep" / "r.pdf";
  r = run({"report", h5.string(), "--out", html.string(), "--pdf", pdf.string(), "--units", "us"});
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_EQ(entries(dir_ / "rep"), 2u);  // no temporary left
  EXPECT_NE(read_text(html).find("data-units=\"us\""), std::string::npos);
  const std::string p = read_text(pdf);
  EXPECT_EQ(p.rfind("%PDF-", 0), 0u);
  std::size_t pages = 0;  // "/Type /Page" objects, not "/Type /Pages"
  for (std::size_t at = 0; (at = p.find("/Type /Page", at)) != std::string::npos; at += 11)
    if (p.compare(at + 11, 1, "s") != 0) ++pages;
  EXPECT_GE(pages, 4u) << "identity, findings, site, results, ..., appendix";
}

}  // namespace
