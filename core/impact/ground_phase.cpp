// The ground phase (ground_phase.h; equations G1-G14 in docs/physics.md, "Ground phase").
#include "core/impact/ground_phase.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/roots.h"
#include "core/flight/dopri5.h"
#include "core/impact/bounce.h"
#include "core/impact/fast_contact.h"
#include "core/impact/ground_forces.h"
#include "core/impact/terrain_edges.h"

namespace fragsim::impact {

double ground_clearance(const GroundBody& body, const Quat& q, const Vec3& n) {
  return fragments::support_extent(body.shape, q, -n);
}

namespace {

using ground::Contact;
using ground::crease_loads;
using ground::friction_acceleration;
using ground::GroundRhs;
using ground::GVec;
using ground::plane_load;
using ground::PlaneLoad;
using ground::Resistance;
using ground::TriangleEdges;

enum class Next { kContinue, kDone, kNoChange };

// No edge: a crossing at a vertex (arrive_at_vertex).
constexpr std::uint32_t kNoVertex = std::numeric_limits<std::uint32_t>::max();

// A slip slower than this fraction of the speed has ended: the sticking impulse that removes it
// changes the velocity by 2/7 of it (G7).
constexpr double kSlipEnd_rel = 1e-6;

class GroundMotion {
 public:
  GroundMotion(const scene::Site& site, const flight::FlightModel& air, const GroundBody& body,
               const GroundSettings& settings, GroundObserver& observer)
      : site_(site),
        air_(air),
        body_(body),
        set_(settings),
        obs_(observer),
        material_(&site.materials()[site.terrain_material()]),
        ode_(GroundRhs{&air_, &contact_, &res_, &origin_},
             flight::Dopri5Options{settings.rtol, settings.rtol}) {
    res_.round = body.round();
    res_.mu = material_->friction;
    res_.mu_r = material_->rolling_resistance;
    radius_m_ = res_.round ? body.shape.half_m.x() : 0.0;
    if (res_.round)
      res_.ratio = body.shape.inertia_kg_m2.x() / (body.mass_kg * radius_m_ * radius_m_);
    const auto& cell = site.terrain_index().cell;
    nudge_m_ = 1e-7 * std::max(1e-3, std::min(cell.x(), cell.y()));
    g_ = air.gravity_mps2;
    still_air_ = air.atmosphere == nullptr || air.atmosphere->wind().squaredNorm() == 0.0;
  }

  GroundResult run(const GroundState& start);

 private:
  // Entering a contact.
  Next enter_face(std::uint32_t tri, const Vec3& p, const Vec3& v, const Vec3& omega);
  Next settle_on_face(std::uint32_t tri, const Vec3& p, const Vec3& v, const Vec3& omega);
  bool fast(const Vec3& v) const { return v.norm() >= material_->fast_contact_speed_mps(); }
  void use_material_of(std::uint32_t tri);
  Next fast_contact_on(std::uint32_t tri, const Vec3& p, const Vec3& v, const Vec3& omega);
  Next enter_crease(std::uint32_t tri, std::uint32_t other, std::uint32_t from_id,
                    std::uint32_t to_id, const Vec3& p, const Vec3& v, const Vec3& w);
  void restart_integrator(const Vec3& p, const Vec3& v, const Vec3& w);
  void set_presented_area(const Vec3& v);
  void choose_line();
  void settle_rolling_or_slipping(bool stick = false);
  // One integrator step and the events within it.
  Next step();
  struct Exit {
    double t;
    int edge;  // -1: none
  };
  Exit find_exit(double ta, double tb) const;
  Next walk_face_step();
  Next walk_crease_step();
  Next after_step();
  Next after_slip_step(const GVec& y0);
  bool slipping() const { return res_.round && res_.slipping && !contact_.crease; }
  double step_end_time() const;
  // Events.
  Next cross_edge(std::uint32_t next, std::uint32_t from_id, std::uint32_t to_id);
  Next edge_impact(std::uint32_t next, const Vec3& v_in, bool concave, std::uint32_t from_id,
                   std::uint32_t to_id);
  Next arrive_at_vertex(std::uint32_t vertex);
  Next stop_or_restart(double residual_dt = 0.0);
  bool advance_closed_form(double dt, const Vec3& a, const Vec3& dw);
  Next settle_in_contact_set();
  Next finish(GroundEnd end);
  Next take_off(std::uint32_t tri, const Vec3& v, const Vec3& omega);
  bool captured_in_crease(std::uint32_t next, std::uint32_t from_id, std::uint32_t to_id,
                          const Vec3& v2) const;
  bool vertex_is_local_min(std::uint32_t vertex) const;
  // State along the current step.
  Vec3 pos(double t) const { return origin_ + ode_.dense(t).head<3>(); }
  Vec3 vel(double t) const { return ode_.dense(t).segment<3>(3); }
  Vec3 w_at(double t) const { return ode_.dense(t).segment<3>(6); }
  Vec3 omega_of(const Vec3& w) const { return res_.round ? Vec3(w / radius_m_) : Vec3::Zero(); }
  void set_state(double t, const Vec3& p, const Vec3& v, const Vec3& w) {
    t_ = t;
    p_ = p;
    v_ = v;
    w_ = w;
  }
  bool emit(double ta, const Vec3& pa, const Vec3& va, double tb, const Vec3& pb, const Vec3& vb,
            const Vec3& wb);
  Vec3 place_on_plane(const Vec3& p, std::uint32_t tri, const Vec3& n) const;
  Vec3 lift_to(const Vec3& p_old, const Vec3& p_new);
  void turn_with_terrain(const Vec3& from, const Vec3& to);
  TriangleEdges edges_of(std::uint32_t tri) const { return ground::edges_of(site_, tri); }
  std::int64_t triangle_beyond(const Vec3& p, const Vec3& dir) const;
  double kinetic_per_mass(const Vec3& v, const Vec3& w) const {
    return 0.5 * v.squaredNorm() + (res_.round ? 0.5 * res_.ratio * w.squaredNorm() : 0.0);
  }

