// Histories in lanes (core/run/lane_runner.h): whole runs give the same bits as one history at a
// time (with and without bounce, records and trajectories included, at 1 and 2 threads and odd
// chunk sizes); the runner ends every job, reports them in order, passes a job's exception to
// its caller and stays usable after it.
#include "core/run/lane_runner.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <new>
#include <stdexcept>
#include <vector>

#include "core/flight/trajectory.h"
#include "core/run/run.h"
#include "core/run/run_fixtures.h"

namespace fragsim::run {
namespace {

using testing::expect_same_figures;
using testing::mixed_scenario;

RunResult run_with(Scenario sc, bool serial, int threads, std::int64_t chunk) {
  sc.settings.threads = threads;
  sc.settings.chunk_histories = chunk;
  RunControl control;
  control.serial_histories = serial;
  return run(sc, control);
}

TEST(HistoriesInLanes, GiveTheSameBitsAsOneHistoryAtATime) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build: histories run one at a time";
  for (const bool bounce : {false, true}) {
    Scenario sc = mixed_scenario(1201, 799);
    sc.settings.bounce = bounce;
    sc.settings.record_trajectories = true;
    const RunResult serial = run_with(sc, true, 1, 256);
    ASSERT_GT(serial.max_ptn_density_per_m2, 0.0);
    ASSERT_FALSE(serial.trajectories.empty());
    for (const auto& [threads, chunk] : {std::pair{1, 256}, std::pair{2, 7}, std::pair{2, 1000}}) {
      SCOPED_TRACE(::testing::Message()
                   << "bounce " << bounce << ", threads " << threads << ", chunk " << chunk);
      const RunResult lanes = run_with(sc, false, threads, chunk);
      expect_same_figures(serial, lanes);
      EXPECT_EQ(serial.stats.rhs_evaluations, lanes.stats.rhs_evaluations);
      EXPECT_EQ(serial.stats.chords, lanes.stats.chords);
    }
  }
}

// A drag flight of path length ~ `length` m in s, as a job: it posts one attempt per step.
struct Flights {
  flight::Atmosphere air{flight::AtmosphereSpec{}};
  flight::DragCoefficient cd{[] {
    fragments::CdSpec s;
    s.constant = 1.2;
    return s;
  }()};
  flight::FlightModel model{&air, &cd, kStandardGravity_mps2, 1e-3, 0.03, 0.0};
  // End state's first component after `steps` steps from a speed depending on i.
  double fly(std::int64_t i, int steps) const {
    flight::Dopri5Options opt;
    opt.rtol = opt.atol = 1e-6;
    flight::Dopri5<7, flight::TrajectoryIntegrator::ArcRhs> ode(
        flight::TrajectoryIntegrator::ArcRhs{model}, opt);
    Eigen::Matrix<double, 7, 1> y;
    y << 0, 0, 1, 300.0 + 10.0 * static_cast<double>(i), 0, 20, 0;
    ode.reset(0.0, y);
    for (int s = 0; s < steps; ++s) ode.step(1e9);
    return ode.y()[0];
  }
};

TEST(LaneRunner, EndsEveryJobAndReportsThemInOrderWithTheScalarBits) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build";
  const Flights f;
  constexpr std::int64_t kJobs = 37;
  auto steps = [](std::int64_t i) { return static_cast<int>(1 + (i * 7) % 13); };
  std::vector<double> serial(kJobs), lanes(kJobs, -1.0);
  for (std::int64_t i = 0; i < kJobs; ++i) serial[i] = f.fly(i, steps(i));
  std::vector<std::int64_t> order;
  LaneRunner runner;
  runner.run(
      kJobs,
      [&](std::int64_t i, int lane) {
        EXPECT_GE(lane, 0);
        EXPECT_LT(lane, flight::kLanes);
        lanes[static_cast<std::size_t>(i)] = f.fly(i, steps(i));
        return true;
      },
      [&](std::int64_t i) { order.push_back(i); });
  ASSERT_EQ(order.size(), static_cast<std::size_t>(kJobs));
  for (std::int64_t i = 0; i < kJobs; ++i) {
    EXPECT_EQ(order[static_cast<std::size_t>(i)], i);
    EXPECT_EQ(serial[static_cast<std::size_t>(i)], lanes[static_cast<std::size_t>(i)]) << i;
  }
  // Several lanes were busy at once: fewer kernel calls than attempts.
  EXPECT_GT(runner.lane_attempts(), 2 * runner.kernel_calls());
  EXPECT_EQ(flight::thread_attempt_lanes, nullptr);  // the hook is cleared after the run
}

TEST(LaneRunner, AJobsExceptionReachesTheCallerAndTheRunnerStaysUsable) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build";
  const Flights f;
  LaneRunner runner;
  std::vector<std::int64_t> done;
  EXPECT_THROW(runner.run(
                   20,
                   [&](std::int64_t i, int) {
                     f.fly(i, 3);
                     if (i == 5) throw std::runtime_error("job 5");
                     return true;
                   },
                   [&](std::int64_t i) { done.push_back(i); }),
               std::runtime_error);
  for (const std::int64_t i : done) EXPECT_LT(i, 5);  // nothing reported past the failed job
  EXPECT_EQ(flight::thread_attempt_lanes, nullptr);
  std::int64_t count = 0;
  runner.run(
      9,
      [&](std::int64_t i, int) {
        f.fly(i, 2);
        return true;
      },
      [&](std::int64_t) { ++count; });
  EXPECT_EQ(count, 9);
}

TEST(LaneRunner, NoJobStartsAWindowAheadOfTheOldestUnreportedOne) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build";
  const Flights f;
  LaneRunner runner;
  constexpr std::int64_t kJobs = 3 * LaneRunner::kWindow;
  std::int64_t reported = 0, furthest_ahead = 0;
  std::vector<std::int64_t> order;
  runner.run(
      kJobs,
      [&](std::int64_t i, int) {
        furthest_ahead = std::max(furthest_ahead, i - reported);
        f.fly(i, i == 0 ? 400 : 1);  // job 0 holds the oldest place for a long time
        return true;
      },
      [&](std::int64_t i) {
        order.push_back(i);
        reported = i + 1;
      });
  ASSERT_EQ(order.size(), static_cast<std::size_t>(kJobs));
  for (std::int64_t i = 0; i < kJobs; ++i) EXPECT_EQ(order[static_cast<std::size_t>(i)], i);
  EXPECT_EQ(furthest_ahead, LaneRunner::kWindow - 1);  // the window is used, and not exceeded
}

TEST(LaneRunner, AnExceptionFromDoneReachesTheCaller) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build";
  const Flights f;
  LaneRunner runner;
  EXPECT_THROW(runner.run(
                   12,
                   [&](std::int64_t i, int) {
                     f.fly(i, 2);
                     return true;
                   },
                   [](std::int64_t i) {
                     if (i == 3) throw std::bad_alloc();
                   }),
               std::bad_alloc);
  EXPECT_EQ(flight::thread_attempt_lanes, nullptr);
}

TEST(LaneRunner, AJobReturningFalseStopsTheTakingOfNewJobs) {
  if (!kHistoryLanesBuilt) GTEST_SKIP() << "sanitizer build";
  const Flights f;
  LaneRunner runner;
  std::int64_t started = 0;
  runner.run(
      100,
      [&](std::int64_t i, int) {
        ++started;
        f.fly(i, 2);
        return i < 10;
      },
      [](std::int64_t) {});
  EXPECT_LE(started, 10 + flight::kLanes);
}

}  // namespace
}  // namespace fragsim::run
