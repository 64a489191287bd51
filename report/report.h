#pragma once
// The study report (docs/report.md): `fragsim report RESULTS.h5 --out report.html [--pdf
// report.pdf] [--units si|us]` and GET /v1/jobs/{id}/report.html|.pdf.
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "api/units.h"

namespace fragsim::report {

struct ReportOptions {
  std::filesystem::path results_h5;
  std::filesystem::path out_html;
  std::optional<std::filesystem::path> out_pdf;
  api::UnitSystem units = api::UnitSystem::kSi;
  std::string chromium;  // browser for the PDF; default: $CHROMIUM, else /usr/bin/chromium
};

struct ReportWritten {
  std::vector<std::filesystem::path> files;
  double html_s = 0.0, pdf_s = 0.0;  // time to write each
  std::size_t html_bytes = 0;
};

// The page for `results_h5` (read_report_inputs's errors pass through).
std::string report_html(const std::filesystem::path& results_h5, api::UnitSystem units);

// Writes the HTML (and the PDF) atomically: each appears complete or not at all, and nothing
// is left behind when any step fails. Throws InputError("RESULTS.h5" | "--out" | "--pdf", ...)
// naming the file and the problem.
ReportWritten write_report(const ReportOptions& options);

}  // namespace fragsim::report
