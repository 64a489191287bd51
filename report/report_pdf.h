#pragma once
// A PDF of a report page, printed by headless chromium (Debian package "chromium"; the one the
// viewer's tests drive): no header or footer, A4 from the page's print style, no network (the
// page is self-contained and the browser is told to resolve no host and use no proxy).
#include <chrono>
#include <filesystem>
#include <string>

namespace fragsim::report {

// The browser: `configured` if not empty, else $CHROMIUM, else /usr/bin/chromium.
std::string chromium_path(const std::string& configured = "");

// Prints `html` (a file) to `pdf` (created). Throws std::runtime_error with the browser's last
// output lines when it is missing, fails, or runs longer than `timeout`.
void print_pdf(const std::filesystem::path& html, const std::filesystem::path& pdf,
               const std::string& chromium,
               std::chrono::seconds timeout = std::chrono::seconds(120));

}  // namespace fragsim::report
