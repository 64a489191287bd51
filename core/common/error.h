#pragma once
// Errors the core reports about its inputs. `field` names the offending element with the same
// names and indices the scenario contract uses (e.g. "site.buildings[3].footprint_m[2]"), so the
// api layer can pass it straight to the user; the core itself knows nothing of JSON.
#include <stdexcept>
#include <string>

namespace fragsim {

class InputError : public std::runtime_error {
 public:
  InputError(std::string field, const std::string& message)
      : std::runtime_error(field.empty() ? message : field + ": " + message),
        field_(std::move(field)),
        message_(message) {}
  const std::string& field() const { return field_; }
  const std::string& message() const { return message_; }

 private:
  std::string field_;
  std::string message_;
};

}  // namespace fragsim
