#include "api/command_line.h"

#include <charconv>
#include <cmath>
#include <limits>

#include "api/json_fields.h"

namespace fragsim::api {

namespace {

std::string quoted(std::string_view text) {
  return "\"" + std::string(text) + "\"";
}

}  // namespace

bool ArgReader::at(std::string_view name) {
  if (done()) return false;
  if (word() == name) return true;
  if (name.size() > 2) tried_.emplace_back(name);  // "-q" and "-h" are never suggested
  return false;
}

void ArgReader::advance(std::size_t words) {
  k_ += words;
  tried_.clear();
}

bool ArgReader::take_flag(std::string_view name, std::string_view alias) {
  const bool found = at(name) || (!alias.empty() && at(alias));
  if (found) advance(1);
  return found;
}

std::optional<std::string> ArgReader::take_value(std::string_view name) {
  if (at(name)) {
    if (k_ + 1 >= words_.size()) throw InvocationError(std::string(name) + ": needs a value");
    std::string value = words_[k_ + 1];
    advance(2);
    return value;
  }
  if (done()) return std::nullopt;
  const std::string& w = word();
  if (w.size() > name.size() && w.compare(0, name.size(), name) == 0 && w[name.size()] == '=') {
    std::string value = w.substr(name.size() + 1);
    advance(1);
    return value;
  }
  return std::nullopt;
}

std::optional<std::string> ArgReader::take_nonempty(std::string_view name, std::string_view what) {
  auto value = take_value(name);
  if (value && value->empty())
    throw InvocationError(std::string(name) + ": empty " + std::string(what));
  return value;
}

void ArgReader::unknown_option(std::vector<std::string> accepted) const {
  accepted.insert(accepted.end(), tried_.begin(), tried_.end());
  const std::string name = word().substr(0, word().find('='));
  const std::string guess = suggest_key(name, accepted);
  throw InvocationError(name + ": unknown option" +
                        (guess.empty() ? "" : " (did you mean " + guess + "?)"));
}

std::optional<std::int64_t> to_integer(std::string_view text) {
  std::int64_t v = 0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end) return std::nullopt;
  return v;
}

std::optional<double> to_number(std::string_view text) {
  double v = 0.0;
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, v);
  if (text.empty() || ec != std::errc() || ptr != end || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::int64_t integer_option(std::string_view name, std::string_view text, std::int64_t lo,
                            std::int64_t hi, std::string_view note) {
  const auto v = to_integer(text);
  if (v && *v >= lo && *v <= hi) return *v;
  const std::string range = hi == std::numeric_limits<std::int64_t>::max()
                                ? ">= " + std::to_string(lo)
                                : "in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  throw InvocationError(std::string(name) + ": expected an integer " + range + std::string(note) +
                        ", got " + quoted(text));
}

double number_option(std::string_view name, std::string_view text, std::string_view what,
                     NumberRange r, std::string_view note) {
  const auto v = to_number(text);
  const bool above = v && (r.lo_open ? *v > r.lo : *v >= r.lo);
  if (above && *v <= r.hi) return *v;
  const std::string range = std::isinf(r.hi)
                                ? std::string(r.lo_open ? "> " : ">= ") + format_number(r.lo)
                                : std::string("in ") + (r.lo_open ? "(" : "[") +
                                      format_number(r.lo) + ", " + format_number(r.hi) + "]";
  throw InvocationError(std::string(name) + ": expected " + std::string(what) + " " + range +
                        std::string(note) + ", got " + quoted(text));
}

}  // namespace fragsim::api
