#pragma once
// Input checks shared by the terrain and building builders (internal to core/scene).
// Every failure throws InputError with a field path in the scenario's own names and indices.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/error.h"
#include "core/common/types.h"
#include "core/scene/site_spec.h"

namespace fragsim::scene::detail {

// "base[i]"
std::string indexed(const std::string& base, std::size_t i);
// "site.materials.<name>" (or site.materials["<name>"] when the name is not identifier-like).
std::string material_field(const std::string& name);
// Field prefix of the terrain form in use: "site.terrain.plane", ".grid" or ".mesh".
std::string terrain_form_field(const TerrainSpec& terrain);

[[noreturn]] void fail(const std::string& field, const std::string& message);
// Shortest text that reads back to the same double ("0.5", "3", "1e-06"), as the api layer's
// messages print numbers.
std::string format_number(double v);
void require_finite(double v, const std::string& field);
// Finite and > 0: "must be > 0 (got -1)".
void require_positive(double v, const std::string& field);
// Finite and >= lo: "must be >= 0 (got -0.1)".
void require_at_least(double v, double lo, const std::string& field);
// Finite and in [lo, hi]: "must be in [0, 1] (got 1.5)".
void require_in(double v, double lo, double hi, const std::string& field);

// Zero-area test, relative to the triangle's own size: area < 1e-12 * (longest edge)^2, i.e. its
// height is below 2e-12 of its longest edge. A scale-free threshold catches repeated and collinear
// vertices whatever the units or the triangle size, while any real sliver passes (a triangle whose
// height is 1e-12 of its length carries no geometry at the 1e-9 level, far below input precision).
// The edges are differences of nearby doubles, so they are exact even at UTM-sized coordinates.
inline constexpr double kZeroAreaRelative = 1e-12;
bool is_zero_area(const Vec3& a, const Vec3& b, const Vec3& c);
bool is_zero_area_2d(const Vec2& a, const Vec2& b, const Vec2& c);

// Checks a triangle mesh: vertices finite, at least one triangle, indices in range, no zero-area
// triangle. `field` is the mesh's path ("site.terrain.mesh", "site.buildings[1].mesh");
// `empty_field`/`empty_message` name the error for an empty mesh. Vertex and triangle counts must
// fit uint32 indices.
void validate_mesh(const MeshSpec& mesh, const std::string& field, const std::string& empty_field,
                   const std::string& empty_message);

// 2-D polygon checks (footprints), coordinates already relative to a nearby point:
// at least 3 vertices, finite, no repeated consecutive vertex, simple (no two edges cross or touch
// other than adjacent edges at their shared vertex), non-zero area. Edge k runs from vertex k to
// vertex k+1 (mod n). `what` names the polygon in messages ("zero-area footprint").
void validate_simple_polygon(const std::vector<Vec2>& poly, const std::string& field,
                             const char* what = "footprint");

// Holes of a validated footprint `outer` (courtyards), `field` their path
// ("site.buildings[2].holes_m"): each a simple polygon (validate_simple_polygon) strictly inside
// `outer`, touching it nowhere, and the holes pairwise disjoint: none crosses or touches another,
// none lies inside another. Errors name the hole: "holes_m[1]: crosses holes_m[0] (...)".
void validate_holes(const std::vector<Vec2>& outer, const std::vector<std::vector<Vec2>>& holes,
                    const std::string& field);

}  // namespace fragsim::scene::detail
