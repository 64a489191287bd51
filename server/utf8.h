#pragma once
// Text that came from a client is echoed in error messages and logs, which must stay valid
// UTF-8 (a JSON error body cannot carry invalid bytes; building one threw and became a 500).
#include <string>
#include <string_view>

namespace fragsim::server {

// Valid UTF-8 (RFC 3629: no overlong forms, no surrogates, nothing above U+10FFFF)?
bool is_valid_utf8(std::string_view s);

// `s` with every byte that is not part of a valid UTF-8 sequence written as the four characters
// "\xNN" (hex); valid text, ASCII or not, is kept as it is.
std::string escape_invalid_utf8(std::string_view s);

}  // namespace fragsim::server
