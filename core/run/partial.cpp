#include "core/run/partial.h"

#include <algorithm>
#include <iterator>
#include <stdexcept>
#include <string>
#include <tuple>

#include "core/common/error.h"
#include "core/run/bracket.h"
#include "core/run/figures.h"

// Merging shards' partials and finishing them into a result (core/run/partial.h).
namespace fragsim::run {

namespace {

// "shard 1 of 3 missing", "shards 0, 2, 5, ... (7 of 9) missing".
std::string missing_shards(const PartialRun& p) {
  std::vector<std::int64_t> missing;
  for (std::int64_t k = 0, i = 0; k < p.shard_count && missing.size() < 8; ++k) {
    while (i < static_cast<std::int64_t>(p.shards.size()) &&
           p.shards[static_cast<std::size_t>(i)] < k)
      ++i;
    if (i == static_cast<std::int64_t>(p.shards.size()) ||
        p.shards[static_cast<std::size_t>(i)] != k)
      missing.push_back(k);
  }
  const std::int64_t count = p.shard_count - static_cast<std::int64_t>(p.shards.size());
  const std::string total = std::to_string(p.shard_count);
  if (count == 1) return "shard " + std::to_string(missing[0]) + " of " + total + " missing";
  std::string list;
  for (const std::int64_t k : missing) list += (list.empty() ? "" : ", ") + std::to_string(k);
  if (count > static_cast<std::int64_t>(missing.size())) list += ", ...";
  return "shards " + list + " (" + std::to_string(count) + " of " + total + ") missing";
}

// a += b for counts from partial files: a sum out of range is a damaged or forged partial.
void add_count(std::int64_t& a, std::int64_t b) {
  if (__builtin_add_overflow(a, b, &a))
    throw InputError("shards", "counts out of range (a damaged or forged partial)");
}

}  // namespace

void merge(PartialRun& into, PartialRun&& other) {
  if (into.shard_count != other.shard_count)
    throw InputError("shards", "partials of different splits (" + std::to_string(into.shard_count) +
                                   " and " + std::to_string(other.shard_count) + " shards)");
  if (into.tally.size() != other.tally.size() ||
      into.tally.partitions() != other.tally.partitions())
    throw InputError("shards", "partials of different sites or settings");
  for (const std::int64_t k : other.shards)
    if (std::find(into.shards.begin(), into.shards.end(), k) != into.shards.end())
      throw InputError("shards", "shard " + std::to_string(k) + " is there twice");
  // On a throw `into` gets back what it held: unchanged when a piece of a stratum does not fit
  // (checked before any sum moves), partly merged when an exact sum overflows midway (only a
  // forged partial can do that; every caller then discards `into`).
  PartialRun sum = std::move(into);
  try {
    sum.tally.merge(other.tally);
  } catch (const std::overflow_error& e) {
    into = std::move(sum);
    throw InputError("shards", std::string(e.what()) + " (a damaged or forged partial)");
  }
  sum.shards.insert(sum.shards.end(), other.shards.begin(), other.shards.end());
  std::sort(sum.shards.begin(), sum.shards.end());
  for (std::size_t o = 0; o < kOutcomeCount; ++o)
    add_count(sum.outcome_histories[o], other.outcome_histories[o]);
  add_count(sum.left_hazardous_histories, other.left_hazardous_histories);
  add_count(sum.histories_done, other.histories_done);
  add_count(sum.pilot_histories, other.pilot_histories);
  for (const auto m : RunStats::counters()) add_count(sum.stats.*m, other.stats.*m);
  sum.batches = std::max(sum.batches, other.batches);
  sum.tallied_batches = std::max(sum.tallied_batches, other.tallied_batches);
  sum.cancelled = sum.cancelled || other.cancelled;
  if (sum.cancelled) sum.stop_reason = StopReason::kCancelled;
  std::move(other.records.begin(), other.records.end(), std::back_inserter(sum.records));
  std::move(other.trajectories.begin(), other.trajectories.end(),
            std::back_inserter(sum.trajectories));
  sum.integration_s += other.integration_s;
  sum.geometry_s += other.geometry_s;
  sum.tally_s += other.tally_s;
  sum.wall_s = std::max(sum.wall_s, other.wall_s);
  if (__builtin_add_overflow(sum.threads, other.threads, &sum.threads))
    throw InputError("shards", "thread counts out of range (a damaged or forged partial)");
  into = std::move(sum);
}

void merge(BatchState& into, BatchState&& other) {
  if (into.batch != other.batch)
    throw InputError("shards", "states of different batches (" + std::to_string(into.batch) +
                                   " and " + std::to_string(other.batch) + ")");
  merge(into.part, std::move(other.part));
  into.elapsed_s = std::max(into.elapsed_s, other.elapsed_s);
  for (auto& l : other.learnt) into.learnt.push_back(std::move(l));
  std::stable_sort(into.learnt.begin(), into.learnt.end(),
                   [](const auto& a, const auto& b) { return a.shard < b.shard; });
}

RunResult finish(const Scenario& sc, const scene::Site& site, PartialRun p,
                 const RunControl& control) {
  RunResult r = finish_tally(sc, site, std::move(p));
  // settings.ground_bracket: the whole study is done; its variants are runs of their own.
  if (sc.settings.ground_bracket && !r.cancelled)
    r.ground_bracket = run_ground_bracket(sc, control);
  return r;
}

RunResult finish_tally(const Scenario& sc, const scene::Site& site, PartialRun p) {
  if (!p.cancelled && static_cast<std::int64_t>(p.shards.size()) != p.shard_count)
    throw InputError("shards", missing_shards(p));
  try {
    if (p.cancelled) p.tally.close_open_strata();  // the strata a cancellation cut short
  } catch (const std::overflow_error& e) {
    throw InputError("shards", std::string(e.what()) + " (a damaged or forged partial)");
  }
  if (!p.tally.open_strata().empty())
    throw InputError("shards", "partials do not cover the run's histories");
  RunResult r;
  r.cancelled = p.cancelled;
  std::int64_t histories = 0;
  for (const auto& g : sc.groups) {
    histories += g.samples;
    r.real_fragments += g.count;
  }
  const std::int64_t max_batches =
      sc.settings.precision ? std::max<std::int64_t>(1, sc.settings.precision->max_batches) : 1;
  r.samples = r.cancelled ? histories * max_batches : histories * p.tallied_batches;
  r.histories_done = p.histories_done + p.pilot_histories;
  r.pilot_histories = p.pilot_histories;
  r.seed = sc.settings.seed;
  r.batches = r.cancelled ? p.batches + 1 : p.batches;  // the partial batch counts (one's estimate)
  r.stop_reason = p.stop_reason;
  r.precision = p.precision;
  r.stats = p.stats;
  r.timing.wall_s = p.wall_s;
  r.timing.threads = p.threads;
  r.timing.integration_s = p.integration_s;
  r.timing.geometry_s = p.geometry_s;
  r.timing.tally_s = p.tally_s;
  if (r.timing.wall_s > 0.0) {
    r.timing.fragments_per_s = static_cast<double>(r.histories_done) / r.timing.wall_s;
    r.timing.fragments_per_s_per_thread = r.timing.fragments_per_s / r.timing.threads;
  }
  // A cancelled run's figures are never shown (callers write nothing for it, and `fragsim
  // merge` and fragsimd refuse a cancelled shard's partial): its counts are enough, and a cancel
  // returns without the figures' work or sorting millions of records (seconds under TSan: a cancel
  // must end within a second, docs/http-api.md).
  if (r.cancelled) return r;
  fill_figures(sc, site, p, p.tallied_batches, r);
  auto by_history = [](const auto& a, const auto& b) {
    return std::tie(a.group, a.history) < std::tie(b.group, b.history);
  };
  // One process's records of one batch arrive in this order already (chunk order).
  if (!std::is_sorted(p.records.begin(), p.records.end(), by_history))
    std::sort(p.records.begin(), p.records.end(), by_history);
  std::sort(p.trajectories.begin(), p.trajectories.end(), by_history);
  r.fragments = std::move(p.records);
  r.trajectories = std::move(p.trajectories);
  return r;
}

}  // namespace fragsim::run
