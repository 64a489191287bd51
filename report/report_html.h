#pragma once
// The study report as one self-contained HTML page (docs/report.md): every figure's data, the
// plotting libraries (Observable Plot on d3, report/assets/vendor) and the page's own script and
// style are inlined, so it renders with no network and prints well (A4). Numbers a person reads
// are in the chosen unit system; each carries its summary.json key and SI value
// (data-key: a JSON pointer into summary.json; data-si), so tests and tools can check them.
#include <string>

#include "api/units.h"
#include "report/report_inputs.h"

namespace fragsim::report {

// `written_utc`: when the report is written (ISO 8601), shown on the page.
std::string render_report_html(const ReportInputs& in, api::UnitSystem units,
                               const std::string& written_utc);

// HTML text escaping (&, <, >, ", ').
std::string escape_html(std::string_view text);

// JSON text safe inside <script type="application/json">: '<', '>' and '&' as \u escapes,
// invalid UTF-8 replaced.
std::string json_for_script(const nlohmann::json& j);

// Scalars inline, objects indented; arrays of scalars on one (wrapping) line.
std::string pretty_json(const nlohmann::ordered_json& j);

}  // namespace fragsim::report
