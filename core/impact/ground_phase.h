#pragma once
// The ground phase: what a fragment does while it is in contact with the terrain after its
// bounces have died out: slide, roll (a sphere slips first, then rolls), rest, and leaving the
// ground again at a crest (docs/physics.md, "Ground phase", eqs. G1-G14). The paper gives no model
// for this phase; this one is a rigid body in unilateral contact with the piecewise-planar
// terrain:
//
// * on one triangle (face mode) the centre moves in the triangle's plane under gravity, the same
//   aerodynamic drag as in flight (Cd(Mach), atmosphere, wind; a slider's presented area is its
//   frontal area along the motion at its ground attitude) and Coulomb friction mu N opposing the
//   velocity (sliders: cuboid, ellipsoid, cylinder, toppled onto a stable face as they enter
//   one), or, for a sphere (and a point mass as a sphere), slipping friction at the contact point
//   until the contact point's velocity vanishes, then rolling with rolling resistance mu_r N;
// * at a triangle edge the velocity meets the next plane: moving away from it (a convex edge)
//   the body takes off and flies if it leaves at >= the take-off speed (the caller flies it with
//   the full flight model), and below that speed the short hop is contracted into an impact at
//   the edge; moving into it (a concave edge) it is an impact. Impacts go through the
//   Mirtich/Stronge impulse model (bounce.h): speed is neither created nor destroyed by fiat;
// * in a valley (a concave edge the body presses into from both sides) it moves along the
//   crease line (crease mode), held by both planes, until it stops, reaches the edge's end or one
//   plane lets go;
// * it rests where static friction can hold it: on a face within the friction angle, in a crease
//   whose line is within it, at a vertex that is a local minimum (a pit).
//
// Motion between events is integrated by DOPRI5 with dense output (core/flight/dopri5.h) at the
// flight's tolerance; events (edge, end of crease, stop, end of slip, lift) are located on the
// dense output with the Illinois root finder. Every call terminates: by rest, leaving the site,
// the time limit, the observer, a take-off, or at `max_steps` (reported as such).
#include <cstdint>

#include "core/common/types.h"
#include "core/flight/flight_model.h"
#include "core/fragments/support.h"
#include "core/scene/site.h"

namespace fragsim::impact {

// The fragment as the ground phase sees it.
struct GroundBody {
  fragments::ContactBody shape;  // contact geometry and principal moments of inertia
  double mass_kg = 0.0;
  // Body -> site at the start. A slider first topples onto the face it stands over (G13), then
  // keeps its attitude relative to the terrain under it: at an edge it is turned with the terrain
  // (the least rotation taking the old normal to the new), and it topples again whenever it
  // enters a face anew (after an edge impact, a ricochet, or off a crease).
  Quat attitude = Quat::Identity();
  double flat_tol_m = 0.0;     // contact_point's tolerance (bounce.h)
  double density_kg_m3 = 0.0;  // mass / volume (the terrain's embedment test)
  // Spheres (and point masses as spheres) roll; every other shape slides.
  bool round() const { return shape.type == fragments::ShapeType::kSphere; }
};

struct GroundSettings {
  double t_max_s = 120.0;
  long max_steps = 100000;
  // A take-off (convex edge) or an edge impact's rebound at least this fast along the new plane's
  // normal leaves the ground; slower, the body stays on it (bounce_limits.min_rebound_speed_mps).
  double takeoff_speed_mps = 0.5;
  double rtol = 1e-6;  // integrator tolerance (as in flight)
};

// Kinematic state of the body. On the ground: its centre sits at its clearance above the plane
// of `triangle` (the support extent of the body toward that plane).
struct GroundState {
  double t_s = 0.0;
  Vec3 position_m{0, 0, 0};  // centre of mass, local
  Vec3 velocity_mps{0, 0, 0};
  Vec3 omega_radps{0, 0, 0};  // site axes (0 for sliders)
  std::uint32_t triangle = 0;
  Quat attitude = Quat::Identity();  // in a result: the body's attitude at the end
};

enum class GroundEnd {
  kRest,
  kLeftSite,
  kMaxTime,
  kStoppedByObserver,
  kStepCap,
  kTakeOff,   // left the ground: `state` is where and how (the caller flies from it)
  kEmbedded,  // an edge impact too fast and steep to ricochet (scene::Material::embeds)
};

struct GroundResult {
  GroundEnd end = GroundEnd::kRest;
  GroundState state;
  double path_m = 0.0;     // distance the centre travelled on the ground
  long steps = 0;          // integrator steps and events
  long impacts = 0;        // impulses at edges (concave edges, contracted hops), fast contacts
  long fast_contacts = 0;  // contacts resolved by the material's fast_contact law (F6)
  long fast_slides = 0;    // pieces that started faster than its switch speed (expected 0)
};

// One piece of the ground path, over one terrain triangle (its xy-path stays inside that
// triangle's, up to rounding; b may lie on its edge): the centre goes from a (time ta, velocity
// va) to b. The path between is the integrator's; the chord a-b is what tallies and building
// queries use.
struct GroundSegment {
  Vec3 a{0, 0, 0}, b{0, 0, 0};
  double ta = 0.0, tb = 0.0;
  Vec3 va{0, 0, 0}, vb{0, 0, 0};
  Vec3 omega_b{0, 0, 0};
  std::uint32_t triangle = 0;
  double ha = 0.0, hb = 0.0;  // heights of a and b above the plane of `triangle`, vertically
};

// An impulse at an edge (or a contracted hop's landing).
struct GroundImpact {
  double t_s = 0.0;
  Vec3 position_m{0, 0, 0};
  Vec3 velocity_before_mps{0, 0, 0}, velocity_after_mps{0, 0, 0};
  Vec3 omega_before_radps{0, 0, 0}, omega_after_radps{0, 0, 0};
  std::uint32_t triangle = 0;        // the plane hit
  Quat attitude = Quat::Identity();  // body -> site at the impact (the spins' rotational energy)
};

// What the caller does along the way (tallies, building queries, records).
class GroundObserver {
 public:
  virtual ~GroundObserver() = default;
  // Every piece of the path in order; return true to stop the motion at its end (a building
  // hit, or nothing left to tally).
  virtual bool on_segment(const GroundSegment& s) = 0;
  virtual void on_impact(const GroundImpact&) {}
  // A hint: the path will cross into triangle t next (start loading its data).
  virtual void prefetch(std::uint32_t) {}
};

// Runs the ground phase from `start` (on `start.triangle`, velocity along its plane, or about to
// meet it). `air` gives gravity and drag exactly as in flight.
GroundResult move_on_ground(const scene::Site& site, const flight::FlightModel& air,
                            const GroundBody& body, const GroundSettings& settings,
                            const GroundState& start, GroundObserver& observer);

// Clearance of a body at attitude q above a plane with unit normal n: its support extent
// toward -n.
double ground_clearance(const GroundBody& body, const Quat& q, const Vec3& n);

// Tolerances of the model's rest and capture rules (docs/physics.md, "Ground phase").
// A stop is taken when the path still to go before the speed reaches zero is below this.
inline constexpr double kRestTravel_m = 1e-6;
// A slide or roll off a straight line steps at most this fraction of the time to its stop predicted
// at the present deceleration (docs/physics.md G10; a step choice, not a rule of the model).
inline constexpr double kCurvedStopStepFraction = 0.5;
// A body that would climb out of a crease (or a pit) by less than this is held in it.
inline constexpr double kCaptureHeight_m = 1e-3;

}  // namespace fragsim::impact
