// The report's sections after the findings (page.h): the site, the fragment groups, the
// settings, the result tables, the convergence evidence, what sets the HFD, the limitations.
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "report/page.h"

namespace fragsim::report {

namespace {

double number_or(const Json& j, const char* key, double fallback) {
  const auto it = j.find(key);
  return it != j.end() && it->is_number() ? it->get<double>() : fallback;
}

const Json& object_or_empty(const Json& j, const char* key) {
  static const Json kEmpty = Json::object();
  const auto it = j.find(key);
  return it != j.end() && it->is_object() ? *it : kEmpty;
}

std::string warning_item(const std::string& text_html) {
  return "<li>" + text_html + "</li>";
}

// A scenario quantity: a number, a [lo, hi] pair or a distribution object.
std::string quantity(const Page& p, const Json& q, Kind k) {
  if (q.is_number()) return p.value(q.get<double>(), k);
  if (q.is_array() && q.size() == 2 && q[0].is_number() && q[1].is_number())
    return p.value(q[0].get<double>(), k, false) + "–" + p.value(q[1].get<double>(), k);
  if (!q.is_object()) return "—";
  std::string out = esc(str_or(q, "dist", "value"));
  std::vector<std::string> keys;  // the usual order of a distribution's parameters, then others
  for (const char* known :
       {"value", "median", "mean", "mode", "mu", "sigma", "sigma_ln", "min", "max"})
    if (q.contains(known)) keys.emplace_back(known);
  for (auto it = q.begin(); it != q.end(); ++it)
    if (std::find(keys.begin(), keys.end(), it.key()) == keys.end()) keys.push_back(it.key());
  for (const std::string& key : keys) {
    const Json& v = q.at(key);
    if (key == "dist" || !v.is_number()) continue;
    const bool dimensionless = key == "sigma_ln" || key == "shape" || key == "k";
    out += ", " + esc(key) + " " + p.value(v.get<double>(), dimensionless ? Kind::kCount : k);
  }
  return out;
}

std::string shape_text(const Json& shape) {
  if (!shape.is_object()) return "sphere";
  std::string out = str_or(shape, "type", "sphere");
  if (const auto a = shape.find("aspect"); a != shape.end()) out += ", aspect " + a->dump();
  return out;
}

void precision_rows(Page& p, const Json& prec) {
  p.raw("<table class=\"grid\"><thead>");
  p.row({"figure", "building", "basis", "value", "allowed", "met"}, true);
  p.raw("</thead><tbody>");
  const auto& targets = prec.value("targets", Json::array());
  for (std::size_t k = 0; k < targets.size(); ++k) {
    const std::string base = "/precision/targets/" + std::to_string(k);
    const Json& t = targets[k];
    p.row({esc(str_or(t, "figure", "")), esc(str_or(t, "building", "")),
           esc(str_or(t, "basis", "")), p.num(base + "/value", Kind::kCount, false),
           t.value("allowed", Json()).is_number() ? p.num(base + "/allowed", Kind::kCount, false)
                                                  : "—",
           t.value("met", false) ? "yes" : "<strong class=\"flag\">no</strong>"});
  }
  p.raw("</tbody></table>");
}

void mechanism_table(Page& p, const Json& a) {
  const Json& by = object_or_empty(a, "by_mechanism");
  p.raw("<table class=\"grid\"><thead>");
  p.row({"mechanism", "HFD of its fragments alone", "±1 se band"}, true);
  p.raw("</thead><tbody>");
  for (auto it = by.begin(); it != by.end(); ++it) {
    const std::string base = "/hfd_attribution/by_mechanism/" + it.key();
    p.row({esc(it.key()), p.bound_mark(base + "/hfd_bound") + p.num(base + "/hfd_m", Kind::kLength),
           p.num(base + "/hfd_band_m/0", Kind::kLength, false) + " to " +
               p.num(base + "/hfd_band_m/1", Kind::kLength)});
  }
  p.raw("</tbody></table>");
}

void group_table(Page& p, const Json& a) {
  const auto it = a.find("by_group");
  if (it == a.end() || !it->is_array()) {
    p.raw("<p>By group: not computed (");
    p.text(str_or(a, "by_group_omitted_reason", "no reason recorded"));
    p.raw(").</p>");
    return;
  }
  p.raw("<table class=\"grid\"><thead>");
  p.row({"fragment group", "HFD of its fragments alone", "±1 se band"}, true);
  p.raw("</thead><tbody>");
  for (std::size_t k = 0; k < it->size(); ++k) {
    const std::string base = "/hfd_attribution/by_group/" + std::to_string(k);
    p.row({esc(str_or((*it)[k], "group", "")),
           p.bound_mark(base + "/hfd_bound") + p.num(base + "/hfd_m", Kind::kLength),
           p.num(base + "/hfd_band_m/0", Kind::kLength, false) + " to " +
               p.num(base + "/hfd_band_m/1", Kind::kLength)});
  }
  p.raw("</tbody></table>");
}

void at_hfd_shares(Page& p, const Json& a) {
  const Json& at = object_or_empty(a, "at_hfd");
  if (at.empty()) return;
  p.raw("<p>At the triangle that sets the HFD (");
  p.raw(p.num("/hfd_attribution/at_hfd/distance_m", Kind::kLength) + ", density " +
        p.num("/hfd_attribution/at_hfd/density_per_m2", Kind::kDensity));
  p.raw("), the density comes from: ");
  std::string parts;
  const Json& m = object_or_empty(at, "share_by_mechanism");
  for (auto it = m.begin(); it != m.end(); ++it) {
    if (!parts.empty()) parts += "; ";
    parts +=
        esc(it.key()) + " " + p.value(100.0 * it.value().get<double>(), Kind::kCount, false) + " %";
  }
  const auto groups = a.value("groups", Json::array());
  const auto shares = at.value("share_by_group", Json::array());
  for (std::size_t k = 0; k < groups.size() && k < shares.size(); ++k)
    if (shares[k].is_number() && shares[k].get<double>() > 0)
      parts += "; group “" + esc(groups[k].is_string() ? groups[k].get<std::string>() : "") + "” " +
               p.value(100.0 * shares[k].get<double>(), Kind::kCount, false) + " %";
  p.raw(parts + ".</p>");
}

void bracket_table(Page& p, const Json& b) {
  p.raw(
      "<h3>Ground constants bracket</h3><p>The figures at each end of each uncertain ground "
      "constant's range for the material ");
  p.raw("<code>" + esc(str_or(b, "material", "")) + "</code>");
  p.raw(", one constant at a time (paired runs): HFD from " +
        p.bound_mark("/ground_bracket/hfd_range_bound") +
        p.num("/ground_bracket/hfd_range_m/0", Kind::kLength) + " to " +
        p.num("/ground_bracket/hfd_range_m/1", Kind::kLength) + ".</p>");
  p.raw("<table class=\"grid\"><thead>");
  p.row({"constant", "nominal", "low end: value, HFD", "high end: value, HFD"}, true);
  p.raw("</thead><tbody>");
  const auto& rows = b.value("rows", Json::array());
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const std::string base = "/ground_bracket/rows/" + std::to_string(k);
    p.row({esc(str_or(rows[k], "constant", "")), p.num(base + "/nominal", Kind::kCount, false),
           p.num(base + "/low/value", Kind::kCount, false) + ", " +
               p.bound_mark(base + "/low/hfd_bound") + p.num(base + "/low/hfd_m", Kind::kLength),
           p.num(base + "/high/value", Kind::kCount, false) + ", " +
               p.bound_mark(base + "/high/hfd_bound") +
               p.num(base + "/high/hfd_m", Kind::kLength)});
  }
  p.raw("</tbody></table>");
}

}  // namespace

