#pragma once
// SHA-256 (FIPS 180-4) of a byte string, for provenance: summary.json records the digest of the
// scenario file exactly as read, so a result can be matched to its input.
#include <string>
#include <string_view>

namespace fragsim::api {

// Lower-case hex digest (64 characters).
std::string sha256_hex(std::string_view data);

}  // namespace fragsim::api
