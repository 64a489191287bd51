// Rigid-body properties of the fragment shapes: resolved size, principal moments of inertia,
// surface area and tumble-averaged presented area. Uniform density throughout.
#include <cmath>
#include <string>

#include "core/common/elliptic.h"
#include "core/common/error.h"
#include "core/fragments/sampling.h"

namespace fragsim::fragments {

namespace {

// Number of entries of dims_m / aspect for each shape (layout in group.h).
std::size_t dims_count(ShapeType s) {
  switch (s) {
    case ShapeType::kSphere: return 1;
    case ShapeType::kCuboid: return 3;
    case ShapeType::kEllipsoid: return 3;
    case ShapeType::kCylinder: return 2;
    case ShapeType::kPoint:
    case ShapeType::kPolyhedron: return 0;
  }
  return 0;
}

// Volume of the solid with dimensions d (layout in group.h).
double volume(ShapeType s, const Vec3& d) {
  switch (s) {
    case ShapeType::kSphere: return kPi / 6.0 * d[0] * d[0] * d[0];
    case ShapeType::kCuboid: return d[0] * d[1] * d[2];
    case ShapeType::kEllipsoid: return kPi / 6.0 * d[0] * d[1] * d[2];  // 4/3 pi (a/2)(b/2)(c/2)
    case ShapeType::kCylinder: return kPi / 4.0 * d[0] * d[0] * d[1];
    case ShapeType::kPoint:
    case ShapeType::kPolyhedron: return 0.0;  // not used (polyhedron_mass_properties)
  }
  return 0.0;
}

// Copies `v` (checked: right length, finite, > 0) into a Vec3; throws InputError naming `field`.
Vec3 checked_dims(ShapeType s, const std::vector<double>& v, const char* field) {
  const std::size_t n = dims_count(s);
  if (v.size() != n) {
    throw InputError(field, std::string("a ") + shape_type_name(s) + " needs " + std::to_string(n) +
                                (n == 1 ? " value" : " values"));
  }
  Vec3 d = Vec3::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    if (!std::isfinite(v[k]) || !(v[k] > 0.0)) {
      throw InputError(std::string(field) + "[" + std::to_string(k) + "]",
                       "must be a finite number > 0");
    }
    d[static_cast<Eigen::Index>(k)] = v[k];
  }
  return d;
}

// A polyhedron: the hull as given (scale 1; density mass / V0) or, with a density, scaled by
// s = cbrt(m / (rho V0)) about its centre of mass. Inertia = m / V s^2 J0, J0 the hull's principal
// moments per unit density (eq. P5: moments of a uniform solid scale as mass x length^2).
MassProperties polyhedron_mass_properties(const ShapeSpec& shape, double mass_kg,
                                          const std::optional<double>& area_override) {
  if (!shape.polyhedron)
    throw InputError("shape.vertices_m", "the hull is not built (fragments::polyhedron_shape)");
  const Polyhedron& p = *shape.polyhedron;
  MassProperties mp;
  mp.mass_kg = mass_kg;
  mp.polyhedron = shape.polyhedron;
  if (shape.density_kg_m3) {
    const double rho = *shape.density_kg_m3;
    if (!std::isfinite(rho) || !(rho > 0.0)) {
      throw InputError("shape.density_kg_m3", "must be a finite number > 0");
    }
    mp.scale = std::cbrt(mass_kg / (rho * p.volume_m3()));
  }
  const double s2 = mp.scale * mp.scale;
  mp.dims_m = 2.0 * mp.scale * p.half_extent_m();
  mp.inertia_kg_m2 = mass_kg / p.volume_m3() * s2 * p.inertia_m5();
  mp.surface_m2 = s2 * p.surface_m2();
  // Cauchy: exact for the (convex) hull.
  mp.presented_area_m2 = area_override ? *area_override : 0.25 * mp.surface_m2;
  return mp;
}

}  // namespace

const char* shape_type_name(ShapeType s) {
  switch (s) {
    case ShapeType::kSphere: return "sphere";
    case ShapeType::kCuboid: return "cuboid";
    case ShapeType::kEllipsoid: return "ellipsoid";
    case ShapeType::kCylinder: return "cylinder";
    case ShapeType::kPoint: return "point";
    case ShapeType::kPolyhedron: return "polyhedron";
  }
  return "unknown";
}

