// Whole-run benchmark on a scenario (default: the bundled demo site). Runs it with 1 thread and
// with all threads (headline throughput, profiling off), then once more with profiling on for the
// time split between integration, geometry queries and tallies. Results are written down in
// docs/benchmarks.md.
//
// With --rtol-sweep it also runs the scenario at integrator.rtol 1e-3 .. 1e-8 and compares each
// result with a 1e-10 reference run. The histories are the same random draws at every rtol
// (common random numbers), so the differences are integration error, not Monte Carlo noise.
//
// With --bounce the scenario runs with settings.bounce on (bounce, slide and roll); with
// --samples-scale X every group's samples are multiplied by X (quick looks); --rigid-ground
// removes every material's embedment and fast-contact models (every terrain impact a rigid-body
// impulse).
// --bounce-ratio runs bounce off and on in alternation on 1 thread (N rounds) and prints the
// ratio of the best throughputs: the figure of the ground-phase issue (bounce-on throughput at
// least half the bounce-off one, measured in the same run).
//
//   build/bench/bench_demo_run [scenario.json] [--repeat N] [--rtol-sweep] [--bounce]
//                              [--samples-scale X] [--one-thread] [--rigid-ground]
//                              [--bounce-ratio] [--serial-histories] [--lanes-ratio] [--per-cpu]
//
// --per-cpu: the two-thread figure against what the machine allows. Each round runs the scenario
// on 1 thread pinned to each CPU in turn, then on all threads unpinned, and prints the parallel
// efficiency: the all-threads rate over the sum of the pinned rates (the most any number of
// threads could reach when the CPUs differ in speed, as a VM's vCPUs may), and the speed-up over
// the fastest CPU's rate, with its bound (the sum over the fastest).
// --one-thread: only the 1-thread runs (no all-threads run, no profiled run).
// --serial-histories: one history at a time per thread (RunControl::serial_histories), instead of
// flight::kLanes histories in lanes (core/run/lane_runner.h); --lanes-ratio runs the two in
// alternation on 1 thread and prints the ratio of the best throughputs (same results).
#include <pthread.h>
#include <sched.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "api/scenario_json.h"
#include "core/run/run.h"

using namespace fragsim;

