// The flight phase of a history (history_impl.h): integrator steps, cut into chords; each chord
// queried against the site (or skipped), a hit refined on the interpolant, the body's own
// contact with the terrain (bounce mode), the PTN tally along the chord.
#include <algorithm>
#include <cmath>

#include "core/common/roots.h"
#include "core/impact/contacts.h"
#include "core/run/history_impl.h"

namespace fragsim::run::detail {

FlightEvent History::fly() {
  flight::TrajectoryIntegrator integ(model_, st_.rtol);
  integ.reset(state_.t, state_.p, state_.v);
  scene::BuildingProximity near_buildings(site_);
  FlightStep s;
  s.t1 = state_.t;
  s.p1 = state_.p;
  s.v1 = state_.v;
  s.a1 = model_.acceleration(s.p1, s.v1);
  FlightEvent ev;
  for (;;) {
    // Checked before a step, so everything up to the end state has been examined and tallied.
    if (work_ >= st_.max_history_work) {
      ev = {FlightEnd::kWorkLimit, s.t1, s.p1, s.v1};
      break;
    }
    if (!flight_step(integ, s, ev)) break;
    ++work_;
    bool done = examine_step(integ, s, near_buildings, ev);
    if (!done) done = catch_slip_through(integ, s, ev);
    // Trajectory record: the step's end, or where it was cut short (time stays increasing
    // across bounces, and no point lies past a contact).
    record_point(done ? ev.t : s.t1, done ? ev.p : s.p1, done ? ev.v : s.v1,
                 TrajectoryEvent::kFlight);
    if (done) break;
    if (!site_.terrain_bounds().contains_xy(s.p1.x(), s.p1.y())) {
      ev = {FlightEnd::kLeftSite, s.t1, s.p1, s.v1};
      break;
    }
    if (can_never_matter(s.p1, s.v1, segment_rot_ke_j_)) {
      ev = {FlightEnd::kHarmless, s.t1, s.p1, s.v1};
      break;
    }
  }
  out_.stats.rhs_evaluations += integ.rhs_evaluations();
  return ev;
}

// One accepted integrator step; false (with the event) when the flight cannot go on: the time
// limit, or a step size underflow.
bool History::flight_step(flight::TrajectoryIntegrator& integ, FlightStep& s, FlightEvent& ev) {
  bool ok;
  {
    SectionTimer timer(prof_, out_.integration_s);
    ok = integ.step(st_.max_flight_time_s);
  }
  if (!ok) {
    ev.end =
        integ.t() >= st_.max_flight_time_s ? FlightEnd::kMaxTime : FlightEnd::kIntegrationFailed;
    ev.t = integ.t();
    ev.p = integ.position();
    ev.v = integ.velocity();
    return false;
  }
  ++out_.stats.integrator_steps;
  const flight::TrajectoryIntegrator::StepEnd e = integ.step_end();
  s.t0 = e.t0;
  s.p0 = s.p1;
  s.v0 = s.v1;
  s.a0 = s.a1;
  s.t1 = e.t1;
  s.p1 = e.p;
  s.v1 = e.v;
  s.a1 = e.a;
  return true;
}

// The step's chords, each examined in turn until one ends the flight. Under gravity and drag in
// still or sinking air z(t) has no interior minimum within a step (z'' = -g - k|v_rel| (v_z -
// w_z) < 0 where v_z = 0 and w_z <= 0), so the step's lowest point is one of its ends and steps
// above everything are free. An updraft (w_z > 0) can make z'' > 0 at rest: then every step is
// examined.
bool History::examine_step(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                           scene::BuildingProximity& near_buildings, FlightEvent& ev) {
  // With a finite body the terrain is met up to one bounding radius before the centre's path
  // reaches it: steps and chords that low are examined.
  const double top_z = ctx_.top_z + radius_m_;
  if (ctx_.step_min_at_ends && std::min(s.p0.z(), s.p1.z()) > top_z) return false;
  // Curvature at both ends and in the middle (an apex inside the step is where it peaks).
  double tm;
  Vec3 pm, vm;
  integ.state_at_fraction(0.5, tm, pm, vm);
  const double kappa =
      std::max({impact::path_curvature(s.v0, s.a0), impact::path_curvature(s.v1, s.a1),
                impact::path_curvature(vm, model_.acceleration(pm, vm))});
  const int n = impact::chord_count((s.p1 - s.p0).norm(), kappa, st_.sagitta_m);
  out_.stats.chords += n;
  Chord c;
  c.pa = s.p0;
  c.ta = s.t0;
  Vec3 va = s.v0;
  // Chord ends evenly spaced in the step's variable: in path length in the s-phase.
  for (int k = 1; k <= n; ++k) {
    c.tb = s.t1;
    c.pb = s.p1;
    Vec3 vb = s.v1;
    if (k < n) integ.state_at_fraction(static_cast<double>(k) / n, c.tb, c.pb, vb);
    if (std::min(c.pa.z(), c.pb.z()) > top_z) {
      ++out_.stats.chords_skipped;
    } else {
      c.e_bound = chord_energy_bound(s, k, c.pa, va);
      c.deviation_m = impact::chord_deviation_bound((c.pb - c.pa).norm(), kappa);
      if (examine_chord(integ, s, c, near_buildings, ev)) return true;
    }
    c.pa = c.pb;
    va = vb;
    c.ta = c.tb;
  }
  return false;
}

// In still air drag only removes mechanical energy, and a chord's lowest point is one of its
// ends, so no point of a chord has more kinetic energy than E(ta) - m g z_min: a chord below the
// hazardous energy by that bound needs no PTN walk. E(ta) is the step's start energy for its
// first chord (exact) and the interpolant's energy at the chord's start for the others, with a
// slack of 1e-3 + 10 rtol (relative) for the interpolant's error (~rtol).
double History::chord_energy_bound(const FlightStep& s, int k, const Vec3& pa,
                                   const Vec3& va) const {
  const double e_step = 0.5 * mass_ * s.v0.squaredNorm() + mass_ * g_ * s.p0.z();
  if (k == 1) return e_step;
  const double e_chord = 0.5 * mass_ * va.squaredNorm() + mass_ * g_ * pa.z();
  return std::min(e_step, e_chord + std::abs(e_chord) * (1e-3 + 10.0 * st_.rtol));
}

// One chord [ta, tb]: the scene query for the centre's path, the body's contact with the
// terrain, whichever comes first ends the flight; the PTN tally up to there.
bool History::examine_chord(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                            const Chord& c, scene::BuildingProximity& near_buildings,
                            FlightEvent& ev) {
  const double ta = c.ta, tb = c.tb;
  const Vec3 &pa = c.pa, &pb = c.pb;
  const double zlo = std::min(pa.z(), pb.z());
  const double clear = terrain_clearance(pa, pb);
  const std::optional<scene::SceneHit> hit = query_chord(pa, pb, clear, near_buildings);
  const double t_hit = hit ? refine_hit(integ, s, *hit, ta, tb, pa, pb) : tb;
  // A finite body touches the terrain before its centre gets there.
  std::optional<FlightEvent> touch;
  if (st_.bounce && radius_m_ > 0.0 && zlo <= ctx_.terrain_max_z + radius_m_) {
    SectionTimer timer(prof_, out_.geometry_s);
    touch =
        body_terrain_contact(integ, c, clear, t_hit,
                             hit && hit->terrain ? static_cast<std::int64_t>(hit->triangle) : -1);
  }
  double s_end = 1.0;  // the path for the PTN tally: the chord, up to the contact
  if (touch) {
    ev = *touch;
    s_end = tb > ta ? std::clamp((touch->t - ta) / (tb - ta), 0.0, 1.0) : 0.0;
  } else if (hit) {
    ev.t = t_hit;
    integ.state(t_hit, ev.p, ev.v);
    ev.normal = hit->normal;
    ev.triangle = hit->triangle;
    ev.material = hit->material;
    ev.end = hit->terrain ? FlightEnd::kTerrain : FlightEnd::kBuilding;
    ev.building = hit->building;
    ev.surface = hit->surface;
    s_end = std::min(hit->t, 1.0);
  }
  const bool may_be_hazardous = !ctx_.still_air || !ctx_.step_min_at_ends ||
                                c.e_bound - mass_ * g_ * zlo >= st_.hazardous_ke_j;
  if (may_be_hazardous) {
    add_ptn_segment(
        pa, pa + s_end * (pb - pa),
        [&](double u) { return integ.velocity(ta + u * s_end * (tb - ta)); }, flight_mechanism(),
        clear);
  }
  return touch || hit;
}

// The scene query for the chord's straight segment, with the parts of the scene it can reach.
// A surface met from behind (moving away from it) is where the path starts on it, e.g. a
// launch from ground level or a bounce: looked past (at most a few surfaces meet at a point).
std::optional<scene::SceneHit> History::query_chord(const Vec3& pa, const Vec3& pb, double clear,
                                                    scene::BuildingProximity& near_buildings) {
  unsigned mask = 0;
  if (clear <= kTerrainQuerySlack_m) mask |= scene::kQueryTerrain;
  if (near_buildings.maybe_near(pa, pb) && site_.segment_near_buildings(pa, pb))
    mask |= scene::kQueryBuildings;
  if (mask == 0) return std::nullopt;
  SectionTimer timer(prof_, out_.geometry_s);
  ++out_.stats.scene_queries;
  // tfar slightly beyond 1: a hit exactly at a chord junction is never lost.
  const Vec3 d = pb - pa;
  double tnear = 0.0;
  std::optional<scene::SceneHit> hit = site_.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
  for (int skip = 0; hit && hit->normal.dot(d) >= 0.0 && skip < 4; ++skip) {
    tnear = hit->t + 1e-9;
    hit = site_.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
  }
  if (hit && hit->normal.dot(d) >= 0.0) hit.reset();
  return hit;
}

// The chord's clearance over the terrain (TerrainIndex2D::clearance), +inf above every prism.
// The walk stops once the chord is within kTerrainQuerySlack_m of a bucket's highest terrain:
// then both the scene query and the PTN walk are needed anyway.
double History::terrain_clearance(const Vec3& pa, const Vec3& pb) const {
  if (std::min(pa.z(), pb.z()) > ctx_.prisms.top_z()) return kInfinity;
  return site_.terrain_index().clearance(pa, pb, kTerrainQuerySlack_m);
}

// The centre's path meets a surface: the crossing refined on the interpolant against the hit
// triangle's plane (the chord hit point is on that plane), bracketed within the chord, else the
// step; an arc that only skims the plane keeps the chord's hit.
double History::refine_hit(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                           const scene::SceneHit& hit, double ta, double tb, const Vec3& pa,
                           const Vec3& pb) const {
  const Vec3 q = pa + hit.t * (pb - pa);
  const auto pos = [&](double t) { return integ.position(t); };
  double th = impact::refine_plane_crossing(pos, hit.normal, q, ta, tb);
  if (std::isnan(th)) th = impact::refine_plane_crossing(pos, hit.normal, q, s.t0, s.t1);
  if (std::isnan(th)) th = ta + hit.t * (tb - ta);
  return th;
}

// A path that slipped through the terrain (e.g. exactly through a shared vertex in float
// precision) is caught at the step's end and its crossing located on the interpolant.
bool History::catch_slip_through(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                                 FlightEvent& ev) const {
  if (site_.terrain_is_plane() || s.p1.z() > ctx_.terrain_max_z) return false;
  const double h1 = site_.terrain_height(s.p1.x(), s.p1.y());
  if (std::isnan(h1) || !(s.p1.z() < h1 - 1e-6)) return false;
  double lo = s.t0, hi = s.t1;
  for (int it = 0; it < 60; ++it) {  // bisection: the height function has kinks at edges
    const double t_mid = 0.5 * (lo + hi);
    const Vec3 pm = integ.position(t_mid);
    const double hm = site_.terrain_height(pm.x(), pm.y());
    if (std::isnan(hm) || pm.z() >= hm)
      lo = t_mid;
    else
      hi = t_mid;
  }
  ev.end = FlightEnd::kTerrain;
  ev.t = hi;
  integ.state(hi, ev.p, ev.v);
  const std::int64_t tri = site_.terrain_triangle_at(ev.p.x(), ev.p.y());
  ev.triangle = tri < 0 ? 0u : static_cast<std::uint32_t>(tri);
  ev.normal = tri < 0 ? Vec3::UnitZ() : site_.terrain_triangle_normal(ev.triangle);
  ev.material = tri < 0 ? site_.terrain_material() : site_.terrain_triangle_material(ev.triangle);
  return true;
}

// ---- the body's contact with the terrain (bounce mode) ----

// Is the body's lowest point on triangle `tri` moving into its plane at time t?
bool History::contact_approaching(const flight::TrajectoryIntegrator& integ, std::uint32_t tri,
                                  double t) const {
  const Vec3& n = site_.terrain_triangle_normal(tri);
  const flight::RotationState s = rotation(t);
  const Quat q = s.q.normalized();
  const Vec3 r = fragments::contact_point(body_, q, n, flat_tol_m_);
  return (integ.velocity(t) + (q * s.omega_body).cross(r)).dot(n) < 0.0;
}

// Signed clearance of the body from the plane of terrain triangle `tri` at time t: the centre's
// height above the plane along its normal minus the body's reach toward it (support function).
// <= 0: touching or overlapping. Farther than one bounding radius the sign is known without the
// attitude: the bound (distance - radius, also > 0) is returned instead, which leaves every sign
// unchanged.
double History::clearance(const flight::TrajectoryIntegrator& integ, std::uint32_t tri,
                          double t) const {
  const Vec3& n = site_.terrain_triangle_normal(tri);
  const Vec3& v0 = site_.terrain_vertices()[site_.terrain_triangles()[tri][0]];
  const double d = n.dot(integ.position(t) - v0);
  if (d > radius_m_) return d - radius_m_;
  return d - fragments::support_extent(body_, attitude(t), -n);
}

// The first time in [ta, tb] at which the body touches the plane of `tri` while approaching it
// (clearance falls from > 0 to <= 0), or NaN. Sampled at a few points, then refined. The
// clearance at ta is read only when the first sample touches (as the bracket's other end, or for
// the "already touching" test): otherwise nothing depends on it. Reading it later gives the same
// bits: the attitude at ta is the base's, set by advance_base, for a body propagated from it, and
// a pure function of t for an asymmetric one (SegmentRotation::at).
double History::first_touch(const flight::TrajectoryIntegrator& integ, std::uint32_t tri, double ta,
                            double tb) const {
  constexpr int kSamples = 4;
  rot_.advance_base(ta);
  double t_prev = ta;
  double g_prev = 0.0;
  bool have_prev = false;  // g_prev = g(t_prev) taken
  const auto g = [&](double t) { return clearance(integ, tri, t); };
  for (int k = 1; k <= kSamples; ++k) {
    const double t = (k == kSamples) ? tb : ta + (tb - ta) * k / kSamples;
    const double gk = g(t);
    if (gk <= 0.0) {
      if (!have_prev) g_prev = g(t_prev);
      // The side that touches (clearance <= 0): the bracket's end on or after the root.
      if (g_prev > 0.0) return illinois(g, t_prev, t, g_prev, gk, 1e-13, 60).hi;
      // Already touching at the start of this sample interval. Right after a bounce or a
      // take-off the body sits on the plane and is leaving it: look further. Otherwise
      // (touching and approaching) the contact is now.
      if (k == 1 && t_prev > rot_.start_time() && contact_approaching(integ, tri, t_prev))
        return t_prev;
    }
    t_prev = t;
    g_prev = gk;
    have_prev = true;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

// Is the body clear of the plane of terrain triangle `tri` all along the chord? The centre's
// distance to the plane is linear along the segment pa -> pb, so its least value is at an end;
// the path strays from the segment by at most c.deviation_m, and the body reaches at most one
// bounding radius from its centre. Then first_touch would find every clearance sample positive
// (History::clearance returns distance - radius there) and report no touch: skipping it changes
// no result, and saves its five samples on the interpolant (each an inversion of t(s) in the
// s-phase). A chord's ends are on the interpolant, as first_touch's samples are.
bool History::chord_clear_of_plane(const Chord& c, std::uint32_t tri) const {
  const Vec3& n = site_.terrain_triangle_normal(tri);
  const Vec3& v0 = site_.terrain_vertices()[site_.terrain_triangles()[tri][0]];
  const double d = std::min(n.dot(c.pa - v0), n.dot(c.pb - v0));
  // 1e-9 of the coordinates: the rounding of the two dot products.
  const double rounding = 1e-9 * (1.0 + c.pa.cwiseAbs().maxCoeff() + v0.cwiseAbs().maxCoeff());
  return d - c.deviation_m - rounding > radius_m_;
}

// Is the body clear of the terrain all along the chord, by the chord's clearance over the
// terrain alone (`clear`, TerrainIndex2D::clearance: at most z_C - H(C) at every chord point C,
// from the buckets' highest terrain rounded up)? On a plane or grid terrain, a continuous height
// field H over the grid's rectangle with slopes at most s: every point of the body is within
// rho = R + D of a chord point C (R the bounding radius, D = c.deviation_m the path's distance
// from the chord). A terrain point it touches is then within rho of C horizontally, so at most
// H(C) + s rho high, and at least z_C - rho: a touch needs z_C - H(C) <= (1 + s) rho. Both chord
// ends in the rectangle (so all of the chord: H is defined under it). Then no plane test can
// find a touch of the terrain either, and no triangle need be looked at (chord_clear_of_plane
// loads two); a mesh terrain (overhangs, holes) is left to chord_clear_of_plane.
bool History::chord_clear_of_terrain(const Chord& c, double clear) const {
  const double s = ctx_.lattice_max_slope;
  if (!st_.terrain_clearance_skip || !std::isfinite(s)) return false;
  // A chord above every prism has clear = +inf without a walk: its height over the highest
  // terrain is the bound then.
  const double lower =
      std::isfinite(clear) ? clear : std::min(c.pa.z(), c.pb.z()) - ctx_.terrain_max_z;
  const double rounding = 1e-9 * (1.0 + c.pa.cwiseAbs().maxCoeff() + c.pb.cwiseAbs().maxCoeff());
  if (!(lower - rounding > (1.0 + s) * (radius_m_ + c.deviation_m))) return false;
  const scene::TerrainIndex2D& index = site_.terrain_index();
  const auto inside = [&](const Vec3& p) {
    const Vec2 g = (p.head<2>() - index.origin).cwiseQuotient(index.cell);
    return g.x() >= 0.0 && g.y() >= 0.0 && g.x() <= index.nx && g.y() <= index.ny;
  };
  return inside(c.pa) && inside(c.pb);
}

// Is a touch of the plane of terrain triangle `tri` at `at` (over terrain triangle `under`; -1:
// off the terrain) a touch of nothing? Yes when the contact point is both far from `tri` and off
// the ground: more than one body width, 2 R, from the triangle horizontally (no part of the body
// is over it), and more than R above the plane of the triangle under it. The plane touched is then
// the triangle's extended far beyond it, e.g. a back slope's under the end of a chord that crosses
// a crest, metres above the front slope at the chord's start, where a spinning body's lowest point
// can move into it. A body reaching across an edge to a lower neighbour touches the nearer plane
// first, a little above the farther face; a contact point at the ground beyond the triangle is
// where the body meets the ground anyway: both kept. The horizontal distance is bounded below by
// the largest signed distance to the triangle's three edge lines (outward positive).
bool History::touches_beyond_triangle(const Vec3& at, std::uint32_t tri, std::int64_t under) const {
  if (under < 0 || under == static_cast<std::int64_t>(tri)) return false;
  const auto below = static_cast<std::uint32_t>(under);
  if (!(at.z() - site_.terrain_plane_height(below, at.x(), at.y()) > radius_m_)) return false;
  const auto& ids = site_.terrain_triangles()[tri];
  const auto& vs = site_.terrain_vertices();
  const Vec2 a = vs[ids[0]].head<2>(), b = vs[ids[1]].head<2>(), c = vs[ids[2]].head<2>();
  const double orient = (b - a).x() * (c - a).y() - (b - a).y() * (c - a).x();
  const double sign = orient < 0.0 ? -1.0 : 1.0;  // outward normals for either winding
  const Vec2 p = at.head<2>();
  double beyond = -std::numeric_limits<double>::infinity();
  for (const auto& [u, w] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
    const Vec2 d = w - u;
    const double len = d.norm();
    if (!(len > 0.0)) continue;
    beyond = std::max(beyond, sign * (d.y() * (p - u).x() - d.x() * (p - u).y()) / len);
  }
  return beyond > 2.0 * radius_m_;
}

// Body contact with the terrain within [c.ta, tb] (tb <= c.tb: up to the centre's own hit). The
// contact plane: the terrain triangle under the centre at tb (or the one its path crossed),
// then the triangle under the contact point if that differs (a contact that moves onto a
// neighbouring triangle), at most twice; a touch of a triangle's plane more than a body width
// beyond the triangle is none. `clear`: the chord's clearance over the terrain.
std::optional<FlightEvent> History::body_terrain_contact(const flight::TrajectoryIntegrator& integ,
                                                         const Chord& c, double clear, double tb,
                                                         std::int64_t hint) const {
  const double ta = c.ta;
  if (chord_clear_of_terrain(c, clear)) {
    rot_.advance_base(ta);  // as below: the same bits with or without this shortcut
    return std::nullopt;
  }
  std::int64_t tri = hint;
  if (tri < 0) {
    const Vec3 pb = integ.position(tb);
    tri = site_.terrain_triangle_at(pb.x(), pb.y());
  }
  if (tri < 0) return std::nullopt;
  if (chord_clear_of_plane(c, static_cast<std::uint32_t>(tri))) {
    // first_touch's one effect besides its answer: the attitude's base moves to ta (the attitude
    // of an axisymmetric body is propagated from it; the same base gives the same bits).
    rot_.advance_base(ta);
    return std::nullopt;
  }
  double tc = first_touch(integ, static_cast<std::uint32_t>(tri), ta, tb);
  Vec3 at{0, 0, 0};         // the body's point on the plane of `tri` at tc
  std::int64_t under = -1;  // the terrain triangle under it
  for (int pass = 0; !std::isnan(tc); ++pass) {
    const Vec3& n = site_.terrain_triangle_normal(static_cast<std::uint32_t>(tri));
    at = integ.position(tc) + fragments::contact_point(body_, attitude(tc), n, flat_tol_m_);
    under = site_.terrain_triangle_at(at.x(), at.y());
    if (pass == 2 || under < 0 || under == tri) break;
    const double t2 = first_touch(integ, static_cast<std::uint32_t>(under), ta, tb);
    if (std::isnan(t2)) break;  // the neighbour's plane is not reached: keep the first
    tri = under;
    tc = t2;
  }
  if (std::isnan(tc) || touches_beyond_triangle(at, static_cast<std::uint32_t>(tri), under))
    return std::nullopt;
  FlightEvent ev;
  ev.end = FlightEnd::kTerrain;
  ev.t = tc;
  integ.state(tc, ev.p, ev.v);
  ev.triangle = static_cast<std::uint32_t>(tri);
  ev.normal = site_.terrain_triangle_normal(ev.triangle);
  ev.material = site_.terrain_triangle_material(ev.triangle);
  return ev;
}

}  // namespace fragsim::run::detail
