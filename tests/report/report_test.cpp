// The study report (report/report.h; docs/report.md): every number on the page that names a
// summary.json key equals that figure (SI value exactly, shown value to its printed digits, in
// SI and US units); markup in scenario text is shown as text; bad input is refused naming the
// file and leaves nothing behind. The browser side (figures drawn, no network, the PDF) is
// tested in viewer/test/report.test.mjs.
#include "report/report.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <regex>

#include "api/compare_json.h"
#include "api/run_outputs.h"
#include "api/test_support.h"
#include "core/common/error.h"
#include "core/run/paired.h"
#include "core/run/run.h"
#include "formats/output_dir.h"
#include "formats/results_h5.h"
#include "report/report_html.h"

namespace fragsim::report {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;

// The minimal example (one building, B1) on a small plane, fragments slow and steep enough to
// leave a hazardous area; `cancelled` writes the results of a run marked cancelled.
fs::path write_run(const Json& scenario, const fs::path& dir, bool cancelled = false) {
  const api::ScenarioDocument doc = api::parse_scenario_document(scenario);
  const auto site = api::validate_scenario(doc.scenario);
  run::RunResult result = run::run(doc.scenario);
  result.cancelled = cancelled;
  formats::OutputDir out(dir);
  api::stage_run_outputs(out, result, *site, doc, api::build_provenance());
  out.commit();
  return dir / api::kResultsFileName;
}

Json small_scenario() {
  Json sc = api::testing::on_small_plane(api::testing::minimal_example());
  auto& g = sc["fragment_groups"][0];
  g["speed_mps"] = {{"dist", "normal"}, {"mean", 60}, {"sigma", 5}};
  g["direction"]["elevation_deg"] = {40, 80};
  g["count"] = 20000;
  return sc;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

struct Figure {
  std::string key, kind, shown;
  double si = 0.0;
};

// Every <span class="num" data-key=... data-si=... data-kind=...>shown</span> on the page.
std::vector<Figure> keyed_figures(const std::string& html) {
  static const std::regex kSpan(
      R"re(<span class="num" data-key="([^"]*)" data-si="([^"]*)" data-kind="([a-z]*)">([^<]*)</span>)re");
  std::vector<Figure> out;
  for (std::sregex_iterator it(html.begin(), html.end(), kSpan), end; it != end; ++it)
    out.push_back({(*it)[1], (*it)[3], (*it)[4], std::stod((*it)[2])});
  return out;
}

// The SI value converted as the page says it converts (api/units.h factors).
double converted(double si, const std::string& kind, bool us) {
  if (!us) return si;
  if (kind == "length") return si / 0.3048;
  if (kind == "energy") return si / 1.3558179483314004;
  if (kind == "mass") return si / 0.45359237;
  if (kind == "speed") return si / 0.3048;
  if (kind == "density") return si * 600 * 0.3048 * 0.3048;
  return si;
}

// Half a unit of the shown value's last digit ("138.8" -> 0.05; "1.52e+03" -> 5): the shown value
// must be within it of the converted figure.
double half_last_digit(const std::string& shown) {
  const auto e = shown.find_first_of("eE");
  const std::string mantissa = shown.substr(0, e);
  const auto dot = mantissa.find('.');
  const int decimals = dot == std::string::npos ? 0 : static_cast<int>(mantissa.size() - dot - 1);
  const int exponent = e == std::string::npos ? 0 : std::stoi(shown.substr(e + 1));
  return 0.5 * std::pow(10.0, exponent - decimals);
}

class Report : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_report_"); }
  void TearDown() override { fs::remove_all(dir_); }

  void check_figures(const fs::path& h5, bool us) {
    const Json summary = Json::parse(read_text(h5.parent_path() / api::kSummaryFileName));
    const auto figures =
        keyed_figures(report_html(h5, us ? api::UnitSystem::kUs : api::UnitSystem::kSi));
    ASSERT_GE(figures.size(), 60u);  // identity, findings, sectors, buildings, outcomes, ...
    for (const Figure& f : figures) {
      SCOPED_TRACE(f.key + " shown " + f.shown);
      const Json::json_pointer ptr(f.key);
      ASSERT_TRUE(summary.contains(ptr));
      EXPECT_EQ(f.si, summary.at(ptr).get<double>());  // %.17g round-trips exactly
      const double want = converted(f.si, f.kind, us);
      EXPECT_NEAR(std::stod(f.shown), want, half_last_digit(f.shown) * (1 + 1e-9));
    }
  }

  fs::path dir_;
};

TEST_F(Report, EveryKeyedNumberEqualsSummaryJsonInSi) {
  check_figures(write_run(small_scenario(), dir_ / "run"), false);
}

TEST_F(Report, EveryKeyedNumberEqualsSummaryJsonConvertedInUsUnits) {
  const fs::path h5 = write_run(small_scenario(), dir_ / "run");
  check_figures(h5, true);
  const std::string html = report_html(h5, api::UnitSystem::kUs);
  // The threshold of 1 per 55.74 m^2 reads as 1 per 600 ft^2.
  EXPECT_NE(html.find("per 600 ft²"), std::string::npos);
  EXPECT_NE(html.find("data-units=\"us\""), std::string::npos);
}

TEST_F(Report, MarkupInScenarioTextIsShownAsText) {
  Json sc = small_scenario();
  sc["description"] = "<script>alert('d')</script> & \"quoted\"";
  sc["site"]["buildings"][0]["id"] = "<img src=x onerror=alert(1)>";
  sc["fragment_groups"][0]["name"] = "</script><b>group</b>";
  const std::string html = report_html(write_run(sc, dir_ / "run"), api::UnitSystem::kSi);
  EXPECT_EQ(html.find("<script>alert"), std::string::npos);
  EXPECT_EQ(html.find("<img src=x"), std::string::npos);
  EXPECT_EQ(html.find("<b>group</b>"), std::string::npos);
  EXPECT_NE(html.find("&lt;script&gt;alert(&#39;d&#39;)&lt;/script&gt; &amp; &quot;quoted&quot;"),
            std::string::npos);
  EXPECT_NE(html.find("&lt;img src=x onerror=alert(1)&gt;"), std::string::npos);
  // In the figures' JSON the id stays data: no "</script>" can end the script element.
  EXPECT_NE(html.find("\\u003cimg src=x onerror=alert(1)\\u003e"), std::string::npos);
  EXPECT_EQ(html.find("</script><b>"), std::string::npos);
}

// Nothing hazardous and no building: the page is still whole (HFD 0, empty boundary, no
// buildings table), every keyed number still equal to summary.json.
TEST_F(Report, ASiteWithNothingHazardousAndNoBuildingIsReportedWhole) {
  Json sc = small_scenario();
  sc["site"]["buildings"] = Json::array();
  sc["settings"]["hfd_threshold_per_m2"] = 1e6;
  const fs::path h5 = write_run(sc, dir_ / "run");
  const std::string html = report_html(h5, api::UnitSystem::kSi);
  EXPECT_NE(html.find("The site has no buildings."), std::string::npos);
  EXPECT_NE(html.find("data-key=\"/hazardous_fragment_distance_m\" data-si=\"0\""),
            std::string::npos);
  check_figures(h5, false);
}

TEST_F(Report, TheNormalisedScenarioIsInTheAppendixWhole) {
  const fs::path h5 = write_run(small_scenario(), dir_ / "run");
  const std::string html = report_html(h5, api::UnitSystem::kSi);
  const auto start = html.find("<pre id=\"scenario\">");
  ASSERT_NE(start, std::string::npos);
  const auto end = html.find("</pre>", start);
  std::string text = html.substr(start + 19, end - start - 19);
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"&lt;", "<"}, {"&gt;", ">"}, {"&quot;", "\""}, {"&#39;", "'"}, {"&amp;", "&"}})
    for (std::size_t at; (at = text.find(from)) != std::string::npos;)
      text.replace(at, from.size(), to);
  EXPECT_EQ(Json::parse(text),
            Json::parse(formats::read_attribute_string(h5, "/", "scenario_json")));
}

