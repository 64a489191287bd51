#include "core/run/history.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/flight/segment_rotation.h"
#include "core/flight/trajectory.h"
#include "core/fragments/support.h"
#include "core/impact/bounce.h"
#include "core/impact/contacts.h"
#include "core/impact/ground_motion.h"
#include "core/scene/building_proximity.h"

namespace fragsim::run {
namespace {

using Clock = std::chrono::steady_clock;

// Accumulates wall time into a slot only when profiling is on (clock reads cost ~20 ns each).
class SectionTimer {
 public:
  SectionTimer(bool on, double& slot) : on_(on), slot_(slot) {
    if (on_) start_ = Clock::now();
  }
  ~SectionTimer() {
    if (on_) slot_ += std::chrono::duration<double>(Clock::now() - start_).count();
  }
  SectionTimer(const SectionTimer&) = delete;
  SectionTimer& operator=(const SectionTimer&) = delete;

 private:
  bool on_;
  double& slot_;
  Clock::time_point start_;
};

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

// Where and how a history ended.
struct EndState {
  Outcome outcome = Outcome::kGround;
  double t = 0.0;
  Vec3 p{0, 0, 0};
  Vec3 v{0, 0, 0};
  std::int32_t building = -1;
  std::int32_t surface = -1;
  bool penetrated = false;
  double residual_ke_j = 0.0;
};

// The first impact of a history (terrain or building).
struct FirstImpact {
  bool seen = false;
  double t = 0.0;
  Vec3 p{0, 0, 0};
  Vec3 v{0, 0, 0};
  double angle_deg = 0.0;
};

// What ended one flight segment.
enum class FlightEnd {
  kTerrain,    // terrain contact at (t, p, v) on `triangle`
  kBuilding,   // building hit
  kLeftSite,
  kMaxTime,
  kHarmless,
  kIntegrationFailed,
};

struct FlightEvent {
  FlightEnd end = FlightEnd::kTerrain;
  double t = 0.0;
  Vec3 p{0, 0, 0};
  Vec3 v{0, 0, 0};
  Vec3 normal = Vec3::UnitZ();
  std::uint32_t triangle = 0;  // terrain triangle or building triangle
  std::uint32_t building = 0;
  scene::SurfaceType surface = scene::SurfaceType::kTerrain;
  std::uint16_t material = 0;
};

// One history: sampling, then flight segments separated by bounces, then (with bounce) a slide
// or roll to rest. Tallies accumulate in the scratch list and are written at the end.
class History {
 public:
  History(const RunContext& ctx, std::uint32_t group, std::int64_t history, bool record_trajectory,
          HistoryScratch& scratch, ChunkOutput& out)
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
        init_(fragments::sample_fragment(sc_.groups[group], group,
                                         static_cast<std::uint64_t>(history), st_.seed)),
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
  }

  void simulate();

 private:
  // Can this fragment ever matter again? Below the hazardous threshold it cannot add to the PTN
  // density; with no buildings on the site nothing else is tallied. In still air drag, impacts
  // and sliding only remove energy, so its kinetic energy can never exceed
  // KE + m g (z - lowest terrain). With wind, drag can add energy in the ground frame, but not in
  // the wind's (inertial: the wind is uniform and steady), so from this state on
  // |v - w|^2 <= |v - w|^2_now + 2 g (z - lowest terrain) and |v| <= |w| + that root (impacts
  // and sliding, which only remove ground-frame energy, are covered because the bound is
  // evaluated afresh from every new state).
  bool can_never_matter(const Vec3& p, const Vec3& v) const {
    if (site_.has_buildings() || !st_.harmless_cutoff) return false;
    const double drop = p.z() - ctx_.terrain_min_z;
    if (ctx_.still_air) {
      const double ke_max = 0.5 * mass_ * v.squaredNorm() + mass_ * g_ * drop;
      return ke_max < st_.hazardous_ke_j;
    }
    const Vec3& w = sc_.atmosphere.wind_mps;
    const double v_max =
        w.norm() + std::sqrt(std::max(0.0, (v - w).squaredNorm() + 2.0 * g_ * drop));
    return 0.5 * mass_ * v_max * v_max < st_.hazardous_ke_j;
  }

