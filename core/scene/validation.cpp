#include "core/scene/validation.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>

#include "core/scene/polygon.h"

namespace fragsim::scene::detail {

std::string indexed(const std::string& base, std::size_t i) {
  return base + "[" + std::to_string(i) + "]";
}

std::string material_field(const std::string& name) {
  const bool identifier = !name.empty() && std::all_of(name.begin(), name.end(), [](char ch) {
    return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_' || ch == '-';
  });
  return identifier ? "site.materials." + name : "site.materials[\"" + name + "\"]";
}

std::string terrain_form_field(const TerrainSpec& terrain) {
  // The scenario nests the form under its name: {"terrain": {"grid": {...}, "material": ...}}.
  switch (terrain.geometry.index()) {
    case 0: return "site.terrain.plane";
    case 1: return "site.terrain.grid";
    default: return "site.terrain.mesh";
  }
}

void fail(const std::string& field, const std::string& message) {
  throw InputError(field, message);
}

void require_finite(double v, const std::string& field) {
  if (!std::isfinite(v)) fail(field, "not finite");
}

std::string format_number(double v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);  // shortest round-trip form
  return std::string(buf, r.ptr);
}

void require_positive(double v, const std::string& field) {
  require_finite(v, field);
  if (!(v > 0)) fail(field, "must be > 0 (got " + format_number(v) + ")");
}

void require_at_least(double v, double lo, const std::string& field) {
  require_finite(v, field);
  if (!(v >= lo))
    fail(field, "must be >= " + format_number(lo) + " (got " + format_number(v) + ")");
}

void require_in(double v, double lo, double hi, const std::string& field) {
  require_finite(v, field);
  if (!(v >= lo && v <= hi))
    fail(field, "must be in [" + format_number(lo) + ", " + format_number(hi) + "] (got " +
                    format_number(v) + ")");
}

bool is_zero_area(const Vec3& a, const Vec3& b, const Vec3& c) {
  const Vec3 e0 = b - a, e1 = c - b, e2 = a - c;
  const double longest2 = std::max({e0.squaredNorm(), e1.squaredNorm(), e2.squaredNorm()});
  const double area = 0.5 * e0.cross(c - a).norm();
  return !(area >= kZeroAreaRelative * longest2) || longest2 == 0.0;
}

bool is_zero_area_2d(const Vec2& a, const Vec2& b, const Vec2& c) {
  const double longest2 =
      std::max({(b - a).squaredNorm(), (c - b).squaredNorm(), (a - c).squaredNorm()});
  const double area = 0.5 * std::abs(orient2d(a, b, c));
  return !(area >= kZeroAreaRelative * longest2) || longest2 == 0.0;
}

void validate_mesh(const MeshSpec& mesh, const std::string& field, const std::string& empty_field,
                   const std::string& empty_message) {
  constexpr auto kMaxIndex = static_cast<std::size_t>(std::numeric_limits<std::uint32_t>::max());
  if (mesh.vertices_m.empty() || mesh.triangles.empty()) fail(empty_field, empty_message);
  if (mesh.vertices_m.size() >= kMaxIndex)
    fail(field + ".vertices_m", "too many vertices (limit 2^32 - 1)");
  if (mesh.triangles.size() >= kMaxIndex)
    fail(field + ".triangles", "too many triangles (limit 2^32 - 1)");
  for (std::size_t v = 0; v < mesh.vertices_m.size(); ++v) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(mesh.vertices_m[v][k]))
        fail(indexed(indexed(field + ".vertices_m", v), static_cast<std::size_t>(k)), "not finite");
    }
  }
  const auto nv = static_cast<std::int64_t>(mesh.vertices_m.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const std::string tf = indexed(field + ".triangles", t);
    const auto& tri = mesh.triangles[t];
    for (std::size_t k = 0; k < 3; ++k) {
      if (tri[k] < 0 || tri[k] >= nv)
        fail(indexed(tf, k), "vertex index " + std::to_string(tri[k]) +
                                 " out of range (vertices: " + std::to_string(nv) + ")");
    }
    if (is_zero_area(mesh.vertices_m[tri[0]], mesh.vertices_m[tri[1]], mesh.vertices_m[tri[2]]))
      fail(tf, "zero-area triangle");
  }
}

