// The ground phase of a history (history_impl.h): the motion is core/impact/ground_phase.h; this
// file holds what the history does along it (building queries, PTN tally, records, the
// harmless cut-off) and how the phase ends.
#include <algorithm>
#include <cmath>

#include "core/run/history_impl.h"

namespace fragsim::run::detail {

// The history's side of the ground phase.
class GroundTally final : public impact::GroundObserver {
 public:
  explicit GroundTally(History& h) : h_(h), near_buildings_(h.site_) {}

  // A building met along the piece ends the history there; the PTN tally while hazardous; the
  // harmless cut-off (no buildings on the site).
  bool on_segment(const impact::GroundSegment& sg) override {
    h_.record_point(sg.tb, sg.b, sg.vb, TrajectoryEvent::kGround);
    double s_end = 1.0;
    if (h_.site_.has_buildings()) s_end = building_along(sg);
    // The PTN rule looks at the velocity where the path enters a prism: the piece's start for
    // its own triangle; other prisms (a centre above person height) at the chord's points.
    const double v2max = std::max(sg.va.squaredNorm(), sg.vb.squaredNorm());
    if (0.5 * h_.mass_ * v2max >= h_.st_.hazardous_ke_j) h_.add_ptn_ground_step(sg, s_end);
    if (building) return true;
    harmless = h_.can_never_matter(sg.b, sg.vb, h_.rotational_ke(h_.state_.q, sg.omega_b));
    return harmless;
  }

  void on_impact(const impact::GroundImpact& i) override {
    ++h_.ground_impacts_;
    ++h_.out_.stats.ground_impacts;
    const double z = i.position_m.z();
    h_.audit_impact(h_.energy(z, i.velocity_before_mps, i.attitude, i.omega_before_radps),
                    h_.energy(z, i.velocity_after_mps, i.attitude, i.omega_after_radps));
    h_.record_point(i.t_s, i.position_m, i.velocity_before_mps, TrajectoryEvent::kTerrainImpact);
  }

  void prefetch(std::uint32_t t) override { h_.ctx_.prisms.prefetch(t); }

  std::optional<FlightEvent> building;  // the building hit, if any
  bool harmless = false;                // stopped because it can never matter again

 private:
  // The chord's parameter where it enters a building (1 if none), setting `building`.
  double building_along(const impact::GroundSegment& sg) {
    const Vec3 &a = sg.a, &b = sg.b;
    if (!near_buildings_.maybe_near(a, b) || !h_.site_.segment_near_buildings(a, b)) return 1.0;
    SectionTimer timer(h_.prof_, h_.out_.geometry_s);
    ++h_.out_.stats.scene_queries;
    const auto hit = h_.site_.intersect(a, b - a, 0.0, 1.0, scene::kQueryBuildings);
    if (!hit || !(hit->normal.dot(b - a) < 0.0)) return 1.0;
    FlightEvent ev;
    ev.end = FlightEnd::kBuilding;
    ev.t = sg.ta + hit->t * (sg.tb - sg.ta);
    ev.p = a + hit->t * (b - a);
    ev.v = sg.va + hit->t * (sg.vb - sg.va);
    ev.normal = hit->normal;
    ev.triangle = hit->triangle;
    ev.building = hit->building;
    ev.surface = hit->surface;
    ev.material = hit->material;
    building = ev;
    return hit->t;
  }