std::string threshold_words(const Json& s, UnitSystem u) {
  const double t = number_or(s, "hfd_threshold_per_m2", NAN);
  if (!(t > 0)) return "no threshold";
  if (u == UnitSystem::kUs)
    return "1 hazardous fragment per " + printf_string("%.4g", 600.0 / (t * api::k600SqFtM2)) +
           " ft²";
  return "1 hazardous fragment per " + printf_string("%.1f", 1.0 / t) + " m²";
}

void warnings(Page& p) {
  const Json& s = p.summary();
  std::string items;
  const Json& sb = object_or_empty(s, "site_boundary");
  if (const auto note = sb.find("note"); note != sb.end() && note->is_string())
    items += warning_item("<strong>The HFD is a lower bound.</strong> HFD ≥ " +
                          p.num("/hazardous_fragment_distance_m", Kind::kLength) +
                          ": hazardous density reaches the site boundary in " +
                          p.num("/site_boundary/hfd_sectors_cut", Kind::kPlain, false) +
                          " of 36 sectors; extend the terrain.");
  else if (p.bound_mark("/hfd_band_bound/1") == "≥ ")
    items += warning_item(
        "The upper end of the HFD band reaches the site boundary: it is a lower bound.");
  const Json& left = object_or_empty(sb, "left_site_hazardous");
  if (number_or(left, "fragments", 0) > 0)
    items +=
        warning_item(p.num("/site_boundary/left_site_hazardous/fragments", Kind::kCount, false) +
                     " real fragments left the site while still hazardous: where they land is "
                     "not modelled.");
  if (const auto prec = s.find("precision"); prec != s.end() && prec->is_object()) {
    if (!prec->value("all_met", false))
      items += warning_item(
          "<strong>Precision targets not met</strong> (section 6): the figures "
          "are less certain than the study asked for.");
  } else {
    items += warning_item(
        "No precision target was set: the uncertainty of each figure is its "
        "standard error shown here (section 6).");
  }
  for (const char* o : {"max_flight_time", "integration_failed", "work_limit", "started_inside"}) {
    const std::string key = std::string("/outcomes/") + o + "/histories";
    const Json* h = at_pointer(s, key);
    if (h != nullptr && h->is_number() && h->get<double>() > 0)
      items +=
          warning_item(p.num(key, Kind::kPlain, false) + " histories ended as <code>" + o +
                       "</code> (section 5, outcomes): their fragments are not in the density.");
  }
  if (!p.in().scenario.value("settings", Json::object()).value("bounce", false))
    items += warning_item(
        "Ground ricochet is off (<code>settings.bounce</code> false): every "
        "fragment stops where it first reaches the ground (section 8).");
  comparison_warning(p, items);
  if (items.empty()) return;
  p.raw("<ul class=\"warnings\" id=\"warnings\">" + items + "</ul>");
}

