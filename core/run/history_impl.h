#pragma once
// The inside of one fragment history (history.h is the outside): a loop over phases, each phase a
// sequence of named events, in the way OpenMC splits its particle loop.
//
//   launch ──▶ flight ──▶ terrain impact ──▶ flight ... ──▶ ground ──▶ (take-off ──▶ flight ...)
//                 │                                            │
//                 └── building hit, left site, harmless, max time, rest ... ──▶ finish (tallies)
//
// history.cpp: the loop, launch, terrain impact, finish. history_flight.cpp: the flight phase
// (integrator step → chords → scene query / body contact → hit refinement → tally).
// history_ground.cpp: the ground phase (core/impact/ground_phase.h) and its tallies.
#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>

#include "core/flight/segment_rotation.h"
#include "core/flight/trajectory.h"
#include "core/fragments/support.h"
#include "core/impact/ground_phase.h"
#include "core/run/energy_audit.h"
#include "core/run/history.h"
#include "core/scene/building_proximity.h"

namespace fragsim::run::detail {

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

// The fragment between phases: where the next phase starts from.
struct BodyState {
  double t = 0.0;
  Vec3 p{0, 0, 0}, v{0, 0, 0};
  Vec3 omega{0, 0, 0};  // site axes
  Quat q = Quat::Identity();
  std::uint32_t triangle = 0;  // ground phase: the terrain triangle it is on
};

// What ended one flight segment.
enum class FlightEnd {
  kTerrain,   // terrain contact at (t, p, v) on `triangle`
  kBuilding,  // building hit
  kLeftSite,
  kMaxTime,
  kHarmless,
  kIntegrationFailed,
  kWorkLimit,  // Settings::max_history_work reached
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

// One accepted integrator step of a flight: [t0, t1] with its end states.
struct FlightStep {
  double t0 = 0.0, t1 = 0.0;
  Vec3 p0, v0, a0, p1, v1, a1;
};

// One chord [ta, tb] of a step: its ends on the interpolant, a bound on the kinetic plus potential
// energy along it (chord_energy_bound), and a bound on how far the path between its ends strays
// from the straight segment pa -> pb (+inf when not known).
struct Chord {
  double ta = 0.0, tb = 0.0;
  Vec3 pa, pb;
  double e_bound = 0.0;
  double deviation_m = std::numeric_limits<double>::infinity();
};

enum class Phase { kFlight, kGround, kDone };

class GroundTally;  // history_ground.cpp

class History {
 public:
  History(const RunContext& ctx, std::uint32_t group, std::int64_t history, bool record_trajectory,
          HistoryScratch& scratch, ChunkOutput& out, const fragments::DirectionCells* cells,
          const fragments::LaunchStratum* stratum);
  void simulate();

 private:
  friend class GroundTally;

  // ---- the loop's events (history.cpp) ----
  Phase launch();
  Phase start_on_ground();
  Phase flight_phase();
  Phase terrain_impact(const FlightEvent& ev);
  Phase fast_terrain_contact(const FlightEvent& ev, const scene::Material& mat);
  Phase leave_terrain(const FlightEvent& ev, const Vec3& v, const Vec3& omega, bool capped);
  Phase ground_phase();
  Phase after_ground_phase(const impact::GroundResult& r, const GroundTally& tally);
  void building_hit(const FlightEvent& ev);
  void end_as(Outcome outcome, double t, const Vec3& p, const Vec3& v);
  void finish();
  void fold_tallies();
  std::int8_t exit_sector() const;
  FragmentRecord fragment_record() const;

  // ---- flight (history_flight.cpp) ----
  FlightEvent fly();
  bool flight_step(flight::TrajectoryIntegrator& integ, FlightStep& s, FlightEvent& ev);
  bool examine_step(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                    scene::BuildingProximity& near_buildings, FlightEvent& ev);
  bool examine_chord(const flight::TrajectoryIntegrator& integ, const FlightStep& s, const Chord& c,
                     scene::BuildingProximity& near_buildings, FlightEvent& ev);
  double chord_energy_bound(const FlightStep& s, int k, const Vec3& pa, const Vec3& va) const;
  // A chord whose clearance over the terrain (TerrainIndex2D::clearance) is more than this
  // cannot meet the terrain: the scene query leaves the terrain out. The slack covers the scene's
  // float hit tests (Embree rounds to ~1e-7 of the coordinates, 0.1 mm at 1 km): a chord that
  // skims a surface closer than that is still queried, so the answer is the query's.
  static constexpr double kTerrainQuerySlack_m = 0.01;
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();
  double terrain_clearance(const Vec3& pa, const Vec3& pb) const;
  std::optional<scene::SceneHit> query_chord(const Vec3& pa, const Vec3& pb, double clear,
                                             scene::BuildingProximity& near_buildings);
  double refine_hit(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                    const scene::SceneHit& hit, double ta, double tb, const Vec3& pa,
                    const Vec3& pb) const;
  bool catch_slip_through(const flight::TrajectoryIntegrator& integ, const FlightStep& s,
                          FlightEvent& ev) const;
  // The body's contact with the terrain (bounce mode).
  std::optional<FlightEvent> body_terrain_contact(const flight::TrajectoryIntegrator& integ,
                                                  const Chord& c, double clear, double tb,
                                                  std::int64_t hint) const;
  bool chord_clear_of_terrain(const Chord& c, double clear) const;
  bool touches_beyond_triangle(const Vec3& at, std::uint32_t tri, std::int64_t under) const;
  bool chord_clear_of_plane(const Chord& c, std::uint32_t tri) const;
  double first_touch(const flight::TrajectoryIntegrator& integ, std::uint32_t tri, double ta,
                     double tb) const;
  double clearance(const flight::TrajectoryIntegrator& integ, std::uint32_t tri, double t) const;
  bool contact_approaching(const flight::TrajectoryIntegrator& integ, std::uint32_t tri,
                           double t) const;