namespace {

void print_row(const char* label, const run::RunResult& r) {
  const double n = static_cast<double>(r.histories_done);
  std::printf("%-22s threads %d  histories %lld  wall %.3f s  %.0f fragments/s  %.0f per thread\n",
              label, r.timing.threads, static_cast<long long>(r.histories_done), r.timing.wall_s,
              r.timing.fragments_per_s, r.timing.fragments_per_s_per_thread);
  std::printf(
      "%-22s per fragment: %.1f rhs evals, %.1f steps, %.2f chords (%.2f skipped), "
      "%.2f scene queries, %.1f PTN triangle tests, %.2f bounces, %.1f ground steps\n",
      "", static_cast<double>(r.stats.rhs_evaluations) / n,
      static_cast<double>(r.stats.integrator_steps) / n, static_cast<double>(r.stats.chords) / n,
      static_cast<double>(r.stats.chords_skipped) / n,
      static_cast<double>(r.stats.scene_queries) / n,
      static_cast<double>(r.stats.ptn_triangle_tests) / n, static_cast<double>(r.stats.bounces) / n,
      static_cast<double>(r.stats.ground_steps) / n);
  if (r.stats.bounces > 0)
    std::printf("%-22s per fragment: %.3f ground impacts, %.3f take-offs; ground step caps %lld\n",
                "", static_cast<double>(r.stats.ground_impacts) / n,
                static_cast<double>(r.stats.takeoffs) / n,
                static_cast<long long>(r.stats.ground_step_caps));
}

// The figures a change in the physics or its discretisation would move (to compare builds).
void print_results(const run::RunResult& r) {
  double sum_d = 0.0;
  for (double d : r.ptn_density_per_m2) sum_d += d;
  double imp = 0.0, imp_se2 = 0.0, pen = 0.0;
  for (const auto& b : r.buildings) {
    imp += b.impacts.mean;
    imp_se2 += b.impacts.std_error * b.impacts.std_error;
    pen += b.penetrations.mean;
  }
  std::printf(
      "%-22s HFD %.2f m (band %.1f .. %.1f), max PTN density %.6g /m2 (triangle %lld), "
      "sum of densities %.9g, building impacts %.4f (se %.4f), penetrations %.4f\n",
      "results", r.hazardous_fragment_distance_m, r.hfd_lower_m, r.hfd_upper_m,
      r.max_ptn_density_per_m2, static_cast<long long>(r.max_ptn_triangle), sum_d, imp,
      std::sqrt(imp_se2), pen);
  std::printf("%-22s outcomes (histories):", "");
  for (int k = 0; k < run::kOutcomeCount; ++k)
    if (r.outcome_histories[static_cast<std::size_t>(k)] > 0)
      std::printf(" %s %lld", run::outcome_name(static_cast<run::Outcome>(k)),
                  static_cast<long long>(r.outcome_histories[static_cast<std::size_t>(k)]));
  std::printf("\n");
}

// RunControl of every run (--serial-histories).
run::RunControl g_control;

// Two variants of a run in alternation, 1 thread, best of `rounds` each (process CPU time:
// steadier than wall time on a shared machine). `set(sc, control, k)` makes variant k (0, 1).
template <class Set>
void alternate(run::Scenario sc, const std::shared_ptr<const scene::Site>& site, int rounds,
               const Set& set, const char* const (&names)[2], double (&best)[2],
               run::RunResult (&last)[2]) {
  sc.settings.threads = 1;
  sc.settings.profile = false;
  for (int r = 0; r < rounds; ++r) {
    for (int k = 0; k < 2; ++k) {
      run::RunControl control = g_control;
      set(sc, control, k);
      const std::clock_t c0 = std::clock();
      last[k] = run::run(sc, site, control);
      const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      const double rate = static_cast<double>(last[k].histories_done) / cpu_s;
      best[k] = std::max(best[k], rate);
      std::printf("round %d %-26s %.0f fragments per CPU-second\n", r + 1, names[k], rate);
    }
  }
}

// One history at a time against histories in lanes; the two must give the same figures.
void lanes_ratio(const run::Scenario& sc, const std::shared_ptr<const scene::Site>& site,
                 int rounds) {
  double best[2] = {0.0, 0.0};
  run::RunResult last[2];
  alternate(
      sc, site, rounds,
      [](run::Scenario&, run::RunControl& control, int k) { control.serial_histories = k == 0; },
      {"one history at a time", "histories in lanes"}, best, last);
  const bool same =
      last[0].hazardous_fragment_distance_m == last[1].hazardous_fragment_distance_m &&
      last[0].ptn_density_per_m2 == last[1].ptn_density_per_m2 &&
      last[0].stats.rhs_evaluations == last[1].stats.rhs_evaluations;
  print_results(last[1]);
  std::printf(
      "best of %d (CPU time, 1 thread): one history at a time %.0f/s, in lanes %.0f/s, "
      "ratio %.3f; results %s\n",
      rounds, best[0], best[1], best[1] / best[0], same ? "identical" : "DIFFERENT");
}

// Bounce off and on (the ground-phase issue's ratio).
void bounce_ratio(const run::Scenario& sc, const std::shared_ptr<const scene::Site>& site,
                  int rounds) {
  double best[2] = {0.0, 0.0};
  run::RunResult last[2];
  alternate(
      sc, site, rounds,
      [](run::Scenario& s, run::RunControl&, int k) { s.settings.bounce = k == 1; },
      {"bounce off", "bounce on"}, best, last);
  print_row("bounce off (last)", last[0]);
  print_results(last[0]);
  print_row("bounce on (last)", last[1]);
  print_results(last[1]);
  std::printf("best of %d: bounce off %.0f/s, bounce on %.0f/s, ratio on/off %.3f\n", rounds,
              best[0], best[1], best[1] / best[0]);
}

// The two-thread figure against the machine's own CPUs (see --per-cpu above). One thread runs on
// the calling thread (run::run with threads = 1 spawns none), so pinning it pins the run; the
// worker threads of the all-threads run inherit the calling thread's mask, so it is restored
// first.
void per_cpu(run::Scenario sc, const std::shared_ptr<const scene::Site>& site, int rounds) {
  cpu_set_t all;
  CPU_ZERO(&all);
  if (pthread_getaffinity_np(pthread_self(), sizeof(all), &all) != 0) {
    std::fprintf(stderr, "per-cpu: cannot read this thread's CPU mask\n");
    return;
  }
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &all)) cpus.push_back(c);
  const int threads = static_cast<int>(cpus.size());
  const auto rate = [&] { return run::run(sc, site, g_control).timing.fragments_per_s; };
  for (int r = 0; r < rounds; ++r) {
    std::vector<double> alone;
    sc.settings.threads = 1;
    for (int c : cpus) {
      cpu_set_t one;
      CPU_ZERO(&one);
      CPU_SET(c, &one);
      if (pthread_setaffinity_np(pthread_self(), sizeof(one), &one) != 0) {
        std::fprintf(stderr, "per-cpu: cannot pin this thread to cpu %d\n", c);
        return;
      }
      alone.push_back(rate());
    }
    if (pthread_setaffinity_np(pthread_self(), sizeof(all), &all) != 0) {
      std::fprintf(stderr, "per-cpu: cannot restore this thread's CPU mask\n");
      return;
    }
    sc.settings.threads = threads;
    const double together = rate();
    double sum = 0.0, fastest = 0.0;
    std::printf("round %d  1 thread pinned:", r + 1);
    for (std::size_t i = 0; i < cpus.size(); ++i) {
      std::printf(" cpu %d %.0f/s", cpus[i], alone[i]);
      sum += alone[i];
      fastest = std::max(fastest, alone[i]);
    }
    std::printf(
        "\n         %d threads %.0f/s: %.2f x the fastest CPU (bound %.2f x), efficiency %.3f of "
        "the pinned sum\n",
        threads, together, together / fastest, sum / fastest, together / sum);
  }
}