void validate_simple_polygon(const std::vector<Vec2>& poly, const std::string& field,
                             const char* what) {
  const std::size_t n = poly.size();
  if (n < 3)
    fail(field,
         std::string("a ") + what + " needs at least 3 vertices (got " + std::to_string(n) + ")");
  for (std::size_t k = 0; k < n; ++k) {
    if (poly[k] == poly[(k + 1) % n])
      fail(indexed(field, (k + 1) % n), "repeats the previous vertex (zero-length edge)");
  }
  const auto edge_name = [](std::size_t a, std::size_t b) {
    return "edges " + std::to_string(a) + " and " + std::to_string(b);
  };
  // Adjacent edges share a vertex; they only overlap when the polygon folds back on itself.
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& a = poly[k];
    const Vec2& b = poly[(k + 1) % n];
    const Vec2& c = poly[(k + 2) % n];
    if (orient2d(a, b, c) == 0.0 && (b - a).dot(c - b) < 0.0) {
      const std::size_t e0 = k, e1 = (k + 1) % n;
      fail(field,
           "self-crossing polygon (" + edge_name(std::min(e0, e1), std::max(e0, e1)) + " overlap)");
    }
  }
  // Non-adjacent edges must not meet at all. O(n^2): footprints have tens to hundreds of vertices.
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t m = k + 2; m < n; ++m) {
      if (k == 0 && m == n - 1) continue;  // adjacent through the closing vertex
      if (segments_intersect(poly[k], poly[(k + 1) % n], poly[m], poly[(m + 1) % n]))
        fail(field, "self-crossing polygon (" + edge_name(k, m) + " cross)");
    }
  }
  double longest2 = 0.0;
  for (std::size_t k = 0; k < n; ++k)
    longest2 = std::max(longest2, (poly[(k + 1) % n] - poly[k]).squaredNorm());
  if (!(std::abs(signed_area(poly)) >= kZeroAreaRelative * longest2))
    fail(field, std::string("zero-area ") + what);
}

namespace {

// The first pair of edges, one of `a` and one of `b`, that meet (cross, touch or overlap), as
// "its edge i meets <b_name> edge j"; empty when the closed polygons' boundaries are disjoint.
// O(|a| |b|): footprints and their holes have at most kMaxFootprintVertices vertices together.
std::string boundaries_meet(const std::vector<Vec2>& a, const std::vector<Vec2>& b,
                            const std::string& b_name) {
  for (std::size_t i = 0; i < a.size(); ++i) {
    for (std::size_t j = 0; j < b.size(); ++j) {
      if (segments_intersect(a[i], a[(i + 1) % a.size()], b[j], b[(j + 1) % b.size()]))
        return "its edge " + std::to_string(i) + " meets " + b_name + " edge " + std::to_string(j);
    }
  }
  return {};
}

}  // namespace

void validate_holes(const std::vector<Vec2>& outer, const std::vector<std::vector<Vec2>>& holes,
                    const std::string& field) {
  for (std::size_t k = 0; k < holes.size(); ++k) {
    const std::string hk = indexed(field, k);
    validate_simple_polygon(holes[k], hk, "hole");
    // Boundaries apart, a hole is inside the footprint exactly when one of its vertices is.
    if (const std::string meet = boundaries_meet(holes[k], outer, "footprint_m"); !meet.empty())
      fail(hk, "not inside the footprint (" + meet + ")");
    if (!point_in_polygon(outer, holes[k][0])) fail(hk, "not inside the footprint");
    for (std::size_t j = 0; j < k; ++j) {
      const std::string hj = "holes_m[" + std::to_string(j) + "]";
      if (const std::string meet = boundaries_meet(holes[k], holes[j], hj); !meet.empty())
        fail(hk, "crosses " + hj + " (" + meet + ")");
      if (point_in_polygon(holes[j], holes[k][0])) fail(hk, "lies inside " + hj);
      if (point_in_polygon(holes[k], holes[j][0])) fail(hk, "contains " + hj);
    }
  }
}

}  // namespace fragsim::scene::detail
