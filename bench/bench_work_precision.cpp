// Work-precision sweep: landing range and time of 2-D quadratic-drag flights over a flat plane,
// through the whole run pipeline (sampling, DOPRI5, chords, plane contact, hit refinement), against
// the hodograph quadrature reference (tests/validation/hodograph_reference.h), for a grid of
// integrator.rtol x integrator.sagitta_m. Prints max relative error and cost per fragment.
//
//   build/bench/bench_work_precision [samples_per_case]
#include <cstdio>
#include <cstdlib>

#include "core/run/run.h"
#include "validation/hodograph_reference.h"

using namespace fragsim;

int main(int argc, char** argv) {
  const std::int64_t samples = argc > 1 ? std::atoll(argv[1]) : 4000;
  const double rho = 1.225, cd = 0.47, mass = 0.1, density = 7850.0, g = 9.80665;
  const double radius = std::cbrt(3.0 * mass / (4.0 * kPi * density));
  const double area = kPi * radius * radius;
  const double k = rho * cd * area / (2.0 * mass);
  const double speed = 300.0;
  const double elevations_deg[] = {5.0, 15.0, 30.0, 45.0, 60.0, 75.0};

  // Reference landings (launch and landing at z = 0).
  struct Ref {
    double range, time;
  };
  std::vector<Ref> refs;
  for (double e : elevations_deg) {
    validation::HodographReference h(speed, e * kDegToRad, k, g);
    const auto l = h.landing();
    refs.push_back({l.x_m, l.t_s});
  }

  std::printf(
      "# 2-D quadratic drag, steel sphere %.3f kg, v0 %.0f m/s, k = %.4e 1/m, %lld "
      "histories per elevation, 1 thread\n",
      mass, speed, k, static_cast<long long>(samples));
  std::printf("%-8s %-9s %14s %14s %12s %10s %10s\n", "rtol", "sagitta", "max_rel_range",
              "max_rel_time", "us/fragment", "rhs/frag", "chords/frag");
  for (double rtol : {1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9}) {
    for (double sag : {0.01, 0.05, 0.25, 1.0}) {
      run::Scenario sc;
      scene::PlaneTerrainSpec plane;
      plane.extent_m = {-100.0, -5000.0, 20000.0, 5000.0};
      plane.cell_m = 50.0;
      sc.site.terrain.geometry = plane;
      sc.site.terrain.material = "soil";
      sc.site.materials["soil"] = scene::MaterialSpec{};
      sc.atmosphere.model = flight::AtmosphereSpec::Model::kConstant;
      sc.atmosphere.density_kg_m3 = rho;
      sc.gravity_mps2 = g;
      for (double e : elevations_deg) {
        fragments::FragmentGroupSpec grp;
        grp.count = 1.0;
        grp.samples = samples;
        grp.shape.type = fragments::ShapeType::kSphere;
        grp.shape.density_kg_m3 = density;
        grp.mass_kg = fragments::Distribution::fixed(mass);
        grp.speed_mps = fragments::Distribution::fixed(speed);
        grp.direction.elevation_min_deg = grp.direction.elevation_max_deg = e;
        grp.direction.azimuth_min_deg = grp.direction.azimuth_max_deg = 0.0;
        grp.cd.constant = cd;
        sc.groups.push_back(grp);
      }
      sc.settings.rtol = rtol;
      sc.settings.sagitta_m = sag;
      sc.settings.threads = 1;
      sc.settings.record_fragments = true;
      sc.settings.max_flight_time_s = 600.0;
      const run::RunResult r = run::run(sc);
      const double wall = r.timing.wall_s;  // the run itself, without building the site
      double err_range = 0.0, err_time = 0.0;
      for (const auto& f : r.fragments) {
        if (f.outcome != run::Outcome::kGround) {
          err_range = err_time = std::numeric_limits<double>::infinity();
          break;
        }
        const Ref& ref = refs[f.group];
        err_range = std::max(err_range, std::abs(f.end_position_m.x() - ref.range) / ref.range);
        err_time = std::max(err_time, std::abs(f.end_time_s - ref.time) / ref.time);
      }
      const double n = static_cast<double>(r.samples);
      std::printf("%-8.0e %-9.2f %14.3e %14.3e %12.2f %10.1f %10.1f\n", rtol, sag, err_range,
                  err_time, 1e6 * wall / n, static_cast<double>(r.stats.rhs_evaluations) / n,
                  static_cast<double>(r.stats.chords) / n);
    }
  }
  return 0;
}