TEST_F(Report, RefusesWhatIsNotAResultsFileNamingIt) {
  const fs::path text = dir_ / "notes.txt";
  std::ofstream(text) << "not hdf5\n";
  const auto refused = [&](const fs::path& in, const std::string& what) {
    try {
      write_report({in, dir_ / "out" / "r.html", std::nullopt, api::UnitSystem::kSi, "", {}});
      ADD_FAILURE() << "accepted " << in;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "RESULTS.h5");
      EXPECT_NE(e.message().find(in.string()), std::string::npos) << e.message();
      EXPECT_NE(e.message().find(what), std::string::npos) << e.message();
    }
    EXPECT_FALSE(fs::exists(dir_ / "out"));  // nothing left behind, not even the folder
  };
  refused(dir_ / "missing.h5", "no such file");
  refused(text, "not an HDF5 file");
  refused(dir_, "not a regular file");
  refused(write_run(small_scenario(), dir_ / "cancelled", true), "cancelled run");
}

TEST_F(Report, AnUnwritableOutputIsRefusedAndLeavesNothing) {
  const fs::path h5 = write_run(small_scenario(), dir_ / "run");
  std::ofstream(dir_ / "a_file") << "x";
  const auto before = std::distance(fs::directory_iterator(dir_), fs::directory_iterator());
  for (const fs::path& out : {dir_ / "a_file" / "r.html", dir_ / "run"}) {
    try {
      write_report({h5, out, std::nullopt, api::UnitSystem::kSi, "", {}});
      ADD_FAILURE() << "wrote " << out;
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), "--out");
      EXPECT_NE(e.message().find(out.string()), std::string::npos) << e.message();
    }
  }
  // A PDF that cannot be printed (no such browser): neither file appears.
  try {
    write_report(
        {h5, dir_ / "r.html", dir_ / "r.pdf", api::UnitSystem::kSi, "/nonexistent/chromium", {}});
    ADD_FAILURE() << "printed without a browser";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--pdf");
    EXPECT_NE(e.message().find("/nonexistent/chromium"), std::string::npos) << e.message();
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), before);
  for (const auto& f : fs::directory_iterator(dir_ / "run"))
    EXPECT_EQ(f.path().filename().string().find(".tmp."), std::string::npos) << f.path();
}

