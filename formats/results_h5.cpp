// results.h5 with the HDF5 C API. Files use the 1.8 object format (readable by HDF5 >= 1.8, h5py,
// MATLAB) with dense attribute storage, so the scenario JSON can be a root attribute of any size.
#include "formats/results_h5.h"

#include <hdf5.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <mutex>
#include <stdexcept>
#include <type_traits>

#include "formats/h5_writer.h"

namespace fragsim::formats {

namespace {

using namespace h5;

std::vector<double> flatten(const std::vector<Vec3>& points) {
  std::vector<double> out;
  out.reserve(3 * points.size());
  for (const Vec3& p : points) out.insert(out.end(), {p.x(), p.y(), p.z()});
  return out;
}

const char* kSurfaceColumns = "terrain,wall,roof,window";

std::string outcome_names() {
  std::string names;
  for (int k = 0; k < run::kOutcomeCount; ++k) {
    if (k) names += ",";
    names += run::outcome_name(static_cast<run::Outcome>(k));
  }
  return names;
}

std::string trajectory_event_names() {
  std::string names;
  for (int k = 0; k < run::kTrajectoryEventCount; ++k) {
    if (k) names += ",";
    names += run::trajectory_event_name(static_cast<run::TrajectoryEvent>(k));
  }
  return names;
}

void write_terrain(Writer& w, const scene::Site& site) {
  w.group("/terrain");
  std::vector<Vec3> vertices;
  vertices.reserve(site.terrain_vertices().size());
  for (const Vec3& v : site.terrain_vertices()) vertices.push_back(site.to_input(v));
  const auto xyz = flatten(vertices);
  w.dataset("/terrain/vertices_m", xyz.data(), vertices.size(), 3);
  std::vector<std::uint32_t> tris;
  tris.reserve(3 * site.terrain_triangle_count());
  for (const auto& t : site.terrain_triangles()) tris.insert(tris.end(), t.begin(), t.end());
  w.dataset("/terrain/triangles", tris.data(), site.terrain_triangle_count(), 3);
  std::vector<double> area(site.terrain_triangle_count());
  for (std::size_t t = 0; t < area.size(); ++t)
    area[t] = site.terrain_triangle_area(static_cast<std::uint32_t>(t));
  w.dataset("/terrain/area_m2", area);
  std::vector<std::uint32_t> material(site.terrain_triangle_count());
  for (std::size_t t = 0; t < material.size(); ++t)
    material[t] = site.terrain_triangle_material(static_cast<std::uint32_t>(t));
  w.dataset("/terrain/material", material);
  std::vector<std::string> names;
  for (const scene::Material& m : site.materials()) names.push_back(m.name);
  w.strings("/terrain/material_names", names);
}

void write_buildings(Writer& w, const run::RunResult& r, const scene::Site& site) {
  w.group("/buildings");
  const std::size_t n = r.buildings.size();
  std::vector<std::string> ids;
  std::vector<double> impacts, impacts_se, penetrations, penetrations_se, residual, residual_se;
  std::vector<double> by_surface[4];  // impacts, se, penetrations, se: n x 4 each
  for (const auto& b : r.buildings) {
    ids.push_back(b.id);
    impacts.push_back(b.impacts.mean);
    impacts_se.push_back(b.impacts.std_error);
    penetrations.push_back(b.penetrations.mean);
    penetrations_se.push_back(b.penetrations.std_error);
    residual.push_back(b.residual_ke_j.mean);
    residual_se.push_back(b.residual_ke_j.std_error);
    for (std::size_t s = 0; s < scene::kSurfaceTypeCount; ++s) {
      by_surface[0].push_back(b.impacts_by_surface[s].mean);
      by_surface[1].push_back(b.impacts_by_surface[s].std_error);
      by_surface[2].push_back(b.penetrations_by_surface[s].mean);
      by_surface[3].push_back(b.penetrations_by_surface[s].std_error);
    }
  }
  w.strings("/buildings/id", ids);
  w.dataset("/buildings/expected_impacts", impacts);
  w.dataset("/buildings/impacts_std_error", impacts_se);
  w.dataset("/buildings/expected_penetrations", penetrations);
  w.dataset("/buildings/penetrations_std_error", penetrations_se);
  w.dataset("/buildings/residual_ke_j", residual);
  w.dataset("/buildings/residual_ke_std_error_j", residual_se);
  const char* names[4] = {"impacts_by_surface", "impacts_by_surface_std_error",
                          "penetrations_by_surface", "penetrations_by_surface_std_error"};
  for (int k = 0; k < 4; ++k) {
    const std::string path = std::string("/buildings/") + names[k];
    w.dataset(path, by_surface[k].data(), n, scene::kSurfaceTypeCount);
    w.dataset_attribute(path, "columns", kSurfaceColumns);
  }

  // Geometry, for viewers: the meshes as built (footprints extruded), in input coordinates.
  std::vector<double> area;
  for (const auto& b : site.buildings())
    area.insert(area.end(), b.surface_area_m2.begin(), b.surface_area_m2.end());
  w.dataset("/buildings/surface_area_m2", area.data(), site.buildings().size(),
            scene::kSurfaceTypeCount);
  w.dataset_attribute("/buildings/surface_area_m2", "columns", kSurfaceColumns);
  std::vector<Vec3> vertices;
  for (const Vec3& v : site.building_vertices()) vertices.push_back(site.to_input(v));
  const auto xyz = flatten(vertices);
  w.dataset("/buildings/vertices_m", xyz.data(), vertices.size(), 3);
  std::vector<std::uint32_t> tris, tri_building;
  std::vector<std::uint8_t> tri_surface;
  for (const auto& t : site.building_triangles()) {
    tris.insert(tris.end(), t.v.begin(), t.v.end());
    tri_building.push_back(t.building);
    tri_surface.push_back(static_cast<std::uint8_t>(t.surface));
  }
  w.dataset("/buildings/triangles", tris.data(), site.building_triangles().size(), 3);
  w.dataset("/buildings/triangle_building", tri_building);
  w.dataset("/buildings/triangle_surface", tri_surface);
  w.dataset_attribute("/buildings/triangle_surface", "values",
                      "0 terrain, 1 wall, 2 roof, 3 window");
}

void write_fragments(Writer& w, const std::vector<run::FragmentRecord>& records) {
  w.group("/fragments");
  const std::size_t n = records.size();
  const auto column = [&](const char* name, auto field) {
    using T = std::decay_t<decltype(field(records[0]))>;
    std::vector<T> v;
    v.reserve(n);
    for (const auto& r : records) v.push_back(field(r));
    w.dataset(std::string("/fragments/") + name, v);
  };
  const auto vectors = [&](const char* name, auto field) {
    std::vector<double> xyz;  // n x 3, gathered straight from the records
    xyz.reserve(3 * n);
    for (const auto& r : records) {
      const Vec3& p = field(r);
      xyz.insert(xyz.end(), {p.x(), p.y(), p.z()});
    }
    w.dataset(std::string("/fragments/") + name, xyz.data(), n, 3);
  };
  using R = run::FragmentRecord;
  column("group", [](const R& r) { return r.group; });
  column("history", [](const R& r) { return r.history; });
  column("weight", [](const R& r) { return r.weight; });
  column("mass_kg", [](const R& r) { return r.mass_kg; });
  column("area_m2", [](const R& r) { return r.area_m2; });
  vectors("launch_position_m", [](const R& r) { return r.launch_position_m; });
  vectors("launch_velocity_mps", [](const R& r) { return r.launch_velocity_mps; });
  column("outcome", [](const R& r) { return static_cast<std::uint8_t>(r.outcome); });
  column("end_time_s", [](const R& r) { return r.end_time_s; });
  vectors("end_position_m", [](const R& r) { return r.end_position_m; });
  vectors("end_velocity_mps", [](const R& r) { return r.end_velocity_mps; });
  column("first_impact_time_s", [](const R& r) { return r.first_impact_time_s; });
  vectors("first_impact_position_m", [](const R& r) { return r.first_impact_position_m; });
  vectors("first_impact_velocity_mps", [](const R& r) { return r.first_impact_velocity_mps; });
  column("impact_angle_deg", [](const R& r) { return r.impact_angle_deg; });
  column("impact_ke_j", [](const R& r) { return r.impact_ke_j; });
  column("building", [](const R& r) { return r.building; });
  column("surface", [](const R& r) { return r.surface; });
  column("penetrated", [](const R& r) { return static_cast<std::uint8_t>(r.penetrated ? 1 : 0); });
  column("residual_ke_j", [](const R& r) { return r.residual_ke_j; });
  column("bounces", [](const R& r) { return r.bounces; });
  column("ground_impacts", [](const R& r) { return r.ground_impacts; });
  column("takeoffs", [](const R& r) { return r.takeoffs; });
  column("ground_path_m", [](const R& r) { return r.ground_path_m; });
  w.dataset_attribute("/fragments/outcome", "names", outcome_names());
  w.dataset_attribute("/fragments/surface", "values", "-1 none, 1 wall, 2 roof, 3 window");
}

void write_trajectories(Writer& w, const std::vector<run::TrajectoryRecord>& trajectories) {
  w.group("/trajectories");
  std::vector<std::uint32_t> group;
  std::vector<std::uint64_t> history, offsets{0};
  std::vector<double> t_s;
  std::vector<Vec3> points, velocities;
  std::vector<std::uint8_t> events;
  for (const auto& tr : trajectories) {
    const std::size_t n = tr.t_s.size();
    if (tr.position_m.size() != n || tr.velocity_mps.size() != n || tr.event.size() != n)
      throw std::logic_error("results.h5: trajectory with " + std::to_string(n) + " times, " +
                             std::to_string(tr.position_m.size()) + " points, " +
                             std::to_string(tr.velocity_mps.size()) + " velocities and " +
                             std::to_string(tr.event.size()) + " events");
    group.push_back(tr.group);
    history.push_back(tr.history);
    t_s.insert(t_s.end(), tr.t_s.begin(), tr.t_s.end());
    points.insert(points.end(), tr.position_m.begin(), tr.position_m.end());
    velocities.insert(velocities.end(), tr.velocity_mps.begin(), tr.velocity_mps.end());
    for (const auto e : tr.event) events.push_back(static_cast<std::uint8_t>(e));
    offsets.push_back(t_s.size());
  }
  w.dataset("/trajectories/group", group);
  w.dataset("/trajectories/history", history);
  w.dataset("/trajectories/offsets", offsets);
  w.dataset("/trajectories/t_s", t_s);
  const auto xyz = flatten(points);
  w.dataset("/trajectories/position_m", xyz.data(), points.size(), 3);
  const auto vxyz = flatten(velocities);
  w.dataset("/trajectories/velocity_mps", vxyz.data(), velocities.size(), 3);
  w.dataset("/trajectories/event", events);
  w.dataset_attribute("/trajectories/event", "names", trajectory_event_names());
}

// /hfd: the HFD, its band and sectors, and where the terrain's boundary cuts them.
void write_hfd(Writer& w, const run::RunResult& r, const scene::Site& site,
               const run::Scenario& scenario, const std::string& note) {
  const run::SiteBoundary& b = r.site_boundary;
  const Handle hfd = w.group("/hfd");
  w.attribute(hfd, "bound", b.hfd_cut ? "lower" : "none");
  w.attribute(hfd, "note", note);
  w.scalar("/hfd/hazardous_fragment_distance_m", r.hazardous_fragment_distance_m);
  const std::vector<double> band = {r.hfd_lower_m, r.hfd_upper_m};
  w.dataset("/hfd/band_m", band);
  w.dataset("/hfd/by_sector_m", r.hfd_by_sector_m.data(), r.hfd_by_sector_m.size());
  const std::vector<double> origin = {r.hfd_origin_m.x(), r.hfd_origin_m.y(), r.hfd_origin_m.z()};
  w.dataset("/hfd/origin_m", origin);
  w.scalar("/hfd/threshold_per_m2", scenario.settings.hfd_threshold_per_m2);
  w.dataset_attribute("/hfd/by_sector_m", "sectors",
                      "k: azimuth [10k, 10k+10) deg from +x (east) toward +y (north)");
  const auto flag = [](bool cut) { return static_cast<std::uint8_t>(cut ? 1 : 0); };
  const char* values = "0 none (a value), 1 lower (the terrain's boundary cuts it: a lower bound)";
  w.scalar("/hfd/bound", flag(b.hfd_cut));
  w.dataset_attribute("/hfd/bound", "values", values);
  const std::vector<std::uint8_t> band_bound = {flag(b.band_lower_cut), flag(b.band_upper_cut)};
  w.dataset("/hfd/band_bound", band_bound);
  w.dataset_attribute("/hfd/band_bound", "values", values);
  std::vector<std::uint8_t> sector_bound;
  for (const bool cut : b.hfd_sector_cut) sector_bound.push_back(flag(cut));
  w.dataset("/hfd/by_sector_bound", sector_bound);
  w.dataset_attribute("/hfd/by_sector_bound", "values", values);
  w.dataset("/hfd/boundary_triangles", site.terrain_boundary_triangles());
  w.scalar("/hfd/boundary_max_density_per_m2", b.max_boundary_density_per_m2);
  w.scalar("/hfd/left_site_hazardous_histories", std::int64_t{b.left_hazardous_histories});
  w.scalar("/hfd/left_site_hazardous_fragments", b.left_hazardous.mean);
  w.scalar("/hfd/left_site_hazardous_fragments_std_error", b.left_hazardous.std_error);
  std::vector<double> by_sector, by_sector_se;
  for (const run::Estimate& e : b.left_hazardous_by_sector) {
    by_sector.push_back(e.mean);
    by_sector_se.push_back(e.std_error);
  }
  w.dataset("/hfd/left_site_hazardous_by_sector", by_sector);
  w.dataset("/hfd/left_site_hazardous_by_sector_std_error", by_sector_se);
}

// /hfd/attribution: each mechanism's and group's field alone (rows in the order of the names),
// and the shares at the triangles that set the HFD (row 0) and sector k's HFD (row 1 + k).
void write_attribution_figures(Writer& w, const std::string& path,
                               const std::vector<run::HfdFigures>& fields) {
  const std::size_t n = fields.size();
  std::vector<double> hfd, band, by_sector;
  std::vector<std::uint8_t> bound, band_bound, by_sector_bound;
  for (const run::HfdFigures& f : fields) {
    hfd.push_back(f.hfd_m);
    band.insert(band.end(), {f.lower_m, f.upper_m});
    by_sector.insert(by_sector.end(), f.by_sector_m.begin(), f.by_sector_m.end());
    bound.push_back(f.cut.any() ? 1 : 0);
    band_bound.insert(band_bound.end(),
                      {std::uint8_t{f.lower_cut.any()}, std::uint8_t{f.upper_cut.any()}});
    for (const bool cut : f.cut.sectors) by_sector_bound.push_back(cut ? 1 : 0);
  }
  w.group(path);
  w.dataset(path + "/hfd_m", hfd);
  w.dataset(path + "/band_m", band.data(), n, 2);
  w.dataset(path + "/by_sector_m", by_sector.data(), n, run::kHfdSectors);
  w.dataset(path + "/bound", bound);
  w.dataset(path + "/band_bound", band_bound.data(), n, 2);
  w.dataset(path + "/by_sector_bound", by_sector_bound.data(), n, run::kHfdSectors);
}

void write_attribution_shares(Writer& w, const run::HfdAttribution& a, std::size_t groups) {
  std::vector<const run::DensityShares*> rows = {&a.at_hfd};
  for (const auto& s : a.at_sector_hfd) rows.push_back(&s);
  std::vector<std::int64_t> triangle;
  std::vector<double> distance, density, by_mechanism, by_group;
  for (const run::DensityShares* s : rows) {
    triangle.push_back(s->triangle);
    distance.push_back(s->distance_m);
    density.push_back(s->density_per_m2);
    by_mechanism.insert(by_mechanism.end(), s->by_mechanism.begin(), s->by_mechanism.end());
    if (!a.by_group.empty()) {
      const bool known = s->by_group.size() == groups;
      for (std::size_t g = 0; g < groups; ++g) by_group.push_back(known ? s->by_group[g] : 0.0);
    }
  }
  const std::string at = "/hfd/attribution/at_hfd";
  const Handle h = w.group(at);
  w.attribute(h, "rows", "0: the HFD's triangle; 1 + k: sector k's (triangle -1: none)");
  w.dataset(at + "/triangle", triangle);
  w.dataset(at + "/distance_m", distance);
  w.dataset(at + "/density_per_m2", density);
  w.dataset(at + "/share_by_mechanism", by_mechanism.data(), rows.size(),
            static_cast<std::size_t>(run::kPtnMechanismCount));
  if (!a.by_group.empty()) w.dataset(at + "/share_by_group", by_group.data(), rows.size(), groups);
}

void write_hfd_attribution(Writer& w, const run::RunResult& r, const run::Scenario& scenario) {
  const run::HfdAttribution& a = r.hfd_attribution;
  const Handle h = w.group("/hfd/attribution");
  w.attribute(h, "by_group_omitted_reason", a.by_group_omitted_reason);
  std::vector<std::string> mechanisms, groups;
  for (int m = 0; m < run::kPtnMechanismCount; ++m)
    mechanisms.emplace_back(run::ptn_mechanism_name(static_cast<run::PtnMechanism>(m)));
  for (const auto& g : scenario.groups) groups.push_back(g.name);
  w.strings("/hfd/attribution/mechanism_names", mechanisms);
  w.strings("/hfd/attribution/group_names", groups);
  write_attribution_figures(w, "/hfd/attribution/by_mechanism",
                            {a.by_mechanism.begin(), a.by_mechanism.end()});
  if (!a.by_group.empty()) write_attribution_figures(w, "/hfd/attribution/by_group", a.by_group);
  write_attribution_shares(w, a, scenario.groups.size());
}

// /ground_bracket (settings.ground_bracket): one row per constant, widest HFD swing first;
// columns low, high. The nominal run's figures as attributes.
void write_ground_bracket(Writer& w, const run::GroundBracket& b) {
  const Handle h = w.group("/ground_bracket");
  w.attribute(h, "material", b.material);
  w.attribute(h, "samples_scale", b.samples_scale);
  w.attribute(h, "histories_per_run", std::int64_t{b.histories_per_run});
  w.attribute(h, "cancelled", std::uint8_t{b.cancelled ? std::uint8_t{1} : std::uint8_t{0}});
  w.attribute(h, "nominal_hfd_m", b.nominal.hfd_m);
  w.attribute(h, "nominal_hfd_bound", b.nominal.hfd_lower_bound ? "lower" : "none");
  w.attribute(h, "nominal_building_impacts", b.nominal.building_impacts);
  w.attribute(h, "nominal_building_penetrations", b.nominal.building_penetrations);
  const std::size_t n = b.rows.size();
  if (n == 0) return;  // cancelled before the first row
  std::vector<std::string> constants;
  std::vector<double> nominal, value, hfd, impacts, penetrations;
  std::vector<std::uint8_t> bound;
  for (const run::BracketRow& r : b.rows) {
    constants.push_back(r.constant);
    nominal.push_back(r.nominal);
    for (const run::BracketFigures* f : {&r.low, &r.high}) {
      value.push_back(f->value);
      hfd.push_back(f->hfd_m);
      bound.push_back(f->hfd_lower_bound ? 1 : 0);
      impacts.push_back(f->building_impacts);
      penetrations.push_back(f->building_penetrations);
    }
  }
  w.strings("/ground_bracket/constant", constants);
  w.dataset("/ground_bracket/nominal", nominal);
  w.dataset("/ground_bracket/value", value.data(), n, 2);
  w.dataset("/ground_bracket/hfd_m", hfd.data(), n, 2);
  w.dataset("/ground_bracket/hfd_bound", bound.data(), n, 2);
  w.dataset("/ground_bracket/building_impacts", impacts.data(), n, 2);
  w.dataset("/ground_bracket/building_penetrations", penetrations.data(), n, 2);
}

}  // namespace

void write_results_h5(const std::filesystem::path& path, const run::RunResult& r,
                      const scene::Site& site, const run::Scenario& scenario,
                      const ResultsTexts& texts) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const std::size_t m = site.terrain_triangle_count();
  if (r.ptn_density_per_m2.size() != m || r.ptn_std_error_per_m2.size() != m)
    throw std::logic_error("results.h5: " + std::to_string(r.ptn_density_per_m2.size()) +
                           " PTN values for " + std::to_string(m) + " terrain triangles");
  if (r.buildings.size() != site.buildings().size())
    throw std::logic_error("results.h5: " + std::to_string(r.buildings.size()) +
                           " building results for " + std::to_string(site.buildings().size()) +
                           " buildings");

