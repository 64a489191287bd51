#pragma once
// Sampling one fragment history from its group. The random slots are fixed (see RandomStream):
// never renumber them, only append.
#include <cstdint>
#include <limits>

#include "core/common/random.h"
#include "core/common/types.h"
#include "core/fragments/direction_cells.h"
#include "core/fragments/group.h"

namespace fragsim::fragments {

enum Slot : std::uint32_t {
  kSlotMass = 0,
  kSlotSpeed = 1,
  kSlotDirection = 2,    // k=0 elevation, k=1 azimuth
  kSlotOrientation = 3,  // k=0,1 and kSlotOrientation2 k=0: uniform random rotation (not read
                         // when the group fixes its attitude)
  kSlotOrientation2 = 4,
  kSlotSpin = 5,           // k=0 magnitude
  kSlotSpinAxis = 6,       // k=0,1 axis on the sphere (body frame)
  kSlotDirectionCell = 7,  // k=0: the cell of an importance-sampled direction (DirectionCells)
  kSlotSobolJitter = 8,    // its four 32-bit words: the bits below a Sobol coordinate's 32
  kSlotSobolJitter2 = 9,
  kSlotFirstFree = 16,  // later issues (bounce) use slots from here
};

// Physical ranges sample_fragment passes to Distribution::sample (validate the group's
// distributions with the same ranges): a mass is > 0, a speed or spin rate >= 0. The upper ends
// are generous physical limits (docs/scenario.md, "Limits"), far beyond any fragment:
//  - mass <= 1e5 kg: a 10 m x 3 m x 0.3 m reinforced-concrete wall panel weighs about 22 t;
//  - speed <= 2e4 m/s: twice the fastest explosively driven metal, shaped-charge jet tips at
//    8-10 km/s (Walters & Zukas 1989, Fundamentals of Shaped Charges); fragments from cased
//    charges stay below the Gurney velocities of high explosives, about 3 km/s;
//  - spin <= 1e5 rad/s: a 1 cm fragment spinning that fast has a 500 m/s rim speed.
struct PhysRange {
  double lo, hi;
};
inline constexpr PhysRange kMassRange{kPositiveLowerBound, 1e5};
inline constexpr PhysRange kSpeedRange{0.0, 2e4};
inline constexpr PhysRange kSpinRange{0.0, 1e5};

// Mass properties of a rigid body of uniform density (body frame = principal axes).
struct MassProperties {
  double mass_kg = 0.0;
  Vec3 dims_m{0, 0, 0};  // resolved dims (layout as ShapeSpec::dims_m, unused entries 0);
                         // polyhedron: its bounding box along the body axes
  std::shared_ptr<const Polyhedron> polyhedron;  // polyhedron: the shared hull ...
  double scale = 1.0;                            // ... scaled by this about its centre of mass
  Vec3 inertia_kg_m2{0, 0, 0};                   // principal moments about body x, y, z
  double surface_m2 = 0.0;                       // total surface area (0 for point)
  double presented_area_m2 = 0.0;  // tumble-averaged: surface / 4 (Cauchy), or the override
};

// Resolves dims, inertia and presented area of `shape` for a given mass. Point: inertia 0,
// presented area from `area_override` (required). `area_override` replaces the presented area.
MassProperties mass_properties(const ShapeSpec& shape, double mass_kg,
                               const std::optional<double>& area_override);

// Surface area of an ellipsoid with semi-axes a, b, c (Carlson symmetric integrals, exact).
double ellipsoid_surface_area(double a, double b, double c);

// Rotation from the group's local frame to site axes: Rz(yaw) * Ry(-pitch) * Rx(roll).
Mat3 frame_rotation(const FrameSpec& frame);

// Rotation from body axes to the group's local frame for a fixed attitude: frame_rotation's
// yaw/pitch/roll convention applied to the attitude's angles.
Mat3 attitude_rotation(const AttitudeSpec& attitude);

// Unit direction in the local frame, uniform on the sphere within the ranges, from u1, u2.
Vec3 sample_direction(const DirectionSpec& d, double u_elevation, double u_azimuth);
// The same with sin of the elevation range's ends given (s_lo, s_hi: computed once per group).
Vec3 sample_direction(const DirectionSpec& d, double s_lo, double s_hi, double u_elevation,
                      double u_azimuth);

// Uniformly distributed random rotation (Shoemake 1992) from three uniforms.
Quat uniform_rotation(double u1, double u2, double u3);

struct FragmentInit {
  std::uint32_t group = 0;
  std::uint64_t history = 0;
  double weight = 0.0;  // real fragments this history stands for: count / samples
  fragments::ShapeType shape = ShapeType::kSphere;
  MassProperties body;
  Vec3 position_m{0, 0, 0};  // input (site) coordinates; the run converts to local
  Vec3 velocity_mps{0, 0, 0};
  Quat orientation = Quat::Identity();  // body -> site
  Vec3 omega_body_radps{0, 0, 0};
  double launch_speed_mps = 0.0;   // sampled explosion-induced speed (before frame velocity)
  Vec3 launch_direction{1, 0, 0};  // unit, site axes, explosion-induced part
  // With DirectionCells: the direction's cell, and p/q (already in `weight`).
  std::uint32_t direction_cell = 0;
  double likelihood_ratio = 1.0;
};

// Stratum `index` of `count` equal strata of u_cell (settings.stratified_launch); `weight_factor`
// corrects the weight of a stratum holding more or fewer histories than the batch's share
// (samples / count): 1 for all but a last stratum that takes a remainder.
//
// Or (settings.stratified_launch.method "sobol") point `sobol_point` of the scrambled Sobol net
// `sobol_net` (a number unique per group, batch and block; -1: not this method): the launch
// uniforms are that point's coordinates (core/fragments/sobol.h).
struct LaunchStratum {
  std::int64_t index = 0;
  std::int64_t count = 1;
  double weight_factor = 1.0;
  std::int64_t sobol_net = -1;
  std::uint32_t sobol_point = 0;
};

// What sample_fragment needs of a group that is the same for all its histories: the truncated
// mass, speed and spin distributions and the frame's rotation, worked out once (bit for bit the
// values it would compute per history). Keeps pointers into `group`, which must outlive it.
struct GroupLaunch {
  explicit GroupLaunch(const FragmentGroupSpec& group);
  const FragmentGroupSpec* group;
  TruncatedDistribution mass, speed, spin;
  Mat3 frame;                                   // frame_rotation(group.frame)
  double sin_elevation_min, sin_elevation_max;  // of group.direction's elevation range
};

// `cells`: draw the direction from its importance density (direction_cells.h); null or uniform:
// the plain draw (bit for bit), with the cell reported when given. `stratum` (needs non-uniform
// cells, e.g. DirectionCells::equal): u_cell is drawn within the stratum; a Sobol point gives
// u_elevation, u_azimuth, u_speed, u_mass (and u_cell with non-uniform cells).
FragmentInit sample_fragment(const FragmentGroupSpec& group, std::uint32_t group_index,
                             std::uint64_t history, std::uint64_t seed,
                             const DirectionCells* cells = nullptr,
                             const LaunchStratum* stratum = nullptr);
// The same from the group's precomputed launch constants (the run's per-history path).
FragmentInit sample_fragment(const GroupLaunch& launch, std::uint32_t group_index,
                             std::uint64_t history, std::uint64_t seed,
                             const DirectionCells* cells = nullptr,
                             const LaunchStratum* stratum = nullptr);

}  // namespace fragsim::fragments
