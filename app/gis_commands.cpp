// The GIS commands (docs/gis.md): `fragsim site import IMPORT.json --out SITE.json` and
// `fragsim export RESULTS.h5 --out DIR`.
#include <filesystem>
#include <iostream>

#include "api/scenario_json.h"
#include "api/site_document.h"
#include "app/commands.h"
#include "core/common/error.h"
#include "core/scene/site.h"
#include "formats/output_dir.h"
#include "gis/gdal_support.h"
#include "gis/results_export.h"
#include "gis/site_import.h"
#include "gis/site_to_gis.h"
#include "report/report.h"

namespace fragsim::app {

namespace {

namespace fs = std::filesystem;

// The imported site, checked as POST /v1/sites checks a site. An error names the building by its
// id (a feature of the GIS file), since the user never wrote "buildings[3]".
std::shared_ptr<const scene::Site> check_site(const nlohmann::ordered_json& site,
                                              const std::string& import_file) {
  try {
    const api::SiteDocument doc = api::parse_site_document(nlohmann::json::parse(site.dump()));
    return api::build_site(doc);
  } catch (const InputError& e) {
    std::string where = e.field();
    if (where.rfind("buildings[", 0) == 0) {
      const auto k = std::stoul(where.substr(10));
      if (k < site["buildings"].size())
        where += " (building \"" + site["buildings"][k]["id"].get<std::string>() + "\")";
    }
    throw InputError(
        "", import_file + ": the imported site is not valid: " + where + ": " + e.message());
  }
}

void write_atomically(const fs::path& out, const std::string& text) {
  const fs::path dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError("--out", dir.string() + " is not a directory");
  formats::OutputDir staged(dir);
  staged.stage_text(out.filename().string(), text);
  staged.commit();
}

}  // namespace

int site_import_command(const Options& o) {
  const nlohmann::json j = api::parse_json_text(read_file(o.scenario));
  const fs::path base =
      fs::path(o.scenario).has_parent_path() ? fs::path(o.scenario).parent_path() : fs::path(".");
  const gis::SiteImport spec = gis::parse_site_import(j, base);
  const gis::ImportedSite imported = gis::import_site(spec);
  const auto site = check_site(imported.site, o.scenario);
  write_atomically(o.out, imported.site.dump());
  const auto& t = imported.terrain;
  std::cout << "ok: " << o.out << "\n  CRS: ";
  if (t.srs.IsEmpty()) {
    std::cout << "none (local metres)\n";
  } else {
    std::cout << imported.site["origin"]["crs"].get<std::string>() << " (" << gis::crs_label(t.srs)
              << ")\n";
  }
  if (const auto& m = imported.mesh) {
    std::cout << "  terrain: " << spec.mesh_terrain->meshes.size() << " mesh files, "
              << m->file_facets << " facets -> ";
    if (m->nx > 0) std::cout << "grid " << m->nx << " x " << m->ny << " nodes, ";
    if (m->nx == 0) std::cout << "mesh of " << m->vertices << " vertices, ";
    std::cout << site->terrain_triangle_count() << " triangles";
    if (m->uncovered_nodes > 0)
      std::cout << " (resampled: " << m->uncovered_nodes
                << " lattice nodes outside the meshes dropped with their cells)";
  } else {
    std::cout << "  terrain: " << (t.as_grid ? "grid " : "mesh ") << t.nx << " x " << t.ny
              << " vertices, " << site->terrain_triangle_count() << " triangles";
    if (t.filled_cells > 0) std::cout << ", " << t.filled_cells << " nodata cells filled";
  }
  if (spec.zones) std::cout << "\n  zones: " << imported.zones;
  std::cout << "\n  buildings: " << imported.buildings << "\n";
  return kExitOk;
}

int site_export_gis_command(const Options& o) {
  const nlohmann::json j = api::parse_json_text(read_file(o.scenario));
  // A scenario with an inline site, or a site document.
  const bool scenario = j.is_object() && j.contains("fragment_groups");
  const nlohmann::json site = scenario ? j.value("site", nlohmann::json()) : j;
  if (scenario && site.is_null()) throw InputError("site", "the scenario has no inline site");
  (void)api::parse_site_document(site);  // the site is checked before anything is written
  const gis::SiteGisReport r = gis::write_site_gis(site, o.out);
  std::cout << "ok: " << o.out << "\n";
  for (const auto& f : r.files) std::cout << "  " << (fs::path(o.out) / f).string() << "\n";
  for (const auto& n : r.notes) std::cout << "note: " << n << "\n";
  return kExitOk;
}

int shape_import_command(const Options& o) {
  std::string axes = o.axes;
  nlohmann::json j = axes;
  if (axes.find(',') != std::string::npos) {  // "x,-z,y"
    j = nlohmann::json::array();
    for (std::size_t b = 0, e = 0; e != std::string::npos; b = e + 1) {
      e = axes.find(',', b);
      j.push_back(axes.substr(b, e == std::string::npos ? e : e - b));
    }
  }
  const gis::AxisMap map = gis::parse_axes(j, "--axes");
  std::cout << gis::shape_from_mesh_file(o.scenario, map, 1e-6).dump() << "\n";
  return kExitOk;
}

int export_command(const Options& o) {
  gis::ExportOptions options;
  options.results_h5 = o.scenario;
  options.out_dir = o.out;
  options.pixel_m = o.pixel_m;
  options.units = o.units;
  options.smoothing_m = o.smoothing_m;
  const gis::ExportReport r = gis::export_results(options);
  std::cout << "ok: " << o.out << " (CRS " << (r.crs.empty() ? "none: local metres" : r.crs)
            << "; raster " << r.raster_cols << " x " << r.raster_rows << " cells of " << r.pixel_m
            << " m; " << r.hazardous_triangles << " terrain triangles at or above the threshold)\n";
  for (const auto& f : r.files) std::cout << "  " << (fs::path(o.out) / f).string() << "\n";
  for (const auto& n : r.notes) std::cout << "note: " << n << "\n";
  return kExitOk;
}

int report_command(const Options& o) {
  report::ReportOptions options;
  options.results_h5 = o.scenario;
  options.out_html = o.out;
  if (!o.pdf.empty()) options.out_pdf = o.pdf;
  if (!o.compare.empty()) options.compare_json = o.compare;
  options.units = o.units;
  const report::ReportWritten w = report::write_report(options);
  std::cout << "ok: " << o.out << " (" << w.html_bytes / 1024 << " KiB, " << w.html_s << " s)";
  if (!o.pdf.empty()) std::cout << " and " << o.pdf << " (" << w.pdf_s << " s)";
  std::cout << "\n";
  return kExitOk;
}

}  // namespace fragsim::app