ShapeSpec polyhedron_shape(std::vector<Vec3> vertices_m, std::optional<double> density_kg_m3,
                           const std::string& field) {
  ShapeSpec s;
  s.type = ShapeType::kPolyhedron;
  s.polyhedron = Polyhedron::from_points(vertices_m, field);
  s.vertices_m = std::move(vertices_m);
  s.density_kg_m3 = density_kg_m3;
  return s;
}

double ellipsoid_surface_area(double a, double b, double c) {
  // DLMF 19.33.2: S = 4 pi abc R_G(a^-2, b^-2, c^-2). R_G is homogeneous of degree 1/2, so this
  // equals 4 pi R_G(b^2 c^2, c^2 a^2, a^2 b^2), which needs no division and stays finite for a
  // flat ellipsoid (c = 0 gives the two-sided disk 2 pi ab).
  const double a2 = a * a, b2 = b * b, c2 = c * c;
  return 4.0 * kPi * carlson_rg(b2 * c2, c2 * a2, a2 * b2);
}

MassProperties mass_properties(const ShapeSpec& shape, double mass_kg,
                               const std::optional<double>& area_override) {
  MassProperties mp;
  mp.mass_kg = mass_kg;
  const ShapeType s = shape.type;

  if (s == ShapeType::kPoint) {
    // No extent, no rotational inertia: the presented area must come from the group.
    if (!area_override) throw InputError("area_m2", "required for a point mass");
    mp.presented_area_m2 = *area_override;
    return mp;
  }
  if (s == ShapeType::kPolyhedron) return polyhedron_mass_properties(shape, mass_kg, area_override);

  // Resolve the size: fixed dims, or scaled to volume = mass / density with the given proportions.
  Vec3 d;
  if (!shape.dims_m.empty()) {
    d = checked_dims(s, shape.dims_m, "shape.dims_m");
  } else if (shape.density_kg_m3) {
    const double rho = *shape.density_kg_m3;
    if (!std::isfinite(rho) || !(rho > 0.0)) {
      throw InputError("shape.density_kg_m3", "must be a finite number > 0");
    }
    Vec3 aspect = Vec3::Zero();
    if (shape.aspect.empty()) {
      aspect.head(static_cast<Eigen::Index>(dims_count(s))).setOnes();
    } else {
      aspect = checked_dims(s, shape.aspect, "shape.aspect");
    }
    // volume(scale * aspect) = scale^3 volume(aspect).
    const double scale = std::cbrt(mass_kg / rho / volume(s, aspect));
    d = scale * aspect;
  } else {
    throw InputError("shape",
                     std::string("a ") + shape_type_name(s) + " needs dims_m or density_kg_m3");
  }
  mp.dims_m = d;

  // Principal moments of inertia about the centre of mass (standard results for uniform solids)
  // and exact surface areas.
  const double m = mass_kg;
  switch (s) {
    case ShapeType::kSphere: {
      const double r = 0.5 * d[0];
      mp.inertia_kg_m2.setConstant(0.4 * m * r * r);  // 2/5 m r^2
      mp.surface_m2 = 4.0 * kPi * r * r;
      break;
    }
    case ShapeType::kCuboid: {
      const double a2 = d[0] * d[0], b2 = d[1] * d[1], c2 = d[2] * d[2];
      mp.inertia_kg_m2 = Vec3(b2 + c2, a2 + c2, a2 + b2) * (m / 12.0);
      mp.surface_m2 = 2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0]);
      break;
    }
    case ShapeType::kEllipsoid: {
      const Vec3 semi = 0.5 * d;
      const double a2 = semi[0] * semi[0], b2 = semi[1] * semi[1], c2 = semi[2] * semi[2];
      mp.inertia_kg_m2 = Vec3(b2 + c2, a2 + c2, a2 + b2) * (m / 5.0);
      mp.surface_m2 = ellipsoid_surface_area(semi[0], semi[1], semi[2]);
      break;
    }
    case ShapeType::kCylinder: {
      const double r = 0.5 * d[0], len = d[1];
      const double transverse = m * (3.0 * r * r + len * len) / 12.0;
      mp.inertia_kg_m2 = Vec3(transverse, transverse, 0.5 * m * r * r);
      mp.surface_m2 = 2.0 * kPi * r * (r + len);
      break;
    }
    case ShapeType::kPoint:
    case ShapeType::kPolyhedron: break;
  }

  // Cauchy's surface-area formula: averaged over uniformly random orientations, the projected
  // area of a convex body is a quarter of its surface (docs/physics.md, "Reference formulas").
  mp.presented_area_m2 = area_override ? *area_override : 0.25 * mp.surface_m2;
  return mp;
}

}  // namespace fragsim::fragments
