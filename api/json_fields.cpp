#include "api/json_fields.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <utility>

#include "api/scenario_keys.h"
#include "core/scene/site_limits.h"

namespace fragsim::api {

namespace {

bool identifier_like(std::string_view key) {
  return !key.empty() && std::all_of(key.begin(), key.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_' || ch == '-';
  });
}

// Levenshtein distance (insertions, deletions, substitutions), one row of the DP table.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      const std::size_t substitute = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      row[j] = std::min({up + 1, row[j - 1] + 1, substitute});
      diagonal = up;
    }
  }
  return row[b.size()];
}

[[noreturn]] void wrong_type(const std::string& expected, const Json& j, const std::string& path) {
  fail(path, "expected " + expected + ", got " + json_type_name(j));
}

}  // namespace

std::string child_path(const std::string& parent, std::string_view key) {
  if (!identifier_like(key)) return parent + "[\"" + std::string(key) + "\"]";
  return parent.empty() ? std::string(key) : parent + "." + std::string(key);
}

std::string index_path(const std::string& parent, std::size_t index) {
  return parent + "[" + std::to_string(index) + "]";
}

void fail(const std::string& path, const std::string& message) {
  throw InputError(path, message);
}

std::string json_type_name(const Json& j) {
  if (j.is_number_integer()) return "integer";
  if (j.is_number_float()) return "number";
  return j.type_name();  // object, array, string, boolean, null
}

std::string format_number(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string suggest_key(std::string_view key, const std::vector<std::string>& accepted) {
  // A missing unit suffix is the commonest slip: "mass" for "mass_kg", "height" for "height_m".
  for (const auto& a : accepted) {
    if (a.size() > key.size() + 1 && a.compare(0, key.size(), key) == 0 && a[key.size()] == '_')
      return a;
  }
  const std::size_t limit = key.size() >= 8 ? 2 : 1;
  std::string best;
  std::size_t best_distance = limit + 1;
  for (const auto& a : accepted) {
    const std::size_t d = edit_distance(key, a);
    if (d < best_distance) {
      best = a;
      best_distance = d;
    }
  }
  return best;
}

double read_number(const Json& j, const std::string& path) {
  if (!j.is_number()) wrong_type("number", j, path);
  const double v = j.get<double>();
  if (!std::isfinite(v)) fail(path, "not finite");
  return v;
}

std::int64_t read_integer(const Json& j, const std::string& path, std::int64_t lo,
                          std::int64_t hi) {
  const auto below = [&](const std::string& got) {
    fail(path, "must be >= " + std::to_string(lo) + " (got " + got + ")");
  };
  const auto above = [&](const std::string& got) {
    fail(path, "must be <= " + std::to_string(hi) + " (got " + got + ")");
  };
  if (j.is_number_unsigned()) {
    const auto v = j.get<std::uint64_t>();
    if (v > static_cast<std::uint64_t>(hi)) above(std::to_string(v));
    const auto s = static_cast<std::int64_t>(v);
    if (s < lo) below(std::to_string(v));
    return s;
  }
  if (j.is_number_integer()) {
    const auto v = j.get<std::int64_t>();
    if (v < lo) below(std::to_string(v));
    if (v > hi) above(std::to_string(v));
    return v;
  }
  if (j.is_number_float()) {
    const double d = j.get<double>();
    if (!std::isfinite(d)) fail(path, "not finite");
    if (d != std::floor(d)) fail(path, "expected integer, got " + format_number(d));
    // Converted only within [-2^63, 2^63): 2^63 itself (what INT64_MAX becomes as a double, so
    // `d > hi` lets it through) is out of int64's range, and the cast would be undefined.
    if (d < -9223372036854775808.0) below(format_number(d));
    if (d >= 9223372036854775808.0) above(format_number(d));
    const auto v = static_cast<std::int64_t>(d);
    if (v < lo) below(format_number(d));
    if (v > hi) above(format_number(d));
    return v;
  }
  wrong_type("integer", j, path);
}

std::uint64_t read_unsigned(const Json& j, const std::string& path) {
  if (j.is_number_unsigned()) return j.get<std::uint64_t>();
  if (j.is_number_integer()) {
    const auto v = j.get<std::int64_t>();
    if (v < 0) fail(path, "must be >= 0 (got " + std::to_string(v) + ")");
    return static_cast<std::uint64_t>(v);
  }
  if (j.is_number_float()) {
    const double d = j.get<double>();
    if (!std::isfinite(d)) fail(path, "not finite");
    if (d != std::floor(d)) fail(path, "expected integer, got " + format_number(d));
    if (d < 0) fail(path, "must be >= 0 (got " + format_number(d) + ")");
    // 2^64 is the first double past the range.
    if (d >= 18446744073709551616.0) fail(path, "must be < 2^64 (got " + format_number(d) + ")");
    return static_cast<std::uint64_t>(d);
  }
  wrong_type("integer", j, path);
}

bool read_bool(const Json& j, const std::string& path) {
  if (!j.is_boolean()) wrong_type("boolean", j, path);
  return j.get<bool>();
}

std::string read_string(const Json& j, const std::string& path) {
  if (!j.is_string()) wrong_type("string", j, path);
  return j.get<std::string>();
}

const Json& read_array(const Json& j, const std::string& path) {
  if (!j.is_array()) wrong_type("array", j, path);
  return j;
}

const Json& read_array(const Json& j, const std::string& path, std::size_t size) {
  if (!j.is_array()) wrong_type("array of " + std::to_string(size) + " numbers", j, path);
  if (j.size() != size)
    fail(path, "expected " + std::to_string(size) + " elements, got " + std::to_string(j.size()));
  return j;
}

std::vector<double> read_numbers(const Json& j, const std::string& path) {
  read_array(j, path);
  std::vector<double> out;
  out.reserve(j.size());
  for (std::size_t k = 0; k < j.size(); ++k) out.push_back(read_number(j[k], index_path(path, k)));
  return out;
}

Vec3 read_vec3(const Json& j, const std::string& path) {
  read_array(j, path, 3);
  return Vec3(read_number(j[0], index_path(path, 0)), read_number(j[1], index_path(path, 1)),
              read_number(j[2], index_path(path, 2)));
}

std::array<double, 2> read_vec2(const Json& j, const std::string& path) {
  read_array(j, path, 2);
  return {read_number(j[0], index_path(path, 0)), read_number(j[1], index_path(path, 1))};
}

void check_gt(double v, double lo, const std::string& path) {
  if (!(v > lo)) fail(path, "must be > " + format_number(lo) + " (got " + format_number(v) + ")");
}

void check_ge(double v, double lo, const std::string& path) {
  if (!(v >= lo)) fail(path, "must be >= " + format_number(lo) + " (got " + format_number(v) + ")");
}

void check_le(double v, double hi, const std::string& path) {
  if (!(v <= hi)) fail(path, "must be <= " + format_number(hi) + " (got " + format_number(v) + ")");
}

void check_in(double v, double lo, double hi, const std::string& path) {
  if (!(v >= lo && v <= hi))
    fail(path, "must be in [" + format_number(lo) + ", " + format_number(hi) + "] (got " +
                   format_number(v) + ")");
}

void check_gt_le(double v, double lo, double hi, const std::string& path) {
  check_gt(v, lo, path);
  check_le(v, hi, path);
}

void check_ge_le(double v, double lo, double hi, const std::string& path) {
  check_ge(v, lo, path);
  check_le(v, hi, path);
}

void check_abs_le(double v, double bound, const std::string& path) {
  check_in(v, -bound, bound, path);
}

void check_abs_le(const Vec3& v, double bound, const std::string& path) {
  for (int k = 0; k < 3; ++k)
    check_abs_le(v[k], bound, index_path(path, static_cast<std::size_t>(k)));
}

Vec3 read_position(const Json& j, const std::string& path) {
  const Vec3 p = read_vec3(j, path);
  check_abs_le(p.x(), scene::kMaxAbsCoordinate_m, index_path(path, 0));
  check_abs_le(p.y(), scene::kMaxAbsCoordinate_m, index_path(path, 1));
  check_abs_le(p.z(), scene::kMaxAbsElevation_m, index_path(path, 2));
  return p;
}

ObjectReader::ObjectReader(const Json& j, std::string path, std::string_view kind)
    : ObjectReader(j, std::move(path), object_keys(kind)) {}

ObjectReader::ObjectReader(const Json& j, std::string path,
                           const std::vector<std::string>& accepted)
    : j_(j), path_(std::move(path)) {
  if (!j.is_object()) wrong_type("object", j, path_);
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    if (std::find(accepted.begin(), accepted.end(), key) != accepted.end()) continue;
    const std::string guess = suggest_key(key, accepted);
    fail(child_path(path_, key),
         guess.empty() ? "unknown key" : "unknown key (did you mean \"" + guess + "\"?)");
  }
}

