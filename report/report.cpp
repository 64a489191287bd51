// Writing the study report (report.h).
#include "report/report.h"

#include <chrono>
#include <ctime>
#include <fstream>
#include <memory>

#include "api/machine.h"
#include "core/common/error.h"
#include "formats/output_dir.h"
#include "report/report_html.h"
#include "report/report_inputs.h"
#include "report/report_pdf.h"

namespace fragsim::report {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

fs::path parent_of(const fs::path& p) {
  return p.has_parent_path() ? p.parent_path() : fs::path(".");
}

// An output file's directory, staged: InputError(option) when it cannot be used.
std::unique_ptr<formats::OutputDir> open_dir(const fs::path& file, const char* option) {
  if (file.filename().empty() || file.filename() == "." || file.filename() == "..")
    throw InputError(option, file.string() + ": not a file name");
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw InputError(option, file.string() + ": is a directory");
  try {
    return std::make_unique<formats::OutputDir>(parent_of(file));
  } catch (const std::exception& e) {
    throw InputError(option, file.string() + ": " + e.what());
  }
}

void stage(formats::OutputDir& dir, const fs::path& file, const char* option,
           const std::function<void(const fs::path&)>& write) {
  try {
    dir.stage(file.filename().string(), write);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(option, file.string() + ": " + e.what());
  }
}

void write_text(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

}  // namespace

std::string report_html(const fs::path& results_h5, api::UnitSystem units,
                        const std::optional<fs::path>& compare_json) {
  ReportInputs in = read_report_inputs(results_h5);
  if (compare_json) add_comparison(in, *compare_json, "--compare");
  return render_report_html(in, units, api::utc_now_iso8601());
}

ReportWritten write_report(const ReportOptions& o) {
  ReportWritten w;
  const auto t0 = Clock::now();
  const std::string html = report_html(o.results_h5, o.units, o.compare_json);
  w.html_bytes = html.size();
  auto html_dir = open_dir(o.out_html, "--out");
  stage(*html_dir, o.out_html, "--out", [&](const fs::path& p) { write_text(p, html); });
  w.html_s = seconds_since(t0);
  std::unique_ptr<formats::OutputDir> pdf_dir;
  if (o.out_pdf) {
    const auto t1 = Clock::now();
    pdf_dir = open_dir(*o.out_pdf, "--pdf");
    // chromium reads the page from a file named .html: a staged copy next to the PDF.
    stage(*pdf_dir, *o.out_pdf, "--pdf", [&](const fs::path& p) {
      const fs::path page = p.string() + ".page.html";
      write_text(page, html);
      try {
        print_pdf(page, p, chromium_path(o.chromium));
      } catch (...) {
        std::error_code ec;
        fs::remove(page, ec);
        throw;
      }
      std::error_code ec;
      fs::remove(page, ec);
    });
    w.pdf_s = seconds_since(t1);
  }
  html_dir->commit();
  w.files.push_back(o.out_html);
  if (pdf_dir) {
    pdf_dir->commit();
    w.files.push_back(*o.out_pdf);
  }
  return w;
}

}  // namespace fragsim::report