void site_section(Page& p) {
  const Json site = p.in().scenario.value("site", Json::object());
  const Json origin = site.value("origin", Json::object());
  const Json terrain = site.value("terrain", Json::object());
  p.raw("<section id=\"site\"><h2>3. The site</h2><table class=\"kv\">");
  const std::string crs = str_or(origin, "crs", "");
  p.kv("Coordinate reference system",
       crs.empty() ? "none: local coordinates (x east, y north, metres)" : esc(crs));
  if (!crs.empty())
    p.kv("Site origin", "easting " + p.value(number_or(origin, "easting_m", 0), Kind::kCoordinate) +
                            ", northing " +
                            p.value(number_or(origin, "northing_m", 0), Kind::kCoordinate));
  std::string source = "triangle mesh";
  if (const auto g = terrain.find("grid"); g != terrain.end())
    source = "elevation grid " + std::to_string(g->value("nx", 0)) + " × " +
             std::to_string(g->value("ny", 0)) + " samples at " +
             p.value(number_or(*g, "spacing_m", 0), Kind::kLength);
  else if (const auto pl = terrain.find("plane"); pl != terrain.end())
    source = "plane, cells of " + p.value(number_or(*pl, "cell_m", 0), Kind::kLength);
  p.kv("Terrain", source + ", " + std::to_string(p.in().results.triangles.size()) + " triangles");
  p.kv("Terrain material",
       "<code>" + esc(str_or(terrain, "material", "")) + "</code>" +
           (terrain.contains("zones")
                ? ", with " + std::to_string(terrain["zones"].size()) + " material zones"
                : std::string()));
  p.kv("Buildings", std::to_string(p.in().results.buildings.size()));
  p.kv("HFD origin", p.num("/hfd_origin_m/0", Kind::kCoordinate, false) + ", " +
                         p.num("/hfd_origin_m/1", Kind::kCoordinate, false) + ", " +
                         p.num("/hfd_origin_m/2", Kind::kCoordinate) + " (site coordinates)");
  p.raw(
      "</table><figure id=\"fig-site\"><div class=\"plot\" "
      "data-plot=\"overview\"></div><figcaption>");
  p.text(overview_caption(p.units()));
  p.raw("</figcaption></figure></section>\n");
}

