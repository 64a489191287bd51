// Client text made safe to echo in JSON error bodies and logs (server/utf8.h).
#include "server/utf8.h"

#include <gtest/gtest.h>

namespace fragsim::server {
namespace {

TEST(Utf8, ValidTextIsKeptAsItIs) {
  for (const std::string s : {"", "plain ascii", "caf\xc3\xa9", "\xe2\x82\xac 5",
                              "\xf0\x9f\x92\xa5 boom", "\xed\x9f\xbf", "\xf4\x8f\xbf\xbf"}) {
    EXPECT_TRUE(is_valid_utf8(s)) << s;
    EXPECT_EQ(escape_invalid_utf8(s), s);
  }
}

// RFC 3629: stray continuation bytes, bytes that never occur, overlong forms, surrogates, code
// points above U+10FFFF, truncated sequences.
TEST(Utf8, InvalidBytesAreWrittenAsHexEscapes) {
  const std::pair<std::string, std::string> cases[] = {
      {"\x80", "\\x80"},
      {"a\xff"
       "b",
       "a\\xffb"},
      {"\xc0\xaf", "\\xc0\\xaf"},                    // overlong '/'
      {"\xe0\x80\xaf", "\\xe0\\x80\\xaf"},           // overlong
      {"\xed\xa0\x80", "\\xed\\xa0\\x80"},           // surrogate U+D800
      {"\xf4\x90\x80\x80", "\\xf4\\x90\\x80\\x80"},  // above U+10FFFF
      {"\xe2\x82", "\\xe2\\x82"},                    // truncated
      {"ok \xc3\xa9 \xfe", "ok \xc3\xa9 \\xfe"},     // valid non-ASCII kept next to an invalid byte
  };
  for (const auto& [in, out] : cases) {
    EXPECT_FALSE(is_valid_utf8(in)) << out;
    EXPECT_EQ(escape_invalid_utf8(in), out);
    EXPECT_TRUE(is_valid_utf8(escape_invalid_utf8(in)));
  }
}

}  // namespace
}  // namespace fragsim::server