  const QuietErrors quiet;
  Writer w(path);
  const hid_t root = w.file();
  w.attribute(root, "file_type", kResultsFileType);
  w.attribute(root, "format_version", std::int32_t{kResultsFormatVersion});
  w.attribute(root, "fragsim_version", texts.version);
  w.attribute(root, "git_sha", texts.git_sha);
  if (texts.scenario_sha256) w.attribute(root, "scenario_sha256", *texts.scenario_sha256);
  w.attribute(root, "seed", std::uint64_t{r.seed});
  w.attribute(root, "samples", std::int64_t{r.samples});
  w.attribute(root, "histories_done", std::int64_t{r.histories_done});
  w.attribute(root, "batches", std::int64_t{r.batches});
  w.attribute(root, "stop_reason", run::stop_reason_name(r.stop_reason));
  w.attribute(root, "real_fragments", r.real_fragments);
  w.attribute(root, "cancelled", std::uint8_t{r.cancelled ? std::uint8_t{1} : std::uint8_t{0}});
  w.attribute(root, "scenario_json", texts.scenario_json);
  w.attribute(root, "created_utc", texts.created_utc);
  w.attribute(root, "wall_s", r.timing.wall_s);
  w.attribute(root, "threads", std::int32_t{r.timing.threads});
  w.attribute(root, "machine", texts.machine);
  w.attribute(root, "hfd_bound", r.site_boundary.hfd_cut ? "lower" : "none");
  // The figures exactly as summary.json holds them (the report reads them from here).
  w.attribute(root, "summary_json", texts.summary_json);

