// The command-line reader both programs use (api/command_line.h): the two spellings of an option,
// flags and operands, strict numbers, and the one voice of its errors ("NAME: problem").
#include "api/command_line.h"

#include <gtest/gtest.h>

#include <limits>
#include <string>
#include <vector>

namespace fragsim::api {
namespace {

using Words = std::vector<std::string>;
constexpr double kInf = std::numeric_limits<double>::infinity();

// The InvocationError's message of `f`, or "" when it throws none.
template <class F>
std::string error_of(F f) {
  try {
    f();
  } catch (const InvocationError& e) {
    return e.what();
  }
  return "";
}

TEST(ArgReader, ReadsBothSpellingsFlagsAndOperands) {
  const Words w = {"s.json", "--out", "d", "--threads=3", "-q", "-", "--out="};
  ArgReader r(w);
  EXPECT_FALSE(r.at_option());
  EXPECT_FALSE(r.take_value("--out"));  // not at --out: nothing consumed
  EXPECT_EQ(r.take_operand(), "s.json");
  EXPECT_FALSE(r.take_value("--ou"));  // a prefix is not the option
  EXPECT_EQ(r.take_value("--out"), "d");
  EXPECT_FALSE(r.take_value("--thread"));  // "--threads=3" is not "--thread=..."
  EXPECT_EQ(r.take_value("--threads"), "3");
  EXPECT_TRUE(r.at_option());
  EXPECT_TRUE(r.take_flag("--quiet", "-q"));
  EXPECT_FALSE(r.at_option());  // a lone "-" is an operand (standard input, by convention)
  EXPECT_EQ(r.take_operand(), "-");
  EXPECT_EQ(error_of([&] { r.take_nonempty("--out", "directory name"); }),
            "--out: empty directory name");
  EXPECT_TRUE(r.done());
}

TEST(ArgReader, ErrorsNameTheOption) {
  const Words last = {"--out"};
  ArgReader r(last);
  EXPECT_EQ(error_of([&] { r.take_value("--out"); }), "--out: needs a value");
  EXPECT_EQ(error_of([&] { r.unknown_option(); }), "--out: unknown option");
  const Words typo = {"--thread=4"};
  ArgReader t(typo);
  EXPECT_EQ(error_of([&] {
              t.unknown_option({"--threads", "--quiet"});
            }),
            "--thread: unknown option (did you mean --threads?)");
  EXPECT_EQ(error_of([&] { t.unknown_option({"--zzzzzzzz"}); }), "--thread: unknown option");
}

// The options tried at a word are the ones its command takes: the nearest is suggested without
// a list, and a word consumed forgets them.
TEST(ArgReader, SuggestsTheNearestOptionTriedAtThisWord) {
  const Words w = {"--quiet", "--samples-scal=2"};
  ArgReader r(w);
  EXPECT_FALSE(r.take_value("--samples-scale"));
  EXPECT_TRUE(r.take_flag("--quiet", "-q"));
  EXPECT_FALSE(r.take_flag("--quiet", "-q"));
  EXPECT_FALSE(r.take_value("--out"));
  EXPECT_EQ(error_of([&] { r.unknown_option(); }), "--samples-scal: unknown option");
  EXPECT_FALSE(r.take_value("--samples-scale"));
  EXPECT_EQ(error_of([&] { r.unknown_option(); }),
            "--samples-scal: unknown option (did you mean --samples-scale?)");
  const Words short_flag = {"-x"};
  ArgReader s(short_flag);
  EXPECT_FALSE(s.take_flag("--quiet", "-q"));
  EXPECT_EQ(error_of([&] { s.unknown_option(); }), "-x: unknown option");
}

TEST(CommandLineNumbers, AreStrict) {
  EXPECT_EQ(to_integer("42"), 42);
  EXPECT_EQ(to_integer("-7"), -7);
  EXPECT_EQ(to_integer("9223372036854775807"), std::numeric_limits<std::int64_t>::max());
  for (const char* bad : {"", "+1", " 1", "1 ", "1.0", "0x10", "1e3", "9223372036854775808", "-"})
    EXPECT_FALSE(to_integer(bad)) << bad;
  EXPECT_EQ(to_number("0.5"), 0.5);
  EXPECT_EQ(to_number("1e3"), 1000.0);
  EXPECT_EQ(to_number("-2"), -2.0);
  for (const char* bad : {"", "+1", " 1", "1s", "inf", "-inf", "nan", "infinity", "1e999", "0x1p3"})
    EXPECT_FALSE(to_number(bad)) << bad;
}

TEST(CommandLineNumbers, RangesAreCheckedAndNamed) {
  EXPECT_EQ(integer_option("--n", "0", 0, 10), 0);
  EXPECT_EQ(integer_option("--n", "10", 0, 10), 10);
  EXPECT_EQ(error_of([] { integer_option("--n", "11", 0, 10, " (0: all)"); }),
            "--n: expected an integer in [0, 10] (0: all), got \"11\"");
  EXPECT_EQ(
      error_of([] { integer_option("--n", "x", 1, std::numeric_limits<std::int64_t>::max()); }),
      "--n: expected an integer >= 1, got \"x\"");
  EXPECT_EQ(number_option("--s", "86400", "seconds", {0.0, true, 86400.0}), 86400.0);
  EXPECT_EQ(error_of([] {
              number_option("--s", "0", "seconds", {0.0, true, 86400.0});
            }),
            "--s: expected seconds in (0, 86400], got \"0\"");
  EXPECT_EQ(number_option("--d", "0", "days", {0.0, false, 36500.0}), 0.0);
  EXPECT_EQ(error_of([] {
              number_option("--d", "-1", "days", {0.0, false, 36500.0}, " (0: none)");
            }),
            "--d: expected days in [0, 36500] (0: none), got \"-1\"");
  EXPECT_EQ(error_of([] {
              number_option("--x", "inf", "a number", {0.0, true, kInf});
            }),
            "--x: expected a number > 0, got \"inf\"");
  EXPECT_EQ(number_option("--x", "1e-300", "a number", {0.0, true, kInf}), 1e-300);
}

}  // namespace
}  // namespace fragsim::api
