#pragma once
// Structured log lines on stderr, logfmt: one event per line,
//   ts=2026-11-23T10:00:00.123Z level=info msg="job done" job_id=j_0123456789abcdef wall_s=0.61
// Values with spaces, quotes or '=' are quoted and escaped. Thread-safe; a line is never torn.
#include <initializer_list>
#include <string>
#include <string_view>
#include <utility>

namespace fragsim::server {

enum class LogLevel { kDebug = 0, kInfo = 1, kWarn = 2, kError = 3 };

using LogField = std::pair<std::string_view, std::string>;

void set_log_level(LogLevel level);
LogLevel parse_log_level(const std::string& name);  // "debug" | "info" | "warn" | "error"
bool log_enabled(LogLevel level);
void log(LogLevel level, std::string_view message, std::initializer_list<LogField> fields = {});

// Current UTC time as ISO 8601 with milliseconds ("2026-11-23T10:00:00.123Z").
std::string utc_now();
std::string format_double(double v);  // shortest round-trip text

}  // namespace fragsim::server