void groups_section(Page& p) {
  const Json groups = p.in().scenario.value("fragment_groups", Json::array());
  p.raw("<section id=\"groups\"><h2>4. Fragment groups and settings</h2>");
  p.raw("<table class=\"grid\"><thead>");
  p.row({"group", "real fragments", "samples", "shape", "mass", "launch speed", "drag"}, true);
  p.raw("</thead><tbody>");
  for (const Json& g : groups) {
    const auto cd = g.find("cd");
    p.row({esc(str_or(g, "name", "")), p.value(number_or(g, "count", 0), Kind::kCount, false),
           p.value(number_or(g, "samples", 0), Kind::kPlain, false),
           esc(shape_text(g.value("shape", Json()))),
           quantity(p, g.value("mass_kg", Json()), Kind::kMass),
           quantity(p, g.value("speed_mps", Json()), Kind::kSpeed),
           cd != g.end() && cd->is_number() ? "C<sub>d</sub> " + esc(cd->dump())
                                            : "C<sub>d</sub>(Mach) table"});
  }
  p.raw("</tbody></table>");
}

void settings_section(Page& p) {
  const Json st = p.in().scenario.value("settings", Json::object());
  p.raw("<table class=\"kv\">");
  p.kv("Hazardous fragment", "kinetic energy ≥ " + p.num("/hazardous_ke_j", Kind::kEnergy) +
                                 " at a person's height of " +
                                 p.num("/person_height_m", Kind::kLength));
  p.kv("Threshold density", p.num("/hfd_threshold_per_m2", Kind::kDensity) + " (" +
                                threshold_words(p.summary(), p.units()) + ")");
  const bool bounce = st.value("bounce", false);
  std::string b = bounce ? "on: fragments ricochet, roll and slide on the terrain" : "off";
  if (bounce) {
    const Json mats =
        p.in().scenario.value("site", Json::object()).value("materials", Json::object());
    b += "; materials: ";
    std::size_t k = 0;
    for (auto it = mats.begin(); it != mats.end(); ++it, ++k) b += (k ? ", " : "") + esc(it.key());
  }
  p.kv("Ground ricochet", b);
  p.kv("Longest flight", p.value(number_or(st, "max_flight_time_s", NAN), Kind::kSeconds));
  p.raw("</table><p>Material constants and all other settings: Appendix A.</p></section>\n");
}

void sector_table(Page& p) {
  const auto& env = p.in().boundary;
  p.raw("<h3>HFD by sector</h3><table class=\"grid compact\" id=\"sectors\"><thead>");
  p.row({"sector", "bearings", "HFD", "envelope", "+1 se envelope"}, true);
  p.raw("</thead><tbody>");
  for (int k = 0; k < 36; ++k) {
    const auto uk = static_cast<std::size_t>(k);
    const std::string base = "/hfd_by_sector_m/" + std::to_string(k);
    const std::string cut = p.bound_mark("/hfd_by_sector_bound/" + std::to_string(k));
    p.row({std::to_string(k), api::sector_bearing_range(k), cut + p.num(base, Kind::kLength),
           cut + p.value(env.envelope.radius_m.at(uk), Kind::kLength),
           cut + p.value(env.envelope_upper.radius_m.at(uk), Kind::kLength)});
  }
  p.raw("</tbody></table>");
}

