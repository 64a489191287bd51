// The JSON reading helpers: paths, type names, number formatting, key suggestions.
#include "api/json_fields.h"

#include <gtest/gtest.h>

#include <limits>

namespace fragsim::api {
namespace {

TEST(JsonFields, Paths) {
  EXPECT_EQ(child_path("", "site"), "site");
  EXPECT_EQ(child_path("site", "terrain"), "site.terrain");
  EXPECT_EQ(child_path("site.materials", "wet soil"), "site.materials[\"wet soil\"]");
  EXPECT_EQ(child_path("site.materials", "rc-wall_2"), "site.materials.rc-wall_2");
  EXPECT_EQ(index_path("fragment_groups", 3), "fragment_groups[3]");
}

TEST(JsonFields, TypeNamesAndNumbers) {
  EXPECT_EQ(json_type_name(Json(3)), "integer");
  EXPECT_EQ(json_type_name(Json(3u)), "integer");
  EXPECT_EQ(json_type_name(Json(3.5)), "number");
  EXPECT_EQ(json_type_name(Json("x")), "string");
  EXPECT_EQ(json_type_name(Json(nullptr)), "null");
  EXPECT_EQ(json_type_name(Json::array()), "array");
  EXPECT_EQ(json_type_name(Json::object()), "object");
  EXPECT_EQ(json_type_name(Json(true)), "boolean");
  EXPECT_EQ(format_number(3.0), "3");
  EXPECT_EQ(format_number(0.1), "0.1");
  EXPECT_EQ(format_number(1e-12), "1e-12");
  EXPECT_EQ(format_number(-2.5), "-2.5");
}

TEST(JsonFields, Suggestions) {
  const std::vector<std::string> keys = {"seed", "integrator", "threads", "mass_kg", "height_m"};
  EXPECT_EQ(suggest_key("integrater", keys), "integrator");
  EXPECT_EQ(suggest_key("seeed", keys), "seed");
  EXPECT_EQ(suggest_key("Seed", keys), "seed");
  EXPECT_EQ(suggest_key("mass", keys), "mass_kg");
  EXPECT_EQ(suggest_key("height", keys), "height_m");
  EXPECT_EQ(suggest_key("colour", keys), "");
  EXPECT_EQ(suggest_key("thread_count", keys), "");
}

TEST(JsonFields, Integers) {
  EXPECT_EQ(read_integer(Json(5), "n", 0, 10), 5);
  EXPECT_EQ(read_integer(Json(5.0), "n", 0, 10), 5);
  EXPECT_EQ(read_unsigned(Json(18446744073709551615ull), "seed"), 18446744073709551615ull);
  try {
    read_integer(Json(11), "n", 0, 10);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "n");
    EXPECT_EQ(e.message(), "must be <= 10 (got 11)");
  }
  try {
    read_unsigned(Json(1.5e20), "seed");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.message(), "must be < 2^64 (got 1.5e+20)");
  }
}

TEST(JsonFields, IntegersAtTheEdgeOfInt64AreErrorsNotUndefined) {
  // Issue 10 (UBSan): 2^63 written as a float passed `d > INT64_MAX as a double` (which is 2^63)
  // and was converted to int64, which is undefined.
  constexpr auto lo = std::numeric_limits<std::int64_t>::min();
  constexpr auto hi = std::numeric_limits<std::int64_t>::max();
  const auto message = [&](const Json& j) {
    try {
      read_integer(j, "triangles[0][1]", lo, hi);
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "triangles[0][1]");
      return e.message();
    }
    return std::string("<no error>");
  };
  EXPECT_EQ(message(Json::parse("9223372036854775808.0")),
            "must be <= 9223372036854775807 (got 9223372036854775808)");
  EXPECT_EQ(message(Json::parse("9223372036854775808")),
            "must be <= 9223372036854775807 (got 9223372036854775808)");
  EXPECT_EQ(message(Json::parse("1e19")), "must be <= 9223372036854775807 (got 1e+19)");
  EXPECT_EQ(message(Json::parse("-1e19")), "must be >= -9223372036854775808 (got -1e+19)");
  EXPECT_EQ(read_integer(Json::parse("-9223372036854775808.0"), "n", lo, hi), lo);
  EXPECT_EQ(read_integer(Json::parse("9.007199254740992e15"), "n", lo, hi), 9007199254740992);
  // A bound that is not a double: 2^53 + 1 as a double is 2^53; the integer compare is exact.
  const std::int64_t odd = 9007199254740993;
  EXPECT_EQ(read_integer(Json(9007199254740992.0), "n", 0, odd), 9007199254740992);
  EXPECT_THROW(read_integer(Json(9007199254740994.0), "n", 0, odd), InputError);
}

}  // namespace
}  // namespace fragsim::api