  // PTN contributions of the straight piece a -> b (times ta, tb); velocity_at(s) gives the
  // velocity at chord parameter s in [0, 1].
  template <class VelocityFn>
  void add_ptn_segment(const Vec3& a, const Vec3& b, const VelocityFn& velocity_at) {
    if (std::min(a.z(), b.z()) > ctx_.prisms.top_z()) return;
    SectionTimer timer(prof_, out_.tally_s);
    site_.terrain_index().for_each_candidate(
        Vec2(a.x(), a.y()), Vec2(b.x(), b.y()), [&](std::uint32_t tri) {
          ++out_.stats.ptn_triangle_tests;
          double s_in, s_out;
          if (!ctx_.prisms.clip(tri, a, b, s_in, s_out)) return;
          // State where the path enters the prism.
          const Vec3 v = velocity_at(s_in);
          const double speed2 = v.squaredNorm();
          if (0.5 * mass_ * speed2 < st_.hazardous_ke_j || !(speed2 > 0.0)) return;
          const double area = ctx_.prisms.projected_area(tri, v / std::sqrt(speed2));
          if (area > 0.0) scratch_.ptn.push_back({tri, weight_ / area});
        });
  }

  // PTN contribution of a ground step (slide/roll). The step lies over one triangle T (its
  // xy-path stays inside T's projection), so when the centre's height above T's plane is within
  // [0, H] at both ends it is inside T's prism throughout and enters it at the step's start: the
  // only prism test is T's, at velocity va (what clip() over the candidate walk would find, as
  // the step begins on T's edge or where the slide starts). Otherwise the general walk.
  void add_ptn_ground_step(const impact::GroundSegment& sg, double s_end) {
    const Vec3 b = sg.a + s_end * (sg.b - sg.a);
    const double ha = sg.ha, hb = sg.ha + s_end * (sg.hb - sg.ha);  // linear along the segment
    const double top = ctx_.prisms.person_height_m();
    if (!(ha >= 0.0 && ha <= top && hb >= 0.0 && hb <= top)) {
      add_ptn_segment(sg.a, b, [&](double s) { return sg.va + s * s_end * (sg.vb - sg.va); });
      return;
    }
    // A later step over the same triangle (after kGroundMaxDt_s) would only add a contribution
    // that the first-crossing rule discards.
    if (sg.triangle == last_ground_prism_) return;
    SectionTimer timer(prof_, out_.tally_s);
    ++out_.stats.ptn_triangle_tests;
    const double speed2 = sg.va.squaredNorm();
    if (0.5 * mass_ * speed2 < st_.hazardous_ke_j || !(speed2 > 0.0)) return;
    const double area = ctx_.prisms.projected_area(sg.triangle, sg.va / std::sqrt(speed2));
    if (area > 0.0) {
      scratch_.ptn.push_back({sg.triangle, weight_ / area});
      last_ground_prism_ = sg.triangle;
    }
  }

  // Ground phase: can the fragment, at centre p (surface height z_surface under it) with
  // velocity v, never again be hazardous nor reach a building? (impact::ground_never_matters)
  bool ground_can_never_matter(const Vec3& p, double z_surface, const Vec3& v, bool rolling) const {
    if (!site_.has_buildings() || !st_.harmless_cutoff) return can_never_matter(p, v);
    const scene::Material& mat = site_.materials()[site_.terrain_material()];
    impact::GroundBoundInput b;
    b.mass_kg = mass_;
    b.gravity_mps2 = g_;
    b.k = impact::ground_k(rolling);
    b.friction = rolling ? mat.rolling_resistance : mat.friction;
    b.terrain_min_z = ctx_.terrain_min_z;
    b.terrain_min_nz = ctx_.terrain_min_nz;
    b.hazardous_ke_j = st_.hazardous_ke_j;
    return impact::ground_never_matters(site_, b, p, z_surface, v);
  }

  flight::RotationState rotation(double t) const { return rot_.at(t); }
  Quat attitude(double t) const { return rot_.attitude(t); }

  // Is the body's lowest point on triangle `tri` moving into its plane at time t?
  bool contact_approaching(const flight::TrajectoryIntegrator& integ, std::uint32_t tri,
                           double t) const {
    const Vec3& n = site_.terrain_triangle_normal(tri);
    const flight::RotationState s = rotation(t);
    const Quat q = s.q.normalized();
    const Vec3 r = fragments::contact_point(body_, q, n, flat_tol_m_);
    return (integ.velocity(t) + (q * s.omega_body).cross(r)).dot(n) < 0.0;
  }