  write_terrain(w, site);

  {
    const Handle ptn = w.group("/ptn");
    w.dataset("/ptn/density_per_m2", r.ptn_density_per_m2);
    w.dataset("/ptn/std_error_per_m2", r.ptn_std_error_per_m2);
    w.attribute(ptn, "person_height_m", scenario.settings.person_height_m);
    w.attribute(ptn, "hazardous_ke_j", scenario.settings.hazardous_ke_j);
    w.attribute(ptn, "max_density_per_m2", r.max_ptn_density_per_m2);
    w.attribute(ptn, "max_triangle", std::int64_t{r.max_ptn_triangle});
  }
  write_hfd(w, r, site, scenario, texts.hfd_note);
  write_hfd_attribution(w, r, scenario);
  if (r.ground_bracket) write_ground_bracket(w, *r.ground_bracket);

  write_buildings(w, r, site);

  {
    w.group("/outcomes");
    std::vector<std::string> names;
    std::vector<std::int64_t> histories;
    std::vector<double> fragments, fragments_se;
    for (int k = 0; k < run::kOutcomeCount; ++k) {
      const auto o = static_cast<std::size_t>(k);
      names.emplace_back(run::outcome_name(static_cast<run::Outcome>(k)));
      histories.push_back(r.outcome_histories[o]);
      fragments.push_back(r.outcome_fragments[o].mean);
      fragments_se.push_back(r.outcome_fragments[o].std_error);
    }
    w.strings("/outcomes/name", names);
    w.dataset("/outcomes/histories", histories);
    w.dataset("/outcomes/fragments", fragments);
    w.dataset("/outcomes/fragments_std_error", fragments_se);
  }

