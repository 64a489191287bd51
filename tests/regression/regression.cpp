#include "regression/regression.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iomanip>
#include <map>
#include <numeric>
#include <set>
#include <sstream>
#include <stdexcept>

#include "api/scenario_json.h"
#include "api/sha256.h"
#include "core/common/types.h"
#include "core/run/run.h"
#include "fragsim/version.h"

namespace fragsim::regression {
namespace {

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Size of one terrain cell: the HFD is the distance of a triangle centroid, so it moves in steps
// of about a cell whatever the statistics. Plane and grid terrains: the grid cell (the 2-D index
// bucket is exactly one cell); meshes: the side of a square of two mean triangles.
double terrain_cell_m(const scene::Site& site) {
  if (site.terrain_is_lattice()) {
    const Vec2& c = site.terrain_index().cell;
    return std::max(c.x(), c.y());
  }
  double area = 0.0;
  const auto n = static_cast<std::uint32_t>(site.terrain_triangle_count());
  for (std::uint32_t t = 0; t < n; ++t) area += site.terrain_triangle_area(t);
  return n ? std::sqrt(2.0 * area / n) : 0.0;
}

Json estimate_json(const run::Estimate& e) {
  return Json{{"mean", e.mean}, {"se", e.std_error}};
}

Json vec_json(const Vec3& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

std::string number(double v) {
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}

// --- comparison ---------------------------------------------------------------------------

class Comparer {
 public:
  explicit Comparer(Comparison& out) : out_(out) {}

  // A mean with its standard error. The tolerance:
  //   kSigmas * sqrt(se_base^2 + se_new^2) + kRelativeFloor * max(|base|, |new|) + kAbsoluteFloor
  // * kSigmas = 4: a rerun with the same seed and unchanged physics is identical (the run is
  //   bit-reproducible), and a rerun whose random numbers are drawn differently (another seed, a
  //   change of sampling) is an independent estimate of the same figure, which differs from the
  //   base by more than 4 combined se with probability 6e-5 for a normal estimate. The set
  //   compares about 630 figures (many exactly 0 on both sides); in the calibration (20 other
  //   seeds per scenario, docs/testing.md) no mean moved beyond 3.5 combined se. A real shift of
  //   6 combined se is flagged (tested).
  // * The relative floor (1e-9) absorbs rounding: a change of summation order or of compiler
  //   moves a sum by ~1e-15 of itself, far below any statistical move; it matters only where
  //   both se are 0 (every history ended the same way: the figure is exact and must stay so).
  // * The absolute floor (1e-12 of the figure's unit: fragments, fragments/m^2) is a guard at
  //   zero, far below one history's contribution (the smallest non-zero density stored in the
  //   baselines is 5e-4 per m^2, one history).
  void estimate(const std::string& name, double base, double base_se, double now, double now_se) {
    const double combined = std::hypot(base_se, now_se);
    const double tol = kSigmas * combined +
                       kRelativeFloor * std::max(std::abs(base), std::abs(now)) + kAbsoluteFloor;
    check(name, base, base_se, now, now_se, combined, tol);
  }

  // A count of histories (an outcome): binomial se sqrt(c (1 - c/N)) over all histories, which
  // is at least the stratified one; integers, no floor (0 and N are exact).
  void count(const std::string& name, double base, double now, double histories) {
    const auto se = [&](double c) {
      return histories > 0 ? std::sqrt(std::max(0.0, c * (1.0 - c / histories))) : 0.0;
    };
    const double combined = std::hypot(se(base), se(now));
    check(name, base, se(base), now, se(now), combined, kSigmas * combined);
  }

  // A hazardous fragment distance with its band [lower, upper] (the HFDs of the fields mean - se
  // and mean + se). Half the band stands for one se of the HFD (the field moved by one se moves
  // the threshold crossing by about that much): tolerance
  //   kSigmas * sqrt(((upper-lower)_base/2)^2 + ((upper-lower)_new/2)^2) + one terrain cell
  // (the HFD is a centroid's distance: it moves in steps of a cell) + the floors.
  void hfd(const std::string& name, const Json& base, const Json& now, double cell_m) {
    const double b = base.at("hfd_m").get<double>(), n = now.at("hfd_m").get<double>();
    const double b_se = 0.5 * (base.at("upper_m").get<double>() - base.at("lower_m").get<double>());
    const double n_se = 0.5 * (now.at("upper_m").get<double>() - now.at("lower_m").get<double>());
    const double combined = std::hypot(b_se, n_se);
    const double tol = kSigmas * combined + cell_m +
                       kRelativeFloor * std::max(std::abs(b), std::abs(n)) + kAbsoluteFloor;
    check(name, b, b_se, n, n_se, combined, tol);
  }

  // A sector's HFD. Sectors are where the field is thinnest: a sector's HFD is often set by a
  // few triangles crossed by a handful of histories, whose standard errors are poor (a triangle
  // no history crossed has se 0), so it jumps by tens of metres between independent runs
  // while the +-1 se bands of both runs are narrow (calibration, docs/testing.md). A sector is
  // compared at field level instead: the sector HFDs of the fields mean -+ kSigmas se (stored
  // as lower_k_m, upper_k_m) of the two runs must overlap within one terrain cell,
  //   max(lower_k_base, lower_k_new) <= min(upper_k_base, upper_k_new) + cell,
  // i.e. some field within kSigmas se of both runs gives both HFDs. The overall HFD and the
  // densities along the rays and at the densest triangles are the sharper checks of the field.
  void sector_hfd(const std::string& name, const Json& base, const Json& now, double cell_m) {
    const double b = base.at("hfd_m").get<double>(), n = now.at("hfd_m").get<double>();
    const double b_se = 0.5 * (base.at("upper_m").get<double>() - base.at("lower_m").get<double>());
    const double n_se = 0.5 * (now.at("upper_m").get<double>() - now.at("lower_m").get<double>());
    const double lo =
        std::max(base.at("lower_k_m").get<double>(), now.at("lower_k_m").get<double>());
    const double hi =
        std::min(base.at("upper_k_m").get<double>(), now.at("upper_k_m").get<double>());
    const double combined = std::hypot(b_se, n_se);
    ++out_.figures;
    const double gap = lo - hi;
    if (combined > 0.0)
      out_.sigmas.push_back({name, std::abs(n - b) / combined, std::max(0.0, gap) / cell_m});
    if (gap <= cell_m + kRelativeFloor * std::max(lo, hi) + kAbsoluteFloor) return;
    std::ostringstream note;
    note << "the " << kSigmas << " se bands [" << number(base.at("lower_k_m").get<double>()) << ", "
         << number(base.at("upper_k_m").get<double>()) << "] (base) and ["
         << number(now.at("lower_k_m").get<double>()) << ", "
         << number(now.at("upper_k_m").get<double>()) << "] (new) are " << number(gap)
         << " m apart, more than one cell (" << number(cell_m) << " m)";
    out_.moved.push_back(Moved{name, b, b_se, n, n_se, combined, cell_m, note.str(), false});
  }

  void missing(const std::string& name, const std::string& note) {
    ++out_.figures;
    Moved m;
    m.figure = name;
    m.note = note;
    m.missing = true;
    out_.moved.push_back(m);
  }

 private:
  void check(const std::string& name, double base, double base_se, double now, double now_se,
             double combined, double tol) {
    ++out_.figures;
    const double diff = std::abs(now - base);
    if (combined > 0.0) out_.sigmas.push_back({name, diff / combined, diff / tol});
    if (diff <= tol) return;
    out_.moved.push_back(Moved{name, base, base_se, now, now_se, combined, tol, "", false});
  }
  Comparison& out_;
};

// Elements of an array of objects keyed by `key` (a building id, a triangle index, ...).
std::map<std::string, const Json*> by_key(const Json& array, const char* key) {
  std::map<std::string, const Json*> m;
  for (const Json& e : array) m[e.at(key).dump()] = &e;
  return m;
}

std::string unquoted(std::string s) {
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') return s.substr(1, s.size() - 2);
  return s;
}

// The HFD flagged as a lower bound in one run and not in the other is a changed result, however
// close the numbers: say so. The hazardous fragments leaving the site are compared as an estimate.
void compare_site_boundary(Comparer& cmp, Comparison& out, const Json& base, const Json& now) {
  if (!base.contains("site_boundary")) {
    cmp.missing("site_boundary", "missing in the base (regenerate)");
    return;
  }
  if (!now.contains("site_boundary")) {
    cmp.missing("site_boundary", "missing in the new run");
    return;
  }
  const Json& b = base.at("site_boundary");
  const Json& n = now.at("site_boundary");
  if (b.at("hfd_cut") == n.at("hfd_cut"))
    ++out.figures;
  else
    cmp.missing("site_boundary.hfd_cut",
                "the HFD is " + std::string(b.at("hfd_cut").get<bool>() ? "" : "not ") +
                    "cut by the site boundary in the base, " +
                    (n.at("hfd_cut").get<bool>() ? "" : "not ") + "now");
  const Json& bl = b.at("left_hazardous");
  const Json& nl = n.at("left_hazardous");
  cmp.estimate("site_boundary.left_hazardous", bl.at("mean").get<double>(),
               bl.at("se").get<double>(), nl.at("mean").get<double>(), nl.at("se").get<double>());
}

}  // namespace

// --- the regression set -------------------------------------------------------------------

const std::vector<Case>& cases() {
  // Reproducible by hand with fragsim run (--samples-scale X; bounce: settings.bounce in the
  // file). About 3 s for the whole set on 2 cores, Release (docs/testing.md).
  static const std::vector<Case> set = {
      {"demo", "examples/demo/scenario.json", std::nullopt, std::nullopt, "none (as shipped)"},
      {"demo-bounce", "examples/demo/scenario.json", true, std::nullopt, "settings.bounce = true"},
      {"minimal", "examples/minimal/scenario.json", std::nullopt, 10.0,
       "samples x 10 (fragsim run --samples-scale 10)"},
      {"minimal-bounce", "examples/minimal/scenario.json", true, 10.0,
       "settings.bounce = true; samples x 10 (fragsim run --samples-scale 10)"},
      {"fletcher-bowen-hard-060fps", "examples/validation/fletcher-bowen/hard-060fps.json",
       std::nullopt, 10.0,
       "samples x 10 (fragsim run --samples-scale 10; bounce, slide and roll of 5,000 blocks)"},
      {"fletcher-bowen-soft-060fps", "examples/validation/fletcher-bowen/soft-060fps.json",
       std::nullopt, 10.0,
       "samples x 10 (fragsim run --samples-scale 10; bounce, slide and roll of 5,000 blocks)"},
  };
  return set;
}

const Case& find_case(const std::string& name) {
  for (const Case& c : cases())
    if (c.name == name) return c;
  throw std::invalid_argument("no regression scenario named \"" + name + "\"");
}

std::filesystem::path source_root() {
  return std::filesystem::path(FRAGSIM_SOURCE_DIR);
}

std::filesystem::path baseline_path(const Case& c) {
  return source_root() / "tests" / "regression" / "baselines" / (c.name + ".json");
}

run::Scenario load_scenario(const Case& c) {
  run::Scenario sc = api::parse_scenario_document_text(read_file(source_root() / c.file)).scenario;
  if (c.bounce) sc.settings.bounce = *c.bounce;
  if (c.samples_scale) {
    for (auto& g : sc.groups) {
      const double scaled = std::round(static_cast<double>(g.samples) * *c.samples_scale);
      g.samples = std::max<std::int64_t>(1, static_cast<std::int64_t>(scaled));
    }
  }
  return sc;
}

CaseRun run_case(const Case& c, std::optional<std::uint64_t> seed) {
  CaseRun r;
  r.scenario = load_scenario(c);
  if (seed) r.scenario.settings.seed = *seed;
  const auto t0 = std::chrono::steady_clock::now();
  r.site = api::validate_scenario(r.scenario);
  r.result = run::run(r.scenario, r.site);
  r.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

SectorHfd hazardous_distances(const scene::Site& site, const std::vector<double>& density,
                              double threshold, const Vec3& origin) {
  SectorHfd h;
  for (std::uint32_t t = 0; t < density.size(); ++t) {
    if (!(density[t] >= threshold) || density[t] <= 0.0) continue;
    const Vec3 c = site.terrain_triangle_centroid(t);
    const double dx = c.x() - origin.x(), dy = c.y() - origin.y();
    const double r = std::hypot(dx, dy);
    h.overall_m = std::max(h.overall_m, r);
    double az = std::atan2(dy, dx) / kDegToRad;
    if (az < 0.0) az += 360.0;
    const auto k = static_cast<std::size_t>(std::clamp(static_cast<int>(az / 10.0), 0, 35));
    h.sector_m[k] = std::max(h.sector_m[k], r);
  }
  return h;
}

std::vector<double> shifted_field(const run::RunResult& r, double sign) {
  std::vector<double> f(r.ptn_density_per_m2.size());
  for (std::size_t t = 0; t < f.size(); ++t)
    f[t] = r.ptn_density_per_m2[t] + sign * r.ptn_std_error_per_m2[t];
  return f;
}

std::vector<SampledTriangle> choose_triangles(const CaseRun& run) {
  const run::RunResult& r = run.result;
  const scene::Site& site = *run.site;
  std::vector<SampledTriangle> out;
  std::set<std::int64_t> seen;

  std::vector<std::uint32_t> order(r.ptn_density_per_m2.size());
  std::iota(order.begin(), order.end(), 0u);
  const auto denser = [&](std::uint32_t a, std::uint32_t b) {
    const double da = r.ptn_density_per_m2[a], db = r.ptn_density_per_m2[b];
    return da != db ? da > db : a < b;
  };
  const std::size_t n_dense = std::min<std::size_t>(kDensestTriangles, order.size());
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(n_dense),
                    order.end(), denser);
  for (std::size_t i = 0; i < n_dense; ++i) {
    if (!(r.ptn_density_per_m2[order[i]] > 0.0)) break;
    out.push_back({order[i], "densest #" + std::to_string(i + 1)});
    seen.insert(order[i]);
  }

  // Rays from the HFD origin, at multiples of a distance: inside the hazardous area, on its
  // edge and beyond it. Through the kSectorRays sectors of largest HFD (at the sector's centre,
  // multiples of the sector's HFD: where the field is), and the four axes (multiples of the HFD,
  // or with no HFD of the densest triangle's distance).
  const Vec3 origin = site.to_local(r.hfd_origin_m);
  const auto ray = [&](double az, double d, const std::string& what) {
    for (double f : kRayDistances) {
      const double x = origin.x() + f * d * std::cos(az * kDegToRad);
      const double y = origin.y() + f * d * std::sin(az * kDegToRad);
      const std::int64_t t = site.terrain_triangle_at(x, y);
      if (t < 0 || !seen.insert(t).second) continue;
      out.push_back({t, what + " " + number(az) + " deg, " + number(f) + " x " +
                            (what == "axis" ? "HFD" : "sector HFD") + " (" + number(f * d) +
                            " m)"});
    }
  };
  std::array<std::size_t, 36> sectors{};
  std::iota(sectors.begin(), sectors.end(), std::size_t{0});
  std::stable_sort(sectors.begin(), sectors.end(), [&](std::size_t a, std::size_t b) {
    return r.hfd_by_sector_m[a] > r.hfd_by_sector_m[b];
  });
  for (int i = 0; i < kSectorRays; ++i) {
    const std::size_t k = sectors[static_cast<std::size_t>(i)];
    if (r.hfd_by_sector_m[k] > 0.0)
      ray(10.0 * static_cast<double>(k) + 5.0, r.hfd_by_sector_m[k], "sector " + std::to_string(k));
  }
  double d = r.hazardous_fragment_distance_m;
  if (!(d > 0.0) && r.max_ptn_triangle >= 0) {
    const Vec3 c = site.terrain_triangle_centroid(static_cast<std::uint32_t>(r.max_ptn_triangle));
    d = std::hypot(c.x() - origin.x(), c.y() - origin.y());
  }
  if (d > 0.0)
    for (double az : {0.0, 90.0, 180.0, 270.0}) ray(az, d, "axis");
  return out;
}

std::vector<SampledTriangle> triangles_of(const Json& figures) {
  std::vector<SampledTriangle> out;
  for (const Json& e : figures.at("ptn_triangles"))
    out.push_back({e.at("triangle").get<std::int64_t>(), e.at("why").get<std::string>()});
  return out;
}

Json measure(const CaseRun& run, const std::vector<SampledTriangle>& triangles) {
  const run::RunResult& r = run.result;
  const scene::Site& site = *run.site;
  const run::Settings& st = run.scenario.settings;
  Json j;

  Json samples = Json::array();
  for (const auto& g : run.scenario.groups) samples.push_back(g.samples);
  j["inputs"] = {{"seed", r.seed},
                 {"bounce", st.bounce},
                 {"samples_per_group", samples},
                 {"histories", r.histories_done},
                 {"real_fragments", r.real_fragments},
                 {"terrain_triangles", site.terrain_triangle_count()},
                 {"terrain_cell_m", terrain_cell_m(site)},
                 {"hfd_threshold_per_m2", st.hfd_threshold_per_m2},
                 {"hfd_origin_m", vec_json(r.hfd_origin_m)},
                 {"sector_band_sigmas", kSigmas}};

  j["hfd"] = {{"hfd_m", r.hazardous_fragment_distance_m},
              {"lower_m", r.hfd_lower_m},
              {"upper_m", r.hfd_upper_m}};

  const Vec3 origin = site.to_local(r.hfd_origin_m);
  const SectorHfd lower =
      hazardous_distances(site, shifted_field(r, -1.0), st.hfd_threshold_per_m2, origin);
  const SectorHfd upper =
      hazardous_distances(site, shifted_field(r, +1.0), st.hfd_threshold_per_m2, origin);
  const SectorHfd lower_k =
      hazardous_distances(site, shifted_field(r, -kSigmas), st.hfd_threshold_per_m2, origin);
  const SectorHfd upper_k =
      hazardous_distances(site, shifted_field(r, +kSigmas), st.hfd_threshold_per_m2, origin);
  Json sectors = Json::array();
  for (std::size_t k = 0; k < 36; ++k) {
    sectors.push_back({{"sector", k},
                       {"azimuth_deg", Json::array({10 * k, 10 * k + 10})},
                       {"hfd_m", r.hfd_by_sector_m[k]},
                       {"lower_m", lower.sector_m[k]},
                       {"upper_m", upper.sector_m[k]},
                       {"lower_k_m", lower_k.sector_m[k]},
                       {"upper_k_m", upper_k.sector_m[k]}});
  }
  j["sector_hfd"] = sectors;

  // Where the terrain's boundary cuts the HFD (a lower bound), and what left the site while
  // hazardous: the flags must not change (compare()), the count is a figure like the others.
  const run::SiteBoundary& sb = r.site_boundary;
  Json sector_cut = Json::array();
  for (std::size_t k = 0; k < 36; ++k)
    if (sb.hfd_sector_cut[k]) sector_cut.push_back(k);
  j["site_boundary"] = {{"hfd_cut", sb.hfd_cut},
                        {"sectors_cut", sector_cut},
                        {"left_hazardous", estimate_json(sb.left_hazardous)},
                        {"left_hazardous_histories", sb.left_hazardous_histories}};

  j["max_ptn"] = {{"density_per_m2", r.max_ptn_density_per_m2},
                  {"std_error_per_m2",
                   r.max_ptn_triangle >= 0
                       ? r.ptn_std_error_per_m2[static_cast<std::size_t>(r.max_ptn_triangle)]
                       : 0.0},
                  {"triangle", r.max_ptn_triangle}};

  Json ptn = Json::array();
  for (const SampledTriangle& s : triangles) {
    if (s.triangle < 0 || static_cast<std::size_t>(s.triangle) >= r.ptn_density_per_m2.size())
      throw std::runtime_error("sampled triangle " + std::to_string(s.triangle) +
                               " is not a terrain triangle of this site");
    const auto t = static_cast<std::uint32_t>(s.triangle);
    ptn.push_back({{"triangle", s.triangle},
                   {"why", s.why},
                   {"centroid_m", vec_json(site.to_input(site.terrain_triangle_centroid(t)))},
                   {"density_per_m2", r.ptn_density_per_m2[t]},
                   {"std_error_per_m2", r.ptn_std_error_per_m2[t]}});
  }
  j["ptn_triangles"] = ptn;

  Json buildings = Json::array();
  for (const run::BuildingResult& b : r.buildings) {
    buildings.push_back({{"id", b.id},
                         {"impacts", estimate_json(b.impacts)},
                         {"penetrations", estimate_json(b.penetrations)}});
  }
  j["buildings"] = buildings;

  Json outcomes = Json::array();
  for (int o = 0; o < run::kOutcomeCount; ++o) {
    const auto i = static_cast<std::size_t>(o);
    outcomes.push_back({{"outcome", run::outcome_name(static_cast<run::Outcome>(o))},
                        {"fragments", estimate_json(r.outcome_fragments[i])},
                        {"histories", r.outcome_histories[i]}});
  }
  j["outcomes"] = outcomes;
  return j;
}

Json make_baseline(const Case& c, const CaseRun& run, const Provenance& p) {
  Json j;
  j["header"] = {
      {"what",
       "fragsim regression baseline: the figures of a whole run of one scenario, checked by "
       "tests/regression/regression_test.cpp (ctest -R Regression) within 4 combined standard "
       "errors; docs/testing.md, \"Regression baselines\""},
      {"generated_by", "deploy/regen-baselines.sh (tests/regression/regen_baselines.cpp)"},
      {"fragsim_version", kVersion},
      {"commit", p.commit},
      {"date", p.date},
      {"regenerate",
       "./deploy/regen-baselines.sh [NAME...]  (after an intended physics change only: review "
       "git diff tests/regression/baselines and say in the commit why the figures moved)"},
      {"scenario",
       {{"name", c.name},
        {"file", c.file},
        {"file_sha256", api::sha256_hex(read_file(source_root() / c.file))},
        {"changes", c.changes}}}};
  const Json figures = measure(run, choose_triangles(run));
  for (const auto& item : figures.items()) j[item.key()] = item.value();
  return j;
}

Json load_baseline(const Case& c) {
  const auto path = baseline_path(c);
  try {
    return Json::parse(read_file(path));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(path.string() + ": " + e.what());
  }
}

std::string baseline_text(const Json& baseline) {
  std::ostringstream s;
  s << "{\n";
  std::size_t i = 0;
  for (const auto& item : baseline.items()) {
    s << "  " << Json(item.key()).dump() << ": ";
    const Json& v = item.value();
    if (v.is_array()) {
      s << "[\n";
      for (std::size_t k = 0; k < v.size(); ++k)
        s << "    " << v[k].dump() << (k + 1 < v.size() ? ",\n" : "\n");
      s << "  ]";
    } else if (item.key() == "header") {
      std::string h = v.dump(2);
      for (std::size_t p = h.find('\n'); p != std::string::npos; p = h.find('\n', p + 1))
        h.insert(p + 1, "  ");
      s << h;
    } else {
      s << v.dump();
    }
    s << (++i < baseline.size() ? ",\n" : "\n");
  }
  s << "}\n";
  return s.str();
}

Comparison compare(const Json& base, const Json& now) {
  Comparison out;
  Comparer cmp(out);

  // Inputs: equal, or the figures are not comparable (regenerate after an intended change).
  const Json& bi = base.at("inputs");
  const Json& ni = now.at("inputs");
  for (const char* key :
       {"seed", "bounce", "samples_per_group", "histories", "real_fragments", "terrain_triangles",
        "terrain_cell_m", "hfd_threshold_per_m2", "hfd_origin_m", "sector_band_sigmas"}) {
    if (!ni.contains(key) || bi.at(key) != ni.at(key)) {
      out.input_mismatches.push_back(std::string("inputs.") + key + ": base " + bi.at(key).dump() +
                                     ", new " + (ni.contains(key) ? ni.at(key).dump() : "missing"));
    }
  }
  const double cell = bi.at("terrain_cell_m").get<double>();

  cmp.hfd("hfd", base.at("hfd"), now.at("hfd"), cell);
  {
    const Json& bs = base.at("sector_hfd");
    const Json& ns = now.at("sector_hfd");
    for (std::size_t k = 0; k < bs.size(); ++k) {
      const std::string name = "sector_hfd[" + std::to_string(k) + "]";
      if (k >= ns.size()) {
        cmp.missing(name, "missing in the new run");
        continue;
      }
      cmp.sector_hfd(name, bs[k], ns[k], cell);
    }
  }

  compare_site_boundary(cmp, out, base, now);

  {
    const Json& b = base.at("max_ptn");
    const Json& n = now.at("max_ptn");
    cmp.estimate("max_ptn.density_per_m2", b.at("density_per_m2").get<double>(),
                 b.at("std_error_per_m2").get<double>(), n.at("density_per_m2").get<double>(),
                 n.at("std_error_per_m2").get<double>());
  }

  {
    const auto now_by = by_key(now.at("ptn_triangles"), "triangle");
    for (const Json& b : base.at("ptn_triangles")) {
      const std::string key = b.at("triangle").dump();
      const std::string name =
          "ptn_triangles[" + key + "] (" + b.at("why").get<std::string>() + ")";
      const auto it = now_by.find(key);
      if (it == now_by.end()) {
        cmp.missing(name, "missing in the new run");
        continue;
      }
      const Json& n = *it->second;
      // Same index, same place: otherwise the terrain was renumbered and the samples mean nothing.
      const Json& bc = b.at("centroid_m");
      const Json& nc = n.at("centroid_m");
      for (std::size_t i = 0; i < 3; ++i) {
        if (std::abs(bc[i].get<double>() - nc[i].get<double>()) > 1e-6) {
          out.input_mismatches.push_back(name + ": centroid " + bc.dump() + " in the base, " +
                                         nc.dump() + " now (terrain renumbered?)");
          break;
        }
      }
      cmp.estimate(name, b.at("density_per_m2").get<double>(),
                   b.at("std_error_per_m2").get<double>(), n.at("density_per_m2").get<double>(),
                   n.at("std_error_per_m2").get<double>());
    }
  }

  {
    const auto now_by = by_key(now.at("buildings"), "id");
    for (const Json& b : base.at("buildings")) {
      const std::string key = b.at("id").dump();
      const std::string name = "buildings." + unquoted(key);
      const auto it = now_by.find(key);
      if (it == now_by.end()) {
        cmp.missing(name, "building missing in the new run");
        continue;
      }
      for (const char* fig : {"impacts", "penetrations"}) {
        const Json& be = b.at(fig);
        const Json& ne = it->second->at(fig);
        cmp.estimate(name + "." + fig, be.at("mean").get<double>(), be.at("se").get<double>(),
                     ne.at("mean").get<double>(), ne.at("se").get<double>());
      }
    }
    if (now.at("buildings").size() != base.at("buildings").size())
      out.input_mismatches.push_back("buildings: " + std::to_string(base.at("buildings").size()) +
                                     " in the base, " + std::to_string(now.at("buildings").size()) +
                                     " now");
  }

  {
    const auto now_by = by_key(now.at("outcomes"), "outcome");
    const double histories = bi.at("histories").get<double>();
    for (const Json& b : base.at("outcomes")) {
      const std::string key = b.at("outcome").dump();
      const std::string name = "outcomes." + unquoted(key);
      const auto it = now_by.find(key);
      if (it == now_by.end()) {
        cmp.missing(name, "outcome missing in the new run");
        continue;
      }
      const Json& n = *it->second;
      cmp.estimate(name + ".fragments", b.at("fragments").at("mean").get<double>(),
                   b.at("fragments").at("se").get<double>(),
                   n.at("fragments").at("mean").get<double>(),
                   n.at("fragments").at("se").get<double>());
      cmp.count(name + ".histories", b.at("histories").get<double>(),
                n.at("histories").get<double>(), histories);
    }
  }
  return out;
}

std::pair<std::string, double> Comparison::largest() const {
  std::pair<std::string, double> best{"", 0.0};
  for (const auto& f : sigmas)
    if (f.sigmas > best.second) best = {f.figure, f.sigmas};
  return best;
}

std::string report(const Comparison& c) {
  std::ostringstream s;
  for (const std::string& m : c.input_mismatches)
    s << "input differs: " << m << " (the figures are not comparable: regenerate)\n";
  for (const Moved& m : c.moved) {
    s << "moved: " << m.figure;
    if (m.missing) {
      s << ": " << m.note << "\n";
      continue;
    }
    const double diff = m.now - m.base;
    s << ": base " << number(m.base) << " ± " << number(m.base_se) << ", new " << number(m.now)
      << " ± " << number(m.now_se) << ", diff " << (diff >= 0 ? "+" : "") << number(diff);
    if (m.combined_se > 0.0)
      s << " = " << number(diff / m.combined_se) << " combined se";
    else
      s << " (both se 0)";
    if (m.note.empty())
      s << ", tolerance " << number(m.tolerance) << "\n";
    else
      s << "; " << m.note << "\n";
  }
  s << c.figures << " figures compared, " << c.moved.size() << " moved";
  const auto largest = c.largest();
  if (largest.second > 0.0)
    s << "; largest move " << number(largest.second) << " combined se (" << largest.first << ")";
  s << "\n";
  return s.str();
}

}  // namespace fragsim::regression