TEST(ReportText, PrettyJsonKeepsScalarArraysOnOneLine) {
  const auto j =
      nlohmann::ordered_json::parse(R"({"a": [1, 2, 3], "b": {"c": "x<y"}, "d": [{"e": 1}]})");
  EXPECT_EQ(pretty_json(j),
            "{\n  \"a\": [1, 2, 3],\n  \"b\": {\n    \"c\": \"x<y\"\n  },\n  \"d\": [\n    {\n"
            "      \"e\": 1\n    }\n  ]\n}");
  EXPECT_EQ(json_for_script(Json{{"k", "</script>&"}}), R"({"k":"\u003c/script\u003e\u0026"})");
  EXPECT_EQ(escape_html("<a href='x'>&\"</a>"), "&lt;a href=&#39;x&#39;&gt;&amp;&quot;&lt;/a&gt;");
}

// A paired comparison (docs/comparison.md): the variant's results.h5 and the comparison's
// compare.json, as `fragsim compare` writes them; the variant moves B1 20 m further out.
struct ComparisonFiles {
  fs::path variant_h5, compare_json;
};
ComparisonFiles write_comparison(const fs::path& dir) {
  const Json base = small_scenario();
  Json variant = base;
  variant["site"]["buildings"][0]["footprint_m"] = {{80, -10}, {100, -10}, {100, 10}, {80, 10}};
  const api::ScenarioDocument bd = api::parse_scenario_document(base);
  const api::ScenarioDocument vd = api::parse_scenario_document(variant);
  const auto bs = api::validate_scenario(bd.scenario), vs = api::validate_scenario(vd.scenario);
  const run::PairedRun paired = run::run_paired(bd.scenario, bs, vd.scenario, vs);
  api::Provenance provenance = api::build_provenance();
  provenance.scenario_sha256 = "variant-sha";
  formats::OutputDir out(dir / "variant");
  api::stage_run_outputs(out, paired.variant, *vs, vd, provenance);
  out.commit();
  api::CompareInputs in;
  in.paired = &paired;
  in.base = &bd.scenario;
  in.base_site = bs.get();
  in.changed = {"site.buildings"};
  in.base_sha256 = "base-sha";
  in.variant_sha256 = "variant-sha";
  in.provenance = api::build_provenance();
  std::ofstream(dir / "compare.json") << api::compare_to_json(in).dump(2);
  return {dir / "variant" / api::kResultsFileName, dir / "compare.json"};
}

