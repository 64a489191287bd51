#pragma once
// What one Monte Carlo run produces. Every tallied figure comes with a standard error estimated
// from per-history sums and sums of squares (groups are independent strata):
//   mean = sum_g S_g,  var = sum_g n_g/(n_g-1) (Q_g - S_g^2/n_g)
// where S_g, Q_g are the sum and sum of squares of the per-history contributions of group g
// (each already multiplied by the history's weight count_g/samples_g).
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/run/hfd.h"
#include "core/scene/site_spec.h"

namespace fragsim::run {

struct PrecisionReport;  // core/run/precision.h

// Why a run stopped.
enum class StopReason : std::uint8_t {
  kSamples = 0,      // no settings.precision: the groups' samples are done
  kTargetsMet = 1,   // every precision target holds (settings.precision)
  kMaxBatches = 2,   // settings.precision.max_batches reached
  kMaxWallTime = 3,  // settings.precision.max_wall_s reached at a batch boundary
  kCancelled = 4,    // partial result
  // Every precision target is met or cannot be met (an HFD target on an HFD the terrain's
  // boundary cuts: docs/precision.md), and at least one cannot.
  kTargetsUnmeetable = 5,
};
inline constexpr int kStopReasonCount = 6;
const char* stop_reason_name(StopReason s);

struct Estimate {
  double mean = 0.0;
  double std_error = 0.0;
};

// How a history ended.
enum class Outcome : std::uint8_t {
  kGround = 0,             // terrain impact (no bounce) / came to rest on the terrain (bounce)
  kBuilding = 1,           // stopped by a building (impact; penetrated or not)
  kMaxFlightTime = 2,      // still flying at max_flight_time_s
  kLeftSite = 3,           // left the terrain's horizontal extent
  kStartedInside = 4,      // launched below the terrain or inside a building: not flown
  kHarmless = 5,           // can never become hazardous and nothing else to tally: tracking stopped
  kIntegrationFailed = 6,  // step size underflow (counted, never silently dropped)
  kEmbedded = 7,   // stopped in the ground at an impact too fast and steep to ricochet (bounce)
  kWorkLimit = 8,  // stopped at Settings::max_history_work steps and events (never on real input)
  // Still moving on the ground at Settings::max_ground_steps (a safety cap, not expected on a
  // valid site): not at rest, so not `ground`.
  kGroundStepCap = 9,
};
inline constexpr int kOutcomeCount = 10;
const char* outcome_name(Outcome o);

// The physics that made a PTN contribution (docs/precision.md, "What sets the HFD").
enum class PtnMechanism : std::uint8_t {
  kDirectFlight = 0,   // flight before the history's first terrain contact
  kAfterRicochet = 1,  // flight after a terrain impact or a take-off from the ground
  kGround = 2,         // the ground phase: sliding, rolling, ploughing on the terrain
};
inline constexpr int kPtnMechanismCount = 3;
const char* ptn_mechanism_name(PtnMechanism m);

// The density at one triangle that sets an HFD, and the shares of it (fractions, summing to 1
// up to rounding) made by each mechanism and each group.
struct DensityShares {
  std::int64_t triangle = -1;  // -1: no triangle at or above the threshold (no HFD)
  double distance_m = 0.0;     // of its centroid from the HFD origin
  double density_per_m2 = 0.0;
  std::array<double, kPtnMechanismCount> by_mechanism{};
  std::vector<double> by_group;  // per scenario group; empty when by_group is omitted
};

// What sets the HFD (docs/precision.md, "What sets the HFD"): the HFD figures of the density
// field each mechanism and each group makes alone, and the shares at the triangles that set the
// HFD and each sector's HFD.
struct HfdAttribution {
  std::array<HfdFigures, kPtnMechanismCount> by_mechanism;
  std::vector<HfdFigures> by_group;     // per scenario group; empty when omitted
  std::string by_group_omitted_reason;  // why by_group is empty ("" when it is not)
  DensityShares at_hfd;
  std::array<DensityShares, kHfdSectors> at_sector_hfd;  // sector k's (triangle -1 when none)
};

// The figures the terrain's boundary makes lower bounds, and what left the site while hazardous.
struct SiteBoundary {
  std::array<bool, 36> hfd_sector_cut{};     // sector k's HFD is a lower bound
  int hfd_sectors_cut = 0;                   // of them
  bool hfd_cut = false;                      // the HFD is a lower bound (some sector is cut)
  bool band_lower_cut = false;               // the band's lower end (field mean - se) is
  bool band_upper_cut = false;               // the band's upper end (field mean + se) is
  double max_boundary_density_per_m2 = 0.0;  // largest density of a triangle at the boundary
  // Real fragments that left the terrain's extent with kinetic energy >= hazardous_ke_j (their
  // landing is not modelled), overall and by the HFD sector of the point where they left.
  Estimate left_hazardous;
  std::array<Estimate, 36> left_hazardous_by_sector{};
  std::int64_t left_hazardous_histories = 0;
};

struct BuildingResult {
  std::string id;
  Estimate impacts;       // expected number of real fragments hitting the building
  Estimate penetrations;  // expected number penetrating
  std::array<Estimate, scene::kSurfaceTypeCount> impacts_by_surface;
  std::array<Estimate, scene::kSurfaceTypeCount> penetrations_by_surface;
  Estimate residual_ke_j;  // expected total residual kinetic energy of penetrating fragments
};

// Per-history record (settings.record_fragments).
struct FragmentRecord {
  std::uint32_t group = 0;
  std::uint64_t history = 0;
  double weight = 0.0;
  double mass_kg = 0.0;
  double area_m2 = 0.0;
  Vec3 launch_position_m{0, 0, 0};  // input coordinates
  Vec3 launch_velocity_mps{0, 0, 0};
  Outcome outcome = Outcome::kGround;
  double end_time_s = 0.0;
  Vec3 end_position_m{0, 0, 0};  // input coordinates: impact / rest / last position
  Vec3 end_velocity_mps{0, 0, 0};
  // First impact (terrain or building); without bounce it is also where the history ended.
  double first_impact_time_s = -1.0;      // -1: no impact
  Vec3 first_impact_position_m{0, 0, 0};  // input coordinates
  Vec3 first_impact_velocity_mps{0, 0, 0};
  double impact_angle_deg = 0.0;  // first impact: between velocity and surface, 0 = grazing
  double impact_ke_j = 0.0;       // first impact
  std::int32_t building = -1;     // index into buildings, -1 none
  std::int32_t surface = -1;      // SurfaceType of the building hit
  bool penetrated = false;
  double residual_ke_j = 0.0;
  std::uint32_t bounces = 0;         // terrain impacts from flight (impulse model)
  std::uint32_t ground_impacts = 0;  // impulses at terrain edges while on the ground
  std::uint32_t takeoffs = 0;        // times it left the ground again (crests, edge rebounds)
  double ground_path_m = 0.0;        // distance travelled on the ground (all ground phases)
};

// What a recorded trajectory point is.
enum class TrajectoryEvent : std::uint8_t {
  kLaunch = 0,
  kFlight = 1,         // end of a flight integrator step
  kTerrainImpact = 2,  // an impulse with the terrain (a landing, or at an edge on the ground)
  kTakeOff = 3,        // left the ground (a crest, an edge impact's rebound, lifted by the air)
  kGround = 4,         // end of a slide/roll piece
  kBuildingHit = 5,
  kEnd = 6,  // the history's last point (rest, harmless, ...)
};
inline constexpr int kTrajectoryEventCount = 7;
const char* trajectory_event_name(TrajectoryEvent e);

struct TrajectoryRecord {
  std::uint32_t group = 0;
  std::uint64_t history = 0;
  std::vector<double> t_s;
  std::vector<Vec3> position_m;  // input coordinates
  std::vector<Vec3> velocity_mps;
  std::vector<TrajectoryEvent> event;
};

struct Timing {
  double wall_s = 0.0;
  double parse_s = 0.0;  // reading and parsing the scenario (set by the caller that parsed it)
  double build_s = 0.0;  // site build (meshes, Embree scene); 0 for a site built before
  int threads = 1;
  // With settings.profile: summed over threads, seconds.
  double integration_s = 0.0;
  double geometry_s = 0.0;
  double tally_s = 0.0;
  double fragments_per_s = 0.0;  // histories per wall second
  double fragments_per_s_per_thread = 0.0;
};

struct RunStats {
  std::int64_t rhs_evaluations = 0;
  std::int64_t integrator_steps = 0;
  std::int64_t chords = 0;
  std::int64_t scene_queries = 0;   // Embree/analytic segment queries actually made
  std::int64_t chords_skipped = 0;  // chords above everything: no query needed
  std::int64_t ptn_triangle_tests = 0;
  std::int64_t bounces = 0;           // terrain impacts resolved by the impulse model
  std::int64_t ground_steps = 0;      // ground-phase integrator steps and events
  std::int64_t ground_impacts = 0;    // impulses at terrain edges on the ground
  std::int64_t takeoffs = 0;          // ground -> flight
  std::int64_t ground_step_caps = 0;  // histories stopped by max_ground_steps (expected 0)
  // Impacts (from flight or on the ground) after which the body's energy, translational and
  // rotational kinetic plus m g z, exceeded the energy before beyond rounding (energy_rose):
  // an impulse can only remove energy, so this is 0 unless the impact model is wrong.
  std::int64_t energy_rises = 0;
  std::int64_t fast_contacts = 0;  // terrain contacts resolved by a fast_contact law (F1-F6)
  // Ground pieces that started faster than their material's fast_contact switch speed: slides
  // the law forbids (expected 0; F6).
  std::int64_t fast_slides = 0;

