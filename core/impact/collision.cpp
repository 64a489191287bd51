// Impulse-based rigid-body collision (paper eqs. 6-36; Mirtich 1996, ch. 4, with Stronge's
// energetic restitution). The solver follows the impact along the normal impulse; its derivation
// (C1-C10: the variable, work, several compression periods, sliding in sigma, Taylor steps, events,
// straight segments, invariant rays, the diverging ray) is in docs/physics.md, "Solving the
// impulse". Each function below names the step it implements.
#include "core/impact/collision.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <utility>

#include "core/common/least_log.h"

namespace fragsim::impact {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kEps = std::numeric_limits<double>::epsilon();

// Tolerances, relative to U = |u0|.
constexpr int kOrder = 14;                     // Taylor order (~ -ln(tol)/2, Jorba & Zou's optimum)
constexpr double kStepTol = 1e-10;             // size of the last Taylor terms of a step
constexpr double kSnapTol = kStepTol;          // error of a straight segment along a ray
constexpr double kStuckTol = 10.0 * kStepTol;  // |u_t| below this counts as 0: below the step
                                               // tolerance the slip is not resolved
constexpr double kEndStickTol = 1e-9;          // ended_sticking
constexpr int kMaxSteps = 500;                 // then finish with a normal-only impulse

// Taylor coefficients of the sliding solution in tau = sigma - sigma_0 (docs/physics.md C5).
struct Series {
  using C = std::array<double, kOrder + 1>;
  C px, py, s, wt;    // state: tangential and normal impulse, friction work
  C ux, uy, uz, rho;  // contact velocity and slip |u_t|
};

double horner(const Series::C& c, double t) {
  double v = c[kOrder];
  for (int n = kOrder - 1; n >= 0; --n) v = v * t + c[static_cast<std::size_t>(n)];
  return v;
}

// Root of the polynomial c(t) - offset in (a, b] given c(a) - offset <= 0 <= c(b) - offset:
// Newton from the secant guess, kept inside the bracket (bisection when it leaves it). Returns a
// point on the far side (c(t) - offset >= 0), as the events need (u_z >= 0 after compression).
double poly_root(const Series::C& c, double offset, double a, double b) {
  double fa = horner(c, a) - offset, fb = horner(c, b) - offset;
  double t = fb > fa ? b - fb * (b - a) / (fb - fa) : 0.5 * (a + b);
  if (!(t > a && t < b)) t = 0.5 * (a + b);
  for (int it = 0; it < 60; ++it) {
    double f = c[kOrder], df = 0.0;
    for (int n = kOrder - 1; n >= 0; --n) {
      df = df * t + f;
      f = f * t + c[static_cast<std::size_t>(n)];
    }
    f -= offset;
    if (f >= 0.0) {
      b = t;
      fb = f;
    } else {
      a = t;
      fa = f;
    }
    if (f == 0.0 || b - a <= 4.0 * kEps * b) break;
    double next = df != 0.0 ? t - f / df : 0.5 * (a + b);
    if (!(next > a && next < b)) next = 0.5 * (a + b);
    if (std::abs(next - t) <= 2.0 * kEps * t) {  // converged: finish on the far side
      if (f < 0.0) t = next + 2.0 * kEps * t;
      if (horner(c, t) - offset >= 0.0 && t <= b) b = t;
      break;
    }
    t = next;
  }
  return b;
}

Mat3 cross_matrix(const Vec3& r) {
  Mat3 m;
  m << 0.0, -r.z(), r.y(), r.z(), 0.0, -r.x(), -r.y(), r.x(), 0.0;
  return m;
}

// The impulse of one impact in the contact frame (docs/physics.md C1-C10).
class Solver {
 public:
  Solver(const Mat3& k_hat, const Vec3& u0, double e, double mu, CollisionResult& res)
      : k_(k_hat), u0_(u0), e2_(e * e), mu_(mu), res_(res) {
    scale_u_ = u0.norm();
    // The unit of sigma, 1 / (|K_hat| (1 + mu)): Taylor coefficients O(|u0|) (docs/physics.md C4).
    time_unit_ = 1.0 / (k_.norm() * (1.0 + mu));
  }