  // Private Members
  const scene::Site& site_;
  flight::FlightModel air_;
  const GroundBody& body_;
  GroundSettings set_;
  GroundObserver& obs_;
  const scene::Material* material_;  // of the triangle in contact (use_material_of)
  Contact contact_;
  Resistance res_;
  Vec3 origin_{0, 0, 0};       // position at the last integrator reset
  Quat q_ = Quat::Identity();  // attitude (sliders: turned with the terrain)
  flight::Dopri5<9, GroundRhs> ode_;
  TriangleEdges edges_{};
  double radius_m_ = 0.0, nudge_m_ = 1e-7, g_ = kStandardGravity_mps2;
  double h_next_ = 0.0;  // step size carried across resets
  bool still_air_ = true;
  // Current state (valid between steps and at events).
  double t_ = 0.0;
  Vec3 p_{0, 0, 0}, v_{0, 0, 0}, w_{0, 0, 0};
  GroundResult r_;
};

GroundResult GroundMotion::run(const GroundState& start) {
  r_ = GroundResult{};
  t_ = start.t_s;
  q_ = body_.attitude;
  contact_.n = site_.terrain_triangle_normal(start.triangle);  // no turn on the first face
  Next next = enter_face(start.triangle, start.position_m, start.velocity_mps, start.omega_radps);
  while (next == Next::kContinue) {
    if (r_.steps >= set_.max_steps) {
      finish(GroundEnd::kStepCap);
      break;
    }
    next = step();
  }
  return r_;
}

Next GroundMotion::finish(GroundEnd end) {
  r_.end = end;
  r_.state.t_s = t_;
  r_.state.position_m = p_;
  r_.state.velocity_mps = end == GroundEnd::kRest ? Vec3::Zero() : v_;
  r_.state.omega_radps = end == GroundEnd::kRest ? Vec3::Zero() : omega_of(w_);
  r_.state.triangle = contact_.tri;
  r_.state.attitude = q_;
  return Next::kDone;
}

Next GroundMotion::take_off(std::uint32_t tri, const Vec3& v, const Vec3& omega) {
  r_.end = GroundEnd::kTakeOff;
  r_.state = {t_, p_, v, omega, tri, q_};
  return Next::kDone;
}

// ---- entering a contact ----

// The law of the material under triangle tri (a zone's) from here on: friction and rolling
// resistance of the slide, restitution of an impulse, the fast-contact constants.
void GroundMotion::use_material_of(std::uint32_t tri) {
  material_ = &site_.materials()[site_.terrain_triangle_material(tri)];
  res_.mu = material_->friction;
  res_.mu_r = material_->rolling_resistance;
}

// The centre put at the body's clearance above triangle tri's plane (normal n), moved
// vertically: its xy stays on the triangle it was found over (on the edge it crossed).
Vec3 GroundMotion::place_on_plane(const Vec3& p, std::uint32_t tri, const Vec3& n) const {
  const double clearance = ground_clearance(body_, q_, n);
  return Vec3(p.x(), p.y(), site_.terrain_plane_height(tri, p.x(), p.y()) + clearance / n.z());
}

// Raising the centre costs kinetic energy (G11): energy is never gained by a change of contact.
// A lift the kinetic energy cannot pay is not made in full: the body then sits lower than its
// clearance (overlapping the plane by the difference, at most its bounding radius). Returns
// where the centre goes.
Vec3 GroundMotion::lift_to(const Vec3& p_old, const Vec3& p_new) {
  const double dz = p_new.z() - p_old.z();
  if (!(dz > 0.0)) return p_new;
  const double ke = kinetic_per_mass(v_, w_);
  const double paid = std::min(dz, ke / g_);
  const double scale = ke > 0.0 ? std::sqrt(std::max(0.0, 1.0 - g_ * paid / ke)) : 0.0;
  v_ *= scale;
  w_ *= scale;
  return Vec3(p_new.x(), p_new.y(), p_old.z() + paid);
}

// A slider turned with the terrain from the plane of normal `from` to that of `to` (G11).
void GroundMotion::turn_with_terrain(const Vec3& from, const Vec3& to) {
  if (!res_.round) q_ = (Quat::FromTwoVectors(from, to) * q_).normalized();
}

// Onto triangle tri: a fast contact if the material has that law and the body is at least its
// switch speed fast (F6), else the body settles on the face.
Next GroundMotion::enter_face(std::uint32_t tri, const Vec3& p, const Vec3& v, const Vec3& omega) {
  use_material_of(tri);
  if (fast(v)) return fast_contact_on(tri, p, v, omega);
  return settle_on_face(tri, p, v, omega);
}

// F6: a contact at least v_s fast is no slide: it embeds, or it ricochets and leaves the ground
// (F5 makes it leave while it keeps v_s), or, slowed below v_s, it goes on along the face.
Next GroundMotion::fast_contact_on(std::uint32_t tri, const Vec3& p, const Vec3& v,
                                   const Vec3& omega) {
  const Vec3& n = site_.terrain_triangle_normal(tri);
  const FastContactOutcome f = fast_contact(*material_->fast_contact, body_.density_kg_m3, v, omega,
                                            n, set_.takeoff_speed_mps);
  ++r_.fast_contacts;
  p_ = p;
  contact_.tri = tri;
  if (f.end != FastContactEnd::kRicochet) return finish(GroundEnd::kEmbedded);
  ++r_.impacts;
  obs_.on_impact({t_, p, v, f.velocity_mps, omega, f.omega_radps, tri, q_});
  if (f.velocity_mps.dot(n) >= set_.takeoff_speed_mps)
    return take_off(tri, f.velocity_mps, f.omega_radps);
  return settle_on_face(tri, p, f.velocity_mps, f.omega_radps);
}

Next GroundMotion::settle_on_face(std::uint32_t tri, const Vec3& p, const Vec3& v,
                                  const Vec3& omega) {
  const Vec3 n_before = contact_.n;
  contact_ = Contact{};
  contact_.tri = tri;
  contact_.n = site_.terrain_triangle_normal(tri);
  const Vec3& n = contact_.n;
  turn_with_terrain(n_before, n);
  // A slider topples onto the face it stands over (G13). Its centre drops (the potential energy
  // is dissipated, not turned into speed); that rule never raises it, and lift_to would pay a
  // rise from the kinetic energy if it did.
  if (!res_.round) q_ = fragments::toppled_attitude(body_.shape, q_, n);
  v_ = v - v.dot(n) * n;
  w_ = res_.round ? Vec3(radius_m_ * omega) : Vec3::Zero();
  p_ = lift_to(p, place_on_plane(p, tri, n));
  edges_ = edges_of(tri);
  if (res_.round) settle_rolling_or_slipping();
  if (v_.squaredNorm() == 0.0 && !(res_.round && res_.slipping)) return stop_or_restart();
  if (v_.squaredNorm() < 2.0 * g_ * kCaptureHeight_m) {  // slow: held where several planes meet?
    const Next held = settle_in_contact_set();
    if (held != Next::kNoChange) return held;
  }
  restart_integrator(p_, v_, w_);
  return Next::kContinue;
}

// Round bodies: rolling if the contact point is (to rounding) at rest and rolling can be
// sustained (G6: the friction rolling needs is within mu N), else slipping.
void GroundMotion::settle_rolling_or_slipping(bool stick) {
  const Vec3& n = contact_.n;
  const Vec3 u = v_ - w_.cross(n);
  const double scale = v_.norm() + w_.norm();
  res_.slipping = !stick && u.norm() > 1e-9 * scale;
  res_.skid = false;
  if (res_.slipping) return;
  // Stick exactly: a tangential impulse at the contact that zeroes u (G7; dissipative).
  const Vec3 u_t = u - u.dot(n) * n;
  v_ -= (res_.ratio / (1.0 + res_.ratio)) * u_t;
  w_ += (1.0 / (1.0 + res_.ratio)) * n.cross(u_t);
  // Can rolling be held? Required friction per mass: -ratio a - mu_r nl v_hat (G6).
  const PlaneLoad load = plane_load(air_.acceleration(p_, v_), n);
  const double k = 1.0 / (1.0 + res_.ratio);
  const Vec3 rr = friction_acceleration(v_, load.at, res_.mu_r * load.nl);
  const Vec3 a = k * (load.at + rr);
  const Vec3 f_req = -res_.ratio * a + rr;
  if (f_req.norm() > res_.mu * load.nl) {
    res_.slipping = true;
    res_.skid = true;
    const double fn = f_req.norm();
    res_.slip_dir0 = fn > 0.0 ? Vec3(-f_req / fn) : Vec3::Zero();
  }
}

// On a face in still air a body moving along the pull of the plane (gravity along it; or on
// level ground in any direction), or starting from rest, stays on that straight line: every
// force is along it. Then only the line is integrated (G3).
void GroundMotion::choose_line() {
  contact_.line = false;
  if (contact_.crease || slipping() || !still_air_) return;
  const Vec3& n = contact_.n;
  const Vec3 at = plane_load(air_.acceleration(p_, v_), n).at;
  const Vec3 vt = v_ - v_.dot(n) * n;
  const double s = vt.norm(), pull = at.norm();
  Vec3 d;
  if (s > 0.0) {
    d = vt / s;
    if ((at - at.dot(d) * d).norm() > 1e-12 * std::max(pull, g_)) return;  // turns
  } else if (pull > 0.0) {
    d = at / pull;
  } else {
    return;
  }
  contact_.line = true;
  contact_.line_dir = d;
}

void GroundMotion::restart_integrator(const Vec3& p, const Vec3& v, const Vec3& w) {
  set_presented_area(v);
  choose_line();
  origin_ = p;
  GVec y;
  y << Vec3::Zero(), v, w;
  ode_.reset(t_, y, h_next_);
}

// A slider does not tumble on the ground: the air meets its projection along the air-relative
// velocity at its ground attitude (G14), held until the next restart. Spheres keep the flight's
// area (the same pi r^2, or a given area_m2); a body at rest relative to the air keeps its area.
void GroundMotion::set_presented_area(const Vec3& v) {
  if (res_.round || air_.area_m2 == 0.0) return;  // vacuum stays vacuum
  const Vec3 v_rel = air_.atmosphere == nullptr ? v : Vec3(v - air_.atmosphere->wind());
  const double s = v_rel.norm();
  if (s > 0.0) air_.area_m2 = fragments::projected_area(body_.shape, q_, v_rel / s);
}

Next GroundMotion::enter_crease(std::uint32_t tri, std::uint32_t other, std::uint32_t from_id,
                                std::uint32_t to_id, const Vec3& p, const Vec3& v, const Vec3& w) {
  use_material_of(tri);  // between two materials: the reference side's (docs/physics.md, G15)
  const auto& vs = site_.terrain_vertices();
  Contact c;
  c.crease = true;
  c.tri = tri;
  c.other = other;
  c.n1 = site_.terrain_triangle_normal(tri);
  c.n2 = site_.terrain_triangle_normal(other);
  c.n = (c.n1 + c.n2).normalized();
  c.from_id = from_id;
  c.to_id = to_id;
  c.from_v = vs[from_id];
  c.to_v = vs[to_id];
  c.e = (c.to_v - c.from_v).normalized();
  if (v.dot(c.e) < 0.0) {  // e along the motion
    std::swap(c.from_v, c.to_v);
    std::swap(c.from_id, c.to_id);
    c.e = -c.e;
  }
  turn_with_terrain(contact_.n, c.n);
  contact_ = c;
  // Centre at both clearances, its position along the edge kept (G8).
  const double c1 = ground_clearance(body_, q_, c.n1), c2 = ground_clearance(body_, q_, c.n2);
  const Vec3 b2 = c.e.cross(c.n1);
  const double beta = (c2 - c1 * c.n1.dot(c.n2)) / c.n2.dot(b2);
  const Vec3 p_on = c.from_v + (p - c.from_v).dot(c.e) * c.e + c1 * c.n1 + beta * b2;
  // Velocity along the crease; a round body rolls along it with no gain of kinetic energy.
  const double ke_before = kinetic_per_mass(v, w);
  v_ = v.dot(c.e) * c.e;
  w_ = res_.round ? Vec3(c.n.cross(v_)) : Vec3::Zero();
  res_.slipping = false;
  const double ke_after = kinetic_per_mass(v_, w_);
  if (ke_after > ke_before && ke_after > 0.0) {
    const double s = std::sqrt(ke_before / ke_after);
    v_ *= s;
    w_ *= s;
  }
  p_ = lift_to(p, p_on);
  if (v_.squaredNorm() == 0.0 && !(res_.round && res_.slipping)) return stop_or_restart();
  restart_integrator(p_, v_, w_);
  return Next::kContinue;
}

// ---- stepping ----

// The step may not pass the time limit, the stop of the centre (the friction direction flips
// there: G10) nor, slipping, the end of the slip or of the spin (the law changes there).
double GroundMotion::step_end_time() const {
  // A hair short of the time x reaches zero at its present rate of decrease (inf if growing).
  const auto before_zero = [](const Vec3& x, const Vec3& dx) {
    const double s = x.norm();
    const double dec = s > 0.0 ? -dx.dot(x) / s : 0.0;
    return dec > 0.0 ? (1.0 - 1e-3) * s / dec : std::numeric_limits<double>::infinity();
  };
  const GVec& dy = ode_.dy();
  const Vec3 a = dy.segment<3>(3), dw = dy.segment<3>(6);
  if (!slipping()) {
    // A slide or roll off a straight line closes in on its stop geometrically (G10): the pull
    // across the motion turns the velocity at a rate ~ 1/|v|, so no step reaches the stop. A step
    // to its predicted time is rejected and retaken at ~0.4 of it (0.47 rejected attempts per step
    // on the demo with rigid soil); half the way at once is the same approach without them.
    const double fraction = contact_.line || contact_.crease ? 1.0 : kCurvedStopStepFraction;
    return std::min(set_.t_max_s, t_ + fraction * before_zero(v_, a));
  }
  // The end of a slip (G7) likewise, when the slip's rate of change is not along it (it turns as
  // it ends); a straight one keeps the exact prediction (level ground: slip then roll, G7).
  const Vec3& n = contact_.n;
  const Vec3 u = v_ - w_.cross(n), du = a - dw.cross(n);
  const bool turning = u.cross(du).norm() > 1e-3 * u.norm() * du.norm();
  const double t_slip = (turning ? kCurvedStopStepFraction : 1.0) * before_zero(u, du);
  // Only a skid's spin has a kink at zero (the rolling resistance torque flips there).
  const double t_spin = res_.skid ? before_zero(w_ - w_.dot(n) * n, dw - dw.dot(n) * n)
                                  : std::numeric_limits<double>::infinity();
  return std::min(set_.t_max_s, t_ + std::min(t_slip, t_spin));
}

Next GroundMotion::step() {
  const double t_end = step_end_time();
  if (!(t_end > t_)) return finish(GroundEnd::kMaxTime);
  if (t_end < set_.t_max_s && t_end - t_ <= 1e-12 * std::max(1.0, std::abs(t_))) {
    // A kink (stop, end of slip) so close that no step fits before it: it is now.
    ++r_.steps;
    if (!slipping()) return stop_or_restart();
    const Vec3& n = contact_.n;
    if (res_.skid) w_ = w_.dot(n) * n;  // the skidding ball stops turning
    settle_rolling_or_slipping(/*stick=*/!res_.skid);
    restart_integrator(p_, v_, w_);
    return Next::kContinue;
  }
  ++r_.steps;
  if (!ode_.step(t_end))
    return finish(t_ >= set_.t_max_s ? GroundEnd::kMaxTime : GroundEnd::kStepCap);
  h_next_ = ode_.next_step_size();
  const Next n = contact_.crease ? walk_crease_step() : walk_face_step();
  if (n == Next::kDone) return n;
  return after_step();
}

bool GroundMotion::emit(double ta, const Vec3& pa, const Vec3& va, double tb, const Vec3& pb,
                        const Vec3& vb, const Vec3& wb) {
  const std::uint32_t tri = contact_.tri;
  GroundSegment s;
  s.a = pa;
  s.b = pb;
  s.ta = ta;
  s.tb = tb;
  s.va = va;
  s.vb = vb;
  s.omega_b = omega_of(wb);
  s.triangle = tri;
  s.ha = pa.z() - site_.terrain_plane_height(tri, pa.x(), pa.y());
  s.hb = pb.z() - site_.terrain_plane_height(tri, pb.x(), pb.y());
  r_.path_m += (pb - pa).norm();
  if (fast(va)) ++r_.fast_slides;  // F6 forbids it: counted, never expected
  return obs_.on_segment(s);
}

// Where the path leaves the current triangle within (ta, tb] (edge_of = -1: it stays). Edge by
// edge: a sign change of phi_k (at the end, or halfway for a path that left and came back) is
// located with the Illinois method; an edge the path starts on (phi_k(ta) >= 0, up to rounding)
// is the one it came in by when it moves inward, an exit at once when it moves outward (a corner).
GroundMotion::Exit GroundMotion::find_exit(double ta, double tb) const {
  Exit best{tb, -1};
  // Along the step, phi_k is a polynomial in theta = (t - t0) / h (the dense output projected on
  // the edge's normal): five numbers per edge, a few flops per evaluation.
  const auto dc = ode_.dense_coefficients();
  const auto theta = [&](double t) { return dc.h > 0.0 ? (t - dc.t0) / dc.h : 1.0; };
  const Vec3 va = vel(ta);
  for (int k = 0; k < 3; ++k) {
    const Vec2& nk = edges_.normal[k];
    const auto dot = [&](const GVec& y) { return nk.x() * y[0] + nk.y() * y[1]; };
    const double c0 = nk.x() * origin_.x() + nk.y() * origin_.y() - edges_.offset[k] + dot(dc.y0);
    const double c2 = dot(dc.r2), c3 = dot(dc.r3), c4 = dot(dc.r4), c5 = dot(dc.r5);
    const auto phi = [&](double t) {
      const double th = theta(t), th1 = 1.0 - th;
      return c0 + th * (c2 + th1 * (c3 + th * (c4 + th1 * c5)));
    };
    const double fa = phi(ta), fb = phi(tb), fm = phi(0.5 * (ta + tb));
    double lo = ta, f_lo = fa, hi, f_hi;
    if (fa >= 0.0) {
      if (edges_.rate_k(k, va) > 0.0) return {ta, k};  // leaving through it right away
      if (!(fm < 0.0 && fb > 0.0)) continue;           // the way in; it does not come back to it
      lo = 0.5 * (ta + tb);
      f_lo = fm;
      hi = tb;
      f_hi = fb;
    } else if (fm > 0.0) {
      hi = 0.5 * (ta + tb);
      f_hi = fm;
    } else if (fb > 0.0) {
      hi = tb;
      f_hi = fb;
    } else {
      continue;
    }
    if (!(lo < best.t)) continue;
    const double t_x = illinois(phi, lo, hi, f_lo, f_hi, 1e-13).hi;
    if (t_x < best.t || best.edge < 0) best = {t_x, k};
  }
  return best;
}

// The accepted step, walked triangle by triangle: a step may cross edges between coplanar
// triangles (a plane terrain) without a restart; at the first edge to a plane of another slope it
// is cut (on the dense output) and the edge event handled.
Next GroundMotion::walk_face_step() {
  double ta = ode_.t_prev();
  const double tb = ode_.t();
  Vec3 pa = p_, va = v_;
  for (;;) {
    Exit ex = find_exit(ta, tb);
    if (ex.edge < 0) {
      const Vec3 pb = pos(tb), vb = vel(tb), wb = w_at(tb);
      set_state(tb, pb, vb, wb);
      return emit(ta, pa, va, tb, pb, vb, wb) ? finish(GroundEnd::kStoppedByObserver)
                                              : Next::kContinue;
    }
    // At least a nudge of progress past an edge (rounding can leave an edge point a hair
    // inside its triangle).
    const double speed = va.norm();
    if (speed > 0.0) ex.t = std::min(tb, std::max(ex.t, ta + nudge_m_ / speed));
    const int k = ex.edge;
    const Vec3 px = pos(ex.t), vx = vel(ex.t), wx = w_at(ex.t);
    set_state(ex.t, px, vx, wx);
    if (emit(ta, pa, va, ex.t, px, vx, wx)) return finish(GroundEnd::kStoppedByObserver);
    std::int64_t next = edges_.across[k];
    if (next == -2) next = triangle_beyond(px, vx);
    if (next < 0) return finish(GroundEnd::kLeftSite);
    const auto t2 = static_cast<std::uint32_t>(next);
    obs_.prefetch(t2);
    site_.prefetch_terrain_triangle(t2);
    const Vec3& n2 = site_.terrain_triangle_normal(t2);
    if ((n2 - contact_.n).squaredNorm() > 1e-24)
      return cross_edge(t2, edges_.from[k], edges_.to[k]);
    // Coplanar into another material (a zone boundary): the body enters the face anew under its
    // law, at the boundary.
    if (site_.terrain_triangle_material(t2) != site_.terrain_triangle_material(contact_.tri))
      return enter_face(t2, p_, v_, omega_of(w_));
    // Coplanar: the same law continues; walk on with the same step.
    contact_.tri = t2;
    edges_ = edges_of(t2);
    ta = ex.t;
    pa = px;
    va = vx;
    if (!(ta < tb)) return Next::kContinue;
  }
}

// Crease mode: the centre moves along the edge line; the event is reaching its end.
Next GroundMotion::walk_crease_step() {
  const double ta = ode_.t_prev(), tb = ode_.t();
  const Vec3 pa = p_, va = v_;
  const Contact& c = contact_;
  // Moving toward to_v (e oriented with the motion at entry) or back toward from_v.
  const bool forward = (va.norm() > 0.0 ? va.dot(c.e) : vel(tb).dot(c.e)) >= 0.0;
  const Vec3 end = forward ? c.to_v : c.from_v;
  const double sign = forward ? 1.0 : -1.0;
  const auto psi = [&](double t) { return sign * (pos(t) - end).dot(c.e); };
  const double f_b = psi(tb);
  if (!(f_b > 0.0)) {
    const Vec3 pb = pos(tb), vb = vel(tb), wb = w_at(tb);
    set_state(tb, pb, vb, wb);
    return emit(ta, pa, va, tb, pb, vb, wb) ? finish(GroundEnd::kStoppedByObserver)
                                            : Next::kContinue;
  }
  const double f_a = std::min(0.0, psi(ta));
  const double t_x = f_a == 0.0 ? ta : illinois(psi, ta, tb, f_a, f_b, 1e-13).hi;
  const Vec3 px = pos(t_x), vx = vel(t_x), wx = w_at(t_x);
  set_state(t_x, px, vx, wx);
  if (emit(ta, pa, va, t_x, px, vx, wx)) return finish(GroundEnd::kStoppedByObserver);
  return arrive_at_vertex(forward ? c.to_id : c.from_id);
}

// After a step that stayed on its contact: the air lifting the body off, a contact point that
// stopped slipping, the centre stopping, the time limit.
Next GroundMotion::after_step() {
  if (fast(v_)) return fast_contact_on(contact_.tri, p_, v_, omega_of(w_));  // sped up (F6)
  const Vec3 a_ext = air_.acceleration(p_, v_);
  if (!contact_.crease) {
    if (a_ext.dot(contact_.n) > 0.0) return take_off(contact_.tri, v_, omega_of(w_));
  } else {
    const Vec2 loads = crease_loads(contact_, a_ext);
    if (loads.x() < 0.0 || loads.y() < 0.0) {  // one plane lets go: on the other alone
      const std::uint32_t keep = loads.x() < 0.0 ? contact_.other : contact_.tri;
      if (loads.x() < 0.0 && loads.y() < 0.0) return take_off(contact_.tri, v_, omega_of(w_));
      return enter_face(keep, p_, v_, omega_of(w_));
    }
  }
  if (t_ >= set_.t_max_s) return finish(GroundEnd::kMaxTime);
  const GVec& y0 = ode_.y_prev();
  if (slipping()) return after_slip_step(y0);
  // G10: the friction direction flips where the centre stops: near it (or past it, reversed),
  // stop, then rest or restart.
  const Vec3 v0 = y0.segment<3>(3);
  const double s0 = v0.norm(), s1 = v_.norm();
  if (!(s0 > 0.0)) return Next::kContinue;
  const double dec1 = s1 > 0.0 ? -ode_.dy().segment<3>(3).dot(v_) / s1 : 0.0;
  if (v_.dot(v0) <= 0.0 && s1 <= 0.1 * s0) return stop_or_restart(0.0);  // just past the stop
  const bool near_stop = s1 <= 1e-3 * s0 || (dec1 > 0.0 && s1 * s1 < 2.0 * dec1 * kRestTravel_m);
  // The last hair of the way at the present deceleration, in closed form.
  if (near_stop) return stop_or_restart(dec1 > 0.0 ? s1 / dec1 : 0.0);
  return Next::kContinue;
}

// Has x reached zero over the last step (x0 -> x1): past it, or near it (a straight approach: the
// step was capped at the predicted zero; a curved one: the integrator closes in geometrically, so
// also once x is negligible against `scale`)?
bool reached_zero(const Vec3& x0, const Vec3& x1, double scale) {
  const double s1 = x1.norm();
  const double s0 = x0.norm();
  // Reversed and small: past a zero (reversed but still large: the step turned it round).
  if (x1.dot(x0) <= 0.0 && s1 <= 0.1 * s0) return true;
  return s1 <= 1e-3 * s0 || s1 <= kSlipEnd_rel * scale + 1e-12;
}

// A slipping ball (G4) has two kinks: the slip reaching zero (it sticks, G7: then it rolls, or
// slips on if rolling cannot be held) and its rolling spin reaching zero while it skids (the
// rolling resistance then holds the spin at zero, statically).
Next GroundMotion::after_slip_step(const GVec& y0) {
  const Vec3& n = contact_.n;
  const Vec3 v0 = y0.segment<3>(3), w0 = y0.segment<3>(6);
  const Vec3 u0 = v0 - w0.cross(n), u1 = v_ - w_.cross(n);
  const Vec3 r0 = w0 - w0.dot(n) * n, r1 = w_ - w_.dot(n) * n;
  if (res_.skid && r0.squaredNorm() > 0.0 && reached_zero(r0, r1, v_.norm())) {
    w_ -= r1;  // the ball stops turning (dissipative)
    restart_integrator(p_, v_, w_);
  } else if (reached_zero(u0, u1, v_.norm() + w_.norm())) {
    // The last hair of the slip at the present rates, in closed form (not past its end).
    const GVec& dy = ode_.dy();
    const Vec3 a = dy.segment<3>(3), dw = dy.segment<3>(6);
    const double s1 = u1.norm(), dec = s1 > 0.0 ? -(a - dw.cross(n)).dot(u1) / s1 : 0.0;
    if (u1.dot(u0) > 0.0 && dec > 0.0 && advance_closed_form(s1 / dec, a, dw))
      return finish(GroundEnd::kStoppedByObserver);
    settle_rolling_or_slipping(/*stick=*/true);  // sticks (dissipative), then rolls or slips on
    restart_integrator(p_, v_, w_);
  }
  return Next::kContinue;
}

// The state moved on by dt at constant rates (a, dw): the last hair before a kink, reported as a
// piece of the path. True when the observer stops there.
bool GroundMotion::advance_closed_form(double dt, const Vec3& a, const Vec3& dw) {
  const double t0 = t_;
  const Vec3 p0 = p_, v0 = v_;
  t_ += dt;
  p_ += dt * (v_ + 0.5 * dt * a);
  v_ += dt * a;
  w_ += dt * dw;
  return emit(t0, p0, v0, t_, p_, v_, w_);
}

// The centre has stopped (G10), `residual_dt` after the current state at its present
// deceleration: rest where static friction holds it, else start again from rest along the pull.
Next GroundMotion::stop_or_restart(double residual_dt) {
  if (residual_dt > 0.0) {
    const double s = v_.norm();
    if (advance_closed_form(residual_dt, -(s / residual_dt) * (v_ / s), Vec3::Zero()))
      return finish(GroundEnd::kStoppedByObserver);
  }
  v_.setZero();
  if (res_.round) w_ = contact_.crease ? Vec3::Zero() : Vec3(w_.dot(contact_.n) * contact_.n);
  const Vec3 a_ext = air_.acceleration(p_, v_);
  double drive, cap;
  if (contact_.crease) {
    const Vec2 loads = crease_loads(contact_, a_ext);
    drive = std::abs(a_ext.dot(contact_.e));
    cap =
        (res_.round ? res_.mu_r : res_.mu) * (std::max(0.0, loads.x()) + std::max(0.0, loads.y()));
  } else {
    const PlaneLoad load = plane_load(a_ext, contact_.n);
    drive = load.at.norm();
    cap = (res_.round ? res_.mu_r : res_.mu) * load.nl;
  }
  if (drive <= cap) return finish(GroundEnd::kRest);
  if (!contact_.crease) {
    const Next n = settle_in_contact_set();
    if (n != Next::kNoChange) return n;
    if (res_.round) settle_rolling_or_slipping();
  }
  restart_integrator(p_, v_, w_);
  return Next::kContinue;
}

// A slow body on a face may touch more than its own plane: near a pit vertex (within its bounding
// radius, horizontally) or where it reaches the plane across a concave edge of its triangle. Its
// contact set is then more than one plane (G10). At a local minimum of the terrain it rests
// (gravity lies in the cone of the normals around it); on a crease it rests if friction on both
// planes holds it along the crease line, else it slides along that line (crease mode).
// kNoChange: one plane is all it touches.
Next GroundMotion::settle_in_contact_set() {
  const double reach = fragments::bounding_radius(body_.shape);
  const Vec2 p(p_.x(), p_.y());
  const auto& vs = site_.terrain_vertices();
  for (int k = 0; k < 3; ++k) {
    const Vec3& q = vs[edges_.from[k]];
    if ((Vec2(q.x(), q.y()) - p).norm() <= reach && vertex_is_local_min(edges_.from[k]))
      return finish(GroundEnd::kRest);
  }
  const Vec3 a_ext = air_.acceleration(p_, Vec3::Zero());
  for (int k = 0; k < 3; ++k) {
    if (-edges_.phi_k(k, p_) > reach) continue;  // the edge's line is out of reach
    const Vec3 &a = vs[edges_.from[k]], &b = vs[edges_.to[k]];
    const Vec2 mid(0.5 * (a.x() + b.x()), 0.5 * (a.y() + b.y()));
    std::int64_t other = edges_.across[k];
    if (other == -2) {
      const Vec2 out = mid + nudge_m_ * edges_.normal[k];
      other = site_.terrain_triangle_at(out.x(), out.y());
    }
    if (other < 0) continue;
    const auto t2 = static_cast<std::uint32_t>(other);
    const Vec3& n2 = site_.terrain_triangle_normal(t2);
    const Vec3 m(edges_.normal[k].x(), edges_.normal[k].y(), 0.0);  // across the edge, outward
    if (!(-n2.dot(m) / n2.z() > -contact_.n.dot(m) / contact_.n.z())) continue;  // not a valley
    // Does the body reach the other plane (its clearance toward it)?
    if (n2.dot(p_ - a) > ground_clearance(body_, q_, n2) + 1e-6 * reach) continue;
    Contact c;
    c.crease = true;
    c.n1 = contact_.n;
    c.n2 = n2;
    c.e = (b - a).normalized();
    const Vec2 loads = crease_loads(c, a_ext);
    if (!(loads.x() > 0.0 && loads.y() > 0.0)) continue;  // pressed into one plane only
    const double cap = (res_.round ? res_.mu_r : res_.mu) * (loads.x() + loads.y());
    if (std::abs(a_ext.dot(c.e)) <= cap) return finish(GroundEnd::kRest);
    return enter_crease(contact_.tri, t2, edges_.from[k], edges_.to[k], p_, v_, w_);
  }
  return Next::kNoChange;
}

// ---- events at edges and vertices ----

// The triangle just beyond p along the horizontal direction of dir (-1: off the terrain).
std::int64_t GroundMotion::triangle_beyond(const Vec3& p, const Vec3& dir) const {
  Vec2 d(dir.x(), dir.y());
  const double dn = d.norm();
  if (!(dn > 0.0)) return site_.terrain_triangle_at(p.x(), p.y());
  d *= nudge_m_ / dn;
  return site_.terrain_triangle_at(p.x() + d.x(), p.y() + d.y());
}

// The centre reached the edge from_id-to_id into triangle `next` (of another slope), moving
// with v_ along the current plane (G11).
Next GroundMotion::cross_edge(std::uint32_t next, std::uint32_t from_id, std::uint32_t to_id) {
  const Vec3& n2 = site_.terrain_triangle_normal(next);
  const double vn = v_.dot(n2);
  const Vec3 omega = omega_of(w_);
  if (vn > 0.0) {  // convex: the next plane falls away
    if (vn >= set_.takeoff_speed_mps) return take_off(next, v_, omega);
    // A hop too short to fly: contracted into its landing, whose normal speed it mirrors.
    return edge_impact(next, v_ - 2.0 * vn * n2, false, from_id, to_id);
  }
  if (vn < 0.0) return edge_impact(next, v_, true, from_id, to_id);
  return enter_face(next, p_, v_, omega);
}

// An impulse on the plane of `next` at the current point (G12; bounce.h), then on.
Next GroundMotion::edge_impact(std::uint32_t next, const Vec3& v_in, bool concave,
                               std::uint32_t from_id, std::uint32_t to_id) {
  use_material_of(next);
  if (fast(v_in)) return fast_contact_on(next, p_, v_in, omega_of(w_));
  const Vec3& n2 = site_.terrain_triangle_normal(next);
  if (material_->embeds(v_in, n2, body_.density_kg_m3)) return finish(GroundEnd::kEmbedded);
  const Vec3 omega_in = omega_of(w_);
  const TerrainBounce b = bounce_on_terrain(body_.shape, body_.mass_kg, q_, v_in, omega_in, n2,
                                            *material_, body_.flat_tol_m);
  const Vec3 v_out = b.collision.impact ? b.collision.velocity_mps : v_in;
  const Vec3 w_out = b.collision.impact ? b.collision.omega_radps : omega_in;
  ++r_.impacts;
  obs_.on_impact({t_, p_, v_in, v_out, omega_in, w_out, next, q_});
  if (v_out.dot(n2) >= set_.takeoff_speed_mps) return take_off(next, v_out, w_out);
  const Vec3 v2 = v_out - v_out.dot(n2) * n2;
  const Vec3 w2 = res_.round ? w_out : Vec3::Zero();
  if (concave && from_id != kNoVertex && captured_in_crease(next, from_id, to_id, v2))
    return enter_crease(contact_.tri, next, from_id, to_id, p_, v2, radius_m_ * w2);
  return enter_face(next, p_, v2, w2);
}

// After an impact on the far side of a concave edge: would the body climb the new plane by less
// than kCaptureHeight_m before gravity brings it back (or is it heading back already)? Then it
// is held in the crease (G8) instead of chattering across it.
bool GroundMotion::captured_in_crease(std::uint32_t next, std::uint32_t from_id,
                                      std::uint32_t to_id, const Vec3& v2) const {
  const auto& vs = site_.terrain_vertices();
  const Vec3& n2 = site_.terrain_triangle_normal(next);
  const Vec3 e = (vs[to_id] - vs[from_id]).normalized();
  Vec3 m = n2.cross(e);  // in the next plane, across the edge
  const auto& ids = site_.terrain_triangles()[next];
  const Vec3 centroid = (vs[ids[0]] + vs[ids[1]] + vs[ids[2]]) / 3.0;
  if (m.dot(centroid - vs[from_id]) < 0.0) m = -m;  // away from the edge, into `next`
  const double v_away = v2.dot(m);
  if (v_away <= 0.0) return true;
  // Pulled back toward the edge on the new plane (it rises away from a concave edge), and slow.
  const PlaneLoad load = plane_load(air_.acceleration(p_, v2), n2);
  return load.at.dot(m) < 0.0 && v_away * v_away < 2.0 * g_ * kCaptureHeight_m;
}

// The centre reached the end of its crease edge (G9).
Next GroundMotion::arrive_at_vertex(std::uint32_t vertex) {
  const double s2 = v_.squaredNorm();
  if (s2 < 2.0 * g_ * kCaptureHeight_m && vertex_is_local_min(vertex)) {
    return finish(GroundEnd::kRest);  // a pit: every way out climbs more than it can
  }
  const std::int64_t next = triangle_beyond(p_, v_);
  if (next < 0) return finish(GroundEnd::kLeftSite);
  // Onto the triangle ahead as across an edge (no crease there to be caught in).
  return cross_edge(static_cast<std::uint32_t>(next), kNoVertex, kNoVertex);
}

// Is terrain vertex `vertex` a local minimum (no neighbour lower)? Then gravity lies in the cone
// of the normals around it and the body rests there without friction.
bool GroundMotion::vertex_is_local_min(std::uint32_t vertex) const {
  const auto& vs = site_.terrain_vertices();
  const double z = vs[vertex].z();
  bool lower = false;
  const auto check = [&](std::uint32_t tri) {
    const auto& ids = site_.terrain_triangles()[tri];
    if (ids[0] != vertex && ids[1] != vertex && ids[2] != vertex) return;
    for (const auto id : ids)
      if (vs[id].z() < z) lower = true;
  };
  // Every triangle touching the vertex is in a bucket that contains a point just around it.
  const double d = 4.0 * nudge_m_;
  const Vec3& p = vs[vertex];
  for (int sx = -1; sx <= 1; sx += 2)
    for (int sy = -1; sy <= 1; sy += 2)
      site_.terrain_index().for_each_candidate_at(Vec2(p.x() + sx * d, p.y() + sy * d), check);
  return !lower;
}

}  // namespace

GroundResult move_on_ground(const scene::Site& site, const flight::FlightModel& air,
                            const GroundBody& body, const GroundSettings& settings,
                            const GroundState& start, GroundObserver& observer) {
  GroundMotion m(site, air, body, settings, observer);
  return m.run(start);
}

}  // namespace fragsim::impact