  History& h_;
  scene::BuildingProximity near_buildings_;
};

Phase History::ground_phase() {
  impact::GroundBody body;
  body.shape = body_;
  body.mass_kg = mass_;
  body.attitude = state_.q;
  body.flat_tol_m = flat_tol_m_;
  body.density_kg_m3 = density_kg_m3_;
  impact::GroundSettings gs;
  gs.t_max_s = st_.max_flight_time_s;
  // The ground step cap, or the history's work cap if that comes first (after_ground_phase
  // tells them apart).
  gs.max_steps = std::max<long>(0, std::min(static_cast<long>(st_.max_ground_steps) - ground_steps_,
                                            static_cast<long>(st_.max_history_work - work_)));
  gs.takeoff_speed_mps = st_.min_rebound_speed_mps;
  gs.rtol = st_.rtol;
  const impact::GroundState start{state_.t,     state_.p,        state_.v,
                                  state_.omega, state_.triangle, state_.q};
  GroundTally tally(*this);
  const impact::GroundResult r = impact::move_on_ground(site_, model_, body, gs, start, tally);
  return after_ground_phase(r, tally);
}

// How the ground phase ended: a building, rest, off the site, ..., or a take-off (a new flight).
Phase History::after_ground_phase(const impact::GroundResult& r, const GroundTally& tally) {
  ground_steps_ += r.steps;
  work_ += r.steps;
  out_.stats.ground_steps += r.steps;
  out_.stats.fast_contacts += r.fast_contacts;
  out_.stats.fast_slides += r.fast_slides;
  ground_path_m_ += r.path_m;
  end_as(Outcome::kGround, r.state.t_s, r.state.position_m, r.state.velocity_mps);
  if (tally.building) {
    note_first_impact(tally.building->t, tally.building->p, tally.building->v,
                      tally.building->normal);
    building_hit(*tally.building);
    return Phase::kDone;
  }
  switch (r.end) {
    case impact::GroundEnd::kRest: return Phase::kDone;
    case impact::GroundEnd::kLeftSite: end_.outcome = Outcome::kLeftSite; return Phase::kDone;
    case impact::GroundEnd::kMaxTime: end_.outcome = Outcome::kMaxFlightTime; return Phase::kDone;
    case impact::GroundEnd::kStoppedByObserver:
      end_.outcome = tally.harmless ? Outcome::kHarmless : Outcome::kGround;
      return Phase::kDone;
    case impact::GroundEnd::kStepCap:
      if (ground_steps_ < st_.max_ground_steps) {  // the history's work cap came first
        end_.outcome = Outcome::kWorkLimit;
        return Phase::kDone;
      }
      // Still moving where the safety cap stopped it: not at rest. Not expected on a valid site.
      end_.outcome = Outcome::kGroundStepCap;
      ++out_.stats.ground_step_caps;
      return Phase::kDone;
    case impact::GroundEnd::kEmbedded: end_.outcome = Outcome::kEmbedded; return Phase::kDone;
    case impact::GroundEnd::kTakeOff: break;
  }
  // Off the ground again: a crest taken fast, an edge impact's rebound, or the air lifting it.
  ++takeoffs_;
  ++out_.stats.takeoffs;
  state_.t = r.state.t_s;
  state_.p = r.state.position_m;
  state_.v = r.state.velocity_mps;
  state_.omega = r.state.omega_radps;
  state_.triangle = r.state.triangle;
  state_.q = r.state.attitude;
  record_point(state_.t, state_.p, state_.v, TrajectoryEvent::kTakeOff);
  if (can_never_matter(state_.p, state_.v, rotational_ke(state_.q, state_.omega))) {
    end_.outcome = Outcome::kHarmless;
    return Phase::kDone;
  }
  return Phase::kFlight;
}

// PTN contribution of a ground piece (slide/roll). The piece lies over one triangle T (its
// xy-path stays inside T's projection), so when the centre's height above T's plane is within
// [0, H] at both ends it is inside T's prism throughout and enters it at the piece's start: the
// only prism test is T's, at velocity va (what clip() over the candidate walk would find, as the
// piece begins on T's edge or where the slide starts). Otherwise the general walk.
void History::add_ptn_ground_step(const impact::GroundSegment& sg, double s_end) {
  const Vec3 b = sg.a + s_end * (sg.b - sg.a);
  const double ha = sg.ha, hb = sg.ha + s_end * (sg.hb - sg.ha);  // linear along the chord
  const double top = ctx_.prisms.person_height_m();
  if (!(ha >= 0.0 && ha <= top && hb >= 0.0 && hb <= top)) {
    add_ptn_segment(
        sg.a, b, [&](double s) { return sg.va + s * s_end * (sg.vb - sg.va); },
        PtnMechanism::kGround);
    return;
  }
  // A later piece over the same triangle would only add a contribution that the
  // first-crossing rule discards.
  if (sg.triangle == last_ground_prism_) return;
  SectionTimer timer(prof_, out_.tally_s);
  ++out_.stats.ptn_triangle_tests;
  const double speed2 = sg.va.squaredNorm();
  if (0.5 * mass_ * speed2 < st_.hazardous_ke_j || !(speed2 > 0.0)) return;
  const double area = ctx_.prisms.projected_area(sg.triangle, sg.va / std::sqrt(speed2));
  if (area > 0.0) {
    scratch_.ptn.push_back({sg.triangle, weight_ / area, PtnMechanism::kGround});
    last_ground_prism_ = sg.triangle;
  }
}

}  // namespace fragsim::run::detail