  // Impulse in the contact frame.
  Vec3 run() {
    if (mu_ == 0.0)
      straight(Vec3(0, 0, 1), kInf);  // frictionless: dp = (0, 0, dp_z) throughout
    else
      slide();
    if (!done_) finish_normal_only();
    res_.work_compression_j = wc_;
    res_.work_normal_j = wz_;
    res_.work_friction_j = wt_;
    return p_;
  }

 private:
  Vec3 u() const { return u0_ + k_ * p_; }

  // Taylor coefficients of the sliding solution from the current state (docs/physics.md C5).
  // Order n is a template parameter so that the convolutions unroll into straight-line code.
  template <std::size_t n>
  void expand_order(Series& c, double& half_inv_rho0) const {
    c.ux[n] = k_(0, 0) * c.px[n] + k_(0, 1) * c.py[n] + k_(0, 2) * c.s[n];
    c.uy[n] = k_(1, 0) * c.px[n] + k_(1, 1) * c.py[n] + k_(1, 2) * c.s[n];
    c.uz[n] = k_(2, 0) * c.px[n] + k_(2, 1) * c.py[n] + k_(2, 2) * c.s[n];
    if constexpr (n == 0) {
      c.ux[0] += u0_.x();
      c.uy[0] += u0_.y();
      c.uz[0] += u0_.z();
    }
    if constexpr (n < kOrder) {
      double q = 0.0, r = 0.0;  // q_n of |u_t|^2, sum for rho_n
      for (std::size_t j = 0; 2 * j < n; ++j) q += c.ux[j] * c.ux[n - j] + c.uy[j] * c.uy[n - j];
      q *= 2.0;
      if constexpr (n % 2 == 0) q += c.ux[n / 2] * c.ux[n / 2] + c.uy[n / 2] * c.uy[n / 2];
      if constexpr (n == 0) {
        c.rho[0] = std::sqrt(q);
        half_inv_rho0 = 0.5 / c.rho[0];
      } else {  // |u_t|^2 = q: 2 rho_0 rho_n + sum_{j=1}^{n-1} rho_j rho_{n-j} = q_n
        for (std::size_t j = 1; 2 * j < n; ++j) r += c.rho[j] * c.rho[n - j];
        r *= 2.0;
        if constexpr (n % 2 == 0) r += c.rho[n / 2] * c.rho[n / 2];
        c.rho[n] = (q - r) * half_inv_rho0;
      }
      const double inv = time_unit_ / static_cast<double>(n + 1);
      c.px[n + 1] = -mu_ * c.ux[n] * inv;
      c.py[n + 1] = -mu_ * c.uy[n] * inv;
      c.s[n + 1] = c.rho[n] * inv;
      c.wt[n + 1] = -mu_ * q * inv;
    }
  }
  void expand(Series& c) const {
    c.px[0] = p_.x();
    c.py[0] = p_.y();
    c.s[0] = p_.z();
    c.wt[0] = wt_;
    c.rho[kOrder] = 0.0;  // |u_t| is needed to order kOrder - 1 only
    double half_inv_rho0 = 0.0;
    [&]<std::size_t... n>(std::index_sequence<n...>) {
      (expand_order<n>(c, half_inv_rho0), ...);
    }
    (std::make_index_sequence<kOrder + 1>{});
  }