  if (scenario.settings.record_fragments) write_fragments(w, r.fragments);
  if (scenario.settings.record_trajectories) write_trajectories(w, r.trajectories);
  w.close();
}

// ---- Readers ----

namespace {

Handle open_file(const std::filesystem::path& path) {
  return Handle(H5Fopen(path.string().c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose,
                "cannot open " + path.string());
}

Handle open_dataset(hid_t file, const std::filesystem::path& path, const std::string& name) {
  return Handle(H5Dopen2(file, name.c_str(), H5P_DEFAULT), H5Dclose,
                "no dataset " + name + " in " + path.string());
}

std::size_t element_count(hid_t dset) {
  const Handle space(H5Dget_space(dset), H5Sclose, "dataspace");
  const hssize_t n = H5Sget_simple_extent_npoints(space);
  if (n < 0) throw std::runtime_error("HDF5: dataspace size");
  return static_cast<std::size_t>(n);
}

template <class T>
std::vector<T> read_numeric(const std::filesystem::path& path, const std::string& name,
                            hid_t mem_type) {
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle dset = open_dataset(file, path, name);
  std::vector<T> out(element_count(dset));
  if (!out.empty())
    check(H5Dread(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()),
          "reading " + name + " from " + path.string());
  return out;
}

Handle open_attribute(hid_t file, const std::filesystem::path& path, const std::string& object,
                      const std::string& attribute) {
  return Handle(H5Aopen_by_name(file, object.c_str(), attribute.c_str(), H5P_DEFAULT, H5P_DEFAULT),
                H5Aclose, "no attribute " + attribute + " on " + object + " in " + path.string());
}

template <class T>
T read_attribute_numeric(const std::filesystem::path& path, const std::string& object,
                         const std::string& attribute, hid_t mem_type) {
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle attr = open_attribute(file, path, object, attribute);
  T value{};
  check(H5Aread(attr, mem_type, &value), "reading attribute " + attribute);
  return value;
}

herr_t collect_dataset(hid_t /*obj*/, const char* name, const H5O_info_t* info, void* data) {
  if (info->type == H5O_TYPE_DATASET)
    static_cast<std::vector<std::string>*>(data)->push_back(std::string("/") + name);
  return 0;
}

}  // namespace

std::vector<std::string> list_datasets(const std::filesystem::path& path) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const QuietErrors quiet;
  const Handle file = open_file(path);
  std::vector<std::string> names;
  check(H5Ovisit2(file, H5_INDEX_NAME, H5_ITER_INC, collect_dataset, &names, H5O_INFO_BASIC),
        "listing " + path.string());
  std::sort(names.begin(), names.end());
  return names;
}

