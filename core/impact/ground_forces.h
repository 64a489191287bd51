#pragma once
// The forces of the ground phase (ground_phase.h; docs/physics.md, "Ground phase", G1-G9): the
// load on a plane, Coulomb friction with its static branch, the loads of a crease, and the
// right-hand side the ground phase integrates. Internal to core/impact (ground_phase.cpp and its
// tests).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "core/common/types.h"
#include "core/flight/flight_model.h"

namespace fragsim::impact::ground {

using GVec = Eigen::Matrix<double, 9, 1>;  // displacement (3), velocity (3), w = R omega (3)

// Where the body touches the terrain.
struct Contact {
  bool crease = false;
  std::uint32_t tri = 0;    // face: the triangle; crease: the reference side (tallies)
  std::uint32_t other = 0;  // crease: the triangle across the edge
  Vec3 n{0, 0, 1};          // face: its unit normal; crease: the unit bisector of n1 and n2
  // Face: the motion stays on the straight line along `line_dir` (the pull along the plane is
  // along it and the air is still: every force is along the line), so only the components along
  // it are integrated. Off the line, friction at low speed turns the velocity at a rate
  // mu g / |v|: a stiff mode that rounding alone would excite (G3).
  bool line = false;
  Vec3 line_dir{1, 0, 0};
  Vec3 n1{0, 0, 1}, n2{0, 0, 1};
  Vec3 e{1, 0, 0};                       // crease: unit edge direction, from `from_v` to `to_v`
  Vec3 from_v{0, 0, 0}, to_v{0, 0, 0};   // crease: the edge's end points (local)
  std::uint32_t from_id = 0, to_id = 0;  // their vertex indices
};

// How the body resists motion on the current contact.
struct Resistance {
  bool round = false;
  bool slipping = false;    // round: the contact point slides (G4), else it rolls (G5)
  double mu = 0.0;          // Coulomb friction of the terrain
  double mu_r = 0.0;        // rolling resistance of the terrain
  double ratio = 0.4;       // round: I / (m R^2)
  Vec3 slip_dir0{0, 0, 0};  // round: slip direction while the slip speed is exactly 0
  // round, slipping: a skid (rolling could not be held, G6), in which the rolling resistance
  // torque brakes the spin as in rolling; a slip after an impact is Coulomb friction alone.
  bool skid = false;
};

// Normal load per mass and the tangential part of the external acceleration on a plane (G1).
struct PlaneLoad {
  Vec3 at;    // a_ext - (a_ext . n) n
  double nl;  // -(a_ext . n) if pressing, else 0
  double an;  // a_ext . n (> 0: the air lifts the body off)
};
inline PlaneLoad plane_load(const Vec3& a_ext, const Vec3& n) {
  const double an = a_ext.dot(n);
  return {a_ext - an * n, std::max(0.0, -an), an};
}

// Coulomb friction per mass of magnitude `cap` against the velocity (G2). At zero velocity it is
// static: it holds the body against `drive` if it can (|drive| <= cap), else it resists it with
// `cap` (the body starts moving along drive).
inline Vec3 friction_acceleration(const Vec3& v, const Vec3& drive, double cap) {
  const double s = v.norm();
  if (s > 0.0) return -(cap / s) * v;
  const double d = drive.norm();
  if (d <= cap || !(d > 0.0)) return -drive;
  return -(cap / d) * drive;
}

// Normal loads per mass (N1, N2) of the two planes of a crease against the external acceleration
// across the edge (G8): N1 n1 + N2 n2 = -(a_ext - (a_ext . e) e).
inline Vec2 crease_loads(const Contact& c, const Vec3& a_ext) {
  const Vec3 a_perp = a_ext - a_ext.dot(c.e) * c.e;
  const Vec3 b2 = c.e.cross(c.n1);  // unit: e is perpendicular to n1
  const double x2 = c.n2.dot(b2);
  if (std::abs(x2) < 1e-12) return Vec2(-a_perp.dot(c.n1), 0.0);  // planes (nearly) parallel
  const double n2_load = -a_perp.dot(b2) / x2;
  return Vec2(-a_perp.dot(c.n1) - n2_load * c.n2.dot(c.n1), n2_load);
}

// Acceleration of the centre and rate of w = R omega on the current contact (G2-G9).
struct GroundRhs {
  const flight::FlightModel* air = nullptr;
  const Contact* contact = nullptr;
  const Resistance* res = nullptr;
  const Vec3* origin = nullptr;  // position = *origin + displacement

  GVec operator()(double /*t*/, const GVec& y) const {
    const Vec3 v = y.segment<3>(3), w = y.segment<3>(6);
    const Vec3 a_ext = air->acceleration(*origin + y.head<3>(), v);
    Vec3 a, dw = Vec3::Zero();
    if (contact->crease) {
      a = crease_acceleration(a_ext, v);
      if (res->round) dw = contact->n.cross(a);
    } else {
      face_acceleration(a_ext, v, w, a, dw);
    }
    GVec dy;
    dy << v, a, dw;
    return dy;
  }

  void face_acceleration(const Vec3& a_ext, const Vec3& v, const Vec3& w, Vec3& a, Vec3& dw) const {
    const Vec3& n = contact->n;
    const PlaneLoad load = plane_load(a_ext, n);
    // The velocity along the plane (or the line): friction never sees a normal part that
    // rounding left in v.
    Vec3 vt = v - v.dot(n) * n, drive = load.at;
    if (contact->line) {
      const Vec3& d = contact->line_dir;
      vt = v.dot(d) * d;
      drive = load.at.dot(d) * d;
    }
    if (!res->round) {  // G2: sliding
      a = drive + friction_acceleration(vt, drive, res->mu * load.nl);
      return;
    }
    if (!res->slipping) {  // G5: rolling, k = 1 / (1 + I / (m R^2))
      const double k = 1.0 / (1.0 + res->ratio);
      a = k * (drive + friction_acceleration(vt, drive, res->mu_r * load.nl));
      dw = n.cross(a);
      return;
    }
    // G4: slipping; the friction acts at the contact point, against its velocity u = v - w x n.
    // In a skid also the rolling resistance torque mu_r N R against the rolling part of the spin
    // (static while that part is zero: the friction torque must exceed it to turn the ball).
    const Vec3 u = vt - w.cross(n);
    const double us = u.norm();
    const Vec3 uh = us > 0.0 ? Vec3(u / us) : res->slip_dir0;
    const Vec3 fr = -res->mu * load.nl * uh;
    a = load.at + fr;
    dw = -(1.0 / res->ratio) * n.cross(fr);
    if (res->skid) {
      const Vec3 w_rolling = w - w.dot(n) * n;
      dw += friction_acceleration(w_rolling, dw, res->mu_r * load.nl / res->ratio);
    }
  }

  // G9: along the crease line, friction from both planes' loads.
  Vec3 crease_acceleration(const Vec3& a_ext, const Vec3& v) const {
    const Contact& c = *contact;
    const Vec2 loads = crease_loads(c, a_ext);
    const double nl = std::max(0.0, loads.x()) + std::max(0.0, loads.y());
    const double cap = (res->round ? res->mu_r : res->mu) * nl;
    const double ae = a_ext.dot(c.e), s = v.dot(c.e);
    double fr;
    if (s != 0.0) {
      fr = s > 0.0 ? -cap : cap;
    } else {
      fr = std::abs(ae) <= cap ? -ae : (ae > 0.0 ? -cap : cap);
    }
    const double k = res->round ? 1.0 / (1.0 + res->ratio) : 1.0;
    return (k * (ae + fr)) * c.e;
  }
};

}  // namespace fragsim::impact::ground