  // Step in sigma from the last two Taylor terms of the contact velocity and of the friction work
  // (docs/physics.md C6; Jorba & Zou 2005, sec. 3.2): h = 0.95 exp(min_i ln(x_i) / k_i) over the
  // candidates below. Only the smallest candidate's logarithm matters: a candidate whose lower
  // bound (rough_ln_below, common/least_log.h) lies above the least exact one so far cannot be the
  // minimum, and its logarithm is not taken. The minimum, and so h, is the same double as with
  // every logarithm taken (the min of doubles does not depend on their order).
  double step_size(const Series& c) const {
    const double tol = kStepTol * scale_u_;
    const auto speed = [&](std::size_t n) {
      const double v2 = c.ux[n] * c.ux[n] + c.uy[n] * c.uy[n] + c.uz[n] * c.uz[n];
      return LogCandidate(v2 > 0.0, tol * tol / v2, 2.0 * static_cast<double>(n));
    };
    const LogCandidate s0 = speed(kOrder - 1), s1 = speed(kOrder);
    // The impulse scale over the step: |p|, or the first-order impulse over the velocity terms'
    // step h_u (capped at 50) when that is larger. h_u is needed only then: min(h_u, 50) |p'| <=
    // 50 |p'| <= |p| leaves |p| the larger (rounding is monotone).
    const double p_norm = p_.norm();
    const double dp_norm = Vec3(c.px[1], c.py[1], c.s[1]).norm();
    double log_h = kInf, h_u = kInf;
    bool have_h_u = false;
    if (!(p_norm >= 50.0 * dp_norm)) {
      lower_into(log_h, s0, s1);
      h_u = std::exp(log_h);
      have_h_u = true;
    }
    const double p_scale = std::max(p_norm, std::min(h_u, 50.0) * dp_norm);
    const auto work = [&](std::size_t n) {
      const double w = std::abs(c.wt[n]);
      return LogCandidate(w > 0.0, tol * p_scale / w, static_cast<double>(n));
    };
    const LogCandidate w0 = work(kOrder - 1), w1 = work(kOrder);
    const double log_hu = log_h;
    if (have_h_u) {
      lower_into(log_h, w0, w1);
    } else {  // all four, the two least lower bounds first
      const bool speed_first = !(std::min(w0.lower, w1.lower) < std::min(s0.lower, s1.lower));
      lower_into(log_h, speed_first ? s0 : w0, speed_first ? s1 : w1);
      lower_into(log_h, speed_first ? w0 : s0, speed_first ? w1 : s1);
    }
    return 0.95 * (have_h_u && log_h == log_hu ? h_u : std::exp(log_h));
  }

  // W_z = u0.p + p.K_hat p / 2 - W_t (docs/physics.md C2).
  double normal_work(const Vec3& p, double wt) const {
    return u0_.dot(p) + 0.5 * p.dot(k_ * p) - wt;
  }
  Vec3 p_at(const Series& c, double t) const {
    return Vec3(horner(c.px, t), horner(c.py, t), horner(c.s, t));
  }
  void set_state(const Series& c, double t) {
    p_ = p_at(c, t);
    wt_ = horner(c.wt, t);
    wz_ = normal_work(p_, wt_);
  }

  void end_compression() {
    wc_ += wz_ - w_down_;
    target_ = (1.0 - e2_) * wc_;
    compressing_ = false;
    if (wz_ >= target_) done_ = true;  // e = 0: over at the end of compression
  }
  void begin_recompression() {
    compressing_ = true;
    w_down_ = wz_;
    res_.recompressed = true;
  }

  // Advance by ds along a constant zeta (w = K_hat zeta): u is linear in s, the work quadratic
  // (docs/physics.md C8).
  void advance(const Vec3& zeta, const Vec3& w, double ds) {
    const Vec3 u0 = u();
    wz_ += ds * (u0.z() + 0.5 * w.z() * ds);
    wt_ += ds * (zeta.x() * (u0.x() + 0.5 * w.x() * ds) + zeta.y() * (u0.y() + 0.5 * w.y() * ds));
    p_ += zeta * ds;
  }