void buildings_table(Page& p) {
  const auto& bs = p.summary().value("buildings", Json::array());
  p.raw("<h3>Buildings</h3>");
  if (bs.empty()) {
    p.raw("<p>The site has no buildings.</p>");
    return;
  }
  p.raw("<table class=\"grid\" id=\"buildings\"><thead>");
  p.row({"building", "expected impacts ± se", "expected penetrations ± se",
         "mean residual energy ± se"},
        true);
  p.raw("</thead><tbody>");
  for (std::size_t k = 0; k < bs.size(); ++k) {
    const std::string b = "/buildings/" + std::to_string(k);
    p.row({esc(str_or(bs[k], "id", "")),
           p.pm(b + "/expected_impacts", b + "/impacts_std_error", Kind::kCount),
           p.pm(b + "/expected_penetrations", b + "/penetrations_std_error", Kind::kCount),
           p.num(b + "/residual_ke_j", Kind::kEnergy, false) + " ± " +
               p.num(b + "/residual_ke_std_error_j", Kind::kEnergy)});
  }
  p.raw("</tbody></table>");
}

void outcomes_table(Page& p) {
  const Json& o = object_or_empty(p.summary(), "outcomes");
  p.raw("<h3>How the histories ended</h3><table class=\"grid\" id=\"outcomes\"><thead>");
  p.row({"outcome", "histories", "real fragments ± se"}, true);
  p.raw("</thead><tbody>");
  for (auto it = o.begin(); it != o.end(); ++it) {
    const std::string b = "/outcomes/" + it.key();
    p.row({esc(it.key()), p.num(b + "/histories", Kind::kPlain, false),
           p.pm(b + "/fragments", b + "/fragments_std_error", Kind::kCount)});
  }
  p.raw("</tbody></table>");
}

void convergence_section(Page& p) {
  const Json& s = p.summary();
  p.raw("<section id=\"convergence\"><h2>6. Convergence</h2><p>");
  p.raw(p.num("/samples", Kind::kPlain, false) + " histories in " +
        p.num("/batches", Kind::kPlain, false) + " batch(es); the run stopped on <code>" +
        esc(str_or(s, "stop_reason", "")) + "</code>. The HFD's ±1 se band (" +
        p.num("/hazardous_fragment_distance_band_m/0", Kind::kLength) + " to " +
        p.num("/hazardous_fragment_distance_band_m/1", Kind::kLength) +
        ") is the HFD of the density fields mean − 1 se and mean + 1 se.</p>");
  const auto prec = s.find("precision");
  if (prec == s.end() || !prec->is_object()) {
    p.raw(
        "<p id=\"precision\">No precision target was set (<code>settings.precision</code>): "
        "the run stopped after its fixed number of samples.</p></section>\n");
    return;
  }
  p.raw(std::string("<p id=\"precision\">Precision targets: ") +
        (prec->value("all_met", false) ? "all met."
                                       : "<strong class=\"flag\">not all met.</strong>") +
        "</p>");
  precision_rows(p, *prec);
  p.raw("</section>\n");
}

void attribution_section(Page& p) {
  const Json& s = p.summary();
  p.raw("<section id=\"attribution\"><h2>7. What sets the HFD</h2>");
  const auto a = s.find("hfd_attribution");
  if (a == s.end() || !a->is_object()) {
    p.raw("<p>No attribution was recorded for this run.</p>");
  } else {
    p.raw(
        "<p>The HFD each mechanism and each group would give alone (densities split by how the "
        "fragment reached the person's height: docs/physics.md, “HFD attribution”).</p>");
    mechanism_table(p, *a);
    group_table(p, *a);
    at_hfd_shares(p, *a);
  }
  if (const auto b = s.find("ground_bracket"); b != s.end() && b->is_object()) bracket_table(p, *b);
  p.raw("</section>\n");
}

