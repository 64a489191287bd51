#pragma once
// The site as the user describes it (input coordinates, before validation and meshing).
// Field names follow the scenario contract (docs/scenario.md); InputError paths use them too.
#include <array>
#include <map>
#include <optional>
#include <string>
#include <variant>
#include <vector>

#include "core/common/types.h"

namespace fragsim::scene {

enum class SurfaceType : std::uint8_t { kTerrain = 0, kWall = 1, kRoof = 2, kWindow = 3 };
inline constexpr int kSurfaceTypeCount = 4;
const char* surface_type_name(SurfaceType s);  // "terrain", "wall", "roof", "window"

// Coefficient of restitution: a constant, or a table of e against normal impact speed
// (linear interpolation, clamped at the ends). Used by the bounce model.
struct RestitutionSpec {
  double constant = 0.0;
  std::vector<double> normal_speed_mps;  // strictly increasing, >= 0; empty => constant
  std::vector<double> e;                 // same length, each in [0, 1]
};

// Embedment of fast fragments in a deformable ground (docs/physics.md, "Fast impacts on soil"):
// a fragment arriving faster than min_speed_mps at a grazing angle (between its velocity and the
// surface) of at least theta_c = coefficient_deg / sqrt(sigma), sigma = fragment density / bulk
// density, does not ricochet: it stops in the ground. Johnson & Reid (1975), "Ricochet of spheres
// off water", J. Mech. Eng. Sci. 17, 71-81: theta_c = 18 deg / sqrt(sigma); extended to sand by
// Soliman, Reid & Johnson (1976), Int. J. Mech. Sci. 18, 279-284. Slower or more grazing, the
// rigid-body impulse applies (a ricochet).
struct EmbedmentSpec {
  double bulk_density_kg_m3 = 1700.0;  // of the ground; no default is sourced: set it per site
  double coefficient_deg = 18.0;       // Johnson & Reid (1975)
  double min_speed_mps = 20.0;         // below: rigid contact (docs/physics.md)
};

// Fast contact on a deformable ground (soil, sand): docs/physics.md, "Fast contact on soil"
// (F1-F6); what data there are, and what they cover, in docs/validation.md. A terrain contact at
// least `switch_speed_mps` fast is an impact on a deformable half-space, not a rigid one:
// * F1: the soil resists a body moving through it with a Poncelet force A (s + c rho_s v^2);
//   the switch speed v_s is where its inertial term equals its strength term (v_s^2 = s/(c rho_s)).
//   Below v_s the rigid impulse and Coulomb friction apply (the regime of the block-drop and
//   rockfall data, up to ~30 m/s);
// * F2: at a grazing angle of at least theta_c = critical_angle_coefficient_deg / sqrt(sigma),
//   sigma = fragment density / bulk density (Johnson & Reid 1975), the fragment embeds;
// * F3-F4: more grazing, it ricochets: its path through the soil is an arc (the force keeps the
//   ratio drag/lift = drag_to_lift_ratio), turned through 2 theta_e, theta_e = theta +
//   roughness_deg, so (v_out^2 + v_s^2) = (v^2 + v_s^2) exp(-4 (D/L) theta_e) (stopped when
//   that leaves nothing: embedded);
// * F5: it leaves at theta_out = exit_angle_ratio * theta_e (1: the symmetric arc), its spin
//   slowed with its speed;
// * F6: a body on the ground faster than v_s is such a contact at its own approach angle: there
//   is no Coulomb slide above v_s.
// No measurement at fragment speeds could be read for any of these constants (docs/validation.md):
// the defaults are the mechanics' nominal values, each with the range a study's bracket runs.
struct FastContactSpec {
  double bulk_density_kg_m3 = 1700.0;            // rho_s; no default is sourced: set it per site
  double switch_speed_mps = 30.0;                // v_s (F1)
  double critical_angle_coefficient_deg = 18.0;  // Johnson & Reid (1975) (F2)
  double drag_to_lift_ratio = 1.0;               // D/L of the soil's force on the body (F4)
  double roughness_deg = 2.0;                    // added to the approach angle (F4)
  double exit_angle_ratio = 1.0;                 // theta_out / theta_e (F5)
};

struct MaterialSpec {
  double friction = 0.5;  // Coulomb coefficient, >= 0
  RestitutionSpec restitution;
  // Rolling resistance coefficient (resisting force / normal load) for round fragments rolling
  // on the surface after their bounces (docs/physics.md, "Slide, roll and rest"). The default is
  // illustrative, not sourced.
  double rolling_resistance = 0.1;
  // Penetration threshold: kinetic energy of the normal velocity component per presented area.
  // Absent => the surface is never penetrated.
  std::optional<double> penetration_ke_per_area_j_per_m2;
  // Absent: every terrain impact is a rigid-body impulse.
  std::optional<EmbedmentSpec> embedment;
  // Absent: no fast-contact law (rigid impulse and Coulomb friction at every speed). Not
  // together with `embedment` (it has its own critical angle).
  std::optional<FastContactSpec> fast_contact;
  // The range of each uncertain constant, {low, high}, by name (material_constant_names()): what
  // settings.ground_bracket runs (docs/physics.md, "The bracket"). fast_contact's constants have
  // default ranges (default_fast_contact_ranges) unless given here.
  std::map<std::string, std::array<double, 2>> ranges;
};

// The constants of a material a range may be given for: friction, rolling_resistance,
// restitution (a constant restitution only) and fast_contact's.
const std::vector<std::string>& material_constant_names();
// The constant's value in m (nullopt: the material has no such constant, e.g. no fast_contact,
// or a restitution table).
std::optional<double> material_constant(const MaterialSpec& m, const std::string& name);
// Sets it (the material must have it).
void set_material_constant(MaterialSpec& m, const std::string& name, double value);
// The ranges docs/physics.md documents for fast_contact's constants (none is measured).
const std::map<std::string, std::array<double, 2>>& default_fast_contact_ranges();
// m's ranges: its own, then fast_contact's defaults for the constants it has no range for.
std::map<std::string, std::array<double, 2>> effective_ranges(const MaterialSpec& m);

// The ground materials the paper uses (friction 0.5 hard surface, 0.9 soft ground), available to
// every site under the names "hard" and "soft" unless the site defines a material of that name.
// Their restitution tables are illustrative (see material.cpp). nullopt for any other name.
std::optional<MaterialSpec> builtin_ground_material(const std::string& name);

struct PlaneTerrainSpec {
  double elevation_m = 0.0;
  std::array<double, 4> extent_m{};  // xmin, ymin, xmax, ymax
  double cell_m = 10.0;              // meshed into square cells of this size, two triangles each
};

// Heightfield: vertex (i, j) at (origin_m[0] + i*spacing_m, origin_m[1] + j*spacing_m,
// elevation_m[j*nx + i]) for i < nx, j < ny (row-major, rows along x).
struct GridTerrainSpec {
  std::array<double, 2> origin_m{};
  double spacing_m = 0.0;
  int nx = 0;
  int ny = 0;
  std::vector<double> elevation_m;
};

struct MeshSpec {
  std::vector<Vec3> vertices_m;
  std::vector<std::array<std::int64_t, 3>> triangles;
  std::vector<SurfaceType> surface;  // per triangle; buildings only (empty for terrain)
};

// A polygon in plan (input x, y) whose terrain triangles take `material`: those whose centroid
// lies inside it (docs/scenario.md, "Materials by zone").
struct MaterialZoneSpec {
  std::string material;                          // key into SiteSpec::materials
  std::vector<std::array<double, 2>> polygon_m;  // simple polygon, either orientation
};

// A terrain triangle's material: the last zone that contains its centroid, else its entry of
// triangle_material, else `material`.
struct TerrainSpec {
  std::variant<PlaneTerrainSpec, GridTerrainSpec, MeshSpec> geometry;
  std::string material;  // key into SiteSpec::materials
  // Per triangle, in the terrain's own order (a mesh's as given; a plane's or grid's cell
  // k = j (nx - 1) + i holds triangles 2k and 2k + 1): an index into triangle_material_names.
  // Empty: every triangle has `material`.
  std::vector<std::string> triangle_material_names;
  std::vector<std::int64_t> triangle_material;
  std::vector<MaterialZoneSpec> zones;  // later zones win
};

// A building: either a footprint extruded to a closed mesh (walls + flat roof) or an explicit
// closed mesh with a surface type per triangle. Materials are named per surface type.
struct BuildingSpec {
  std::string id;
  // Footprint form (used when `mesh` is empty):
  std::vector<std::array<double, 2>> footprint_m;  // simple polygon, either orientation
  // Holes (courtyards), open to the sky and walled all round: each a simple polygon, either
  // orientation, strictly inside footprint_m (touching it nowhere), the holes disjoint (none
  // crosses, touches or contains another). Footprint vertices and hole vertices together count
  // against the footprint vertex limit (site_limits.h). Empty: a plain footprint.
  std::vector<std::vector<std::array<double, 2>>> holes_m;
  double height_m = 0.0;                   // above the base
  std::optional<double> base_elevation_m;  // default: lowest terrain height under the footprint
  // Explicit form:
  std::optional<MeshSpec> mesh;
  // Materials by surface type (keys into SiteSpec::materials); window may stay empty when the
  // building has no window triangles.
  std::string wall;
  std::string roof;
  std::string window;
};

struct SiteOrigin {
  std::string crs;
  double easting_m = 0.0;
  double northing_m = 0.0;
  double elevation_m = 0.0;  // altitude above sea level of input z = 0 (used by the atmosphere)
};

struct SiteSpec {
  TerrainSpec terrain;
  std::vector<BuildingSpec> buildings;
  std::map<std::string, MaterialSpec> materials;
  std::optional<SiteOrigin> origin;
};

}  // namespace fragsim::scene
