// fragsim: the command-line front door onto api + core. Never crashes on bad input: every
// exception ends here with a message and an exit code (0 ok, 2 invalid input, 1 internal error,
// 130 cancelled).
#include <csignal>
#include <exception>
#include <iostream>
#include <new>

#include "app/args.h"
#include "app/commands.h"
#include "app/signals.h"
#include "core/common/error.h"
#include "fragsim/version.h"

int main(int argc, char** argv) {
  using namespace fragsim::app;
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
      case Command::kReport: return report_command(options);
      case Command::kSiteExportGis: return site_export_gis_command(options);
      case Command::kShapeImport: return shape_import_command(options);
      case Command::kGroupsFromMunition: return groups_from_munition_command(options);
      case Command::kRun: install_cancel_handlers(); return run_command(options, cancel_flag());
      case Command::kMerge: install_cancel_handlers(); return merge_command(options, cancel_flag());
      case Command::kCompare:
        install_cancel_handlers();
        return compare_command(options, cancel_flag());
      case Command::kSubmit:
        install_cancel_handlers();
        // A server that refuses a body before reading it all closes the connection under the
        // upload: the write fails with EPIPE and the server's answer is reported.
        std::signal(SIGPIPE, SIG_IGN);
        return submit_command(options, cancel_flag());
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