double total_impacts(const run::RunResult& r) {
  double s = 0.0;
  for (const auto& b : r.buildings) s += b.impacts.mean;
  return s;
}

// Largest |difference| of the PTN density over all triangles, relative to the largest density.
double max_density_error(const run::RunResult& r, const run::RunResult& ref) {
  double e = 0.0;
  for (std::size_t t = 0; t < r.ptn_density_per_m2.size(); ++t)
    e = std::max(e, std::abs(r.ptn_density_per_m2[t] - ref.ptn_density_per_m2[t]));
  return ref.max_ptn_density_per_m2 > 0.0 ? e / ref.max_ptn_density_per_m2 : e;
}

void sweep_rtol(run::Scenario sc, const std::shared_ptr<const scene::Site>& site) {
  sc.settings.threads = 1;
  sc.settings.profile = false;
  sc.settings.rtol = 1e-10;
  const run::RunResult ref = run::run(sc, site, g_control);
  std::printf(
      "\n# rtol sweep, 1 thread, reference rtol 1e-10: HFD %.2f m, max density %.4f /m2, "
      "building impacts %.4f\n",
      ref.hazardous_fragment_distance_m, ref.max_ptn_density_per_m2, total_impacts(ref));
  std::printf(
      "rtol     us/fragment  rhs/frag  |dHFD| m  max|dD|/Dmax  |d impacts|  "
      "HFD se band (m)\n");
  for (double rtol : {1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8}) {
    sc.settings.rtol = rtol;
    const run::RunResult r = run::run(sc, site, g_control);
    const double n = static_cast<double>(r.histories_done);
    std::printf("%.0e  %11.2f  %8.1f  %8.3f  %12.3e  %11.3e  %.1f .. %.1f\n", rtol,
                1e6 * r.timing.wall_s / n, static_cast<double>(r.stats.rhs_evaluations) / n,
                std::abs(r.hazardous_fragment_distance_m - ref.hazardous_fragment_distance_m),
                max_density_error(r, ref), std::abs(total_impacts(r) - total_impacts(ref)),
                r.hfd_lower_m, r.hfd_upper_m);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = std::string(FRAGSIM_SOURCE_DIR) + "/examples/demo/scenario.json";
  int repeat = 3;
  bool one_thread = false;
  bool rtol_sweep = false;
  bool bounce = false, rigid_ground = false, ratio = false, lanes = false, cpus = false;
  double samples_scale = 1.0;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeat") == 0 && i + 1 < argc) {
      repeat = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--rtol-sweep") == 0) {
      rtol_sweep = true;
    } else if (std::strcmp(argv[i], "--one-thread") == 0) {
      one_thread = true;
    } else if (std::strcmp(argv[i], "--bounce") == 0) {
      bounce = true;
    } else if (std::strcmp(argv[i], "--rigid-ground") == 0) {
      rigid_ground = true;
    } else if (std::strcmp(argv[i], "--bounce-ratio") == 0) {
      ratio = true;
    } else if (std::strcmp(argv[i], "--serial-histories") == 0) {
      g_control.serial_histories = true;
    } else if (std::strcmp(argv[i], "--lanes-ratio") == 0) {
      lanes = true;
    } else if (std::strcmp(argv[i], "--per-cpu") == 0) {
      cpus = true;
    } else if (std::strcmp(argv[i], "--samples-scale") == 0 && i + 1 < argc) {
      samples_scale = std::atof(argv[++i]);
    } else {
      path = argv[i];
    }
  }
  std::ifstream in(path);
  if (!in) {
    std::fprintf(stderr, "cannot open %s\n", path.c_str());
    return 1;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  run::Scenario sc = api::parse_scenario_text(ss.str());
  sc.settings.record_fragments = false;
  sc.settings.record_trajectories = false;
  sc.settings.bounce = bounce;
  for (auto& g : sc.groups)
    g.samples =
        std::max<std::int64_t>(1, std::llround(static_cast<double>(g.samples) * samples_scale));
  if (rigid_ground)
    for (auto& [name, m] : sc.site.materials) {
      m.embedment.reset();
      m.fast_contact.reset();
    }
  auto site = scene::Site::build(sc.site);
  std::printf("# %s%s%s\n# terrain triangles %zu, buildings %zu, hardware threads %u\n",
              path.c_str(), bounce ? " (bounce on)" : "", rigid_ground ? " (rigid ground)" : "",
              site->terrain_triangle_count(), site->buildings().size(),
              std::thread::hardware_concurrency());
  if (ratio) {
    bounce_ratio(sc, site, repeat);
    return 0;
  }
  if (lanes) {
    lanes_ratio(sc, site, repeat);
    return 0;
  }
  if (cpus) {
    per_cpu(sc, site, repeat);
    return 0;
  }

  const int all = static_cast<int>(std::thread::hardware_concurrency());
  for (int threads : {1, all}) {
    if (one_thread && threads != 1) break;
    run::RunResult best;
    double best_cpu_s = 0.0;
    for (int k = 0; k < repeat; ++k) {
      sc.settings.threads = threads;
      sc.settings.profile = false;
      const std::clock_t c0 = std::clock();
      run::RunResult r = run::run(sc, site, g_control);
      const double cpu_s = static_cast<double>(std::clock() - c0) / CLOCKS_PER_SEC;
      if (k == 0 || cpu_s < best_cpu_s) best_cpu_s = cpu_s;
      if (k == 0 || r.timing.wall_s < best.timing.wall_s) best = std::move(r);
    }
    print_row(threads == 1 ? "1 thread (best of N)" : "all threads (best of N)", best);
    // Process CPU time: a steadier figure than wall time when the machine is shared.
    std::printf("%-22s best CPU time %.3f s: %.0f fragments per CPU-second\n", "", best_cpu_s,
                static_cast<double>(best.histories_done) / best_cpu_s);
    if (threads == 1) print_results(best);
  }
  if (one_thread) return 0;
  sc.settings.threads = 1;
  sc.settings.profile = true;
  const run::RunResult p = run::run(sc, site, g_control);
  const double split = p.timing.integration_s + p.timing.geometry_s + p.timing.tally_s;
  std::printf(
      "profile (1 thread)     wall %.3f s: integration %.3f s (%.0f%%), geometry %.3f s "
      "(%.0f%%), tally %.3f s (%.0f%%), rest (sampling, bookkeeping, timers) %.3f s\n",
      p.timing.wall_s, p.timing.integration_s, 100 * p.timing.integration_s / p.timing.wall_s,
      p.timing.geometry_s, 100 * p.timing.geometry_s / p.timing.wall_s, p.timing.tally_s,
      100 * p.timing.tally_s / p.timing.wall_s, p.timing.wall_s - split);
  if (rtol_sweep) sweep_rtol(sc, site);
  return 0;
}
