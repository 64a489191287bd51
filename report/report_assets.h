#pragma once
// The files the report inlines (report/assets: report.css, report.js, vendor/d3.min.js,
// vendor/plot.umd.min.js), compiled into the binary by report/embed_assets.cmake.
#include <string_view>

namespace fragsim::report {

// The file's bytes; throws std::logic_error for a name that was not embedded.
std::string_view report_asset(std::string_view name);

}  // namespace fragsim::report