const Json* ObjectReader::find(std::string_view key) const {
  const auto it = j_.find(key);
  return it == j_.end() ? nullptr : &*it;
}

const Json& ObjectReader::require(std::string_view key) const {
  const Json* v = find(key);
  if (v == nullptr) fail(at(key), "is required");
  return *v;
}

double ObjectReader::number_or(std::string_view key, double fallback) const {
  const Json* v = find(key);
  return v ? read_number(*v, at(key)) : fallback;
}

std::optional<double> ObjectReader::optional_number(std::string_view key) const {
  const Json* v = find(key);
  if (!v) return std::nullopt;
  return read_number(*v, at(key));
}

std::int64_t ObjectReader::integer(std::string_view key, std::int64_t lo, std::int64_t hi) const {
  return read_integer(require(key), at(key), lo, hi);
}

std::int64_t ObjectReader::integer_or(std::string_view key, std::int64_t fallback, std::int64_t lo,
                                      std::int64_t hi) const {
  const Json* v = find(key);
  return v ? read_integer(*v, at(key), lo, hi) : fallback;
}

bool ObjectReader::bool_or(std::string_view key, bool fallback) const {
  const Json* v = find(key);
  return v ? read_bool(*v, at(key)) : fallback;
}

std::string ObjectReader::string_or(std::string_view key, const std::string& fallback) const {
  const Json* v = find(key);
  return v ? read_string(*v, at(key)) : fallback;
}

Vec3 ObjectReader::vec3_or(std::string_view key, const Vec3& fallback) const {
  const Json* v = find(key);
  return v ? read_vec3(*v, at(key)) : fallback;
}

}  // namespace fragsim::api