std::vector<std::uint64_t> dataset_shape(const std::filesystem::path& path,
                                         const std::string& name) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle dset = open_dataset(file, path, name);
  const Handle space(H5Dget_space(dset), H5Sclose, "dataspace");
  const int rank = H5Sget_simple_extent_ndims(space);
  if (rank < 0) throw std::runtime_error("HDF5: rank of " + name);
  std::vector<hsize_t> dims(static_cast<std::size_t>(rank));
  if (rank > 0) H5Sget_simple_extent_dims(space, dims.data(), nullptr);
  return std::vector<std::uint64_t>(dims.begin(), dims.end());
}

std::vector<double> read_dataset_double(const std::filesystem::path& path,
                                        const std::string& name) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  return read_numeric<double>(path, name, H5T_NATIVE_DOUBLE);
}

std::vector<std::int64_t> read_dataset_int64(const std::filesystem::path& path,
                                             const std::string& name) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  return read_numeric<std::int64_t>(path, name, H5T_NATIVE_INT64);
}

std::vector<std::string> read_dataset_strings(const std::filesystem::path& path,
                                              const std::string& name) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle dset = open_dataset(file, path, name);
  const Handle type(H5Dget_type(dset), H5Tclose, "type of " + name);
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) > 0)
    throw std::runtime_error(name + " in " + path.string() +
                             " is not a fixed-length string dataset");
  const std::size_t width = H5Tget_size(type);
  const std::size_t n = element_count(dset);
  std::vector<char> buffer(n * width);
  if (n > 0)
    check(H5Dread(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, buffer.data()), "reading " + name);
  std::vector<std::string> out;
  for (std::size_t k = 0; k < n; ++k) {
    const char* s = buffer.data() + k * width;
    out.emplace_back(s, std::find(s, s + width, '\0'));
  }
  return out;
}

