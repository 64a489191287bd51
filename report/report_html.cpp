// The study report's page (report_html.h). Each section is one function; numbers go through
// Page::num so that each carries its summary.json key and SI value.
#include "report/report_html.h"

#include <cmath>
#include <cstdio>

#include "report/page.h"
#include "report/report_assets.h"
#include "report/report_figures.h"

namespace fragsim::report {

namespace {

// ---- sections ----

void head(Page& p) {
  p.raw("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">");
  p.raw("<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">");
  p.raw(
      "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; "
      "script-src 'unsafe-inline'; style-src 'unsafe-inline'; img-src data: blob:\">");
  p.raw("<title>");
  p.text("Fragment hazard study: " + p.in().file_name);
  p.raw("</title><style>");
  p.raw(report_asset("report.css"));
  p.raw("</style></head><body>\n");
}

void title(Page& p, const std::string& written_utc) {
  p.raw("<header><h1>Fragment hazard study report</h1>");
  p.raw("<p class=\"units-badge\" id=\"units\" data-units=\"");
  p.raw(api::unit_system_name(p.units()));
  p.raw(p.units() == UnitSystem::kUs ? "\">US customary units (SI values stored)</p>"
                                     : "\">SI units</p>");
  p.raw("<p class=\"description\" id=\"description\">");
  p.text(str_or(p.in().scenario, "description", "(the scenario has no description)"));
  p.raw("</p><p class=\"written\">Report written ");
  p.text(written_utc);
  p.raw(" by fragsim ");
  p.text(p.in().fragsim_version);
  p.raw(" from ");
  p.raw("<code>" + esc(p.in().file_name) + "</code>.</p></header>\n");
}

void identity(Page& p) {
  const ReportInputs& in = p.in();
  const Json& s = p.summary();
  p.raw("<section id=\"identity\"><h2>1. Study identity</h2><table class=\"kv\">");
  p.kv("Scenario SHA-256", "<code>" + esc(in.scenario_sha256) + "</code>");
  p.kv("Code", "fragsim " + esc(in.fragsim_version) + ", git <code>" + esc(in.git_sha) + "</code>");
  p.kv("Seed", esc(s.contains("seed") ? s["seed"].dump() : "n/a"));
  p.kv("Run finished (UTC)", esc(in.created_utc));
  p.kv("Machine", esc(in.machine));
  p.kv("Threads", std::to_string(in.threads));
  p.kv("Run time", p.value(in.wall_s, Kind::kSeconds));
  p.kv("Histories", p.num("/histories_done", Kind::kPlain, false) + " simulated (" +
                        p.num("/samples", Kind::kPlain, false) + " in the estimates, " +
                        p.num("/batches", Kind::kPlain, false) + " batches), representing " +
                        p.num("/real_fragments", Kind::kCount, false) + " real fragments");
  p.kv("Stop reason", esc(str_or(s, "stop_reason", "n/a")));
  p.raw("</table></section>\n");
}

void findings(Page& p) {
  const auto& b = p.in().boundary;
  p.raw("<section id=\"findings\"><h2>2. Findings</h2>");
  warnings(p);
  p.raw("<table class=\"kv key-figures\">");
  p.kv("Hazardous fragment distance (HFD)",
       "<strong>" + p.bound_mark("/hfd_bound") +
           p.num("/hazardous_fragment_distance_m", Kind::kLength) + "</strong>" +
           (p.bound_mark("/hfd_bound").empty() ? "" : " <em class=\"flag\">lower bound</em>"));
  p.kv("HFD ±1 se band", p.bound_mark("/hfd_band_bound/0") +
                             p.num("/hazardous_fragment_distance_band_m/0", Kind::kLength) +
                             " to " + p.bound_mark("/hfd_band_bound/1") +
                             p.num("/hazardous_fragment_distance_band_m/1", Kind::kLength));
  p.kv("Threshold density", p.num("/hfd_threshold_per_m2", Kind::kDensity) + " (" +
                                threshold_words(p.summary(), p.units()) + ")");
  // Where the site boundary cuts the HFD, the boundary drawn from the same field is cut too.
  const std::string cut = p.bound_mark("/hfd_bound"), cut_upper = p.bound_mark("/hfd_band_bound/1");
  p.kv("Site-plan boundary: sector envelope",
       cut + p.value(b.envelope.max_radius_m, Kind::kLength) + " (+1 se: " + cut_upper +
           p.value(b.envelope_upper.max_radius_m, Kind::kLength) + ")");
  p.kv("Site-plan boundary: smoothed contour",
       cut + p.value(b.smoothed_hfd_m, Kind::kLength) + " (closing radius " +
           p.value(b.smoothing_m, Kind::kLength) + "; never shorter than the HFD)");
  p.raw("</table></section>\n");
}

void results(Page& p) {
  p.raw("<section id=\"results\"><h2>5. Results</h2>");
  p.raw("<figure id=\"fig-map\"><div class=\"plot\" data-plot=\"map\"></div><figcaption>");
  p.text(map_caption(p.in(), p.units()));
  p.raw("</figcaption></figure>");
  p.raw("<figure id=\"fig-rose\"><div class=\"plot\" data-plot=\"rose\"></div><figcaption>");
  p.text(rose_caption(p.units()));
  p.raw("</figcaption></figure>");
  p.raw("<figure id=\"fig-profile\"><div class=\"plot\" data-plot=\"profile\"></div><figcaption>");
  p.text(profile_caption(p.units()));
  p.raw("</figcaption></figure>");
  sector_table(p);
  buildings_table(p);
  outcomes_table(p);
  comparison_section(p);
  p.raw("</section>\n");
}

void appendix(Page& p) {
  p.raw("<section id=\"appendix\" class=\"appendix\"><h2>Appendix A. The normalised scenario</h2>");
  p.raw(
      "<p>Every default filled in and every command-line override applied, as stored in the "
      "results file (attribute <code>scenario_json</code>); values in SI as the scenario "
      "states them.</p><pre id=\"scenario\">");
  p.text(pretty_json(p.in().scenario));
  p.raw("</pre></section>\n");
}

void scripts(Page& p, const nlohmann::json& figures) {
  p.raw("<script type=\"application/json\" id=\"report-data\">");
  p.raw(json_for_script(figures));
  p.raw("</script>\n<script>");
  p.raw(report_asset("vendor/d3.min.js"));
  p.raw("</script>\n<script>");
  p.raw(report_asset("vendor/plot.umd.min.js"));
  p.raw("</script>\n<script>");
  p.raw(report_asset("report.js"));
  p.raw("</script>\n</body></html>\n");
}

}  // namespace

std::string escape_html(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string json_for_script(const nlohmann::json& j) {
  const std::string text = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {  // only inside JSON strings: JSON syntax has none of them
    if (c == '<')
      out += "\\u003c";
    else if (c == '>')
      out += "\\u003e";
    else if (c == '&')
      out += "\\u0026";
    else
      out += c;
  }
  return out;
}

namespace {

bool scalar_array(const Json& j) {
  if (!j.is_array()) return false;
  for (const auto& e : j)
    if (e.is_structured()) return false;
  return true;
}

void pretty(const Json& j, int indent, std::string& out) {
  const auto dump = [](const Json& v) {
    return v.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  };
  if (!j.is_structured() || scalar_array(j)) {
    if (!j.is_array()) {
      out += dump(j);
      return;
    }
    out += "[";
    for (std::size_t k = 0; k < j.size(); ++k) out += (k > 0 ? ", " : "") + dump(j[k]);
    out += "]";
    return;
  }
  const std::string pad(static_cast<std::size_t>(indent + 2), ' ');
  const bool object = j.is_object();
  out += object ? "{\n" : "[\n";
  std::size_t k = 0;
  for (auto it = j.begin(); it != j.end(); ++it, ++k) {
    out += pad;
    if (object) out += dump(Json(it.key())) + ": ";
    pretty(*it, indent + 2, out);
    out += k + 1 < j.size() ? ",\n" : "\n";
  }
  out += std::string(static_cast<std::size_t>(indent), ' ') + (object ? "}" : "]");
}

}  // namespace

std::string pretty_json(const Json& j) {
  std::string out;
  pretty(j, 0, out);
  return out;
}

std::string render_report_html(const ReportInputs& in, UnitSystem units,
                               const std::string& written_utc) {
  Page p(in, units);
  head(p);
  title(p, written_utc);
  p.raw("<main>");
  identity(p);
  findings(p);
  site_section(p);
  groups_section(p);
  settings_section(p);
  results(p);
  convergence_section(p);
  attribution_section(p);
  limitations_section(p);
  appendix(p);
  p.raw("</main>");
  scripts(p, figure_data(in, units));
  return p.html;
}

}  // namespace fragsim::report
