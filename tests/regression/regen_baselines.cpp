// Regenerates the regression baselines (tests/regression/baselines/<name>.json) from runs of the
// current code; deploy/regen-baselines.sh builds and calls it. Before overwriting a baseline it
// compares the new run with it and prints what moved, for the review of the diff.
//
//   regen_baselines [--commit SHA] [--out DIR] [NAME...]   regenerate (all scenarios by default)
//   regen_baselines --calibrate N [NAME...]                 N other seeds against the stored seed:
//                                                           how far apart independent runs fall
//   regen_baselines --list                                  the scenario names
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "api/machine.h"
#include "fragsim/version.h"
#include "regression/regression.h"

namespace fs = std::filesystem;
using namespace fragsim::regression;

namespace {

void write_atomically(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  const fs::path tmp = path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text;
    if (!out.flush()) throw std::runtime_error("cannot write " + tmp.string());
  }
  fs::rename(tmp, path);
}

int usage() {
  std::cerr << "usage: regen_baselines [--commit SHA] [--out DIR] [NAME...]\n"
               "       regen_baselines --calibrate N [NAME...]\n"
               "       regen_baselines --list\n";
  return 2;
}

// The run must agree with the sector HFDs repeated in regression.cpp (they give the sectors'
// bands); the test checks the same.
bool consistent(const CaseRun& run) {
  const auto& r = run.result;
  const auto origin = run.site->to_local(r.hfd_origin_m);
  const double thr = run.scenario.settings.hfd_threshold_per_m2;
  const SectorHfd mean = hazardous_distances(*run.site, r.ptn_density_per_m2, thr, origin);
  const SectorHfd lo = hazardous_distances(*run.site, shifted_field(r, -1.0), thr, origin);
  const SectorHfd hi = hazardous_distances(*run.site, shifted_field(r, +1.0), thr, origin);
  return mean.overall_m == r.hazardous_fragment_distance_m && mean.sector_m == r.hfd_by_sector_m &&
         lo.overall_m == r.hfd_lower_m && hi.overall_m == r.hfd_upper_m;
}

}  // namespace

int main(int argc, char** argv) {
  std::string commit = fragsim::kGitSha;
  std::optional<fs::path> out_dir;
  int calibrate = 0;
  std::vector<std::string> names;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--list") {
      for (const Case& c : cases()) std::cout << c.name << "\n";
      return 0;
    } else if (a == "--commit" && i + 1 < argc) {
      commit = argv[++i];
    } else if (a == "--out" && i + 1 < argc) {
      out_dir = argv[++i];
    } else if (a == "--calibrate" && i + 1 < argc) {
      calibrate = std::atoi(argv[++i]);
      if (calibrate <= 0) return usage();
    } else if (!a.empty() && a[0] == '-') {
      return usage();
    } else {
      names.push_back(a);
    }
  }
  if (names.empty())
    for (const Case& c : cases()) names.push_back(c.name);

  try {
    bool all_ok = true;
    for (const std::string& name : names) {
      const Case& c = find_case(name);
      const CaseRun run = run_case(c);
      if (!consistent(run)) {
        std::cerr << name
                  << ": the HFDs repeated in tests/regression/regression.cpp no longer match "
                     "RunResult's (core/run/run.cpp changed the HFD's definition?): update them\n";
        return 1;
      }
      const auto& r = run.result;
      std::cout << name << ": " << r.histories_done << " histories, " << run.wall_s << " s, HFD "
                << r.hazardous_fragment_distance_m << " m [" << r.hfd_lower_m << ", "
                << r.hfd_upper_m << "]\n";

      if (calibrate > 0) {
        // Independent runs (other seeds) compared with the stored seed's run, as the test
        // compares: the figures beyond the tolerance, and the largest moves by kind of figure.
        const Json base = measure(run, choose_triangles(run));
        // family -> (figure, se), (figure, fraction of the tolerance used)
        std::map<std::string, std::pair<std::string, double>> largest, closest;
        std::size_t n = 0, over3 = 0, over4 = 0, moved = 0;
        for (int k = 1; k <= calibrate; ++k) {
          const CaseRun other = run_case(c, r.seed + static_cast<std::uint64_t>(k));
          const Comparison cmp = compare(base, measure(other, triangles_of(base)));
          std::cout << "  seed " << other.result.seed << ": HFD "
                    << other.result.hazardous_fragment_distance_m << " m ["
                    << other.result.hfd_lower_m << ", " << other.result.hfd_upper_m << "], "
                    << cmp.moved.size() << " of " << cmp.figures << " figures moved\n";
          if (!cmp.moved.empty()) std::cout << report(cmp);
          moved += cmp.moved.size();
          for (const auto& f : cmp.sigmas) {
            const std::string family = f.figure.substr(0, f.figure.find_first_of(".[ "));
            if (f.sigmas > largest[family].second) largest[family] = {f.figure, f.sigmas};
            if (f.used > closest[family].second) closest[family] = {f.figure, f.used};
            ++n;
            over3 += f.sigmas > 3.0;
            over4 += f.sigmas > 4.0;
          }
        }
        std::cout << "  " << calibrate << " seeds: " << moved << " figures moved; of " << n
                  << " differences with se > 0, " << over3 << " beyond 3 se, " << over4
                  << " beyond 4 se (normal: " << 2.7e-3 * static_cast<double>(n) << ", "
                  << 6.3e-5 * static_cast<double>(n) << ")\n";
        for (const auto& [family, f] : largest)
          std::cout << "    " << family << ": largest move " << f.second << " se (" << f.first
                    << "); closest to its tolerance: " << closest[family].second << " of it ("
                    << closest[family].first << ")\n";
        all_ok = all_ok && moved == 0;
        continue;
      }

      const Json baseline =
          make_baseline(c, run, Provenance{commit, fragsim::api::utc_now_iso8601()});
      const fs::path path = out_dir ? *out_dir / (c.name + ".json") : baseline_path(c);
      if (fs::exists(path)) {
        try {
          const Json old = Json::parse(std::ifstream(path));
          const Comparison cmp = compare(old, measure(run, triangles_of(old)));
          std::cout << "  against the previous baseline (" << old["header"].value("commit", "?")
                    << "):\n"
                    << report(cmp);
        } catch (const std::exception& e) {
          std::cout << "  previous baseline not comparable: " << e.what() << "\n";
        }
      }
      write_atomically(path, baseline_text(baseline));
      std::cout << "  wrote " << path.string() << "\n";
    }
    return all_ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "regen_baselines: " << e.what() << "\n";
    return 1;
  }
}