  // Straight segment with constant zeta for at most ds_max of normal impulse, through the end of
  // compression and up to the end of restitution (closed form: docs/physics.md C8, C3). Returns
  // true when ds_max was used up before the impact ended.
  bool straight(const Vec3& zeta_in, double ds_max) {
    Vec3 zeta = zeta_in;
    Vec3 w = k_ * zeta;
    double remaining = ds_max;
    for (int guard = 0; guard < 16 && !done_; ++guard) {
      if (w.z() <= 0.0) res_.jammed = true;
      const double uz = u().z();
      enum { kEndCompression, kEndRestitution, kRecompression } next;
      double ds;
      if (compressing_) {
        if (uz >= 0.0 && w.z() > 0.0) {  // u_z rising through 0 (not held at 0 by a jam)
          end_compression();
          continue;
        }
        next = kEndCompression;
        ds = w.z() > 0.0 ? -uz / w.z() : kInf;
      } else {
        const double d = target_ - wz_;  // work still to do
        if (!(d > 0.0)) {
          done_ = true;
          break;
        }
        const double disc = uz * uz + 2.0 * w.z() * d;
        if (w.z() > 0.0) {  // W_z(ds) = target has one positive root; cancellation-free forms
          next = kEndRestitution;
          const double sq = std::sqrt(disc);
          ds = uz >= 0.0 ? 2.0 * d / (uz + sq) : (sq - uz) / w.z();
        } else if (uz > 0.0 && disc >= 0.0) {  // u_z falling but W_z gets there first
          next = kEndRestitution;
          ds = 2.0 * d / (uz + std::sqrt(disc));
        } else if (uz > 0.0) {  // u_z falls back to 0 first
          next = kRecompression;
          ds = uz / -w.z();
        } else {
          begin_recompression();
          continue;
        }
      }
      if (ds >= remaining) {
        if (remaining == kInf) {  // cannot end along this zeta (w_z <= 0): normal-only impulse
          zeta = Vec3(0, 0, 1);
          w = k_.col(2);
          continue;
        }
        advance(zeta, w, remaining);
        return true;
      }
      advance(zeta, w, ds);
      remaining -= ds;
      if (next == kEndCompression) {
        end_compression();
      } else if (next == kEndRestitution) {
        done_ = true;
      } else {
        begin_recompression();
      }
    }
    return false;
  }

  void finish_normal_only() {
    res_.step_cap_reached = true;
    straight(Vec3(0, 0, 1), kInf);
    done_ = true;
  }

  // u_t = 0 reached: stable sticking keeps it 0, otherwise sliding resumes along the diverging
  // ray. Either way zeta is constant for the rest of the impact (docs/physics.md C8, C10).
  void stick() {
    res_.stuck = true;
    const Mat3 kinv = k_.inverse();
    if (std::hypot(kinv(0, 2), kinv(1, 2)) <= mu_ * kinv(2, 2)) {  // sticking_is_stable()
      straight(kinv.col(2) / kinv(2, 2), kInf);
    } else {
      res_.resumed_sliding = true;
      const Vec2 dir = diverging_slip_direction(k_, mu_);
      straight(Vec3(-mu_ * dir.x(), -mu_ * dir.y(), 1.0), kInf);
    }
  }

  // Radial rate h, swirl g and dg/dphi of the slip for unit slip direction d (docs/physics.md C9).
  void slip_rates(const Vec2& d, double& h, double& g, double& dg) const {
    const Vec2 t(-d.y(), d.x());
    const double wx = -mu_ * (k_(0, 0) * d.x() + k_(0, 1) * d.y()) + k_(0, 2);
    const double wy = -mu_ * (k_(1, 0) * d.x() + k_(1, 1) * d.y()) + k_(1, 2);
    h = d.x() * wx + d.y() * wy;
    g = t.x() * wx + t.y() * wy;
    dg = -h - mu_ * (t.x() * (k_(0, 0) * t.x() + k_(0, 1) * t.y()) +
                     t.y() * (k_(1, 0) * t.x() + k_(1, 1) * t.y()));
  }

  // Straight segment along an invariant ray near the slip (docs/physics.md C9): false when the
  // slip is far from one; else the ray direction and the segment length in p_z (infinite: to
  // the end of the impact).
  bool ray_segment(const Vec2& d0, double rho, Vec2& ray, double& ds) const {
    double h, g, dg;
    slip_rates(d0, h, g, dg);
    const double tol = kSnapTol * scale_u_;
    if (h < 0.0 && rho * std::abs(g) <= tol * -h) {
      ray = d0;
      ds = rho / -h;
      return true;
    }
    if (!(rho * std::abs(g) <= 100.0 * tol * std::abs(dg))) return false;  // far from a ray
    Vec2 d = d0;
    for (int it = 0; it < 6; ++it) {
      if (!(dg != 0.0)) return false;
      const double delta = -g / dg;
      if (!(std::abs(delta) <= 0.1)) return false;
      d = (d * std::cos(delta) + Vec2(-d.y(), d.x()) * std::sin(delta)).normalized();
      slip_rates(d, h, g, dg);
      if (std::abs(delta) <= 1e-15) break;
    }
    const double offset = std::abs(d0.x() * d.y() - d0.y() * d.x());  // sin(phi* - phi)
    if (!(rho * offset <= tol) || !(std::abs(g) <= 1e-9 * std::abs(h)) || h == 0.0) return false;
    ray = d;
    ds = h < 0.0 ? rho * d0.dot(d) / -h : kInf;  // converging: until u_t's ray component is 0
    return true;
  }

