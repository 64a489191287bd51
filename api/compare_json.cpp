#include "api/compare_json.h"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>

#include "api/units.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "formats/h5_writer.h"

namespace fragsim::api {

using Json = nlohmann::ordered_json;

namespace {

// Settings that change no result: they may differ between the base and the variant.
constexpr const char* kFreeSettings[] = {"threads",
                                         "chunk_histories",
                                         "record_fragments",
                                         "record_trajectories",
                                         "max_recorded_trajectories",
                                         "profile"};

nlohmann::json without_free_settings(nlohmann::json settings) {
  if (!settings.is_object()) return settings;
  for (const char* key : kFreeSettings) settings.erase(key);
  return settings;
}

// The first key under `path` where a and b differ, "" when equal.
std::string first_difference(const nlohmann::json& a, const nlohmann::json& b,
                             const std::string& path) {
  if (a == b) return "";
  if (a.is_object() && b.is_object()) {
    for (const auto& [key, value] : a.items()) {
      if (!b.contains(key)) return path + "." + key;
      std::string d = first_difference(value, b.at(key), path + "." + key);
      if (!d.empty()) return d;
    }
    for (const auto& item : b.items())
      if (!a.contains(item.key())) return path + "." + item.key();
  }
  if (a.is_array() && b.is_array() && a.size() == b.size()) {
    for (std::size_t i = 0; i < a.size(); ++i) {
      std::string d = first_difference(a[i], b[i], path + "[" + std::to_string(i) + "]");
      if (!d.empty()) return d;
    }
  }
  return path;
}

// A figure of both runs, its paired difference and the unpaired se of that difference.
Json figure(const run::Estimate& base, const run::Estimate& variant, const run::Estimate& diff) {
  const double unpaired = std::hypot(base.std_error, variant.std_error);
  Json reduction = nullptr;
  if (diff.std_error > 0.0) reduction = (unpaired / diff.std_error) * (unpaired / diff.std_error);
  return {{"base", base.mean},
          {"base_std_error", base.std_error},
          {"variant", variant.mean},
          {"variant_std_error", variant.std_error},
          {"difference", diff.mean},
          {"paired_std_error", diff.std_error},
          {"unpaired_std_error", unpaired},
          {"variance_reduction", reduction}};
}

const run::BuildingResult* building_of(const run::RunResult& r, std::int32_t index) {
  return index >= 0 ? &r.buildings[static_cast<std::size_t>(index)] : nullptr;
}

Json buildings_json(const run::PairedRun& p) {
  Json out = Json::array();
  for (const run::BuildingDifference& d : p.difference.buildings) {
    const run::BuildingResult* b = building_of(p.base, d.base_index);
    const run::BuildingResult* v = building_of(p.variant, d.variant_index);
    const run::Estimate none{};
    out.push_back({{"id", d.id},
                   {"in_base", d.in_base},
                   {"in_variant", d.in_variant},
                   {"impacts", figure(b ? b->impacts : none, v ? v->impacts : none, d.impacts)},
                   {"penetrations", figure(b ? b->penetrations : none, v ? v->penetrations : none,
                                           d.penetrations)}});
  }
  return out;
}

Json hfd_json(const run::PairedRun& p, double threshold) {
  const run::RunResult &b = p.base, &v = p.variant;
  const run::HfdDifference& d = p.difference.hfd;
  Json sectors = {{"base_m", Json::array()},
                  {"variant_m", Json::array()},
                  {"difference_m", Json::array()},
                  {"paired_std_error_m", Json::array()}};
  for (int s = 0; s < run::kHfdSectors; ++s) {
    sectors["base_m"].push_back(b.hfd_by_sector_m[s]);
    sectors["variant_m"].push_back(v.hfd_by_sector_m[s]);
    sectors["difference_m"].push_back(d.by_sector_m[s].mean);
    sectors["paired_std_error_m"].push_back(d.by_sector_m[s].std_error);
  }
  return {{"threshold_per_m2", threshold},
          {"base_m", b.hazardous_fragment_distance_m},
          {"base_band_m", {b.hfd_lower_m, b.hfd_upper_m}},
          {"base_lower_bound", b.site_boundary.hfd_cut},
          {"variant_m", v.hazardous_fragment_distance_m},
          {"variant_band_m", {v.hfd_lower_m, v.hfd_upper_m}},
          {"variant_lower_bound", v.site_boundary.hfd_cut},
          {"difference_m", d.hfd_m.mean},
          {"paired_std_error_m", d.hfd_m.std_error},
          {"by_sector", std::move(sectors)}};
}

Json density_json(const run::PairedRun& p, const scene::Site* base_site) {
  const run::PairedDifference& d = p.difference;
  Json out = {{"same_terrain", d.same_terrain}};
  if (!d.same_terrain) return out;
  std::int64_t beyond_2se = 0;
  for (std::size_t t = 0; t < d.density_per_m2.size(); ++t)
    if (std::abs(d.density_per_m2[t]) > 2.0 * d.density_std_error_per_m2[t]) ++beyond_2se;
  out["max_abs_difference_per_m2"] = d.max_abs_density_per_m2;
  out["max_abs_triangle"] = d.max_abs_triangle;
  if (d.max_abs_triangle >= 0) {
    const auto t = static_cast<std::size_t>(d.max_abs_triangle);
    out["max_abs_difference_signed_per_m2"] = d.density_per_m2[t];
    out["max_abs_paired_std_error_per_m2"] = d.density_std_error_per_m2[t];
    if (base_site != nullptr) {
      const Vec3 c =
          base_site->to_input(base_site->terrain_triangle_centroid(static_cast<std::uint32_t>(t)));
      out["max_abs_location_m"] = {c.x(), c.y(), c.z()};
    }
  }
  out["triangles_beyond_2_std_errors"] = beyond_2se;
  return out;
}

Json outcomes_json(const run::PairedRun& p) {
  Json out = Json::object();
  for (int o = 0; o < run::kOutcomeCount; ++o) {
    const auto k = static_cast<std::size_t>(o);
    out[run::outcome_name(static_cast<run::Outcome>(o))] =
        figure(p.base.outcome_fragments[k], p.variant.outcome_fragments[k],
               p.difference.outcome_fragments[k]);
  }
  return out;
}

Json limitations_json(const run::PairedRun& p) {
  Json out = Json::array();
  for (const auto* r : {&p.base, &p.variant}) {
    if (!r->site_boundary.hfd_cut) continue;
    out.push_back(std::string(r == &p.base ? "The base's" : "The variant's") +
                  " HFD is a lower bound: the terrain's boundary cuts it in " +
                  std::to_string(r->site_boundary.hfd_sectors_cut) +
                  " sectors, so the HFD difference is not a measured change.");
  }
  out.push_back("The HFD difference's standard error is a delete-a-group jackknife over " +
                std::to_string(p.difference.jackknife_groups) +
                " groups of histories: the HFD is a largest distance, not a sum over histories, "
                "and for such a statistic the jackknife is indicative only.");
  if (!p.difference.same_terrain)
    out.push_back(
        "The terrains differ: no per-triangle density difference (each site's density is in its "
        "own results.h5).");
  for (const run::BuildingDifference& d : p.difference.buildings)
    if (!(d.in_base && d.in_variant))
      out.push_back("Building " + d.id + " is only in the " + (d.in_base ? "base" : "variant") +
                    ": its figures are compared with 0.");
  return out;
}

// A printf format of one or two doubles.
std::string format(const char* fmt, double a, double b = 0.0) {
  char buf[96];
  std::snprintf(buf, sizeof buf, fmt, a, b);
  return buf;
}

}  // namespace

std::vector<std::string> check_variant(const nlohmann::json& base, const nlohmann::json& variant) {
  // The HFD difference's jackknife takes Sobol nets whole, in kJackknifeGroups groups.
  const nlohmann::json sl =
      base.value("settings", nlohmann::json::object()).value("stratified_launch", nlohmann::json());
  if (sl.is_object() && sl.value("method", "strata") == "sobol" &&
      sl.value("replicates", std::int64_t{16}) < run::kJackknifeGroups)
    throw InputError("settings.stratified_launch.replicates",
                     "must be >= " + std::to_string(run::kJackknifeGroups) +
                         " in a comparison with method \"sobol\" (the jackknife of the HFD "
                         "difference takes whole nets, in " +
                         std::to_string(run::kJackknifeGroups) + " groups)");
  const std::string groups =
      first_difference(base.value("fragment_groups", nlohmann::json()),
                       variant.value("fragment_groups", nlohmann::json()), "fragment_groups");
  if (!groups.empty())
    throw InputError(groups,
                     "differs from the base's: a comparison flies the base's histories over the "
                     "variant's site, so the fragment groups must be the same");
  const std::string settings = first_difference(
      without_free_settings(base.value("settings", nlohmann::json())),
      without_free_settings(variant.value("settings", nlohmann::json())), "settings");
  if (!settings.empty())
    throw InputError(settings,
                     "differs from the base's: a comparison needs the same settings (seed, "
                     "models, thresholds) so that a difference comes from the site alone");
  std::vector<std::string> changed;
  for (const auto& [key, value] : variant.items()) {
    if (key == "fragment_groups" || key == "settings" || key == "description") continue;
    const nlohmann::json b = base.value(key, nlohmann::json());
    if (b == value) continue;
    if (key != "site" || !value.is_object() || !b.is_object()) {
      changed.push_back(key);
      continue;
    }
    for (const auto& [sub, sv] : value.items())
      if (!b.contains(sub) || b.at(sub) != sv) changed.push_back("site." + sub);
    for (const auto& item : b.items())
      if (!value.contains(item.key())) changed.push_back("site." + item.key());
  }
  for (const auto& item : base.items())
    if (!variant.contains(item.key()) && item.key() != "description") changed.push_back(item.key());
  return changed;
}

Json compare_to_json(const CompareInputs& in) {
  const run::PairedRun& p = *in.paired;
  std::int64_t histories = 0;
  for (const auto& g : in.base->groups) histories += g.samples;
  Json j = {{"schema", "fragsim-compare"},
            {"format_version", kCompareFormatVersion},
            {"provenance",
             {{"version", in.provenance.version},
              {"git_sha", in.provenance.git_sha},
              {"base_scenario_sha256", in.base_sha256},
              {"variant_scenario_sha256", in.variant_sha256}}},
            {"method",
             {{"pairing", "common random numbers: the same histories flown over both sites"},
              {"histories", histories},
              {"seed", in.base->settings.seed},
              {"std_errors", "paired: from the per-history differences in the run's strata"},
              {"hfd_std_error", "delete-a-group jackknife"},
              {"jackknife_groups", p.difference.jackknife_groups}}},
            {"changed", in.changed},
            {"hfd", hfd_json(p, in.base->settings.hfd_threshold_per_m2)},
            {"buildings", buildings_json(p)},
            {"outcomes", outcomes_json(p)},
            {"left_site_hazardous",
             figure(p.base.site_boundary.left_hazardous, p.variant.site_boundary.left_hazardous,
                    p.difference.left_hazardous)},
            {"density", density_json(p, in.base_site)},
            {"timing",
             {{"base_wall_s", p.base.timing.wall_s}, {"variant_wall_s", p.variant.timing.wall_s}}},
            {"limitations", limitations_json(p)}};
  return j;
}

void write_compare_h5(const std::filesystem::path& path, const run::PairedRun& p,
                      const scene::Site& base_site, const Json& compare) {
  const std::lock_guard<std::mutex> lock(formats::h5::hdf5_mutex());
  formats::h5::Writer w(path);
  w.attribute(w.file(), "format", "fragsim-compare");
  w.attribute(w.file(), "format_version", static_cast<std::int64_t>(kCompareFormatVersion));
  w.attribute(w.file(), "compare_json", compare.dump());
  w.attribute(w.file(), "geometry", "base/results.h5 (the terrain's triangles, same order)");
  const run::PairedDifference& d = p.difference;
  if (d.same_terrain) {
    const auto g = w.group("/density");
    w.dataset("/density/difference_per_m2", d.density_per_m2);
    w.dataset("/density/paired_std_error_per_m2", d.density_std_error_per_m2);
    std::vector<double> centroids;
    for (std::uint32_t t = 0; t < base_site.terrain_triangle_count(); ++t) {
      const Vec3 c = base_site.to_input(base_site.terrain_triangle_centroid(t));
      centroids.insert(centroids.end(), {c.x(), c.y(), c.z()});
    }
    w.dataset("/density/centroid_m", centroids.data(), base_site.terrain_triangle_count(), 3);
  }
  w.close();
}

std::string render_compare_text(const Json& c, UnitSystem units) {
  std::ostringstream out;
  out << "Paired comparison (" << c["method"]["histories"].get<std::int64_t>()
      << " histories, seed " << c["method"]["seed"].get<std::uint64_t>() << "), variant - base\n";
  out << "  changed: ";
  for (std::size_t k = 0; k < c["changed"].size(); ++k)
    out << (k ? ", " : "") << c["changed"][k].get<std::string>();
  out << (c["changed"].empty() ? "nothing\n" : "\n");
  const Json& h = c["hfd"];
  out << "  HFD: base " << format_length(h["base_m"].get<double>(), units) << ", variant "
      << format_length(h["variant_m"].get<double>(), units) << ", difference "
      << (h["difference_m"].get<double>() >= 0 ? "+" : "")
      << format_length(h["difference_m"].get<double>(), units) << " +- "
      << format_length(h["paired_std_error_m"].get<double>(), units) << " (jackknife)\n";
  int unchanged = 0;
  for (const Json& b : c["buildings"]) {
    if (b["impacts"]["difference"].get<double>() == 0.0 &&
        b["impacts"]["paired_std_error"].get<double>() == 0.0 &&
        b["penetrations"]["difference"].get<double>() == 0.0 &&
        b["penetrations"]["paired_std_error"].get<double>() == 0.0) {
      ++unchanged;
      continue;
    }
    out << "  " << b["id"].get<std::string>() << ":\n";
    for (const char* key : {"impacts", "penetrations"}) {
      const Json& f = b[key];
      out << "    " << key
          << format(": %.4g -> %.4g,", f["base"].get<double>(), f["variant"].get<double>())
          << format(" difference %+.4g +- %.2g (paired;", f["difference"].get<double>(),
                    f["paired_std_error"].get<double>())
          << format(" +- %.2g unpaired)\n", f["unpaired_std_error"].get<double>());
    }
  }
  if (unchanged > 0)
    out << "  " << unchanged << " building" << (unchanged == 1 ? "" : "s")
        << ": the same histories hit them alike in both sites (difference 0, se 0)\n";
  for (const Json& l : c["limitations"]) out << "  note: " << l.get<std::string>() << "\n";
  return out.str();
}

}  // namespace fragsim::api
