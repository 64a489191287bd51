#pragma once
// Reading scenario JSON with field-path errors. Every reader names the value it reads by its path
// in the document ("fragment_groups[1].mass_kg.sigma") and throws fragsim::InputError(path,
// message) when the value has the wrong type, is not finite, or is out of range; ObjectReader also
// rejects keys its kind does not accept (api/scenario_keys.h).
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/common/error.h"
#include "core/common/types.h"

namespace fragsim::api {

using Json = nlohmann::json;

// Paths. Keys that are not identifier-like (letters, digits, '_', '-') are quoted in brackets:
// site.materials["wet soil"], the same convention core/scene uses for material names.
std::string child_path(const std::string& parent, std::string_view key);
std::string index_path(const std::string& parent, std::size_t index);

[[noreturn]] void fail(const std::string& path, const std::string& message);

// "object", "array", "string", "boolean", "null", "integer" (integral JSON numbers) or "number".
std::string json_type_name(const Json& j);
// Shortest text that reads back to the same double ("0.5", "3", "1e-06" -> "1e-06").
std::string format_number(double v);
// The accepted key a misspelt `key` most likely meant, or "" (edit distance, or a missing unit
// suffix: "mass" -> "mass_kg").
std::string suggest_key(std::string_view key, const std::vector<std::string>& accepted);

// Scalars and arrays.
double read_number(const Json& j, const std::string& path);  // finite
// An integer: a JSON integer, or a number with an integral value ("1e6"); within [lo, hi].
std::int64_t read_integer(const Json& j, const std::string& path, std::int64_t lo, std::int64_t hi);
std::uint64_t read_unsigned(const Json& j, const std::string& path);
bool read_bool(const Json& j, const std::string& path);
std::string read_string(const Json& j, const std::string& path);
const Json& read_array(const Json& j, const std::string& path);
const Json& read_array(const Json& j, const std::string& path, std::size_t size);
std::vector<double> read_numbers(const Json& j, const std::string& path);
Vec3 read_vec3(const Json& j, const std::string& path);
std::array<double, 2> read_vec2(const Json& j, const std::string& path);

// Range checks; messages "must be > 0 (got -1)", "must be in [0, 1] (got 2)".
void check_gt(double v, double lo, const std::string& path);
void check_ge(double v, double lo, const std::string& path);
void check_le(double v, double hi, const std::string& path);
void check_in(double v, double lo, double hi, const std::string& path);
// A lower bound, then an upper one, each with its own message: "must be > 0 (got 0)", then
// "must be <= 10 (got 20)".
void check_gt_le(double v, double lo, double hi, const std::string& path);
void check_ge_le(double v, double lo, double hi, const std::string& path);
// |v| <= bound, componentwise for a vector: "must be in [-200, 200] (got 300)".
void check_abs_le(double v, double bound, const std::string& path);
void check_abs_le(const Vec3& v, double bound, const std::string& path);
// A point in site coordinates within the site limits (core/scene/site_limits.h): |x|, |y| up to
// 1e8 m, |z| up to 1e5 m.
Vec3 read_position(const Json& j, const std::string& path);

// A JSON object of a known kind. The constructor checks that `j` is an object and that it has no
// keys outside object_keys(kind): "settings.integrater: unknown key (did you mean "integrator"?)".
class ObjectReader {
 public:
  ObjectReader(const Json& j, std::string path, std::string_view kind);
  // The same with the accepted keys given (documents other than the scenario, e.g. gis/).
  ObjectReader(const Json& j, std::string path, const std::vector<std::string>& accepted);

  const std::string& path() const { return path_; }
  const Json& json() const { return j_; }
  std::string at(std::string_view key) const { return child_path(path_, key); }

  const Json* find(std::string_view key) const;
  bool has(std::string_view key) const { return find(key) != nullptr; }
  const Json& require(std::string_view key) const;  // "<path>.<key>: is required"

  double number(std::string_view key) const { return read_number(require(key), at(key)); }
  double number_or(std::string_view key, double fallback) const;
  std::optional<double> optional_number(std::string_view key) const;
  std::int64_t integer(std::string_view key, std::int64_t lo, std::int64_t hi) const;
  std::int64_t integer_or(std::string_view key, std::int64_t fallback, std::int64_t lo,
                          std::int64_t hi) const;
  bool bool_or(std::string_view key, bool fallback) const;
  std::string string(std::string_view key) const { return read_string(require(key), at(key)); }
  std::string string_or(std::string_view key, const std::string& fallback) const;
  Vec3 vec3(std::string_view key) const { return read_vec3(require(key), at(key)); }
  Vec3 vec3_or(std::string_view key, const Vec3& fallback) const;

 private:
  const Json& j_;
  std::string path_;
};

}  // namespace fragsim::api
