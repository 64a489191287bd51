#pragma once
// The two command lines, `fragsim` (cli/) and `fragsimd` (server/config.h), read by one helper:
// words left to right, an option's value after it ("--out d") or joined by '=' ("--out=d"),
// numbers parsed strictly and checked against their range, and every error message in one voice,
// "NAME: problem" (docs/devguide.md, "Adding a command-line option").
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace fragsim::api {

// A program invoked wrongly: a malformed command line or configuration (exit status 2). The
// message names the option or key first.
class InvocationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The words of a command line, read one at a time from `first`. Each take_* call looks at the
// current word: when it is the option asked for, it consumes the option (and its value) and
// says so; otherwise it consumes nothing and remembers the name it was asked for, so that an
// unknown option can be answered with the nearest of the options tried at that word (the
// options its command takes, without a list to keep in step).
class ArgReader {
 public:
  explicit ArgReader(const std::vector<std::string>& words, std::size_t first = 0)
      : words_(words), k_(first) {}

  bool done() const { return k_ >= words_.size(); }
  const std::string& word() const { return words_[k_]; }
  // "-x", "--name", "--name=value"; a lone "-" is an operand.
  bool at_option() const { return word().size() > 1 && word()[0] == '-'; }
  // The current word as an operand.
  std::string take_operand() {
    std::string w = words_[k_];
    advance(1);
    return w;
  }

  // An option without a value, under any of its spellings ("--quiet", "-q").
  bool take_flag(std::string_view name, std::string_view alias = {});
  // The value of option `name` ("--name v" or "--name=v"); InvocationError "NAME: needs a value"
  // when it is the last word.
  std::optional<std::string> take_value(std::string_view name);
  // As take_value, and an empty value is refused: "NAME: empty WHAT" ("empty file name").
  std::optional<std::string> take_nonempty(std::string_view name, std::string_view what);

  // "WORD: unknown option", with the nearest of `accepted` and of the names tried at this word
  // as a suggestion when one is close.
  [[noreturn]] void unknown_option(std::vector<std::string> accepted = {}) const;

 private:
  bool at(std::string_view name);  // the current word is `name`; else `name` is remembered
  void advance(std::size_t words);

  const std::vector<std::string>& words_;
  std::size_t k_;
  std::vector<std::string> tried_;  // names asked for at the current word
};

// Strict numbers: the whole text, no sign '+', no blanks; a number must be finite.
std::optional<std::int64_t> to_integer(std::string_view text);
std::optional<double> to_number(std::string_view text);

// An option's integer in [lo, hi]: "NAME: expected an integer in [lo, hi]NOTE, got "TEXT""
// ("an integer >= lo" when hi is the largest int64). `note` is appended, e.g.
// " (0: all hardware threads)".
std::int64_t integer_option(std::string_view name, std::string_view text, std::int64_t lo,
                            std::int64_t hi, std::string_view note = {});

// A range of real numbers: [lo or (lo, to hi] (hi infinite: no upper bound).
struct NumberRange {
  double lo = 0.0;
  bool lo_open = true;
  double hi = 0.0;  // inclusive; +infinity for none
};
// An option's real number in `range`: "NAME: expected WHAT in (lo, hi]NOTE, got "TEXT"" ("WHAT >
// lo" without an upper bound); `what` is "a number", "seconds", "days", ...
double number_option(std::string_view name, std::string_view text, std::string_view what,
                     NumberRange range, std::string_view note = {});

}  // namespace fragsim::api