void limitations_section(Page& p) {
  const Json st = p.in().scenario.value("settings", Json::object());
  p.raw("<section id=\"limitations\"><h2>8. Limitations of the models used</h2><ul>");
  p.raw(
      "<li>The PTN density (Gan &amp; Chrostowski, DDESB 2010, eqs. 37–39) counts fragments "
      "crossing a person-sized prism at the stated height; it is a Monte Carlo estimate with the "
      "standard errors shown, on the terrain's triangles (the HFD is taken at triangle "
      "centroids, so it resolves no finer than the triangle size).</li>");
  p.raw(
      "<li>Fragment flight: drag from the stated C<sub>d</sub> on the tumble-averaged area "
      "(surface area / 4), no lift and no orientation-dependent drag, in the stated "
      "atmosphere and still air: wind is not modelled (docs/physics.md).</li>");
  p.raw(
      "<li>The density is known only on the modelled terrain: beyond its edge nothing is "
      "computed, and fragments leaving the site are counted, not followed.</li>");
  if (st.value("bounce", false))
    p.raw(
        "<li>Ground ricochet, rolling and sliding (docs/physics.md G1–G15): each law holds in "
        "the speeds, angles and soils its source measured (stated there); the material "
        "constants are the scenario's (Appendix A), and the built-in hard and soft restitution "
        "tables are illustrative. Non-spherical fragments "
        "slide but never roll or tumble on the ground; in the Authume field test this made "
        "the blind prediction of run-out too short (docs/validation.md).</li>");
  else
    p.raw(
        "<li>Without ground ricochet, fragments stop where they first reach the ground: "
        "ricochets that carry hazardous fragments farther are not in the HFD.</li>");
  if (!p.in().results.buildings.empty())
    p.raw(
        "<li>Building impacts and penetrations use the stated wall, roof and window "
        "penetration thresholds; a fragment that penetrates is not followed inside.</li>");
  p.raw(
      "<li>The site-plan boundary (sector envelope and smoothed contour) is drawn to contain "
      "the hazardous area; it is a presentation of the PTN density, not a separate model "
      "(docs/gis.md, “Site-plan boundary”).</li>");
  p.raw("</ul></section>\n");
}

std::string map_caption(const ReportInputs& in, UnitSystem u) {
  return "PTN hazardous fragment density in classes relative to the threshold, seen from above, "
         "north up, distances from the HFD origin in " +
         std::string(api::present_length(1, u).unit) +
         ". Hazardous area (density at or above the threshold) in red. Site-plan boundary: "
         "sector envelope (solid), its +1 se version (dashed) and the smoothed contour "
         "(closing radius " +
         api::format_length(in.boundary.smoothing_m, u) +
         ", dotted). Circle: the HFD. Buildings in grey.";
}

std::string overview_caption(UnitSystem u) {
  return "The whole modelled terrain seen from above, north up, distances from the HFD origin in " +
         std::string(api::present_length(1, u).unit) +
         ": PTN density in classes relative to the threshold (legend), the buildings (grey, "
         "labelled) and the HFD circle. Section 5 shows the hazardous area close up.";
}

std::string rose_caption(UnitSystem u) {
  return "HFD by 10° sector (filled), with the sector envelope (solid line) and its +1 se "
         "version (dashed), north up, in " +
         std::string(api::present_length(1, u).unit) +
         ". Sectors whose figure the site boundary cuts are marked in red.";
}

std::string profile_caption(UnitSystem u) {
  return "PTN density against distance from the HFD origin: the largest triangle density and "
         "the area-weighted mean in each distance bin, " +
         std::string(api::present_areal_density(1, u).unit) +
         "; horizontal line: the threshold; vertical line: the HFD.";
}

}  // namespace fragsim::report
