#pragma once
// Command-line arguments of `fragsim`.
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace fragsim::cli {

// A malformed command line (exit code 2, like invalid input).
class UsageError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class Command { kHelp, kVersion, kRun, kValidate };

struct Options {
  Command command = Command::kHelp;
  std::string scenario;                 // run, validate
  std::string out;                      // run: --out DIR (required)
  std::optional<int> threads;           // run: --threads N overrides settings.threads
  std::optional<double> samples_scale;  // run: --samples-scale X multiplies every group's samples
  bool quiet = false;                   // run: no progress, no report
};

Options parse_args(const std::vector<std::string>& args);  // args without argv[0]

const char* usage_text();

}  // namespace fragsim::cli
