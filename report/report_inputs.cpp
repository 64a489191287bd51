// Reading a results.h5 for the report (report_inputs.h).
#include "report/report_inputs.h"

#include <array>
#include <cstring>
#include <fstream>

#include "core/common/error.h"
#include "formats/results_h5.h"

namespace fragsim::report {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void refuse(const fs::path& path, const std::string& problem) {
  throw InputError("RESULTS.h5", path.string() + ": " + problem);
}

// The HDF5 signature sits at byte 0, 512, 1024, 2048, ... (HDF5 File Format Specification,
// "Format Signature"); files fragsim writes have it at 0.
bool has_hdf5_signature(const fs::path& path) {
  static constexpr std::array<char, 8> kSignature = {'\x89', 'H',  'D',    'F',
                                                     '\r',   '\n', '\x1a', '\n'};
  std::ifstream in(path, std::ios::binary);
  for (std::streamoff at : {0, 512, 1024, 2048}) {
    std::array<char, 8> head{};
    in.seekg(at);
    if (!in.read(head.data(), head.size())) return false;
    if (head == kSignature) return true;
  }
  return false;
}

std::string attribute_or(const fs::path& f, const char* name, const std::string& fallback) {
  try {
    return formats::read_attribute_string(f, "/", name);
  } catch (const std::exception&) {
    return fallback;
  }
}

void check_readable(const fs::path& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) refuse(path, "no such file");
  if (!fs::is_regular_file(path, ec)) refuse(path, "not a regular file");
  if (!std::ifstream(path, std::ios::binary)) refuse(path, "cannot be read");
  if (!has_hdf5_signature(path)) refuse(path, "not an HDF5 file");
}

void read_attributes(const fs::path& path, ReportInputs& in) {
  try {
    if (formats::read_attribute_string(path, "/", "file_type") != formats::kResultsFileType)
      refuse(path, "not a fragsim results file (file_type is not \"fragsim.results\")");
  } catch (const InputError&) {
    throw;
  } catch (const std::exception&) {
    refuse(path, "not a fragsim results file (no file_type attribute)");
  }
  in.format_version = static_cast<int>(formats::read_attribute_int64(path, "/", "format_version"));
  if (formats::read_attribute_int64(path, "/", "cancelled") != 0)
    refuse(path, "the results of a cancelled run: its figures are partial and are not reported");
  if (in.format_version < 5)
    refuse(path, "results format " + std::to_string(in.format_version) +
                     " stores no summary (format 5 and later do): run the scenario again");
  in.summary =
      nlohmann::ordered_json::parse(formats::read_attribute_string(path, "/", "summary_json"));
  in.scenario =
      nlohmann::ordered_json::parse(formats::read_attribute_string(path, "/", "scenario_json"));
  in.fragsim_version = attribute_or(path, "fragsim_version", "unknown");
  in.git_sha = attribute_or(path, "git_sha", "unknown");
  in.scenario_sha256 = attribute_or(path, "scenario_sha256", "not recorded");
  in.created_utc = attribute_or(path, "created_utc", "unknown");
  in.machine = attribute_or(path, "machine", "not recorded");
  in.wall_s = formats::read_attribute_double(path, "/", "wall_s");
  in.threads = formats::read_attribute_int64(path, "/", "threads");
}

}  // namespace

ReportInputs read_report_inputs(const fs::path& path) {
  check_readable(path);
  ReportInputs in;
  in.file_name = path.filename().string();
  try {
    read_attributes(path, in);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    refuse(path, e.what());
  }
  in.results = gis::read_results_file(path);
  in.boundary = gis::plan_boundary(in.results);
  return in;
}

void add_comparison(ReportInputs& in, const fs::path& compare_json, const std::string& field) {
  std::ifstream file(compare_json, std::ios::binary);
  if (!file) throw InputError(field, compare_json.string() + ": cannot be read");
  nlohmann::ordered_json c;
  try {
    c = nlohmann::ordered_json::parse(file);
  } catch (const std::exception& e) {
    throw InputError(field, compare_json.string() + ": not JSON (" + e.what() + ")");
  }
  if (!c.is_object() || c.value("schema", "") != "fragsim-compare")
    throw InputError(field, compare_json.string() + ": not a fragsim compare.json");
  const auto& prov = c.value("provenance", nlohmann::ordered_json::object());
  if (prov.value("variant_scenario_sha256", "") == in.scenario_sha256)
    in.compare_role = "variant";
  else if (prov.value("base_scenario_sha256", "") == in.scenario_sha256)
    in.compare_role = "base";
  else
    throw InputError(field, compare_json.string() +
                                " compares other runs: neither its base's nor "
                                "its variant's scenario SHA-256 is this results file's (" +
                                in.scenario_sha256 + ")");
  in.compare = std::move(c);
}

}  // namespace fragsim::report