  // Every counter, in this order (sums, the partial file).
  static constexpr auto counters() {
    return std::array{
        &RunStats::rhs_evaluations, &RunStats::integrator_steps, &RunStats::chords,
        &RunStats::scene_queries,   &RunStats::chords_skipped,   &RunStats::ptn_triangle_tests,
        &RunStats::bounces,         &RunStats::ground_steps,     &RunStats::ground_impacts,
        &RunStats::takeoffs,        &RunStats::ground_step_caps, &RunStats::energy_rises,
        &RunStats::fast_contacts,   &RunStats::fast_slides};
  }
  RunStats& operator+=(const RunStats& o) {
    for (const auto m : counters()) this->*m += o.*m;
    return *this;
  }
};

// settings.ground_bracket (core/run/bracket.h): the study's figures at each end of each uncertain
// ground constant's range, one at a time.
struct BracketFigures {
  double value = 0.0;  // the constant's value in this run (the nominal run: its own)
  double hfd_m = 0.0;
  bool hfd_lower_bound = false;                 // the site boundary cuts it (site_boundary.hfd_cut)
  double hfd_lower_m = 0.0, hfd_upper_m = 0.0;  // its band
  double building_impacts = 0.0;                // expected, summed over the buildings
  double building_penetrations = 0.0;
};
struct BracketRow {
  std::string constant;
  double nominal = 0.0;
  BracketFigures low, high;  // at the low and high end of the range
};
struct GroundBracket {
  std::string material;  // the terrain material whose constants are varied
  double samples_scale = 1.0;
  std::int64_t histories_per_run = 0;
  BracketFigures nominal;        // the nominal constants at the same samples (paired)
  std::vector<BracketRow> rows;  // widest HFD swing first
  bool cancelled = false;        // stopped before every run was done: rows are incomplete
};

struct RunResult {
  std::int64_t samples = 0;
  double real_fragments = 0.0;
  std::uint64_t seed = 0;
  bool cancelled = false;  // stopped early: only the counts, stop reason and timing are set
  std::int64_t histories_done = 0;
  // Batches of the groups' samples (settings.precision; 1 without). A run that stopped after
  // K batches is bit-identical to one with precision.max_batches = K and no targets.
  std::int64_t batches = 1;
  // Histories of the importance-sampling pilot batch (learnt from, not in the estimates; 0
  // without settings.precision.direction_importance). samples counts the others.
  std::int64_t pilot_histories = 0;
  StopReason stop_reason = StopReason::kSamples;
  std::shared_ptr<const PrecisionReport> precision;  // the last check; null without precision

