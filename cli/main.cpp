// fragsim: the command-line front door onto api + core. Never crashes on bad input: every
// exception ends here with a message and an exit code (0 ok, 2 invalid input, 1 internal error,
// 130 cancelled).
#include <csignal>
#include <cstring>
#include <exception>
#include <iostream>
#include <new>

#include "cli/args.h"
#include "cli/commands.h"
#include "core/common/error.h"
#include "fragsim/version.h"

namespace {

std::atomic<bool> g_cancel{false};
static_assert(std::atomic<bool>::is_always_lock_free, "the signal handler needs a lock-free flag");

// First signal: ask the run to stop (it returns a partial result, which is discarded, and the
// output directory is cleaned up). Second: default action, i.e. terminate now.
extern "C" void on_signal(int sig) {
  if (g_cancel.exchange(true)) {
    std::signal(sig, SIG_DFL);
    std::raise(sig);
  }
}

void install_signal_handlers() {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = on_signal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace fragsim::cli;
  try {
    const Options options = parse_args(std::vector<std::string>(argv + 1, argv + argc));
    switch (options.command) {
      case Command::kHelp: std::cout << usage_text(); return kExitOk;
      case Command::kVersion:
        std::cout << "fragsim " << fragsim::kVersion << " (git " << fragsim::kGitSha << ")\n";
        return kExitOk;
      case Command::kValidate: return validate_command(options);
      case Command::kSiteImport: return site_import_command(options);
      case Command::kExport: return export_command(options);
      case Command::kSiteExportGis: return site_export_gis_command(options);
      case Command::kRun: install_signal_handlers(); return run_command(options, g_cancel);
      case Command::kMerge: install_signal_handlers(); return merge_command(options, g_cancel);
      case Command::kSubmit:
        install_signal_handlers();
        // A server that refuses a body before reading it all closes the connection under the
        // upload: the write fails with EPIPE and the server's answer is reported.
        std::signal(SIGPIPE, SIG_IGN);
        return submit_command(options, g_cancel);
    }
    return kExitInternal;
  } catch (const UsageError& e) {
    std::cerr << "error: " << e.what() << "\n(see fragsim --help)\n";
    return kExitInvalidInput;
  } catch (const fragsim::InputError& e) {
    std::cerr << "error: " << e.what() << "\n";
    return kExitInvalidInput;
  } catch (const std::bad_alloc&) {
    std::cerr << "error: out of memory\n";
    return kExitInternal;
  } catch (const std::exception& e) {
    std::cerr << "error: internal error: " << e.what() << "\n";
    return kExitInternal;
  } catch (...) {
    std::cerr << "error: internal error (unknown exception)\n";
    return kExitInternal;
  }
}
