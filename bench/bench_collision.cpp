// Cost of one impulse-based impact (core/impact/collision.h) for a few body types, and which
// phases the impacts went through: sliding throughout, stable sticking, unstable sticking (slip
// resumed along the diverging ray), jam, recompression, step cap. Inputs are generated up front
// (fixed seed) so only resolve_collision() is timed; one thread.
//
//   build/bench/bench_collision [impacts_per_type]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <vector>

#include "core/impact/collision.h"

using namespace fragsim;
using impact::CollisionInput;

namespace {

Quat random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  return Quat(g(rng), g(rng), g(rng), g(rng)).normalized();
}

// Solid cuboid with edges d, rotated by q: I_w^-1 in site axes.
Mat3 cuboid_inv_inertia(double m, const Vec3& d, const Quat& q) {
  const Vec3 i(d.y() * d.y() + d.z() * d.z(), d.x() * d.x() + d.z() * d.z(),
               d.x() * d.x() + d.y() * d.y());
  const Mat3 R = q.toRotationMatrix();
  return R * (i * (m / 12.0)).cwiseInverse().asDiagonal() * R.transpose();
}

enum class Kind { kSphere, kCube, kPlate, kRod, kPointMass };

// Ground normal +z; the body touches with its lowest corner (or its lowest point for a sphere),
// falling at 5-50 m/s at 5-85 degrees with up to 50 rad/s of tumble; e in [0, 0.6] (the paper's
// Fig. 2 range), mu in [0.3, 1] (its 0.5 hard / 0.9 soft).
CollisionInput make(Kind kind, std::mt19937_64& rng) {
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> g;
  CollisionInput in;
  in.mass_kg = 0.05 + 5.0 * uni(rng);
  in.normal = Vec3(0, 0, 1);
  in.restitution = 0.6 * uni(rng);
  in.friction = 0.3 + 0.7 * uni(rng);
  const double speed = 5.0 + 45.0 * uni(rng), angle = (5.0 + 80.0 * uni(rng)) * kDegToRad;
  const double az = 2.0 * kPi * uni(rng);
  in.velocity_mps = speed * Vec3(std::cos(angle) * std::cos(az), std::cos(angle) * std::sin(az),
                                 -std::sin(angle));
  in.omega_radps = Vec3(g(rng), g(rng), g(rng)) * (50.0 / std::sqrt(3.0));
  Vec3 d;
  switch (kind) {
    case Kind::kSphere: {
      const double R = 0.05;
      in.inv_inertia_world = Mat3::Identity() / (0.4 * in.mass_kg * R * R);
      in.r_m = Vec3(0, 0, -R);
      break;
    }
    case Kind::kPointMass:
      in.inv_inertia_world.setZero();
      in.omega_radps.setZero();
      in.r_m.setZero();
      break;
    case Kind::kCube: d = Vec3(0.1, 0.1, 0.1); break;
    case Kind::kPlate: d = Vec3(0.2, 0.15, 0.02); break;
    case Kind::kRod: d = Vec3(0.4, 0.02, 0.02); break;
  }
  if (kind == Kind::kCube || kind == Kind::kPlate || kind == Kind::kRod) {
    const Quat q = random_rotation(rng);
    in.inv_inertia_world = cuboid_inv_inertia(in.mass_kg, d, q);
    // Lowest corner along -n.
    const Mat3 R = q.toRotationMatrix();
    Vec3 best(0, 0, 0);
    double lowest = 1e300;
    for (int c = 0; c < 8; ++c) {
      const Vec3 local(((c & 1) ? 0.5 : -0.5) * d.x(), ((c & 2) ? 0.5 : -0.5) * d.y(),
                       ((c & 4) ? 0.5 : -0.5) * d.z());
      const Vec3 r = R * local;
      if (r.z() < lowest) {
        lowest = r.z();
        best = r;
      }
    }
    in.r_m = best;
  }
  // Make the contact point approach the ground (spin can make it recede).
  const double un = (in.velocity_mps + in.omega_radps.cross(in.r_m)).z();
  if (un >= 0.0) in.velocity_mps.z() -= 2.0 * un + 1.0;
  return in;
}

}  // namespace

int main(int argc, char** argv) {
  const int n = argc > 1 ? std::atoi(argv[1]) : 200000;
  struct Case {
    const char* name;
    Kind kind;
  };
  const Case cases[] = {{"sphere", Kind::kSphere},
                        {"point mass", Kind::kPointMass},
                        {"cube", Kind::kCube},
                        {"plate 10:7.5:1", Kind::kPlate},
                        {"rod 20:1:1", Kind::kRod}};
  std::printf("# resolve_collision: %d impacts per body type, 1 thread, ground normal +z\n", n);
  std::printf("%-16s %9s %8s %6s %8s %8s %8s %7s %7s %6s %6s\n", "body", "ns/impact", "steps",
              "max", "slide%", "stick%", "resume%", "jam%", "recomp%", "cap%", "0-slip%");
  std::mt19937_64 rng(1996);
  for (const Case& c : cases) {
    std::vector<CollisionInput> inputs;
    inputs.reserve(static_cast<std::size_t>(n));
    for (int i = 0; i < n; ++i) inputs.push_back(make(c.kind, rng));
    // Warm-up, then the timed pass.
    double sink = 0.0;
    for (int i = 0; i < std::min(n, 2000); ++i)
      sink += impact::resolve_collision(inputs[static_cast<std::size_t>(i)]).velocity_mps.z();
    long steps = 0;
    int max_steps = 0, slide = 0, stick = 0, resume = 0, jam = 0, recomp = 0, cap = 0, noslip = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (const CollisionInput& in : inputs) {
      const auto r = impact::resolve_collision(in);
      sink += r.velocity_mps.z() + r.omega_radps.x();
      steps += r.steps;
      max_steps = std::max(max_steps, r.steps);
      if (!r.stuck) ++slide;
      if (r.stuck && !r.resumed_sliding) ++stick;
      resume += r.resumed_sliding;
      jam += r.jammed;
      recomp += r.recompressed;
      cap += r.step_cap_reached;
      noslip += r.stuck && r.steps == 0;
    }
    const auto t1 = std::chrono::steady_clock::now();
    const double ns = std::chrono::duration<double, std::nano>(t1 - t0).count() / n;
    const double pct = 100.0 / n;
    std::printf("%-16s %9.0f %8.2f %6d %8.2f %8.2f %8.2f %7.2f %7.2f %6.2f %6.2f\n", c.name, ns,
                static_cast<double>(steps) / n, max_steps, slide * pct, stick * pct, resume * pct,
                jam * pct, recomp * pct, cap * pct, noslip * pct);
    if (!std::isfinite(sink)) std::printf("non-finite result!\n");
  }
  std::printf(
      "# slide%%: slip never reached 0; stick%%: reached 0, stable; resume%%: reached 0,\n"
      "# unstable, slid on along the diverging ray; jam%%: (K zeta)_z <= 0 met;\n"
      "# recomp%%: u_z < 0 again in restitution; 0-slip%%: reached 0 without Taylor steps\n"
      "# (straight approach, exact). steps = Taylor steps per impact (mean, max).\n");
  return 0;
}
