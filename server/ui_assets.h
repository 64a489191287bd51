#pragma once
// The web viewer's files (viewer/ in the source tree: index.html, src/, vendor/), served by
// fragsimd at /ui/ (docs/viewer.md). They are compiled into the binary at build time, so the
// daemon serves the page with no network and no install; `--ui-dir DIR` serves them from a
// folder instead (development: edit and reload without rebuilding).
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace fragsim::server {

struct UiFile {
  std::string_view path;  // relative to viewer/, e.g. "index.html", "src/main.js"
  std::string_view bytes;
};

// Every embedded file, sorted by path (generated at build time).
const std::vector<UiFile>& embedded_ui_files();

// A request path below /ui/ that may name a viewer file: "" (the index), "index.html", or
// segments of [A-Za-z0-9._-] under src/ or vendor/, none starting with '.'. Returns the file's
// path relative to viewer/, or nullopt (404) for anything else, ".." included.
std::optional<std::string> ui_file_path(std::string_view below_ui);

// Content type by extension ("text/javascript; charset=utf-8", ...).
std::string ui_content_type(std::string_view path);

// A file's bytes and its ETag (a quoted prefix of its SHA-256).
struct UiContent {
  std::string bytes;
  std::string etag;
};
// From `dir` when not empty (nullopt when missing), else the embedded copy, whose ETags are
// computed once for all files rather than on every request.
std::optional<UiContent> read_ui_file(const std::string& dir, const std::string& path);

}  // namespace fragsim::server