// Every <span class="num" data-source="compare" data-key=... > on the page.
std::vector<Figure> compare_figures(const std::string& html) {
  static const std::regex kSpan(
      R"re(<span class="num" data-source="compare" data-key="([^"]*)" data-si="([^"]*)" data-kind="([a-z]*)">([^<]*)</span>)re");
  std::vector<Figure> out;
  for (std::sregex_iterator it(html.begin(), html.end(), kSpan), end; it != end; ++it)
    out.push_back({(*it)[1], (*it)[3], (*it)[4], std::stod((*it)[2])});
  return out;
}

// The comparison's part of the report: every number equals compare.json (SI exactly, shown to
// its digits in SI and US), the summary's numbers are still checked as on any page, and the
// findings say which run of the comparison this is.
TEST_F(Report, AComparisonsNumbersEqualCompareJson) {
  const ComparisonFiles f = write_comparison(dir_);
  const Json compare = Json::parse(read_text(f.compare_json));
  for (const bool us : {false, true}) {
    const std::string html =
        report_html(f.variant_h5, us ? api::UnitSystem::kUs : api::UnitSystem::kSi, f.compare_json);
    EXPECT_NE(html.find("id=\"comparison-table\""), std::string::npos);
    EXPECT_NE(html.find("the <strong>variant</strong> of a paired comparison"), std::string::npos);
    const auto figures = compare_figures(html);
    ASSERT_GE(figures.size(), 15u);  // HFD, B1's impacts and penetrations, left site, density
    for (const Figure& fig : figures) {
      SCOPED_TRACE(fig.key + " shown " + fig.shown);
      const Json::json_pointer ptr(fig.key);
      ASSERT_TRUE(compare.contains(ptr));
      EXPECT_EQ(fig.si, compare.at(ptr).get<double>());
      const double want = converted(fig.si, fig.kind, us);
      EXPECT_NEAR(std::stod(fig.shown), want, half_last_digit(fig.shown) * (1 + 1e-9));
    }
    EXPECT_GE(keyed_figures(html).size(), 60u);  // the rest of the page as before
  }
  check_figures(f.variant_h5, false);
}

TEST_F(Report, ACompareJsonOfOtherRunsIsRefusedNamingIt) {
  const ComparisonFiles f = write_comparison(dir_);
  const fs::path other = write_run(small_scenario(), dir_ / "other");  // no scenario SHA-256
  try {
    report_html(other, api::UnitSystem::kSi, f.compare_json);
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "--compare");
    EXPECT_NE(std::string(e.what()).find("compares other runs"), std::string::npos) << e.what();
  }
  std::ofstream(dir_ / "not.json") << "{\"schema\": \"fragsim.scenario/1\"}";
  EXPECT_THROW(report_html(f.variant_h5, api::UnitSystem::kSi, dir_ / "not.json"), InputError);
}

}  // namespace
}  // namespace fragsim::report
