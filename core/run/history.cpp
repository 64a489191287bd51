// One fragment history: the loop over phases and the events between them (history_impl.h).
#include <algorithm>
#include <cmath>

#include "core/impact/bounce.h"
#include "core/impact/contacts.h"
#include "core/impact/fast_contact.h"
#include "core/run/hfd.h"
#include "core/run/history_impl.h"

namespace fragsim::run {
namespace detail {
namespace {

double lowest_terrain_z(const scene::Site& site) {
  double z = std::numeric_limits<double>::infinity();
  for (const Vec3& v : site.terrain_vertices()) z = std::min(z, v.z());
  return z;
}

double highest_terrain_z(const scene::Site& site) {
  double z = -std::numeric_limits<double>::infinity();
  for (const Vec3& v : site.terrain_vertices()) z = std::max(z, v.z());
  return z;
}

// A body whose lowest point is within this of the terrain at launch starts on the ground.
constexpr double kLaunchContact_m = 1e-6;

}  // namespace

History::History(const RunContext& ctx, std::uint32_t group, std::int64_t history,
                 bool record_trajectory, HistoryScratch& scratch, ChunkOutput& out,
                 const fragments::DirectionCells* cells, const fragments::LaunchStratum* stratum)
    : ctx_(ctx),
      sc_(*ctx.scenario),
      st_(sc_.settings),
      site_(*ctx.site),
      group_(group),
      history_(history),
      record_trajectory_(record_trajectory),
      scratch_(scratch),
      out_(out),
      prof_(st_.profile),
      init_(fragments::sample_fragment(
          ctx.launch[group], group, static_cast<std::uint64_t>(history), st_.seed, cells, stratum)),
      mass_(init_.body.mass_kg),
      weight_(init_.weight),
      g_(sc_.gravity_mps2),
      body_(fragments::contact_body(init_.shape, init_.body)),
      rot_(body_.inertia_kg_m2) {
  model_.atmosphere = &ctx.atmosphere;
  model_.cd = &ctx.cd[group];
  model_.gravity_mps2 = g_;
  model_.area_m2 = init_.body.presented_area_m2;
  model_.mass_kg = mass_;
  model_.altitude_offset_m = site_.altitude_offset_m();
  radius_m_ = st_.bounce ? fragments::bounding_radius(body_) : 0.0;
  flat_tol_m_ = 1e-6 * radius_m_;
  density_kg_m3_ = mass_ / fragments::body_volume(body_);
}

// ---- the loop ----

void History::simulate() {
  scratch_.ptn.clear();
  if (record_trajectory_) {
    traj_.group = group_;
    traj_.history = static_cast<std::uint64_t>(history_);
  }
  Phase phase = launch();
  while (phase != Phase::kDone) {
    phase = phase == Phase::kFlight ? flight_phase() : ground_phase();
  }
  if (end_.outcome != Outcome::kMaxFlightTime && end_.outcome != Outcome::kStartedInside &&
      end_.outcome != Outcome::kLeftSite) {
    record_point(end_.t, end_.p, end_.v, TrajectoryEvent::kEnd);
  }
  finish();
}

void History::end_as(Outcome outcome, double t, const Vec3& p, const Vec3& v) {
  end_.outcome = outcome;
  end_.t = t;
  end_.p = p;
  end_.v = v;
}

// Launch checks: off the site, inside something, never of interest; with bounce, a body touching
// the terrain starts on the ground (or with an impact, if it moves into it).
Phase History::launch() {
  state_.t = 0.0;
  state_.p = site_.to_local(init_.position_m);
  state_.v = init_.velocity_mps;
  state_.q = init_.orientation;
  state_.omega = init_.orientation * init_.omega_body_radps;
  const Vec3& p = state_.p;
  end_as(Outcome::kGround, 0.0, p, state_.v);
  if (!site_.terrain_bounds().contains_xy(p.x(), p.y())) {
    end_.outcome = Outcome::kLeftSite;
    return Phase::kDone;
  }
  const double h = site_.terrain_height(p.x(), p.y());
  if ((!std::isnan(h) && p.z() < h - kLaunchContact_m) ||
      (site_.has_buildings() && site_.inside_building(p))) {
    end_.outcome = Outcome::kStartedInside;
    return Phase::kDone;
  }
  if (can_never_matter(p, state_.v, rotational_ke(state_.q, state_.omega))) {
    end_.outcome = Outcome::kHarmless;
    return Phase::kDone;
  }
  record_point(0.0, p, state_.v, TrajectoryEvent::kLaunch);
  return st_.bounce ? start_on_ground() : Phase::kFlight;
}

// A body launched touching (or overlapping) the terrain under its centre: lifted onto it; then
// an impact if its contact point moves into the plane, the ground phase if it moves along it
// (slower than the take-off speed off it), else a flight.
Phase History::start_on_ground() {
  const std::int64_t tri = site_.terrain_triangle_at(state_.p.x(), state_.p.y());
  if (tri < 0) return Phase::kFlight;
  const auto t = static_cast<std::uint32_t>(tri);
  const Vec3& n = site_.terrain_triangle_normal(t);
  const double reach = fragments::support_extent(body_, state_.q, -n);
  const double height =
      (state_.p.z() - site_.terrain_plane_height(t, state_.p.x(), state_.p.y())) * n.z();
  if (height - reach > kLaunchContact_m) return Phase::kFlight;
  state_.p += (reach - height) * n;
  state_.triangle = t;
  const Vec3 r = fragments::contact_point(body_, state_.q, n, flat_tol_m_);
  if ((state_.v + state_.omega.cross(r)).dot(n) < 0.0) {
    FlightEvent ev;
    ev.t = 0.0;
    ev.p = state_.p;
    ev.v = state_.v;
    ev.normal = n;
    ev.triangle = t;
    ev.material = site_.terrain_triangle_material(t);
    return terrain_impact(ev);
  }
  return state_.v.dot(n) < st_.min_rebound_speed_mps ? Phase::kGround : Phase::kFlight;
}

Phase History::flight_phase() {
  rot_.start({state_.q, state_.q.conjugate() * state_.omega}, state_.t);
  segment_rot_ke_j_ = rotational_ke(state_.q, state_.omega);
  const FlightEvent ev = fly();
  end_as(Outcome::kGround, ev.t, ev.p, ev.v);
  switch (ev.end) {
    case FlightEnd::kBuilding:
      note_first_impact(ev.t, ev.p, ev.v, ev.normal);
      building_hit(ev);
      return Phase::kDone;
    case FlightEnd::kLeftSite: end_.outcome = Outcome::kLeftSite; return Phase::kDone;
    case FlightEnd::kMaxTime: end_.outcome = Outcome::kMaxFlightTime; return Phase::kDone;
    case FlightEnd::kHarmless: end_.outcome = Outcome::kHarmless; return Phase::kDone;
    case FlightEnd::kIntegrationFailed:
      end_.outcome = Outcome::kIntegrationFailed;
      return Phase::kDone;
    case FlightEnd::kWorkLimit: end_.outcome = Outcome::kWorkLimit; return Phase::kDone;
    case FlightEnd::kTerrain:
      note_first_impact(ev.t, ev.p, ev.v, ev.normal);
      if (!st_.bounce) return Phase::kDone;  // without bounce the first ground impact ends it
      const flight::RotationState rs = rotation(ev.t);
      state_.q = rs.q.normalized();
      state_.omega = state_.q * rs.omega_body;
      return terrain_impact(ev);
  }
  return Phase::kDone;
}

// A terrain impact from flight (paper eqs. 6-36): the impulse, then a new flight, or the ground
// phase when the rebound is slower than the floor (or the bounce cap is reached).
Phase History::terrain_impact(const FlightEvent& ev) {
  const scene::Material& mat = site_.materials()[ev.material];
  if (ev.v.norm() >= mat.fast_contact_speed_mps()) return fast_terrain_contact(ev, mat);
  if (mat.embeds(ev.v, ev.normal, density_kg_m3_)) {  // too fast and steep to ricochet
    end_as(Outcome::kEmbedded, ev.t, ev.p, ev.v);
    record_point(ev.t, ev.p, ev.v, TrajectoryEvent::kTerrainImpact);
    return Phase::kDone;
  }
  const impact::TerrainBounce b = impact::bounce_on_terrain(
      body_, mass_, state_.q, ev.v, state_.omega, ev.normal, mat, flat_tol_m_);
  if (b.collision.impact) {
    audit_impact(energy(ev.p.z(), ev.v, state_.q, state_.omega),
                 energy(ev.p.z(), b.collision.velocity_mps, state_.q, b.collision.omega_radps));
  }
  ++bounces_;
  ++work_;
  ++out_.stats.bounces;
  record_point(ev.t, ev.p, ev.v, TrajectoryEvent::kTerrainImpact);
  const bool hit = b.collision.impact;
  return leave_terrain(ev, hit ? b.collision.velocity_mps : ev.v,
                       hit ? b.collision.omega_radps : state_.omega, bounces_ >= st_.max_bounces);
}

// The body leaves the impact at ev with (v, omega): the ground phase if its rebound along the
// normal is slower than the floor or `capped` (the bounce cap), else a new flight (unless it can
// never matter again).
Phase History::leave_terrain(const FlightEvent& ev, const Vec3& v, const Vec3& omega, bool capped) {
  state_.t = ev.t;
  state_.p = ev.p;
  state_.v = v;
  state_.omega = omega;
  state_.triangle = ev.triangle;
  end_as(Outcome::kGround, ev.t, ev.p, v);
  if (v.dot(ev.normal) < st_.min_rebound_speed_mps || capped) return Phase::kGround;
  if (can_never_matter(ev.p, v, rotational_ke(state_.q, omega))) {
    end_.outcome = Outcome::kHarmless;
    return Phase::kDone;
  }
  record_point(ev.t, ev.p, v, TrajectoryEvent::kTakeOff);
  return Phase::kFlight;
}

// A terrain contact from flight at least the material's switch speed fast (F1-F6): embedded, or
// a ricochet. A ricochet that keeps v_s always flies on (F6); one slowed below it goes on as
// after an impulse. The bounce cap does not send a fast body to the ground: every fast contact
// loses speed (F4), so their sequence ends.
Phase History::fast_terrain_contact(const FlightEvent& ev, const scene::Material& mat) {
  const impact::FastContactOutcome f = impact::fast_contact(
      *mat.fast_contact, density_kg_m3_, ev.v, state_.omega, ev.normal, st_.min_rebound_speed_mps);
  ++work_;
  ++out_.stats.fast_contacts;
  record_point(ev.t, ev.p, ev.v, TrajectoryEvent::kTerrainImpact);
  if (f.end != impact::FastContactEnd::kRicochet) {
    end_as(Outcome::kEmbedded, ev.t, ev.p, ev.v);
    return Phase::kDone;
  }
  audit_impact(energy(ev.p.z(), ev.v, state_.q, state_.omega),
               energy(ev.p.z(), f.velocity_mps, state_.q, f.omega_radps));
  ++bounces_;
  const bool fast = f.velocity_mps.norm() >= mat.fast_contact_speed_mps();
  return leave_terrain(ev, f.velocity_mps, f.omega_radps, !fast && bounces_ >= st_.max_bounces);
}

void History::building_hit(const FlightEvent& ev) {
  const scene::Material& mat = site_.materials()[ev.material];
  const double vn = ev.v.dot(ev.normal);
  const double ke = 0.5 * mass_ * ev.v.squaredNorm();
  const double ke_normal = 0.5 * mass_ * vn * vn;
  const double area = init_.body.presented_area_m2;
  end_as(Outcome::kBuilding, ev.t, ev.p, ev.v);
  end_.building = static_cast<std::int32_t>(ev.building);
  end_.surface = static_cast<std::int32_t>(ev.surface);
  // Penetration: normal kinetic energy per presented area above the material's threshold; the
  // wall absorbs the threshold energy, the rest is residual.
  end_.penetrated = ke_normal > mat.penetration_ke_per_area_j_per_m2 * area;
  end_.residual_ke_j = end_.penetrated ? ke - mat.penetration_ke_per_area_j_per_m2 * area : 0.0;
  record_point(ev.t, ev.p, ev.v, TrajectoryEvent::kBuildingHit);
}

// ---- bounds and records ----

// Can this fragment ever matter again? Below the hazardous threshold it cannot add to the PTN
// density; with no buildings on the site nothing else is tallied. In still air drag, impacts and
// the ground phase only remove mechanical energy (impacts may turn spin into speed, so the
// rotational energy counts), so its kinetic energy never exceeds
// KE + KE_rot + m g (z - lowest terrain). With wind and no bounce the history ends at its first
// ground contact, and in the wind's frame (inertial: uniform, steady wind) drag only removes
// energy: |v| <= |w| + sqrt(|v - w|^2 + 2 g (z - lowest terrain)). With wind and bounce no
// rigorous bound is used (friction on the ground can add energy in the wind's frame, drag in
// the ground's): the history is followed to its end.
bool History::can_never_matter(const Vec3& p, const Vec3& v, double rotational_ke_j) const {
  if (site_.has_buildings() || !st_.harmless_cutoff) return false;
  const double drop = p.z() - ctx_.terrain_min_z;
  if (ctx_.still_air) {
    const double ke_max = 0.5 * mass_ * v.squaredNorm() + rotational_ke_j + mass_ * g_ * drop;
    return ke_max < st_.hazardous_ke_j;
  }
  if (st_.bounce) return false;
  const Vec3& w = sc_.atmosphere.wind_mps;
  const double v_max = w.norm() + std::sqrt(std::max(0.0, (v - w).squaredNorm() + 2.0 * g_ * drop));
  return 0.5 * mass_ * v_max * v_max < st_.hazardous_ke_j;
}

// 1/2 omega . I omega, with omega in site axes and the body at attitude q: the part of the
// rotational energy an impact could turn into speed (none without bounce: the first impact ends
// the history).
double History::rotational_ke(const Quat& q, const Vec3& omega_site) const {
  if (!st_.bounce || omega_site.squaredNorm() == 0.0) return 0.0;
  const Vec3 wb = q.conjugate() * omega_site;
  return 0.5 * wb.dot(body_.inertia_kg_m2.cwiseProduct(wb));
}

BodyEnergy History::energy(double z_m, const Vec3& v, const Quat& q, const Vec3& omega_site) const {
  return {0.5 * mass_ * v.squaredNorm() + rotational_ke(q, omega_site), mass_ * g_ * z_m};
}

// An impact changes no position, so only the kinetic part can differ; an instantaneous impulse
// does no work against the air, so this holds in wind too.
void History::audit_impact(const BodyEnergy& before, const BodyEnergy& after) {
  if (energy_rose(before, after)) ++out_.stats.energy_rises;
}

void History::note_first_impact(double t, const Vec3& p, const Vec3& v, const Vec3& normal) {
  if (first_.seen) return;
  first_ = {true, t, p, v, impact::impact_angle_deg(v, normal)};
}

void History::record_point(double t, const Vec3& p, const Vec3& v, TrajectoryEvent e) {
  if (!record_trajectory_) return;
  const bool plain = e == TrajectoryEvent::kFlight || e == TrajectoryEvent::kGround;
  if (!traj_.t_s.empty() && !(t > traj_.t_s.back())) {
    if (t < traj_.t_s.back() || plain) return;
    const TrajectoryEvent last = traj_.event.back();
    if (last == TrajectoryEvent::kFlight || last == TrajectoryEvent::kGround) {
      traj_.event.back() = e;  // the same point, now known as an event
      traj_.velocity_mps.back() = v;
      return;
    }
  }
  traj_.t_s.push_back(t);
  traj_.position_m.push_back(site_.to_input(p));
  traj_.velocity_mps.push_back(v);
  traj_.event.push_back(e);
}

// ---- end of the history: its tally records ----

void History::finish() {
  fold_tallies();
  if (st_.record_fragments) out_.records.push_back(fragment_record());
  if (record_trajectory_) out_.trajectories.push_back(std::move(traj_));
}

// The per-history tally records: PTN contributions (a prism counts once), the building hit, the
// outcome.
void History::fold_tallies() {
  {
    SectionTimer timer(prof_, out_.tally_s);
    // The first crossing of a prism wins (contributions are pushed in path order). A stamp per
    // triangle marks the ones taken in this history. The fold adds one value per triangle and
    // history, so the order of the list does not change a sum.
    auto& seen = scratch_.seen;
    if (seen.size() != site_.terrain_triangle_count()) {
      seen.assign(site_.terrain_triangle_count(), 0u);
      scratch_.stamp = 0;
    }
    if (++scratch_.stamp == 0) {  // wrapped: no stale mark may equal a new stamp
      std::fill(seen.begin(), seen.end(), 0u);
      scratch_.stamp = 1;
    }
    for (const auto& c : scratch_.ptn) {
      if (seen[c.triangle] == scratch_.stamp) continue;
      seen[c.triangle] = scratch_.stamp;
      out_.ptn.push_back(c);
    }
    out_.ptn_end.push_back(static_cast<std::uint32_t>(out_.ptn.size()));
    if (end_.outcome == Outcome::kBuilding) {
      out_.building_index.push_back(static_cast<std::int32_t>(out_.buildings.size()));
      out_.buildings.push_back({static_cast<std::uint32_t>(end_.building),
                                static_cast<std::uint8_t>(end_.surface), end_.penetrated,
                                end_.residual_ke_j});
    } else {
      out_.building_index.push_back(-1);
    }
    out_.outcomes.push_back(end_.outcome);
    out_.exit_sector.push_back(exit_sector());
    out_.weights.push_back(weight_);
    out_.cells.push_back(init_.direction_cell);
  }
}

// The HFD sector where a history left the site while hazardous (kinetic energy >= the
// threshold as it crossed the terrain's extent), else -1.
std::int8_t History::exit_sector() const {
  if (end_.outcome != Outcome::kLeftSite) return -1;
  if (0.5 * mass_ * end_.v.squaredNorm() < st_.hazardous_ke_j) return -1;
  return static_cast<std::int8_t>(
      hfd_sector(end_.p.x() - ctx_.hfd_origin.x(), end_.p.y() - ctx_.hfd_origin.y()));
}

FragmentRecord History::fragment_record() const {
  FragmentRecord r;
  r.group = group_;
  r.history = static_cast<std::uint64_t>(history_);
  r.weight = weight_;
  r.mass_kg = mass_;
  r.area_m2 = init_.body.presented_area_m2;
  r.launch_position_m = init_.position_m;
  r.launch_velocity_mps = init_.velocity_mps;
  r.outcome = end_.outcome;
  r.end_time_s = end_.t;
  r.end_position_m = site_.to_input(end_.p);
  r.end_velocity_mps = end_.v;
  if (first_.seen) {
    r.first_impact_time_s = first_.t;
    r.first_impact_position_m = site_.to_input(first_.p);
    r.first_impact_velocity_mps = first_.v;
    r.impact_angle_deg = first_.angle_deg;
    r.impact_ke_j = 0.5 * mass_ * first_.v.squaredNorm();
  }
  r.building = end_.building;
  r.surface = end_.surface;
  r.penetrated = end_.penetrated;
  r.residual_ke_j = end_.residual_ke_j;
  r.bounces = bounces_;
  r.ground_impacts = ground_impacts_;
  r.takeoffs = takeoffs_;
  r.ground_path_m = ground_path_m_;
  return r;
}

}  // namespace detail

RunContext::RunContext(const Scenario& sc, const scene::Site& s)
    : scenario(&sc), site(&s), atmosphere(sc.atmosphere), prisms(s, sc.settings.person_height_m) {
  cd.reserve(sc.groups.size());
  launch.reserve(sc.groups.size());
  for (const auto& g : sc.groups) {
    cd.emplace_back(g.cd);
    launch.emplace_back(g);
  }
  terrain_min_z = detail::lowest_terrain_z(s);
  terrain_max_z = detail::highest_terrain_z(s);
  for (std::uint32_t t = 0; t < s.terrain_triangle_count(); ++t)
    terrain_min_nz = std::min(terrain_min_nz, s.terrain_triangle_normal(t).z());
  if (s.terrain_is_lattice() && terrain_min_nz > 0.0)
    lattice_max_slope =
        std::sqrt(std::max(0.0, 1.0 - terrain_min_nz * terrain_min_nz)) / terrain_min_nz;
  hfd_origin = s.to_local(hfd_origin_input(sc, s));
  top_z = prisms.top_z();
  if (s.has_buildings()) top_z = std::max(top_z, s.buildings_bounds().hi.z());
  step_min_at_ends = sc.atmosphere.wind_mps.z() <= 0.0;
  still_air = sc.atmosphere.wind_mps.squaredNorm() == 0.0;
}

void append_histories(ChunkOutput& to, ChunkOutput& piece) {
  const auto ptn_base = static_cast<std::uint32_t>(to.ptn.size());
  for (const std::uint32_t end : piece.ptn_end) to.ptn_end.push_back(ptn_base + end);
  to.ptn.insert(to.ptn.end(), piece.ptn.begin(), piece.ptn.end());
  const auto building_base = static_cast<std::int32_t>(to.buildings.size());
  for (const std::int32_t b : piece.building_index)
    to.building_index.push_back(b < 0 ? -1 : building_base + b);
  to.buildings.insert(to.buildings.end(), piece.buildings.begin(), piece.buildings.end());
  to.outcomes.insert(to.outcomes.end(), piece.outcomes.begin(), piece.outcomes.end());
  to.exit_sector.insert(to.exit_sector.end(), piece.exit_sector.begin(), piece.exit_sector.end());
  to.weights.insert(to.weights.end(), piece.weights.begin(), piece.weights.end());
  to.cells.insert(to.cells.end(), piece.cells.begin(), piece.cells.end());
  for (auto& r : piece.records) to.records.push_back(std::move(r));
  for (auto& t : piece.trajectories) to.trajectories.push_back(std::move(t));
  to.stats += piece.stats;
  to.integration_s += piece.integration_s;
  to.geometry_s += piece.geometry_s;
  to.tally_s += piece.tally_s;
  clear_histories(piece);
}

void clear_histories(ChunkOutput& piece) {
  piece.ptn_end.clear();
  piece.ptn.clear();
  piece.building_index.clear();
  piece.buildings.clear();
  piece.outcomes.clear();
  piece.exit_sector.clear();
  piece.weights.clear();
  piece.cells.clear();
  piece.records.clear();
  piece.trajectories.clear();
  piece.stats = RunStats{};
  piece.integration_s = piece.geometry_s = piece.tally_s = 0.0;
}

void simulate_history(const RunContext& ctx, std::uint32_t group, std::int64_t history,
                      bool record_trajectory, HistoryScratch& scratch, ChunkOutput& out,
                      const fragments::DirectionCells* cells,
                      const fragments::LaunchStratum* stratum) {
  detail::History h(ctx, group, history, record_trajectory, scratch, out, cells, stratum);
  h.simulate();
}

}  // namespace fragsim::run