  // Signed clearance of the body from the plane of terrain triangle `tri` at time t: the centre's
  // height above the plane along its normal minus the body's reach toward it (support
  // function). <= 0: touching or overlapping.
  // Farther than one bounding radius the sign is known without the attitude: the bound
  // (distance - radius, also > 0) is returned instead, which leaves every sign unchanged.
  double clearance(const flight::TrajectoryIntegrator& integ, std::uint32_t tri, double t) const {
    const Vec3& n = site_.terrain_triangle_normal(tri);
    const Vec3& v0 = site_.terrain_vertices()[site_.terrain_triangles()[tri][0]];
    const double d = n.dot(integ.position(t) - v0);
    if (d > radius_m_) return d - radius_m_;
    return d - fragments::support_extent(body_, attitude(t), -n);
  }

  // The first time in [ta, tb] at which the body touches the plane of `tri` while approaching
  // it (clearance falls from > 0 to <= 0), or NaN. Sampled at a few points, then refined.
  double first_touch(const flight::TrajectoryIntegrator& integ, std::uint32_t tri, double ta,
                     double tb) const;

  // Body contact with the terrain within the chord [ta, tb] (bounce mode), no later than t_limit
  // (a building hit or the path's own terrain crossing). Returns the contact, or nothing.
  std::optional<FlightEvent> body_terrain_contact(const flight::TrajectoryIntegrator& integ,
                                                  double ta, double tb, std::int64_t hint) const;

  FlightEvent fly(const Vec3& p_start, const Vec3& v_start, double t_start);
  void slide(const Vec3& p, const Vec3& v, double t, double clearance_m);
  void building_hit(const FlightEvent& ev);
  void note_first_impact(double t, const Vec3& p, const Vec3& v, const Vec3& normal) {
    if (first_.seen) return;
    first_ = {true, t, p, v, impact::impact_angle_deg(v, normal)};
  }
  void finish();
  // Appends a trajectory point (when recording) if it is later than the last one: a contact
  // found at the start of a chord coincides with the step end already recorded.
  void record_point(double t, const Vec3& p) {
    if (!record_trajectory_ || (!traj_.t_s.empty() && !(t > traj_.t_s.back()))) return;
    traj_.t_s.push_back(t);
    traj_.position_m.push_back(site_.to_input(p));
  }