std::vector<unsigned char> read_dataset_raw(const std::filesystem::path& path,
                                            const std::string& name) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle dset = open_dataset(file, path, name);
  const Handle type(H5Dget_type(dset), H5Tclose, "type of " + name);
  std::vector<unsigned char> out(element_count(dset) * H5Tget_size(type));
  if (!out.empty())
    check(H5Dread(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.data()), "reading " + name);
  return out;
}

std::string read_attribute_string(const std::filesystem::path& path, const std::string& object,
                                  const std::string& attribute) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  const QuietErrors quiet;
  const Handle file = open_file(path);
  const Handle attr = open_attribute(file, path, object, attribute);
  const Handle type(H5Aget_type(attr), H5Tclose, "type of " + attribute);
  if (H5Tget_class(type) != H5T_STRING || H5Tis_variable_str(type) > 0)
    throw std::runtime_error("attribute " + attribute + " is not a fixed-length string");
  std::vector<char> buffer(H5Tget_size(type));
  check(H5Aread(attr, type, buffer.data()), "reading attribute " + attribute);
  return std::string(buffer.data(), std::find(buffer.begin(), buffer.end(), '\0') - buffer.begin());
}

double read_attribute_double(const std::filesystem::path& path, const std::string& object,
                             const std::string& attribute) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  return read_attribute_numeric<double>(path, object, attribute, H5T_NATIVE_DOUBLE);
}

std::int64_t read_attribute_int64(const std::filesystem::path& path, const std::string& object,
                                  const std::string& attribute) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  return read_attribute_numeric<std::int64_t>(path, object, attribute, H5T_NATIVE_INT64);
}

std::uint64_t read_attribute_uint64(const std::filesystem::path& path, const std::string& object,
                                    const std::string& attribute) {
  const std::lock_guard<std::mutex> lock(hdf5_mutex());
  return read_attribute_numeric<std::uint64_t>(path, object, attribute, H5T_NATIVE_UINT64);
}

}  // namespace fragsim::formats