  // ---- tallies ----
  template <class VelocityFn>
  // `clear`: the path's clearance over the terrain when known (terrain_clearance): a path
  // higher than a person over every bucket's terrain crosses no prism.
  void add_ptn_segment(const Vec3& a, const Vec3& b, const VelocityFn& velocity_at,
                       PtnMechanism mechanism, double clear = -kInfinity);
  // A flight's contributions: direct until the history's first terrain contact.
  PtnMechanism flight_mechanism() const {
    return bounces_ + takeoffs_ > 0 ? PtnMechanism::kAfterRicochet : PtnMechanism::kDirectFlight;
  }
  void add_ptn_ground_step(const impact::GroundSegment& sg, double s_end);
  bool can_never_matter(const Vec3& p, const Vec3& v, double rotational_ke_j) const;

  // ---- records ----
  void note_first_impact(double t, const Vec3& p, const Vec3& v, const Vec3& normal);
  // Appends a trajectory point (when recording) if it is later than the last one (a contact
  // found at the start of a chord coincides with the step end already recorded), or replaces
  // the last one's event at the same time by a more telling one.
  void record_point(double t, const Vec3& p, const Vec3& v, TrajectoryEvent e);

  flight::RotationState rotation(double t) const { return rot_.at(t); }
  Quat attitude(double t) const { return rot_.attitude(t); }
  double rotational_ke(const Quat& q, const Vec3& omega_site) const;
  // The body's energy at height z (energy_audit.h); counts an impact after which it rose.
  BodyEnergy energy(double z_m, const Vec3& v, const Quat& q, const Vec3& omega_site) const;
  void audit_impact(const BodyEnergy& before, const BodyEnergy& after);

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
  double density_kg_m3_ = 0.0;  // mass / volume (embedment in the ground)
  fragments::ContactBody body_;
  flight::FlightModel model_;
  double radius_m_ = 0.0;  // bounding radius with bounce, 0 without (the path is the centre's)
  double flat_tol_m_ = 0.0;
  flight::SegmentRotation rot_;    // attitude along the current flight segment
  double segment_rot_ke_j_ = 0.0;  // rotational energy of the current flight segment (constant)
  BodyState state_;                // where the next phase starts
  EndState end_;
  FirstImpact first_;
  std::uint32_t bounces_ = 0, ground_impacts_ = 0, takeoffs_ = 0;
  long ground_steps_ = 0;
  std::int64_t work_ = 0;  // steps and events so far (Settings::max_history_work)
  double ground_path_m_ = 0.0;
  std::uint32_t last_ground_prism_ = std::numeric_limits<std::uint32_t>::max();
  TrajectoryRecord traj_;
};

// PTN contributions of the straight piece a -> b; velocity_at(s) gives the velocity at chord
// parameter s in [0, 1]. A hazardous path (kinetic energy >= threshold where it enters a prism)
// adds w / A_PTN (paper eqs. 37-39), tagged with the mechanism that made it.
template <class VelocityFn>
void History::add_ptn_segment(const Vec3& a, const Vec3& b, const VelocityFn& velocity_at,
                              PtnMechanism mechanism, double clear) {
  if (std::min(a.z(), b.z()) > ctx_.prisms.top_z()) return;
  if (clear > ctx_.prisms.person_height_m() + scene::kClearanceSlack_m) return;
  SectionTimer timer(prof_, out_.tally_s);
  // Buckets where the path is higher than a person over their highest terrain are skipped:
  // none of their prisms reaches it (the exact clip would reject each).
  site_.terrain_index().for_each_candidate_below(
      a, b, ctx_.prisms.person_height_m(), [&](std::uint32_t tri) {
        ++out_.stats.ptn_triangle_tests;
        double s_in, s_out;
        if (!ctx_.prisms.clip(tri, a, b, s_in, s_out)) return;
        const Vec3 v = velocity_at(s_in);
        const double speed2 = v.squaredNorm();
        if (0.5 * mass_ * speed2 < st_.hazardous_ke_j || !(speed2 > 0.0)) return;
        const double area = ctx_.prisms.projected_area(tri, v / std::sqrt(speed2));
        if (area > 0.0) scratch_.ptn.push_back({tri, weight_ / area, mechanism});
      });
}

}  // namespace fragsim::run::detail