  // Private Members
  const RunContext& ctx_;
  const Scenario& sc_;
  const Settings& st_;
  const scene::Site& site_;
  std::uint32_t group_;
  std::int64_t history_;
  bool record_trajectory_;
  HistoryScratch& scratch_;
  ChunkOutput& out_;
  bool prof_;
  fragments::FragmentInit init_;
  double mass_, weight_, g_;
  fragments::ContactBody body_;
  flight::FlightModel model_;
  double radius_m_ = 0.0;   // bounding radius with bounce, 0 without (the path is the centre's)
  double flat_tol_m_ = 0.0;
  flight::SegmentRotation rot_;  // attitude along the current flight segment
  EndState end_;
  FirstImpact first_;
  std::uint32_t bounces_ = 0;
  double ground_path_m_ = 0.0;
  std::uint32_t last_ground_prism_ = std::numeric_limits<std::uint32_t>::max();
  TrajectoryRecord traj_;
};

double History::first_touch(const flight::TrajectoryIntegrator& integ, std::uint32_t tri,
                            double ta, double tb) const {
  constexpr int kSamples = 4;
  rot_.advance_base(ta);
  double t_prev = ta;
  double g_prev = clearance(integ, tri, ta);
  for (int k = 1; k <= kSamples; ++k) {
    const double t = (k == kSamples) ? tb : ta + (tb - ta) * k / kSamples;
    const double gk = clearance(integ, tri, t);
    if (gk <= 0.0) {
      if (g_prev > 0.0) {
        auto g = [&](double s) { return clearance(integ, tri, s); };
        // Illinois regula falsi on the clearance (continuous on the bracket: one plane).
        double lo = t_prev, hi = t, glo = g_prev, ghi = gk;
        int side = 0;
        for (int it = 0; it < 60 && hi - lo > 1e-13 * std::max(1.0, std::abs(hi)); ++it) {
          const double m = (lo * ghi - hi * glo) / (ghi - glo);
          const double gm = g(m);
          if (gm > 0.0) {
            lo = m;
            glo = gm;
            if (side == -1) ghi *= 0.5;
            side = -1;
          } else {
            hi = m;
            ghi = gm;
            if (side == 1) glo *= 0.5;
            side = 1;
          }
        }
        return hi;  // the side that touches: clearance <= 0
      }
      // Already touching at the start of this sample interval. Right after a bounce the body
      // sits on the plane and is leaving it: look further. Otherwise (touching and approaching)
      // the contact is now.
      if (k == 1 && t_prev > rot_.start_time() && contact_approaching(integ, tri, t_prev)) return t_prev;
    }
    t_prev = t;
    g_prev = gk;
  }
  return std::numeric_limits<double>::quiet_NaN();
}

std::optional<FlightEvent> History::body_terrain_contact(const flight::TrajectoryIntegrator& integ,
                                                         double ta, double tb,
                                                         std::int64_t hint) const {
  // The contact plane: the terrain triangle under the centre at the chord's end (or the one its
  // path crossed), then the triangle under the contact point if that differs (a contact that
  // moves onto a neighbouring triangle), at most twice.
  std::int64_t tri = hint;
  if (tri < 0) {
    const Vec3 pb = integ.position(tb);
    tri = site_.terrain_triangle_at(pb.x(), pb.y());
  }
  if (tri < 0) return std::nullopt;
  double tc = first_touch(integ, static_cast<std::uint32_t>(tri), ta, tb);
  for (int pass = 0; pass < 2 && !std::isnan(tc); ++pass) {
    const Vec3& n = site_.terrain_triangle_normal(static_cast<std::uint32_t>(tri));
    const Vec3 c = integ.position(tc) + fragments::contact_point(body_, attitude(tc), n, flat_tol_m_);
    const std::int64_t under = site_.terrain_triangle_at(c.x(), c.y());
    if (under < 0 || under == tri) break;
    const double t2 = first_touch(integ, static_cast<std::uint32_t>(under), ta, tb);
    if (std::isnan(t2)) break;  // the neighbour's plane is not reached: keep the first
    tri = under;
    tc = t2;
  }
  if (std::isnan(tc)) return std::nullopt;
  FlightEvent ev;
  ev.end = FlightEnd::kTerrain;
  ev.t = tc;
  ev.p = integ.position(tc);
  ev.v = integ.velocity(tc);
  ev.triangle = static_cast<std::uint32_t>(tri);
  ev.normal = site_.terrain_triangle_normal(ev.triangle);
  ev.material = site_.terrain_material();
  return ev;
}

FlightEvent History::fly(const Vec3& p_start, const Vec3& v_start, double t_start) {
  const bool plane = site_.terrain_is_plane();
  const bool body_contacts = st_.bounce && radius_m_ > 0.0;
  // With a finite body the terrain is met up to one bounding radius before the centre's path
  // reaches it: steps and chords that low are examined.
  const double top_z = ctx_.top_z + radius_m_;
  const double terrain_top_z = ctx_.terrain_max_z + radius_m_;

  flight::TrajectoryIntegrator integ(model_, st_.rtol);
  integ.reset(t_start, p_start, v_start);
  scene::BuildingProximity near_buildings(site_);
  Vec3 p0 = p_start, v0 = v_start;
  Vec3 a0 = model_.acceleration(p0, v0);
  FlightEvent ev;
  while (true) {
    bool ok;
    {
      SectionTimer timer(prof_, out_.integration_s);
      ok = integ.step(st_.max_flight_time_s);
    }
    if (!ok) {
      ev.end = integ.t() >= st_.max_flight_time_s ? FlightEnd::kMaxTime : FlightEnd::kIntegrationFailed;
      ev.t = integ.t();
      ev.p = integ.position();
      ev.v = integ.velocity();
      break;
    }
    ++out_.stats.integrator_steps;
    const double t0 = integ.t_prev(), t1 = integ.t();
    const Vec3 p1 = integ.position(), v1 = integ.velocity(), a1 = integ.acceleration();

    bool done = false;
    // Under gravity and drag in still or sinking air z(t) has no interior minimum within a step
    // (z'' = -g - k|v_rel| (v_z - w_z) < 0 where v_z = 0 and w_z <= 0), so the step's lowest
    // point is one of its ends and steps above everything are free. An updraft (w_z > 0) can
    // make z'' > 0 at rest: then every step is examined.
    if (!ctx_.step_min_at_ends || std::min(p0.z(), p1.z()) <= top_z) {
      // Curvature at both ends and in the middle (an apex inside the step is where it peaks).
      const double tm = 0.5 * (t0 + t1);
      const Vec3 vm = integ.velocity(tm);
      const double kappa = std::max(
          {impact::path_curvature(v0, a0), impact::path_curvature(v1, a1),
           impact::path_curvature(vm, model_.acceleration(integ.position(tm), vm))});
      const int n = impact::chord_count((p1 - p0).norm(), kappa, st_.sagitta_m);
      // In still air drag only removes mechanical energy, and a chord's lowest point is one of
      // its ends, so no point of a chord has more kinetic energy than E(t0) - m g z_min: a
      // chord below the hazardous energy by that bound needs no PTN walk.
      const double e_step = 0.5 * mass_ * v0.squaredNorm() + mass_ * g_ * p0.z();
      out_.stats.chords += n;
      Vec3 pa = p0;
      double ta = t0;
      for (int k = 1; k <= n && !done; ++k) {
        const double tb = (k == n) ? t1 : t0 + (t1 - t0) * k / n;
        const Vec3 pb = (k == n) ? p1 : integ.position(tb);
        const double zlo = std::min(pa.z(), pb.z());
        if (zlo > top_z) {
          ++out_.stats.chords_skipped;
          pa = pb;
          ta = tb;
          continue;
        }
        unsigned mask = 0;
        if (zlo <= ctx_.terrain_max_z) mask |= scene::kQueryTerrain;
        if (near_buildings.maybe_near(pa, pb) && site_.segment_near_buildings(pa, pb))
          mask |= scene::kQueryBuildings;
        std::optional<scene::SceneHit> hit;
        if (mask != 0) {
          SectionTimer timer(prof_, out_.geometry_s);
          ++out_.stats.scene_queries;
          // tfar slightly beyond 1: a hit exactly at a chord junction is never lost.
          const Vec3 d = pb - pa;
          double tnear = 0.0;
          hit = site_.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
          // A surface met from behind (moving away from it) is where the path starts on it,
          // e.g. a launch from ground level or a bounce: look past it. Bounded: at most a few
          // surfaces can pass through one point.
          for (int skip = 0; hit && hit->normal.dot(d) >= 0.0 && skip < 4; ++skip) {
            tnear = hit->t + 1e-9;
            hit = site_.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
          }
          if (hit && hit->normal.dot(d) >= 0.0) hit.reset();
        }
        // The centre's path meets a surface: refine on the interpolant against the hit
        // triangle's plane (the chord hit point is on that plane). Bracket within the step.
        double t_hit = tb;
        if (hit) {
          const Vec3 q = pa + hit->t * (pb - pa);
          auto pos = [&](double t) { return integ.position(t); };
          double th = impact::refine_plane_crossing(pos, hit->normal, q, ta, tb);
          if (std::isnan(th)) th = impact::refine_plane_crossing(pos, hit->normal, q, t0, t1);
          if (std::isnan(th)) th = ta + hit->t * (tb - ta);  // arc skims the plane: chord hit
          t_hit = th;
        }
        // A finite body touches the terrain before its centre gets there.
        std::optional<FlightEvent> touch;
        if (body_contacts && zlo <= terrain_top_z) {
          SectionTimer timer(prof_, out_.geometry_s);
          touch = body_terrain_contact(integ, ta, t_hit,
                                       hit && hit->terrain ? static_cast<std::int64_t>(hit->triangle) : -1);
        }
        if (touch) {
          ev = *touch;
          done = true;
        } else if (hit) {
          ev.t = t_hit;
          ev.p = integ.position(t_hit);
          ev.v = integ.velocity(t_hit);
          ev.normal = hit->normal;
          ev.triangle = hit->triangle;
          ev.material = hit->material;
          ev.end = hit->terrain ? FlightEnd::kTerrain : FlightEnd::kBuilding;
          ev.building = hit->building;
          ev.surface = hit->surface;
          done = true;
        }
        // The path for the PTN tally: the chord, up to the contact (chord parameter ~ time).
        double s_end = 1.0;
        if (touch) {
          s_end = tb > ta ? std::clamp((touch->t - ta) / (tb - ta), 0.0, 1.0) : 0.0;
        } else if (hit) {
          s_end = std::min(hit->t, 1.0);
        }
        const bool may_be_hazardous =
            !ctx_.still_air || !ctx_.step_min_at_ends ||
            e_step - mass_ * g_ * std::min(pa.z(), pb.z()) >= st_.hazardous_ke_j;
        if (may_be_hazardous) {
          add_ptn_segment(pa, pa + s_end * (pb - pa), [&](double s) {
            return integ.velocity(ta + s * s_end * (tb - ta));
          });
        }
        pa = pb;
        ta = tb;
      }
      // Guard: a path that slipped through the terrain (e.g. exactly through a shared vertex
      // in float precision) is caught here and its crossing located on the interpolant.
      if (!done && !plane && p1.z() <= ctx_.terrain_max_z) {
        const double h1 = site_.terrain_height(p1.x(), p1.y());
        if (!std::isnan(h1) && p1.z() < h1 - 1e-6) {
          double lo = t0, hi = t1;
          for (int it = 0; it < 60; ++it) {
            const double t_mid = 0.5 * (lo + hi);
            const Vec3 pm = integ.position(t_mid);
            const double hm = site_.terrain_height(pm.x(), pm.y());
            if (std::isnan(hm) || pm.z() >= hm) lo = t_mid; else hi = t_mid;
          }
          ev.end = FlightEnd::kTerrain;
          ev.t = hi;
          ev.p = integ.position(hi);
          ev.v = integ.velocity(hi);
          const std::int64_t tri = site_.terrain_triangle_at(ev.p.x(), ev.p.y());
          ev.triangle = tri < 0 ? 0u : static_cast<std::uint32_t>(tri);
          ev.normal = tri < 0 ? Vec3::UnitZ() : site_.terrain_triangle_normal(ev.triangle);
          ev.material = site_.terrain_material();
          done = true;
        }
      }
    }
    // Trajectory record: the step's end, or where it was cut short (time stays increasing across
    // bounces, and no point lies past a contact).
    record_point(done ? ev.t : t1, done ? ev.p : p1);
    if (done) break;
    if (!site_.terrain_bounds().contains_xy(p1.x(), p1.y())) {
      ev = {FlightEnd::kLeftSite, t1, p1, v1};
      break;
    }
    if (can_never_matter(p1, v1)) {
      ev = {FlightEnd::kHarmless, t1, p1, v1};
      break;
    }
    p0 = p1;
    v0 = v1;
    a0 = a1;
  }
  out_.stats.rhs_evaluations += integ.rhs_evaluations();
  return ev;
}

void History::building_hit(const FlightEvent& ev) {
  const scene::Material& mat = site_.materials()[ev.material];
  const double vn = ev.v.dot(ev.normal);
  const double ke = 0.5 * mass_ * ev.v.squaredNorm();
  const double ke_normal = 0.5 * mass_ * vn * vn;
  const double area = init_.body.presented_area_m2;
  end_.outcome = Outcome::kBuilding;
  end_.building = static_cast<std::int32_t>(ev.building);
  end_.surface = static_cast<std::int32_t>(ev.surface);
  // Penetration: normal kinetic energy per presented area above the material's threshold; the
  // wall absorbs the threshold energy, the rest is residual.
  end_.penetrated = ke_normal > mat.penetration_ke_per_area_j_per_m2 * area;
  end_.residual_ke_j = end_.penetrated ? ke - mat.penetration_ke_per_area_j_per_m2 * area : 0.0;
}

void History::slide(const Vec3& p, const Vec3& v, double t, double clearance_m) {
  impact::GroundMotionInput in;
  in.t_s = t;
  in.position_m = p;
  in.velocity_mps = v;
  in.clearance_m = clearance_m;
  in.rolling = body_.type == fragments::ShapeType::kSphere;
  in.gravity_mps2 = g_;
  in.t_max_s = st_.max_flight_time_s;
  in.max_steps = st_.max_ground_steps;
  const bool buildings = site_.has_buildings();
  std::optional<FlightEvent> hit_building;
  bool harmless = false;
  scene::BuildingProximity near_buildings(site_);
  const auto on_segment = [&](const impact::GroundSegment& sg) {
    const Vec3 &a = sg.a, &b = sg.b, &va = sg.va, &vb = sg.vb;
    const double ta = sg.ta, tb = sg.tb;
    record_point(tb, b);
    double s_end = 1.0;
    const bool near = buildings && near_buildings.maybe_near(a, b);
    if (near && site_.segment_near_buildings(a, b)) {
      SectionTimer timer(prof_, out_.geometry_s);
      ++out_.stats.scene_queries;
      const auto h = site_.intersect(a, b - a, 0.0, 1.0, scene::kQueryBuildings);
      if (h && h->normal.dot(b - a) < 0.0) {
        s_end = h->t;
        FlightEvent ev;
        ev.end = FlightEnd::kBuilding;
        ev.t = ta + h->t * (tb - ta);
        ev.p = a + h->t * (b - a);
        ev.v = va + h->t * (vb - va);
        ev.normal = h->normal;
        ev.triangle = h->triangle;
        ev.building = h->building;
        ev.surface = h->surface;
        ev.material = h->material;
        hit_building = ev;
      }
    }
    // The acceleration is constant over a step, so |v|^2 (convex in time) peaks at an end: a
    // step slower than hazardous at both ends crosses no prism hazardously.
    const double v2max = std::max(va.squaredNorm(), vb.squaredNorm());
    if (0.5 * mass_ * v2max >= st_.hazardous_ke_j) add_ptn_ground_step(sg, s_end);
    if (hit_building) return true;
    // Surface height under b: on T's plane (b is inside T or on its edge, where the planes meet).
    harmless = ground_can_never_matter(b, b.z() - sg.hb, vb, in.rolling);
    return harmless;
  };
  const impact::GroundMotionResult r = impact::move_on_ground(
      site_, in, on_segment, [&](std::uint32_t tri) { ctx_.prisms.prefetch(tri); });
  out_.stats.ground_steps += r.steps;
  ground_path_m_ = r.path_m;
  end_.t = r.t_s;
  end_.p = r.position_m;
  end_.v = r.velocity_mps;
  if (hit_building) {
    note_first_impact(hit_building->t, hit_building->p, hit_building->v, hit_building->normal);
    building_hit(*hit_building);
    end_.t = hit_building->t;
    end_.p = hit_building->p;
    end_.v = hit_building->v;
    return;
  }
  switch (r.end) {
    case impact::GroundEnd::kRest:
      end_.outcome = Outcome::kGround;
      break;
    case impact::GroundEnd::kLeftSite:
      end_.outcome = Outcome::kLeftSite;
      break;
    case impact::GroundEnd::kMaxTime:
      end_.outcome = Outcome::kMaxFlightTime;
      break;
    case impact::GroundEnd::kStoppedByCaller:
      end_.outcome = harmless ? Outcome::kHarmless : Outcome::kGround;
      break;
    case impact::GroundEnd::kStepCap:
      ++out_.stats.ground_step_caps;
      end_.outcome = Outcome::kGround;  // counted in stats; not expected on a valid site
      break;
  }
}

void History::simulate() {
  scratch_.ptn.clear();
  if (record_trajectory_) {
    traj_.group = group_;
    traj_.history = static_cast<std::uint64_t>(history_);
  }
  const Vec3 p_launch = site_.to_local(init_.position_m);
  end_.p = p_launch;
  end_.v = init_.velocity_mps;
  rot_.set_rtol(st_.rtol);  // the attitude at a contact as accurate as the path
  rot_.start({init_.orientation, init_.omega_body_radps}, 0.0);

  bool flying = true;
  // ---- launch checks ----
  if (!site_.terrain_bounds().contains_xy(p_launch.x(), p_launch.y())) {
    end_.outcome = Outcome::kLeftSite;
    flying = false;
  } else {
    const double h = site_.terrain_height(p_launch.x(), p_launch.y());
    if ((!std::isnan(h) && p_launch.z() < h - 1e-6) ||
        (site_.has_buildings() && site_.inside_building(p_launch))) {
      end_.outcome = Outcome::kStartedInside;
      flying = false;
    } else if (can_never_matter(p_launch, init_.velocity_mps)) {
      end_.outcome = Outcome::kHarmless;
      flying = false;
    }
  }
  if (flying) record_point(0.0, p_launch);

  Vec3 p = p_launch, v = init_.velocity_mps;
  double t = 0.0;
  while (flying) {
    const FlightEvent ev = fly(p, v, t);
    end_.t = ev.t;
    end_.p = ev.p;
    end_.v = ev.v;
    flying = false;
    switch (ev.end) {
      case FlightEnd::kBuilding:
        note_first_impact(ev.t, ev.p, ev.v, ev.normal);
        building_hit(ev);
        break;
      case FlightEnd::kLeftSite:
        end_.outcome = Outcome::kLeftSite;
        break;
      case FlightEnd::kMaxTime:
        end_.outcome = Outcome::kMaxFlightTime;
        break;
      case FlightEnd::kHarmless:
        end_.outcome = Outcome::kHarmless;
        break;
      case FlightEnd::kIntegrationFailed:
        end_.outcome = Outcome::kIntegrationFailed;
        break;
      case FlightEnd::kTerrain: {
        note_first_impact(ev.t, ev.p, ev.v, ev.normal);
        end_.outcome = Outcome::kGround;
        if (!st_.bounce) break;  // without bounce the first ground impact ends the history
        // ---- bounce (paper eqs. 6-36) ----
        const flight::RotationState rs = rotation(ev.t);
        const Quat q = rs.q.normalized();
        const Vec3 omega = q * rs.omega_body;
        const scene::Material& mat = site_.materials()[ev.material];
        const impact::TerrainBounce b =
            impact::bounce_on_terrain(body_, mass_, q, ev.v, omega, ev.normal, mat, flat_tol_m_);
        ++bounces_;
        ++out_.stats.bounces;
        const Vec3 v_after = b.collision.impact ? b.collision.velocity_mps : ev.v;
        const Vec3 w_after = b.collision.impact ? b.collision.omega_radps : omega;
        const double rebound = v_after.dot(ev.normal);
        const double clearance_m = fragments::support_extent(body_, q, -ev.normal);
        if (rebound < st_.min_rebound_speed_mps || bounces_ >= st_.max_bounces) {
          slide(ev.p, v_after, ev.t, clearance_m);
        } else if (can_never_matter(ev.p, v_after)) {
          end_.outcome = Outcome::kHarmless;
        } else {
          p = ev.p;
          v = v_after;
          t = ev.t;
          rot_.start({q, q.conjugate() * w_after}, t);
          flying = true;
        }
        break;
      }
    }
  }
  if (end_.outcome != Outcome::kMaxFlightTime && end_.outcome != Outcome::kStartedInside &&
      end_.outcome != Outcome::kLeftSite) {
    record_point(end_.t, end_.p);
  }
  finish();
}

void History::finish() {
  // ---- per-history tally records (deduplicated: a prism counts once per history) ----
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
  }
  if (st_.record_fragments) {
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
    r.ground_path_m = ground_path_m_;
    out_.records.push_back(r);
  }
  if (record_trajectory_) out_.trajectories.push_back(std::move(traj_));
}

}  // namespace

RunContext::RunContext(const Scenario& sc, const scene::Site& s)
    : scenario(&sc),
      site(&s),
      atmosphere(sc.atmosphere),
      prisms(s, sc.settings.person_height_m) {
  cd.reserve(sc.groups.size());
  for (const auto& g : sc.groups) cd.emplace_back(g.cd);
  terrain_min_z = lowest_terrain_z(s);
  terrain_max_z = highest_terrain_z(s);
  for (std::uint32_t t = 0; t < s.terrain_triangle_count(); ++t)
    terrain_min_nz = std::min(terrain_min_nz, s.terrain_triangle_normal(t).z());
  top_z = prisms.top_z();
  if (s.has_buildings()) top_z = std::max(top_z, s.buildings_bounds().hi.z());
  step_min_at_ends = sc.atmosphere.wind_mps.z() <= 0.0;
  still_air = sc.atmosphere.wind_mps.squaredNorm() == 0.0;
}

void simulate_history(const RunContext& ctx, std::uint32_t group, std::int64_t history,
                      bool record_trajectory, HistoryScratch& scratch, ChunkOutput& out) {
  History h(ctx, group, history, record_trajectory, scratch, out);
  h.simulate();
}

}  // namespace fragsim::run
