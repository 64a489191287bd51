#include "server/compression.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <stdexcept>

namespace fragsim::server {

namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// "q=0", "q=0.0", "q=0.000": the coding is refused.
bool refused(std::string_view params) {
  const std::string p = lower(params);
  const auto q = p.find("q=");
  if (q == std::string::npos) return false;
  const std::string_view v = trim(std::string_view(p).substr(q + 2));
  return !v.empty() && v[0] == '0' &&
         std::all_of(v.begin() + 1, v.end(), [](char c) { return c == '.' || c == '0'; });
}

}  // namespace

bool accepts_gzip(std::string_view header) {
  while (!header.empty()) {
    const std::size_t comma = header.find(',');
    const std::string_view item = header.substr(0, comma);
    header = comma == std::string_view::npos ? std::string_view() : header.substr(comma + 1);
    const std::size_t semi = item.find(';');
    const std::string name = lower(trim(item.substr(0, semi)));
    const std::string_view params =
        semi == std::string_view::npos ? std::string_view() : item.substr(semi + 1);
    if ((name == "gzip" || name == "x-gzip" || name == "*") && !refused(params)) return true;
  }
  return false;
}

bool compressible(std::string_view content_type) {
  const std::string t = lower(content_type.substr(0, content_type.find(';')));
  return t.rfind("text/", 0) == 0 || t == "application/json" || t == "application/yaml" ||
         t == "application/javascript" || t == "image/svg+xml";
}

std::string gzip(std::string_view data, int level) {
  z_stream z{};
  // windowBits 15 + 16: a gzip header and trailer rather than zlib's.
  if (deflateInit2(&z, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("gzip: deflateInit2 failed");
  std::string out(deflateBound(&z, static_cast<uLong>(data.size())) + 32, '\0');
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&z, Z_FINISH);
  out.resize(z.total_out);
  deflateEnd(&z);
  if (rc != Z_STREAM_END) throw std::runtime_error("gzip: deflate failed");
  return out;
}

}  // namespace fragsim::server