  // The impact ends inside this step, in (t0, t_end]: W_z reaches (1 - e^2) W_c (docs/physics.md
  // C3, C7).
  void end_restitution(const Series& c, double w_start, double t0, double t_end) {
    // W_z(tau): dW_z/dsigma = u_z |u_t|, a product of the step's series.
    Series::C work;
    work[0] = w_start;
    for (std::size_t n = 0; n < kOrder; ++n) {
      double m = 0.0;
      for (std::size_t j = 0; j <= n; ++j) m += c.rho[j] * c.uz[n - j];
      work[n + 1] = m * time_unit_ / static_cast<double>(n + 1);
    }
    // Polish on W_z as the state defines it (normal_work()), so that the impact ends on
    // W_z = (1 - e^2) W_c to rounding rather than to the series' truncation: Newton with
    // dW_z/dsigma = u_z |u_t|, then onto the far side.
    double t = poly_root(work, target_, t0, t_end);
    auto w_left = [&](double tt) { return normal_work(p_at(c, tt), horner(c.wt, tt)) - target_; };
    double f = w_left(t);
    for (int it = 0; it < 3 && f != 0.0; ++it) {
      const double df = horner(c.uz, t) * horner(c.rho, t) * time_unit_;
      if (!(df > 0.0)) break;
      const double next = std::clamp(t - f / df, t0, t_end);
      if (next == t) break;
      t = next;
      f = w_left(t);
    }
    for (int it = 0; it < 8 && f < 0.0 && t < t_end; ++it) {
      t = std::min(t_end, t + 4.0 * kEps * std::max(t, kEps * t_end) * (1 << it));
      f = w_left(t);
    }
    set_state(c, t);
    done_ = true;
  }

  // Sliding: Taylor steps in sigma and the events inside them (docs/physics.md C4-C7).
  void slide() {
    Series c;
    // Step cap for an exactly polynomial solution (no last Taylor terms): 50 e-folds of the
    // fastest rate (sigma is in units of its inverse, see the constructor).
    const double h_cap = 50.0;
    while (!done_) {
      if (res_.steps >= kMaxSteps) return;  // run() finishes with a normal-only impulse
      const Vec3 u = this->u();
      const double rho = std::sqrt(u.x() * u.x() + u.y() * u.y());
      if (!(rho > kStuckTol * scale_u_)) {
        stick();
        return;
      }
      const Vec2 d(u.x() / rho, u.y() / rho);
      const Vec3 w = k_ * Vec3(-mu_ * d.x(), -mu_ * d.y(), 1.0);  // du/ds = K_hat zeta
      if (w.z() <= 0.0) res_.jammed = true;
      // Close to an invariant ray: the rest is a straight segment (see ray_segment()).
      {
        Vec2 ray;
        double ds = 0.0;
        if (ray_segment(d, rho, ray, ds)) {
          if (straight(Vec3(-mu_ * ray.x(), -mu_ * ray.y(), 1.0), ds)) stick();
          return;
        }
      }
      expand(c);
      ++res_.steps;
      const double h = std::min(step_size(c), h_cap);
      if (!(h > 0.0)) return;  // cannot happen with rho > 0; normal-only impulse

      // State at the end of the step. Events inside it are roots of the step's polynomials,
      // taken on the far side of the zero; the series stays valid across an event (zeta does
      // not change there), so the step goes on after the end of compression.
      const Vec3 p_h = p_at(c, h);
      const double wt_h = horner(c.wt, h);
      const double uz_h = u0_.z() + k_.row(2).dot(p_h);
      const double w_start = wz_;  // W_z at tau = 0
      double t0 = 0.0;             // events handled up to here
      bool restart = false;
      for (int events = 0; events < 4 && !restart; ++events) {
        if (compressing_) {
          if (!(uz_h >= 0.0)) break;
          const double t = poly_root(c.uz, 0.0, t0, h);
          set_state(c, t);
          end_compression();
          if (done_) return;
          t0 = t;
          continue;
        }
        // u_z falling back below 0 first (jam in restitution): W_z peaks there.
        double t_end = h, w_end = normal_work(p_h, wt_h);
        if (uz_h < 0.0) {
          Series::C neg;
          for (std::size_t n = 0; n <= kOrder; ++n) neg[n] = -c.uz[n];
          t_end = poly_root(neg, 0.0, t0, h);
          w_end = normal_work(p_at(c, t_end), horner(c.wt, t_end));
        }
        if (w_end >= target_) {
          end_restitution(c, w_start, t0, t_end);
          return;
        }
        if (t_end < h) {  // a new compression period: take it from a fresh expansion
          set_state(c, t_end);
          begin_recompression();
          restart = true;
        }
        break;
      }
      if (restart) continue;
      // Jam inside the step (its ends are checked at the step starts): du_z/dsigma =
      // |u_t| (K_hat zeta)_z at the middle. Its series' sign is noise where |u_t| is tiny
      // against |u0| (near sticking), so it is only read where the slip is not.
      const double mid = 0.5 * h;
      double dz = 0.0;
      for (int n = kOrder; n >= 1; --n) dz = dz * mid + n * c.uz[static_cast<std::size_t>(n)];
      if (dz <= 0.0 && horner(c.rho, mid) > 1e-6 * scale_u_) res_.jammed = true;
      p_ = p_h;
      wt_ = wt_h;
      wz_ = normal_work(p_h, wt_h);
    }
  }

