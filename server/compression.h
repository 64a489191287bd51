#pragma once
// Compression of fragsimd's answers. cpp-httplib (Debian's 0.11) compresses a body itself with
// Brotli at its slowest quality whenever the client accepts "br": 5-8 s for the viewer's 1.4 MB
// three.js module, 0.95 s for the demo's PTN JSON (gzip level 6: 0.04 s). So fragsimd compresses
// its text bodies with gzip itself and hands cpp-httplib the result with its length, which it
// sends as is (docs/http-api.md, "Compression").
#include <string>
#include <string_view>

namespace fragsim::server {

// Bodies smaller than this go uncompressed (the headers would cost as much as is saved).
inline constexpr std::size_t kCompressMinBytes = 1024;

// Does an Accept-Encoding header allow gzip? ("gzip", "x-gzip" or "*", without q=0.)
bool accepts_gzip(std::string_view accept_encoding);

// Text worth compressing: text/*, JSON, YAML, JavaScript. Binary formats (HDF5, the scene of
// float arrays, GeoTIFF) are not.
bool compressible(std::string_view content_type);

// The gzip member (RFC 1952) of `data`. Throws std::runtime_error if zlib fails.
std::string gzip(std::string_view data, int level = 6);

}  // namespace fragsim::server
