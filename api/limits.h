#pragma once
// Upper bounds on the physical parameters of a scenario (docs/scenario.md, "Limits"). Each is far
// beyond any real value, with the reason beside it; together with the work cap per history
// (run::Settings::max_history_work) they keep the cost of a history bounded. The site's own
// limits (coordinates, extent, element counts) are in core/scene/site_limits.h, the sampled
// quantities' ranges (mass, speed, spin) in core/fragments/sampling.h.

#include <cstddef>

namespace fragsim::api::limits {

// Gravitational acceleration, m/s^2: ten times Earth's standard gravity (9.80665); Jupiter's
// cloud tops have 24.8.
inline constexpr double kMaxGravity_mps2 = 100.0;
// Air density, kg/m^3: Venus' surface atmosphere, the densest of a rocky planet, is about 65
// (NASA Venus fact sheet); Earth's at sea level 1.225.
inline constexpr double kMaxAirDensity_kg_m3 = 100.0;
// Speed of sound, m/s: 340 in air, about 1,300 in hydrogen, the fastest gas.
inline constexpr double kMaxSoundSpeed_mps = 1e4;
// Wind, each component, m/s: the strongest gust on record is 113 m/s (Barrow Island, 1996; WMO
// Archive of Weather and Climate Extremes).
inline constexpr double kMaxWind_mps = 200.0;
// Drag coefficient (constant or table entries): bluff bodies stay below about 2 (a flat plate
// across the flow, 1.98; Hoerner 1965, Fluid-Dynamic Drag); the demo uses 0.85-1.5.
inline constexpr double kMaxDragCoefficient = 10.0;
// Mach numbers of a Cd table: a 2e4 m/s fragment (the speed bound) flies at Mach 60 in air.
inline constexpr double kMaxMach = 100.0;
// Fragment and ground densities, kg/m^3: osmium, the densest element, is 22,590; light foams
// and aerogels a few kg/m^3.
inline constexpr double kMinDensity_kg_m3 = 1.0;
inline constexpr double kMaxDensity_kg_m3 = 1e5;
// Fragment dimensions, m: from a micrometre to 100 m (a whole wall is 10 m or so).
inline constexpr double kMinDimension_m = 1e-6;
inline constexpr double kMaxDimension_m = 100.0;
// Aspect proportions relative to each other: 1000:1 is a wire or a foil.
inline constexpr double kMinAspect = 1e-3;
inline constexpr double kMaxAspect = 1e3;
// Points of a polyhedron's vertices_m: a scanned boulder's hull has a few hundred vertices; 10,000
// keeps a hull's build (quickhull, ~n log n) and its per-face queries (toppling, frontal area)
// cheap.
inline constexpr std::size_t kMaxPolyhedronVertices = 10'000;
// Presented area, m^2: a 10 m x 10 m panel broadside is 100.
inline constexpr double kMaxArea_m2 = 1e3;
// Real fragments a group stands for: a large stack of munitions yields 1e6-1e8 fragments.
inline constexpr double kMaxCount = 1e12;
// Frame velocity, each component, m/s: the fragment speed bound.
inline constexpr double kMaxFrameSpeed_mps = 2e4;
// Coulomb friction and rolling resistance coefficients: rubber on dry concrete is about 1,
// rolling resistance coefficients 0.001-0.3.
inline constexpr double kMaxFriction = 10.0;
// Normal impact speeds of a restitution table, embedment speeds, rebound speed floor, m/s: the
// fragment speed bound.
inline constexpr double kMaxImpactSpeed_mps = 2e4;
// Person height of the PTN prisms, m (paper eq. 37; 1.8 by default).
inline constexpr double kMaxPersonHeight_m = 100.0;
// Simulated time of a history, s: without drag a fragment thrown straight up at 2 km/s lands
// after 408 s; with drag every real fragment lands within minutes.
inline constexpr double kMaxFlightTime_s = 3600.0;
// Ground-phase steps of a history (bounce_limits.max_ground_steps): the history's work cap
// (run::Settings::max_history_work, 1e6) would stop it first anyway.
inline constexpr long kMaxGroundSteps = 1'000'000;

}  // namespace fragsim::api::limits