  const Mat3 k_;
  const Vec3 u0_;
  const double e2_, mu_;
  CollisionResult& res_;
  double scale_u_ = 0.0, time_unit_ = 0.0;
  Vec3 p_{0, 0, 0};
  double wz_ = 0.0, wt_ = 0.0;
  bool compressing_ = true, done_ = false;
  double wc_ = 0.0;      // normal work over all compression periods so far
  double w_down_ = 0.0;  // W_z when the current compression period began
  double target_ = 0.0;  // (1 - e^2) W_c, valid when !compressing_
};

}  // namespace

Mat3 collision_matrix(double mass_kg, const Mat3& inv_inertia, const Vec3& r) {
  const Mat3 rx = cross_matrix(r);
  return Mat3::Identity() / mass_kg - rx * inv_inertia * rx;
}

Mat3 contact_frame(const Vec3& normal) {
  const Vec3 z = normal.normalized();
  // Complete with the site axis least aligned with the normal.
  const Vec3 a = std::abs(z.x()) <= std::abs(z.y()) && std::abs(z.x()) <= std::abs(z.z())
                     ? Vec3::UnitX()
                     : (std::abs(z.y()) <= std::abs(z.z()) ? Vec3::UnitY() : Vec3::UnitZ());
  const Vec3 x = (a - z * z.dot(a)).normalized();
  const Vec3 y = z.cross(x);
  Mat3 R;
  R.row(0) = x.transpose();
  R.row(1) = y.transpose();
  R.row(2) = z.transpose();
  return R;
}

// docs/physics.md C8 (Mirtich 1996, sec. 4.4).
bool sticking_is_stable(const Mat3& k_hat, double mu) {
  const Mat3 kinv = k_hat.inverse();
  return std::sqrt(kinv(0, 2) * kinv(0, 2) + kinv(1, 2) * kinv(1, 2)) <= mu * kinv(2, 2);
}

// The diverging ray: |d(lambda)| = 1 on (0, |k|] with d(lambda) = (lambda 1 + mu A)^-1 k, by
// safeguarded Newton on 1/|d| - 1 (docs/physics.md C10; More & Sorensen 1983).
Vec2 diverging_slip_direction(const Mat3& k_hat, double mu) {
  const Vec2 k(k_hat(0, 2), k_hat(1, 2));
  const double kn = k.norm();
  if (!(kn > 0.0)) return Vec2(1.0, 0.0);  // no coupling: sticking is stable, any direction
  if (!(mu > 0.0)) return k / kn;
  const double a = mu * k_hat(0, 0), b = mu * k_hat(1, 1), f = mu * k_hat(0, 1);
  double lo = 0.0, hi = kn, lam = kn;
  Vec2 d = k / kn;
  for (int it = 0; it < 100; ++it) {
    const double m00 = lam + a, m11 = lam + b, det = m00 * m11 - f * f;
    const Vec2 dd((m11 * k.x() - f * k.y()) / det, (m00 * k.y() - f * k.x()) / det);
    const double n = dd.norm();
    if (!(n > 0.0)) break;
    d = dd / n;
    const double g = 1.0 / n - 1.0;  // increasing in lambda
    if (g > 0.0)
      hi = lam;
    else
      lo = lam;
    // d(1/|d|)/dlambda = d^T M^-1 d / |d|^3 with M = lambda 1 + mu A.
    const Vec2 mid((m11 * dd.x() - f * dd.y()) / det, (m00 * dd.y() - f * dd.x()) / det);
    const double slope = dd.dot(mid) / (n * n * n);
    double next = slope > 0.0 ? lam - g / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (g == 0.0 || std::abs(next - lam) <= 4.0 * kEps * lam) break;
    lam = next;
  }
  return d;
}

