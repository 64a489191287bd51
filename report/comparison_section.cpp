// The report's part on a paired comparison (docs/comparison.md, docs/report.md): present when the
// report was given the comparison's compare.json. Its numbers are compare.json's (Page::cnum).
#include <string>

#include "report/page.h"

namespace fragsim::report {

namespace {

bool changed(const Json& figure) {
  return figure.value("difference", 0.0) != 0.0 || figure.value("paired_std_error", 0.0) != 0.0;
}

// base, variant, difference ± paired se, unpaired se of a compare.json figure at `key`.
void figure_row(Page& p, const std::string& label, const std::string& key, Kind k) {
  p.row({label, p.cnum(key + "/base", k, false), p.cnum(key + "/variant", k, false),
         p.cnum(key + "/difference", k, false) + " ± " +
             p.cnum(key + "/paired_std_error", Kind::kError, false),
         p.cnum(key + "/unpaired_std_error", Kind::kError, false)});
}

void hfd_row(Page& p) {
  p.row({"HFD (" + std::string(api::present_length(0.0, p.units()).unit) + ")",
         p.cnum("/hfd/base_m", Kind::kLength, false),
         p.cnum("/hfd/variant_m", Kind::kLength, false),
         p.cnum("/hfd/difference_m", Kind::kLength, false) + " ± " +
             p.cnum("/hfd/paired_std_error_m", Kind::kLength, false) + " (jackknife)",
         "—"});
}

void density_line(Page& p, const Json& d) {
  if (!d.value("same_terrain", false)) {
    p.raw("<p>The two sites' terrains differ: no density difference per triangle.</p>");
    return;
  }
  if (d.value("max_abs_triangle", -1) < 0) {
    p.raw("<p>The density is the same on every terrain triangle.</p>");
    return;
  }
  p.raw("<p id=\"comparison-density\">Largest change of the density on one terrain triangle: " +
        p.cnum("/density/max_abs_difference_signed_per_m2", Kind::kDensity, false) + " ± " +
        p.cnum("/density/max_abs_paired_std_error_per_m2", Kind::kError) + " at (" +
        p.cnum("/density/max_abs_location_m/0", Kind::kCoordinate, false) + ", " +
        p.cnum("/density/max_abs_location_m/1", Kind::kCoordinate) + "); " +
        p.cnum("/density/triangles_beyond_2_std_errors", Kind::kPlain, false) +
        " triangles changed by more than 2 paired standard errors (compare.h5 holds every "
        "triangle's difference).</p>");
}

}  // namespace

void comparison_warning(Page& p, std::string& items) {
  if (!p.in().compare) return;
  items += "<li>This run is the <strong>" + esc(p.in().compare_role) +
           "</strong> of a paired comparison (section 5, \"Paired comparison\"): the same "
           "histories were flown over both sites, and the difference of each figure is there "
           "with its paired standard error.</li>";
}

void comparison_section(Page& p) {
  if (!p.in().compare) return;
  const Json& c = *p.in().compare;
  p.raw("<h3 id=\"comparison\">Paired comparison (variant − base)</h3><p>");
  p.text("This run is the " + p.in().compare_role +
         " of a paired comparison (docs/comparison.md): " +
         "the same histories, seed and fragment groups were flown over the base site and the " +
         "variant site. What the variant changes: ");
  std::string what;
  for (const Json& k : c.value("changed", Json::array()))
    what += (what.empty() ? "" : ", ") + k.get<std::string>();
  p.raw("<code>" + esc(what.empty() ? "nothing" : what) + "</code>. ");
  p.text(
      "The difference's paired standard error comes from the per-history differences; the "
      "unpaired one is what two independent runs of the same histories would give.");
  p.raw("</p><table class=\"grid\" id=\"comparison-table\"><thead>");
  p.row({"figure", "base", "variant", "difference ± paired se", "unpaired se"}, true);
  p.raw("</thead><tbody>");
  hfd_row(p);
  const Json& buildings = c.value("buildings", Json::array());
  int unchanged = 0;
  for (std::size_t k = 0; k < buildings.size(); ++k) {
    const Json& b = buildings[k];
    if (!changed(b.value("impacts", Json::object())) &&
        !changed(b.value("penetrations", Json::object()))) {
      ++unchanged;
      continue;
    }
    const std::string key = "/buildings/" + std::to_string(k);
    figure_row(p, str_or(b, "id", "") + ": impacts", key + "/impacts", Kind::kCount);
    figure_row(p, str_or(b, "id", "") + ": penetrations", key + "/penetrations", Kind::kCount);
  }
  figure_row(p, "fragments leaving the site while hazardous", "/left_site_hazardous", Kind::kCount);
  p.raw("</tbody></table>");
  if (unchanged > 0)
    p.raw("<p>" + std::to_string(unchanged) +
          " other buildings are hit by the same histories in both sites (difference 0, "
          "standard error 0).</p>");
  density_line(p, c.value("density", Json::object()));
  p.raw("<ul class=\"comparison-limits\">");
  for (const Json& l : c.value("limitations", Json::array()))
    if (l.is_string()) p.raw("<li>" + esc(l.get<std::string>()) + "</li>");
  p.raw("</ul>");
}

}  // namespace fragsim::report
