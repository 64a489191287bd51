#include "core/run/history.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "core/flight/trajectory.h"
#include "core/impact/contacts.h"
#include "core/impact/ground_response.h"

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
  double angle_deg = 0.0;
  std::int32_t building = -1;
  std::int32_t surface = -1;
  bool penetrated = false;
  double residual_ke_j = 0.0;
};

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
  top_z = prisms.top_z();
  if (s.has_buildings()) top_z = std::max(top_z, s.buildings_bounds().hi.z());
  step_min_at_ends = sc.atmosphere.wind_mps.z() <= 0.0;
}

void simulate_history(const RunContext& ctx, std::uint32_t group, std::int64_t history,
                      bool record_trajectory, HistoryScratch& scratch, ChunkOutput& out) {
  const Scenario& sc = *ctx.scenario;
  const Settings& st = sc.settings;
  const scene::Site& site = *ctx.site;
  const auto& grp = sc.groups[group];
  const bool prof = st.profile;

  const fragments::FragmentInit init =
      fragments::sample_fragment(grp, group, static_cast<std::uint64_t>(history), st.seed);
  const double mass = init.body.mass_kg;
  const double weight = init.weight;
  const double g = sc.gravity_mps2;

  flight::FlightModel model;
  model.atmosphere = &ctx.atmosphere;
  model.cd = &ctx.cd[group];
  model.gravity_mps2 = g;
  model.area_m2 = init.body.presented_area_m2;
  model.mass_kg = mass;
  model.altitude_offset_m = site.altitude_offset_m();

  scratch.ptn.clear();
  TrajectoryRecord traj;
  if (record_trajectory) {
    traj.group = group;
    traj.history = static_cast<std::uint64_t>(history);
  }

  const Vec3 p_launch = site.to_local(init.position_m);
  EndState end;
  end.p = p_launch;
  end.v = init.velocity_mps;

  // Can this fragment ever matter again? Drag only removes energy, so its kinetic energy can never
  // exceed KE + m g (z - lowest terrain). Below the hazardous threshold it cannot add to the PTN
  // density; with no buildings on the site nothing else is tallied, so tracking stops.
  auto can_never_matter = [&](const Vec3& p, const Vec3& v) {
    if (site.has_buildings()) return false;
    const double ke_max = 0.5 * mass * v.squaredNorm() + mass * g * (p.z() - ctx.terrain_min_z);
    return ke_max < st.hazardous_ke_j;
  };

  auto add_ptn_segment = [&](const Vec3& a, const Vec3& b, double ta, double tb,
                             const flight::TrajectoryIntegrator& integ) {
    if (std::min(a.z(), b.z()) > ctx.prisms.top_z()) return;
    SectionTimer timer(prof, out.tally_s);
    site.terrain_index().for_each_candidate(
        Vec2(a.x(), a.y()), Vec2(b.x(), b.y()), [&](std::uint32_t tri) {
          ++out.stats.ptn_triangle_tests;
          double s_in, s_out;
          if (!ctx.prisms.clip(tri, a, b, s_in, s_out)) return;
          // State where the path enters the prism (chord parameter ~ time within one chord).
          const Vec3 v = integ.velocity(ta + s_in * (tb - ta));
          const double speed2 = v.squaredNorm();
          if (0.5 * mass * speed2 < st.hazardous_ke_j || !(speed2 > 0.0)) return;
          const double area = ctx.prisms.projected_area(tri, v / std::sqrt(speed2));
          if (area > 0.0) scratch.ptn.push_back({tri, weight / area});
        });
  };

  bool done = false;
  // ---- launch checks ----
  if (!site.terrain_bounds().contains_xy(p_launch.x(), p_launch.y())) {
    end.outcome = Outcome::kLeftSite;
    done = true;
  } else {
    const double h = site.terrain_height(p_launch.x(), p_launch.y());
    if ((!std::isnan(h) && p_launch.z() < h - 1e-6) ||
        (site.has_buildings() && site.inside_building(p_launch))) {
      end.outcome = Outcome::kStartedInside;
      done = true;
    } else if (can_never_matter(p_launch, init.velocity_mps)) {
      end.outcome = Outcome::kHarmless;
      done = true;
    }
  }

  if (!done) {
    flight::TrajectoryIntegrator integ(model, st.rtol);
    integ.reset(0.0, p_launch, init.velocity_mps);
    if (record_trajectory) {
      traj.t_s.push_back(0.0);
      traj.position_m.push_back(site.to_input(p_launch));
    }
    Vec3 p0 = p_launch, v0 = init.velocity_mps;
    Vec3 a0 = model.acceleration(p0, v0);
    const bool plane = site.terrain_is_plane();
    const Box3& bb = site.buildings_bounds();
    while (!done) {
      bool ok;
      {
        SectionTimer timer(prof, out.integration_s);
        ok = integ.step(st.max_flight_time_s);
      }
      if (!ok) {
        end.outcome = integ.t() >= st.max_flight_time_s ? Outcome::kMaxFlightTime
                                                         : Outcome::kIntegrationFailed;
        end.t = integ.t();
        end.p = integ.position();
        end.v = integ.velocity();
        break;
      }
      ++out.stats.integrator_steps;
      const double t0 = integ.t_prev(), t1 = integ.t();
      const Vec3 p1 = integ.position(), v1 = integ.velocity(), a1 = integ.acceleration();
      if (record_trajectory) {
        traj.t_s.push_back(t1);
        traj.position_m.push_back(site.to_input(p1));
      }

      // Under gravity and drag in still or sinking air z(t) has no interior minimum within a step
      // (z'' = -g - k|v_rel| (v_z - w_z) < 0 where v_z = 0 and w_z <= 0), so the step's lowest
      // point is one of its ends and steps above everything are free. An updraft (w_z > 0) can
      // make z'' > 0 at rest: then every step is examined.
      if (!ctx.step_min_at_ends || std::min(p0.z(), p1.z()) <= ctx.top_z) {
        // Curvature at both ends and in the middle (an apex inside the step is where it peaks).
        const double tm = 0.5 * (t0 + t1);
        const Vec3 vm = integ.velocity(tm);
        const double kappa = std::max(
            {impact::path_curvature(v0, a0), impact::path_curvature(v1, a1),
             impact::path_curvature(vm, model.acceleration(integ.position(tm), vm))});
        const int n = impact::chord_count((p1 - p0).norm(), kappa, st.sagitta_m);
        out.stats.chords += n;
        Vec3 pa = p0;
        double ta = t0;
        for (int k = 1; k <= n && !done; ++k) {
          const double tb = (k == n) ? t1 : t0 + (t1 - t0) * k / n;
          const Vec3 pb = (k == n) ? p1 : integ.position(tb);
          const double zlo = std::min(pa.z(), pb.z());
          if (zlo > ctx.top_z) {
            ++out.stats.chords_skipped;
            pa = pb;
            ta = tb;
            continue;
          }
          unsigned mask = 0;
          if (zlo <= ctx.terrain_max_z) mask |= scene::kQueryTerrain;
          if (site.has_buildings() && zlo <= bb.hi.z() &&
              std::max(pa.x(), pb.x()) >= bb.lo.x() && std::min(pa.x(), pb.x()) <= bb.hi.x() &&
              std::max(pa.y(), pb.y()) >= bb.lo.y() && std::min(pa.y(), pb.y()) <= bb.hi.y()) {
            mask |= scene::kQueryBuildings;
          }
          std::optional<scene::SceneHit> hit;
          if (mask != 0) {
            SectionTimer timer(prof, out.geometry_s);
            ++out.stats.scene_queries;
            // tfar slightly beyond 1: a hit exactly at a chord junction is never lost.
            const Vec3 d = pb - pa;
            double tnear = 0.0;
            hit = site.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
            // A surface met from behind (moving away from it) is where the path starts on it,
            // e.g. a launch from ground level: look past it. Bounded: at most a few surfaces
            // can pass through one point.
            for (int skip = 0; hit && hit->normal.dot(d) >= 0.0 && skip < 4; ++skip) {
              tnear = hit->t + 1e-9;
              hit = site.intersect(pa, d, tnear, 1.0 + 1e-7, mask);
            }
            if (hit && hit->normal.dot(d) >= 0.0) hit.reset();
          }
          const double s_end = hit ? std::min(hit->t, 1.0) : 1.0;
          add_ptn_segment(pa, pa + s_end * (pb - pa), ta, ta + s_end * (tb - ta), integ);
          if (hit) {
            // Refine on the interpolant against the hit triangle's plane; the chord hit point
            // is on that plane. Bracket generously within the step.
            const Vec3 q = pa + hit->t * (pb - pa);
            auto pos = [&](double t) { return integ.position(t); };
            double th = impact::refine_plane_crossing(pos, hit->normal, q, ta, tb);
            if (std::isnan(th)) th = impact::refine_plane_crossing(pos, hit->normal, q, t0, t1);
            if (std::isnan(th)) th = ta + hit->t * (tb - ta);  // arc skims the plane: chord hit
            end.t = th;
            end.p = integ.position(th);
            end.v = integ.velocity(th);
            end.angle_deg = impact::impact_angle_deg(end.v, hit->normal);
            if (hit->terrain) {
              impact::GroundImpact gi{th, end.p, end.v, hit->normal, hit->triangle, hit->material};
              if (impact::respond_to_ground_impact(gi) == impact::GroundResponse::kStop) {
                end.outcome = Outcome::kGround;
                done = true;
              }
            } else {
              const scene::Material& mat = site.materials()[hit->material];
              const double vn = end.v.dot(hit->normal);
              const double ke = 0.5 * mass * end.v.squaredNorm();
              const double ke_normal = 0.5 * mass * vn * vn;
              const double area = init.body.presented_area_m2;
              end.outcome = Outcome::kBuilding;
              end.building = static_cast<std::int32_t>(hit->building);
              end.surface = static_cast<std::int32_t>(hit->surface);
              // Penetration: normal kinetic energy per presented area above the material's
              // threshold; the wall absorbs the threshold energy, the rest is residual.
              end.penetrated = ke_normal > mat.penetration_ke_per_area_j_per_m2 * area;
              end.residual_ke_j =
                  end.penetrated ? ke - mat.penetration_ke_per_area_j_per_m2 * area : 0.0;
              done = true;
            }
          }
          pa = pb;
          ta = tb;
        }
        // Guard: a path that slipped through the terrain (e.g. exactly through a shared vertex
        // in float precision) is caught here and its crossing located on the interpolant.
        if (!done && !plane && p1.z() <= ctx.terrain_max_z) {
          const double h1 = site.terrain_height(p1.x(), p1.y());
          if (!std::isnan(h1) && p1.z() < h1 - 1e-6) {
            double lo = t0, hi = t1;
            for (int it = 0; it < 60; ++it) {
              const double t_mid = 0.5 * (lo + hi);
              const Vec3 pm = integ.position(t_mid);
              const double hm = site.terrain_height(pm.x(), pm.y());
              if (std::isnan(hm) || pm.z() >= hm) lo = t_mid; else hi = t_mid;
            }
            end.t = hi;
            end.p = integ.position(hi);
            end.v = integ.velocity(hi);
            end.angle_deg = impact::impact_angle_deg(end.v, Vec3::UnitZ());
            end.outcome = Outcome::kGround;
            done = true;
          }
        }
      }
      if (done) break;
      if (!site.terrain_bounds().contains_xy(p1.x(), p1.y())) {
        end.outcome = Outcome::kLeftSite;
        end.t = t1;
        end.p = p1;
        end.v = v1;
        break;
      }
      if (can_never_matter(p1, v1)) {
        end.outcome = Outcome::kHarmless;
        end.t = t1;
        end.p = p1;
        end.v = v1;
        break;
      }
      p0 = p1;
      v0 = v1;
      a0 = a1;
    }
    out.stats.rhs_evaluations += integ.rhs_evaluations();
    if (record_trajectory && done && end.outcome != Outcome::kMaxFlightTime) {
      traj.t_s.push_back(end.t);
      traj.position_m.push_back(site.to_input(end.p));
    }
  }

  // ---- per-history tally records (deduplicated: a prism counts once per history) ----
  {
    SectionTimer timer(prof, out.tally_s);
    auto& v = scratch.ptn;
    std::stable_sort(v.begin(), v.end(), [](const PtnContribution& x, const PtnContribution& y) {
      return x.triangle < y.triangle;
    });
    std::uint32_t last = std::numeric_limits<std::uint32_t>::max();
    for (const auto& c : v) {
      if (c.triangle == last) continue;  // first crossing of that prism wins
      out.ptn.push_back(c);
      last = c.triangle;
    }
    out.ptn_end.push_back(static_cast<std::uint32_t>(out.ptn.size()));
    if (end.outcome == Outcome::kBuilding) {
      out.building_index.push_back(static_cast<std::int32_t>(out.buildings.size()));
      out.buildings.push_back({static_cast<std::uint32_t>(end.building),
                               static_cast<std::uint8_t>(end.surface), end.penetrated,
                               end.residual_ke_j});
    } else {
      out.building_index.push_back(-1);
    }
    out.outcomes.push_back(end.outcome);
  }
  if (st.record_fragments) {
    FragmentRecord r;
    r.group = group;
    r.history = static_cast<std::uint64_t>(history);
    r.weight = weight;
    r.mass_kg = mass;
    r.area_m2 = init.body.presented_area_m2;
    r.launch_position_m = init.position_m;
    r.launch_velocity_mps = init.velocity_mps;
    r.outcome = end.outcome;
    r.end_time_s = end.t;
    r.end_position_m = site.to_input(end.p);
    r.end_velocity_mps = end.v;
    r.impact_angle_deg = end.angle_deg;
    r.impact_ke_j = 0.5 * mass * end.v.squaredNorm();
    r.building = end.building;
    r.surface = end.surface;
    r.penetrated = end.penetrated;
    r.residual_ke_j = end.residual_ke_j;
    out.records.push_back(r);
  }
  if (record_trajectory) out.trajectories.push_back(std::move(traj));
}

}  // namespace fragsim::run
