// Sampling one fragment history: launch frame, direction, orientation, spin, and the Philox slots
// each random variable reads.
#include "core/fragments/sampling.h"

#include <algorithm>
#include <cmath>

#include "core/fragments/sobol.h"

namespace fragsim::fragments {

Mat3 frame_rotation(const FrameSpec& frame) {
  // Aerospace-style yaw-pitch-roll: roll about local x, then pitch, then yaw about site z. Pitch
  // enters as Ry(-pitch) because a right-handed rotation about +y by +theta takes +x toward -z,
  // while a positive pitch must raise the nose (+x) toward +z.
  const double yaw = frame.yaw_deg * kDegToRad;
  const double pitch = frame.pitch_deg * kDegToRad;
  const double roll = frame.roll_deg * kDegToRad;
  return (Eigen::AngleAxisd(yaw, Vec3::UnitZ()) * Eigen::AngleAxisd(-pitch, Vec3::UnitY()) *
          Eigen::AngleAxisd(roll, Vec3::UnitX()))
      .toRotationMatrix();
}

Mat3 attitude_rotation(const AttitudeSpec& attitude) {
  // The same convention as the frame, so a user states both the same way.
  FrameSpec f;
  f.yaw_deg = attitude.yaw_deg;
  f.pitch_deg = attitude.pitch_deg;
  f.roll_deg = attitude.roll_deg;
  return frame_rotation(f);
}

Vec3 sample_direction(const DirectionSpec& d, double u_elevation, double u_azimuth) {
  return sample_direction(d, std::sin(d.elevation_min_deg * kDegToRad),
                          std::sin(d.elevation_max_deg * kDegToRad), u_elevation, u_azimuth);
}

Vec3 sample_direction(const DirectionSpec& d, double s_lo, double s_hi, double u_elevation,
                      double u_azimuth) {
  // Archimedes' hat-box theorem: the area of a spherical zone is proportional to the difference
  // of sin(elevation) at its edges, so sin(elevation) uniform and azimuth uniform give a uniform
  // density on the part of the sphere within the ranges.
  const double s = std::clamp(s_lo + u_elevation * (s_hi - s_lo), -1.0, 1.0);
  const double c = std::sqrt(std::max(0.0, (1.0 - s) * (1.0 + s)));
  const double az =
      (d.azimuth_min_deg + u_azimuth * (d.azimuth_max_deg - d.azimuth_min_deg)) * kDegToRad;
  return Vec3(c * std::cos(az), c * std::sin(az), s);
}

Quat uniform_rotation(double u1, double u2, double u3) {
  // Shoemake, K. (1992), "Uniform random rotations", Graphics Gems III, 124-132: with
  // r1 = sqrt(1 - u1), r2 = sqrt(u1), t1 = 2 pi u2, t2 = 2 pi u3, the quaternion
  // (r1 sin t1, r1 cos t1, r2 sin t2, r2 cos t2) is uniform on S^3, hence the rotation is
  // uniform (Haar) on SO(3).
  const double r1 = std::sqrt(1.0 - u1), r2 = std::sqrt(u1);
  const double t1 = 2.0 * kPi * u2, t2 = 2.0 * kPi * u3;
  Quat q(r2 * std::cos(t2), r1 * std::sin(t1), r1 * std::cos(t1), r2 * std::sin(t2));  // (w,x,y,z)
  q.normalize();  // unit to rounding already; keep it exactly so for the integrator
  return q;
}

namespace {

// Attitude relative to the local frame, carried into site axes with the frame: fixed by the group
// (one matrix product, converted once, so it equals frame * attitude to rounding), or uniformly
// random from the orientation slots, which a fixed attitude leaves unread.
Quat body_to_site(const FragmentGroupSpec& group, const Mat3& frame, const RandomStream& rng) {
  if (group.attitude) return Quat(Mat3(frame * attitude_rotation(*group.attitude))).normalized();
  const auto u = rng.uniform_pair(kSlotOrientation);
  const Quat q_local = uniform_rotation(u[0], u[1], rng.uniform(kSlotOrientation2, 0));
  return (Quat(frame) * q_local).normalized();
}

// The launch uniforms of a Sobol point: coordinate d of point i of net k, Owen-scrambled by a
// key drawn per (seed, group, net, d), plus 32 bits of the history's own stream below the
// point's 32 (so that each coordinate is exactly uniform on (0, 1), not on a 2^-32 grid).
struct LaunchUniforms {
  double elevation, azimuth, speed, mass, cell;
};
LaunchUniforms sobol_launch(const LaunchStratum& s, std::uint64_t seed, std::uint32_t group,
                            const RandomStream& rng) {
  constexpr std::uint64_t kNetStreams = 1ull << 62;  // beyond any history number
  const RandomStream net(seed, group, kNetStreams | static_cast<std::uint64_t>(s.sobol_net));
  const auto key0 = net.block(0), key1 = net.block(1);
  const auto low0 = rng.block(kSlotSobolJitter), low1 = rng.block(kSlotSobolJitter2);
  const SobolPoints& sp = sobol_points();
  const auto coordinate = [&](int d, std::uint32_t key, std::uint32_t low) {
    const std::uint32_t x = SobolPoints::scramble(sp.raw(s.sobol_point, d), key);
    const double u =
        (static_cast<double>(x) + (static_cast<double>(low) + 0.5) * 0x1.0p-32) * 0x1.0p-32;
    return std::min(u, 0x1.fffffffffffffp-1);  // x + low rounds up to 2^32 at the top
  };
  return {coordinate(0, key0[0], low0[0]), coordinate(1, key0[1], low0[1]),
          coordinate(2, key0[2], low0[2]), coordinate(3, key0[3], low0[3]),
          coordinate(4, key1[0], low1[0])};
}

// The uniforms of the launch variables: the history's own slots; or a Sobol point; then, with
// importance cells, placed in the cell that u_cell picks (in a stratum of u_cell with strata),
// with the weight's factors and the cell recorded in `f`.
LaunchUniforms launch_uniforms(const RandomStream& rng, std::uint64_t seed,
                               const DirectionCells* cells, const LaunchStratum* stratum,
                               FragmentInit& f) {
  const auto u_direction = rng.uniform_pair(kSlotDirection);
  LaunchUniforms u{u_direction[0], u_direction[1], rng.uniform(kSlotSpeed), rng.uniform(kSlotMass),
                   0.5};
  bool filling = false;
  if (stratum != nullptr && stratum->sobol_net >= 0) {
    u = sobol_launch(*stratum, seed, f.group, rng);
    f.weight *= stratum->weight_factor;
  } else if (cells != nullptr && !cells->uniform()) {
    u.cell = rng.uniform(kSlotDirectionCell);
    if (stratum != nullptr) {
      u.cell = std::min(
          (static_cast<double>(stratum->index) + u.cell) / static_cast<double>(stratum->count),
          std::nextafter(1.0, 0.0));
      f.weight *= stratum->weight_factor;
      filling = true;
    }
  }
  if (cells == nullptr) return u;
  const DirectionCells::Draw d = filling
                                     ? cells->draw_filling(u.elevation, u.speed, u.cell, u.mass)
                                     : cells->draw(u.elevation, u.azimuth, u.speed, u.cell, u.mass);
  f.direction_cell = d.cell;
  f.likelihood_ratio = d.likelihood_ratio;
  f.weight *= d.likelihood_ratio;
  return {d.u_elevation, d.u_azimuth, d.u_speed, d.u_mass, u.cell};
}

}  // namespace

GroupLaunch::GroupLaunch(const FragmentGroupSpec& g)
    : group(&g),
      mass(g.mass_kg, kMassRange.lo, kMassRange.hi),
      speed(g.speed_mps, kSpeedRange.lo, kSpeedRange.hi),
      spin(g.spin_radps, kSpinRange.lo, kSpinRange.hi),
      frame(frame_rotation(g.frame)),
      sin_elevation_min(std::sin(g.direction.elevation_min_deg * kDegToRad)),
      sin_elevation_max(std::sin(g.direction.elevation_max_deg * kDegToRad)) {}

FragmentInit sample_fragment(const FragmentGroupSpec& group, std::uint32_t group_index,
                             std::uint64_t history, std::uint64_t seed, const DirectionCells* cells,
                             const LaunchStratum* stratum) {
  return sample_fragment(GroupLaunch(group), group_index, history, seed, cells, stratum);
}

FragmentInit sample_fragment(const GroupLaunch& launch, std::uint32_t group_index,
                             std::uint64_t history, std::uint64_t seed, const DirectionCells* cells,
                             const LaunchStratum* stratum) {
  const FragmentGroupSpec& group = *launch.group;
  // One Philox stream per (seed, group, history); each variable reads its own fixed slot, so
  // the value of one never depends on whether another is fixed or random (docs/architecture.md,
  // "Reproducibility"). No heap allocation: this runs once per history.
  const RandomStream rng(seed, group_index, history);

  FragmentInit f;
  f.group = group_index;
  f.history = history;
  f.weight = group.count / static_cast<double>(group.samples);
  f.shape = group.shape.type;

  const LaunchUniforms u = launch_uniforms(rng, seed, cells, stratum, f);
  const double u_mass = u.mass, u_speed = u.speed, u_elevation = u.elevation, u_azimuth = u.azimuth;
  const double mass = launch.mass.sample(u_mass);
  f.body = mass_properties(group.shape, mass, group.area_m2);
  const double speed = launch.speed.sample(u_speed);
  const Vec3 dir_local = sample_direction(group.direction, launch.sin_elevation_min,
                                          launch.sin_elevation_max, u_elevation, u_azimuth);
  const Mat3& rot = launch.frame;

  f.position_m = group.frame.origin_m;
  f.launch_speed_mps = speed;
  f.launch_direction = rot * dir_local;
  f.velocity_mps = speed * f.launch_direction + group.frame.velocity_mps;

  f.orientation = body_to_site(group, rot, rng);

  // Spin: magnitude from its distribution, axis uniform on the sphere in the body frame
  // (z = cos(polar angle) uniform on [-1, 1], longitude uniform).
  const double spin = launch.spin.sample(rng.uniform(kSlotSpin, 0));
  const auto u_axis = rng.uniform_pair(kSlotSpinAxis);
  const double z = 2.0 * u_axis[0] - 1.0;
  const double rho = std::sqrt(std::max(0.0, (1.0 - z) * (1.0 + z)));
  const double phi = 2.0 * kPi * u_axis[1];
  f.omega_body_radps = spin * Vec3(rho * std::cos(phi), rho * std::sin(phi), z);
  return f;
}

}  // namespace fragsim::fragments
