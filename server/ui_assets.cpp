#include "server/ui_assets.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "api/sha256.h"

namespace fragsim::server {

namespace {

bool safe_segment(std::string_view s) {
  if (s.empty() || s.front() == '.') return false;
  return std::all_of(s.begin(), s.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
           c == '_' || c == '-';
  });
}

bool ends_with(std::string_view s, std::string_view tail) {
  return s.size() >= tail.size() && s.substr(s.size() - tail.size()) == tail;
}

}  // namespace

std::optional<std::string> ui_file_path(std::string_view below_ui) {
  if (below_ui.empty() || below_ui == "index.html") return std::string("index.html");
  const std::size_t slash = below_ui.find('/');
  if (slash == std::string_view::npos) return std::nullopt;
  const std::string_view top = below_ui.substr(0, slash);
  if (top != "src" && top != "vendor") return std::nullopt;
  std::string_view rest = below_ui.substr(slash + 1);
  while (true) {
    const std::size_t next = rest.find('/');
    if (!safe_segment(rest.substr(0, next))) return std::nullopt;
    if (next == std::string_view::npos) break;
    rest.remove_prefix(next + 1);
  }
  return std::string(below_ui);
}

std::string ui_content_type(std::string_view path) {
  static const std::pair<std::string_view, std::string_view> kTypes[] = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".json", "application/json"},
      {".svg", "image/svg+xml"},
      {".png", "image/png"},
      {".txt", "text/plain; charset=utf-8"},
      {".md", "text/markdown; charset=utf-8"},
  };
  for (const auto& [ext, type] : kTypes)
    if (ends_with(path, ext)) return std::string(type);
  return "application/octet-stream";
}

namespace {

std::string etag_of(std::string_view bytes) {
  std::string tag(1, '"');  // appended piece by piece: GCC 12 misreads "\"" + s (-Wrestrict)
  tag += api::sha256_hex(std::string(bytes)).substr(0, 32);
  tag += '"';
  return tag;
}

// The embedded files' ETags, in embedded_ui_files() order.
const std::vector<std::string>& embedded_etags() {
  static const std::vector<std::string> kTags = [] {
    std::vector<std::string> tags;
    for (const UiFile& f : embedded_ui_files()) tags.push_back(etag_of(f.bytes));
    return tags;
  }();
  return kTags;
}

}  // namespace

std::optional<UiContent> read_ui_file(const std::string& dir, const std::string& path) {
  if (dir.empty()) {
    const auto& files = embedded_ui_files();
    const auto it =
        std::lower_bound(files.begin(), files.end(), path,
                         [](const UiFile& f, const std::string& p) { return f.path < p; });
    if (it == files.end() || it->path != path) return std::nullopt;
    return UiContent{std::string(it->bytes), embedded_etags()[it - files.begin()]};
  }
  const std::filesystem::path file = std::filesystem::path(dir) / path;
  std::error_code ec;
  if (!std::filesystem::is_regular_file(file, ec)) return std::nullopt;
  std::ifstream in(file, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  std::string text = bytes.str();
  std::string etag = etag_of(text);
  return UiContent{std::move(text), std::move(etag)};
}

}  // namespace fragsim::server