  // PTN density per terrain triangle (paper eqs. 37-39), per m^2.
  std::vector<double> ptn_density_per_m2;
  std::vector<double> ptn_std_error_per_m2;
  double max_ptn_density_per_m2 = 0.0;
  std::int64_t max_ptn_triangle = -1;
  Vec3 max_ptn_location_m{0, 0, 0};  // centroid, input coordinates

  // Hazardous fragment distance: largest horizontal distance from hfd_origin_m of a terrain
  // triangle centroid whose density >= the threshold (0 when none).
  Vec3 hfd_origin_m{0, 0, 0};
  double hazardous_fragment_distance_m = 0.0;
  // Indicative band: HFD of the fields (mean - 1 se) and (mean + 1 se).
  double hfd_lower_m = 0.0;
  double hfd_upper_m = 0.0;
  std::array<double, 36>
      hfd_by_sector_m{};  // sector k: azimuth [10k, 10k+10) deg from +x toward +y

  // Where the terrain's boundary cut these figures (core/run/hfd.h): a triangle touching the
  // boundary in the sector has a density (of the field the figure comes from) at or above the
  // threshold, so the figure is only a lower bound. The HFD is cut when any sector is.
  SiteBoundary site_boundary;

  HfdAttribution hfd_attribution;  // what sets the HFD, by mechanism and group
  // settings.ground_bracket: the figures at the ends of the ground constants' ranges (null
  // without it, and for a cancelled run).
  std::shared_ptr<const GroundBracket> ground_bracket;

  std::vector<BuildingResult> buildings;

  // Weighted (real fragments) and raw (histories) counts by outcome.
  std::array<Estimate, kOutcomeCount> outcome_fragments;
  std::array<std::int64_t, kOutcomeCount> outcome_histories{};

  std::vector<FragmentRecord> fragments;       // when recorded, in (group, history) order
  std::vector<TrajectoryRecord> trajectories;  // when recorded
  Timing timing;
  RunStats stats;
};

}  // namespace fragsim::run
