// Shapes: ellipsoid surface area and mass properties of the uniform solids.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "core/common/error.h"
#include "core/fragments/sampling.h"

namespace fragsim::fragments {
namespace {

double rel_err(double got, double want) {
  return std::fabs(got - want) / std::fabs(want);
}

// Closed forms of spheroids with equatorial semi-axis a and polar semi-axis c.
double oblate_area(double a, double c) {  // c < a
  const double e = std::sqrt(1.0 - c * c / (a * a));
  return 2.0 * kPi * a * a * (1.0 + (1.0 - e * e) / e * std::atanh(e));
}
double prolate_area(double a, double c) {  // c > a
  const double e = std::sqrt(1.0 - a * a / (c * c));
  return 2.0 * kPi * a * a * (1.0 + c / (a * e) * std::asin(e));
}

TEST(EllipsoidSurfaceArea, SphereAndSpheroids) {
  // Sphere: 4 pi r^2 to 1e-14. Spheroids: closed forms to 1e-12 relative, in every axis order.
  EXPECT_NEAR(ellipsoid_surface_area(0.7, 0.7, 0.7), 4.0 * kPi * 0.49, 1e-14 * 4.0 * kPi * 0.49);
  double worst = 0.0;
  for (double ratio : {0.05, 0.3, 0.5, 0.9, 0.99, 1.01, 1.5, 2.0, 5.0, 20.0}) {
    const double a = 0.3, c = a * ratio;
    const double want = ratio < 1.0 ? oblate_area(a, c) : prolate_area(a, c);
    for (const auto& abc : {Vec3(a, a, c), Vec3(a, c, a), Vec3(c, a, a)}) {
      const double e = rel_err(ellipsoid_surface_area(abc[0], abc[1], abc[2]), want);
      worst = std::max(worst, e);
      EXPECT_LE(e, 1e-12) << "ratio " << ratio;
    }
  }
  std::printf("[ measured ] spheroid surface area worst relative error: %.3g\n", worst);
}

TEST(EllipsoidSurfaceArea, TriaxialAndFlat) {
  // Semi-axes (1, 2, 3): 48.882146302582059696 (mpmath R_G, confirmed by direct 2-D quadrature of
  // the surface element). Tolerance 1e-14 relative. A flat ellipsoid (c = 0) is a two-sided disk.
  const double s = ellipsoid_surface_area(1.0, 2.0, 3.0);
  EXPECT_NEAR(s, 48.882146302582059696, 1e-14 * 48.9);
  EXPECT_NEAR(ellipsoid_surface_area(3.0, 2.0, 1.0), s, 1e-14 * s);
  EXPECT_NEAR(ellipsoid_surface_area(0.1, 0.2, 0.3), 0.488821463025820596957, 1e-14 * 0.49);
  EXPECT_NEAR(ellipsoid_surface_area(3.0, 2.0, 0.0), 2.0 * kPi * 6.0, 1e-14 * 2.0 * kPi * 6.0);
  std::printf("[ measured ] ellipsoid (1,2,3) surface relative error: %.3g\n",
              rel_err(s, 48.882146302582059696));
}

ShapeSpec shape(ShapeType t, std::vector<double> dims) {
  ShapeSpec s;
  s.type = t;
  s.dims_m = std::move(dims);
  return s;
}

// Tolerance in the closed-form tests: 1e-14 relative (a handful of roundings per formula).
constexpr double kRel = 1e-14;

TEST(MassProperties, Sphere) {
  const double m = 2.0, d = 0.1, r = 0.05;
  const auto mp = mass_properties(shape(ShapeType::kSphere, {d}), m, std::nullopt);
  EXPECT_EQ(mp.mass_kg, m);
  EXPECT_EQ(mp.dims_m, Vec3(d, 0, 0));
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(mp.inertia_kg_m2[k], 0.4 * m * r * r, kRel * 0.4 * m * r * r);
  EXPECT_NEAR(mp.surface_m2, 4.0 * kPi * r * r, kRel * 4.0 * kPi * r * r);
  EXPECT_NEAR(mp.presented_area_m2, kPi * r * r, kRel * kPi * r * r);  // Cauchy: surface/4 = pi r^2
}

TEST(MassProperties, Cuboid) {
  const double m = 3.0, a = 0.1, b = 0.2, c = 0.3;
  const auto mp = mass_properties(shape(ShapeType::kCuboid, {a, b, c}), m, std::nullopt);
  const Vec3 want(m * (b * b + c * c) / 12, m * (a * a + c * c) / 12, m * (a * a + b * b) / 12);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(mp.inertia_kg_m2[k], want[k], kRel * want[k]);
  const double s = 2 * (a * b + b * c + c * a);
  EXPECT_NEAR(mp.surface_m2, s, kRel * s);
  EXPECT_NEAR(mp.presented_area_m2, s / 4, kRel * s);
}

TEST(MassProperties, Cylinder) {
  const double m = 5.0, d = 0.1, len = 0.4, r = 0.05;
  const auto mp = mass_properties(shape(ShapeType::kCylinder, {d, len}), m, std::nullopt);
  const double ix = m * (3 * r * r + len * len) / 12, iz = m * r * r / 2;  // axis = body z
  EXPECT_NEAR(mp.inertia_kg_m2[0], ix, kRel * ix);
  EXPECT_NEAR(mp.inertia_kg_m2[1], ix, kRel * ix);
  EXPECT_NEAR(mp.inertia_kg_m2[2], iz, kRel * iz);
  const double s = 2 * kPi * r * r + 2 * kPi * r * len;
  EXPECT_NEAR(mp.surface_m2, s, kRel * s);
  EXPECT_NEAR(mp.presented_area_m2, s / 4, kRel * s);
  EXPECT_EQ(mp.dims_m, Vec3(d, len, 0));
}

TEST(MassProperties, Ellipsoid) {
  // Full axes (0.2, 0.4, 0.6) = semi-axes (0.1, 0.2, 0.3): I_x = m (b^2 + c^2) / 5 etc.
  const double m = 1.5, a = 0.1, b = 0.2, c = 0.3;
  const auto mp = mass_properties(shape(ShapeType::kEllipsoid, {0.2, 0.4, 0.6}), m, std::nullopt);
  const Vec3 want(m * (b * b + c * c) / 5, m * (a * a + c * c) / 5, m * (a * a + b * b) / 5);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(mp.inertia_kg_m2[k], want[k], kRel * want[k]);
  EXPECT_NEAR(mp.surface_m2, 0.488821463025820596957, kRel * 0.49);
  EXPECT_NEAR(mp.presented_area_m2, 0.488821463025820596957 / 4, kRel * 0.49);
}

TEST(MassProperties, DensityScaledSizeReproducesVolume) {
  // Volume of the resolved size = mass / density to 1e-14, proportions as `aspect`.
  const double rho = 7850.0;
  for (double m : {1e-4, 0.02, 1.0, 37.5}) {
    const double v = m / rho;
    ShapeSpec s;
    s.density_kg_m3 = rho;

    s.type = ShapeType::kSphere;
    auto mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(kPi / 6 * std::pow(mp.dims_m[0], 3), v, kRel * v);
    EXPECT_NEAR(mp.inertia_kg_m2[0], 0.1 * m * mp.dims_m[0] * mp.dims_m[0],
                kRel * mp.inertia_kg_m2[0]);

    s.type = ShapeType::kCuboid;  // default aspect: a cube
    mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(mp.dims_m.prod(), v, kRel * v);
    EXPECT_NEAR(mp.dims_m[0], mp.dims_m[2], kRel * mp.dims_m[0]);
    s.aspect = {1, 2, 3};
    mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(mp.dims_m.prod(), v, kRel * v);
    EXPECT_NEAR(mp.dims_m[1] / mp.dims_m[0], 2.0, kRel);
    EXPECT_NEAR(mp.dims_m[2] / mp.dims_m[0], 3.0, kRel);

    s.type = ShapeType::kEllipsoid;
    mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(kPi / 6 * mp.dims_m.prod(), v, kRel * v);
    EXPECT_NEAR(mp.dims_m[2] / mp.dims_m[0], 3.0, kRel);

    s.type = ShapeType::kCylinder;
    s.aspect = {1, 4};  // L = 4 d
    mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(kPi / 4 * mp.dims_m[0] * mp.dims_m[0] * mp.dims_m[1], v, kRel * v);
    EXPECT_NEAR(mp.dims_m[1] / mp.dims_m[0], 4.0, kRel);
    EXPECT_EQ(mp.dims_m[2], 0.0);
    s.aspect.clear();  // default: L = d
    mp = mass_properties(s, m, std::nullopt);
    EXPECT_NEAR(mp.dims_m[1], mp.dims_m[0], kRel * mp.dims_m[0]);
    s.aspect.clear();
  }
}

TEST(MassProperties, FixedDimsTakeTheSampledMass) {
  // dims_m given: size fixed, mass as sampled (density implied), even if a density is also set.
  ShapeSpec s = shape(ShapeType::kSphere, {0.1});
  s.density_kg_m3 = 1000.0;
  const auto mp = mass_properties(s, 42.0, std::nullopt);
  EXPECT_EQ(mp.mass_kg, 42.0);
  EXPECT_EQ(mp.dims_m[0], 0.1);
}

TEST(MassProperties, AreaOverrideAndPoint) {
  const auto mp = mass_properties(shape(ShapeType::kCuboid, {1, 1, 1}), 1.0, 0.123);
  EXPECT_EQ(mp.presented_area_m2, 0.123);
  EXPECT_NEAR(mp.surface_m2, 6.0, 1e-15);  // the surface is still reported

  const auto pt = mass_properties(shape(ShapeType::kPoint, {}), 0.5, 0.01);
  EXPECT_EQ(pt.mass_kg, 0.5);
  EXPECT_EQ(pt.inertia_kg_m2, Vec3::Zero());
  EXPECT_EQ(pt.surface_m2, 0.0);
  EXPECT_EQ(pt.presented_area_m2, 0.01);
  try {
    mass_properties(shape(ShapeType::kPoint, {}), 0.5, std::nullopt);
    FAIL() << "point without area_m2 must throw";
  } catch (const InputError& e) {
    EXPECT_EQ(e.field(), "area_m2");
  }
}

TEST(MassProperties, MalformedShapesThrowNamingTheField) {
  const auto field_of = [](const ShapeSpec& s) -> std::string {
    try {
      mass_properties(s, 1.0, std::nullopt);
    } catch (const InputError& e) {
      return e.field();
    }
    return "(no throw)";
  };
  EXPECT_EQ(field_of(shape(ShapeType::kCuboid, {1, 2})), "shape.dims_m");
  EXPECT_EQ(field_of(shape(ShapeType::kCylinder, {1, -2})), "shape.dims_m[1]");
  EXPECT_EQ(field_of(shape(ShapeType::kSphere, {})), "shape");
  ShapeSpec s;
  s.type = ShapeType::kEllipsoid;
  s.density_kg_m3 = 0.0;
  EXPECT_EQ(field_of(s), "shape.density_kg_m3");
  s.density_kg_m3 = 1000.0;
  s.aspect = {1, 2};
  EXPECT_EQ(field_of(s), "shape.aspect");
}

TEST(ShapeTypeName, AllNames) {
  EXPECT_STREQ(shape_type_name(ShapeType::kSphere), "sphere");
  EXPECT_STREQ(shape_type_name(ShapeType::kCuboid), "cuboid");
  EXPECT_STREQ(shape_type_name(ShapeType::kEllipsoid), "ellipsoid");
  EXPECT_STREQ(shape_type_name(ShapeType::kCylinder), "cylinder");
  EXPECT_STREQ(shape_type_name(ShapeType::kPoint), "point");
}

}  // namespace
}  // namespace fragsim::fragments
