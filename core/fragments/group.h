#pragma once
// A fragment group: fragments with statistically identical properties defined in a local frame
// (paper, "Fragment group"). `count` real fragments are represented by `samples` histories,
// each of weight count / samples.
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "core/fragments/distribution.h"
#include "core/fragments/polyhedron.h"

namespace fragsim::fragments {

enum class ShapeType { kSphere, kCuboid, kEllipsoid, kCylinder, kPoint, kPolyhedron };
const char* shape_type_name(ShapeType s);

// Dimensions convention (metres): sphere [diameter]; cuboid [a, b, c] edge lengths along body
// x, y, z; ellipsoid [a, b, c] full axis lengths; cylinder [diameter, length] (axis = body z).
// Either `dims_m` is given (fixed size; mass from mass_kg), or `density_kg_m3` (size follows each
// sampled mass, with proportions from `aspect`, default all 1). A point mass has neither and
// needs the group's area_m2. A polyhedron is the convex hull of `vertices_m` (its body frame: the
// hull's principal axes at its centre of mass): as given (fixed size; mass from mass_kg), or with
// `density_kg_m3` scaled uniformly about its centre of mass to each sampled mass; no dims_m or
// aspect. Build one with polyhedron_shape (the hull is made once and shared).
struct ShapeSpec {
  ShapeType type = ShapeType::kSphere;
  std::vector<double> dims_m;  // empty or as above
  std::optional<double> density_kg_m3;
  std::vector<double> aspect;                    // relative proportions, same layout as dims_m
  std::vector<Vec3> vertices_m;                  // polyhedron: the points as given (input axes)
  std::shared_ptr<const Polyhedron> polyhedron;  // polyhedron: their hull, built once
};

// A polyhedron shape: the hull of `vertices_m` built now (throws InputError naming `field`, e.g.
// "shape.vertices_m", for fewer than 4 points, a non-finite one or a flat set).
ShapeSpec polyhedron_shape(std::vector<Vec3> vertices_m, std::optional<double> density_kg_m3,
                           const std::string& field = "shape.vertices_m");

struct FrameSpec {
  Vec3 origin_m{0, 0, 0};      // input (site) coordinates
  double yaw_deg = 0.0;        // about +z, from +x toward +y
  double pitch_deg = 0.0;      // nose (+x) up
  double roll_deg = 0.0;       // about the body x axis
  Vec3 velocity_mps{0, 0, 0};  // frame velocity (site coordinates), added to every fragment
};

// A fixed attitude of the body axes relative to the group's local frame (oriented debris, a slab
// lying on a slope). All zero: body axes = local axes, so a cuboid [a, b, c] in a level frame lies
// on its a x b face.
struct AttitudeSpec {
  double yaw_deg = 0.0;  // same convention as FrameSpec: R = Rz(yaw) * Ry(-pitch) * Rx(roll)
  double pitch_deg = 0.0;
  double roll_deg = 0.0;
};

struct DirectionSpec {
  // Uniform on the unit sphere restricted to these ranges, in the local frame
  // (x forward, y left, z up; elevation from the xy-plane, azimuth from +x toward +y).
  double elevation_min_deg = -90.0, elevation_max_deg = 90.0;
  double azimuth_min_deg = -180.0, azimuth_max_deg = 180.0;
};

struct CdSpec {
  double constant = 1.0;
  std::vector<double> mach;  // strictly increasing; empty => constant
  std::vector<double> cd;
};

struct FragmentGroupSpec {
  std::string name;
  double count = 1.0;        // real fragments (> 0; need not be an integer)
  std::int64_t samples = 1;  // histories (>= 1)
  FrameSpec frame;
  ShapeSpec shape;
  Distribution mass_kg;
  Distribution speed_mps;
  DirectionSpec direction;
  CdSpec cd;
  std::optional<double> area_m2;  // presented-area override; required for point
  Distribution spin_radps = Distribution::fixed(0.0);  // initial spin magnitude, random axis
  // Body axes relative to the group's local frame; nullopt: uniformly random (default).
  std::optional<AttitudeSpec> attitude;
};

}  // namespace fragsim::fragments
