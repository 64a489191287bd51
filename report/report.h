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
  // A paired comparison's compare.json that this run is the base or variant of (its part of the
  // Results section; docs/comparison.md).
  std::optional<std::filesystem::path> compare_json;
};

struct ReportWritten {
  std::vector<std::filesystem::path> files;
  double html_s = 0.0, pdf_s = 0.0;  // time to write each
  std::size_t html_bytes = 0;
};

// The page for `results_h5` (read_report_inputs's errors pass through), with the comparison of
// `compare_json` when given (InputError("--compare", ...) when it is not this run's).
std::string report_html(const std::filesystem::path& results_h5, api::UnitSystem units,
                        const std::optional<std::filesystem::path>& compare_json = {});

// Writes the HTML (and the PDF) atomically: each appears complete or not at all, and nothing
// is left behind when any step fails. Throws InputError("RESULTS.h5" | "--out" | "--pdf", ...)
// naming the file and the problem.
ReportWritten write_report(const ReportOptions& options);

}  // namespace fragsim::report
