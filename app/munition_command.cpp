// `fragsim groups from-munition MUNITION.json [--out GROUPS.json]`: fragment groups from a
// munition description (api/munition_json.h). The derivation goes to stderr, the groups to
// --out (written whole, and only when the input is valid) or stdout.
#include <filesystem>
#include <iostream>

#include "api/munition_json.h"
#include "api/scenario_json.h"
#include "app/commands.h"
#include "core/common/error.h"
#include "formats/output_dir.h"

namespace fragsim::app {

namespace {

namespace fs = std::filesystem;

void write_whole(const fs::path& out, const std::string& text) {
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("--out", dir.string() + " is not a directory");
  if (fs::is_directory(out, ec)) throw InputError("--out", out.string() + " is a directory");
  formats::OutputDir staged(dir);
  staged.stage_text(out.filename().string(), text);
  staged.commit();
}

}  // namespace

int groups_from_munition_command(const Options& o) {
  const nlohmann::json j = api::parse_json_text(read_file(o.scenario));
  const api::MunitionGroups g = api::groups_from_munition(j);
  std::cerr << "derivation (" << o.scenario << "):\n";
  for (const std::string& s : g.steps) std::cerr << "  " << s << "\n";
  for (const std::string& n : g.notes) std::cerr << "note: " << n << "\n";
  const std::string text = g.groups.dump(2) + "\n";
  if (o.out.empty()) {
    std::cout << text;
    return kExitOk;
  }
  write_whole(o.out, text);
  std::cerr << "ok: " << o.out << " (" << g.groups.size() << " groups)\n";
  return kExitOk;
}

}  // namespace fragsim::app