// docs/physics.md, "Bounce": eqs. 16, 20-21, 26, 33-34; the impulse: C1-C10.
CollisionResult resolve_collision(const CollisionInput& in) {
  CollisionResult res;
  res.velocity_mps = in.velocity_mps;
  res.omega_radps = in.omega_radps;
  const Vec3 u_site = in.velocity_mps + in.omega_radps.cross(in.r_m);  // eq. 16
  res.contact_velocity_before = res.contact_velocity_after = u_site;
  const double nn = in.normal.norm();
  const bool valid = in.mass_kg > 0.0 && std::isfinite(in.mass_kg) && nn > 0.0 &&
                     std::isfinite(nn) && in.inv_inertia_world.allFinite() && in.r_m.allFinite() &&
                     in.velocity_mps.allFinite() && in.omega_radps.allFinite() &&
                     u_site.allFinite() && std::isfinite(in.restitution) &&
                     std::isfinite(in.friction);
  if (!valid) return res;
  const Vec3 n = in.normal / nn;
  if (!(u_site.dot(n) < 0.0)) return res;  // separating or resting: no impact
  res.impact = true;

  const Mat3 R = contact_frame(n);
  Mat3 k_hat = R * collision_matrix(in.mass_kg, in.inv_inertia_world, in.r_m) * R.transpose();
  k_hat = 0.5 * (k_hat + k_hat.transpose());  // exactly symmetric: work is path-independent
  const double e = std::clamp(in.restitution, 0.0, 1.0);
  const double mu = std::max(in.friction, 0.0);
  Solver solver(k_hat, R * u_site, e, mu, res);
  const Vec3 p = R.transpose() * solver.run();

  res.impulse_ns = p;
  res.velocity_mps = in.velocity_mps + p / in.mass_kg;                        // eq. 34
  res.omega_radps = in.omega_radps + in.inv_inertia_world * in.r_m.cross(p);  // eq. 33
  res.contact_velocity_after = res.velocity_mps + res.omega_radps.cross(in.r_m);
  // Rounding guard: rebuilding u from v', w' in site axes can leave u.n at -1e-16 (|v| + |w||r|)
  // when the impact ends with u_z = 0 (e = 0, sticking). A caller detects a new impact by
  // u.n < 0, so lift u.n to a few roundings above 0 with a normal impulse of that size
  // (n.K n > 0); the kinetic energy changes by ~1e-32 of itself.
  for (int it = 0; it < 4 && n.dot(res.contact_velocity_after) < 0.0; ++it) {
    const double floor = 8.0 * std::numeric_limits<double>::epsilon() *
                         (res.velocity_mps.norm() + res.omega_radps.norm() * in.r_m.norm());
    const Vec3 dp = n * ((floor - n.dot(res.contact_velocity_after)) / k_hat(2, 2));
    res.impulse_ns += dp;
    res.velocity_mps += dp / in.mass_kg;
    res.omega_radps += in.inv_inertia_world * in.r_m.cross(dp);
    res.contact_velocity_after = res.velocity_mps + res.omega_radps.cross(in.r_m);
  }
  const Vec3 ut = res.contact_velocity_after - n * n.dot(res.contact_velocity_after);
  res.ended_sticking = ut.norm() <= kEndStickTol * u_site.norm();
  return res;
}

}  // namespace fragsim::impact
