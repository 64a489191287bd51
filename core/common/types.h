#pragma once
// Basic numeric types shared by every core module. SI units everywhere inside the core.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <limits>

namespace fragsim {

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kDegToRad = kPi / 180.0;
inline constexpr double kStandardGravity_mps2 = 9.80665;  // CGPM 1901 / ISO 80000-3

// Axis-aligned box in 3-D.
struct Box3 {
  Vec3 lo{Vec3::Constant(std::numeric_limits<double>::infinity())};
  Vec3 hi{Vec3::Constant(-std::numeric_limits<double>::infinity())};
  void extend(const Vec3& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  void extend(const Box3& b) {
    lo = lo.cwiseMin(b.lo);
    hi = hi.cwiseMax(b.hi);
  }
  bool empty() const { return !(lo.x() <= hi.x()); }
  bool contains_xy(double x, double y) const {
    return x >= lo.x() && x <= hi.x() && y >= lo.y() && y <= hi.y();
  }
};

}  // namespace fragsim
