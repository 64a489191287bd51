#include "core/run/shard_runner.h"

#include <algorithm>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>

#include "core/common/error.h"
#include "core/run/lane_runner.h"

namespace fragsim::run {

namespace {

void check_shard(const Scenario& sc, const Shard& shard, const RunControl& control) {
  if (shard.count < 1 || shard.index < 0 || shard.index >= shard.count)
    throw InputError("shard", "must be I/N with 0 <= I < N (got " + std::to_string(shard.index) +
                                  "/" + std::to_string(shard.count) + ")");
  if (shard.count > 1 && sc.settings.precision && control.synchronizer == nullptr)
    throw InputError("settings.precision",
                     "cannot be split into independent shards: its checks at batch boundaries "
                     "need every history of a batch (divide it with fragsim-mpi, whose ranks "
                     "exchange each batch)");
}

// Adds the tallies and history counts of `from` into `into` (exact sums: any order).
void add_tallies(PartialRun& into, const PartialRun& from) {
  into.tally.merge(from.tally);
  for (std::size_t o = 0; o < kOutcomeCount; ++o)
    into.outcome_histories[o] += from.outcome_histories[o];
  into.left_hazardous_histories += from.left_hazardous_histories;
  into.histories_done += from.histories_done;
  into.pilot_histories += from.pilot_histories;
}

}  // namespace

ShardRunner::ShardRunner(const Scenario& sc, std::shared_ptr<const scene::Site> site,
                         const Shard& shard, const RunControl& control)
    : sc_(sc),
      site_(std::move(site)),
      control_(control),
      shard_(shard),
      sync_(sc.settings.precision ? control.synchronizer : nullptr),
      ctx_(sc, *site_),
      plan_(plan_batches(sc, shard)),
      per_batch_(static_cast<std::int64_t>(plan_.chunks.size())),
      total_(plan_.histories * plan_.max_batches),
      group_offset_(sc.groups.size(), 0),
      strata_(sc),
      reducer_(sc, *site_, strata_, part_),
      precision_(sc, *site_, sync_ != nullptr ? global_ : part_),
      report_every_ns_(static_cast<std::int64_t>(std::max(0.0, control.progress_interval_s) * 1e9)),
      pipeline_(plan_.total_chunks(), thread_count(sc.settings, plan_.total_chunks()), stages()) {
  // Trajectories are recorded for the first max_recorded_trajectories histories in global order.
  for (std::size_t g = 1; g < sc.groups.size(); ++g)
    group_offset_[g] = group_offset_[g - 1] + sc.groups[g - 1].samples;
  part_.shard_count = shard.count;
  part_.shards = {shard.index};
  // One batch's records at once: the fold appends each chunk's without moving the ones before.
  if (sc.settings.record_fragments)
    part_.records.reserve(static_cast<std::size_t>(plan_.histories));
  if (sync_) {
    global_.shard_count = shard.count;
    global_.tally =
        tally::StratifiedTally(part_.tally.size(), static_cast<int>(part_.tally.partitions()));
  }
  const Settings& st = sc.settings;
  if (st.precision && st.precision->direction_importance) {
    learner_ = std::make_unique<DirectionLearner>(sc, *site_, precision_.distances());
    plans_.publish(0, drawable(learner_->pilot(), strata_));
  }
  if (strata_.on() && !strata_.sobol() && !learner_)  // about one equal cell per stratum
    for (std::uint32_t g = 0; g < sc.groups.size(); ++g)
      strata_cells_.push_back(fragments::DirectionCells::for_strata(
          strata_.strata(g), sc.groups[g].direction, st.stratified_launch->speed));
}

PartialRun ShardRunner::run() {
  if (sync_ && plan_.chunks.empty())
    idle_batches();
  else
    pipeline_.run();
  return finish();
}

// The pipeline's stages: a worker's chunk is its batch's cells, then its histories; the fold and
// the count are this runner's.
ShardRunner::Pipeline::Stages ShardRunner::stages() {
  Pipeline::Stages s;
  s.produce = [this](std::int64_t k, WorkerScratch& scratch, ChunkOutput& out) {
    const SamplingPlans::Cells* cells = nullptr;
    if (!batch_cells(k / per_batch_, cells) || !simulate_chunk(k, cells, scratch.history, out))
      return false;
    prefold(k, out, scratch.fold);
    return true;
  };
  s.fold = [this](ChunkOutput& c) { fold(c); };
  s.submitted = [this](std::int64_t k) {
    count_done(plan_.chunks[static_cast<std::size_t>(k % per_batch_)].count);
  };
  s.on_error = [this] { plans_.abort(); };
  return s;
}

// The launch cells of a batch's draws: the fixed strata cells, or the importance-sampling plan
// published for the batch (waited for). False when the run ends or is cancelled meanwhile.
bool ShardRunner::batch_cells(std::int64_t batch, const SamplingPlans::Cells*& cells) {
  cells = strata_cells_.empty() ? nullptr : &strata_cells_;
  if (!learner_) return true;
  cells = plans_.get(batch, [this] { return cancelled(); });
  if (cells != nullptr) return true;
  if (cancelled()) pipeline_.stop();
  return false;
}

// Simulates chunk k of the run (chunk k % per_batch of batch k / per_batch) into `out`. False
// when cancelled midway: the unfinished chunk is dropped, so the folded chunks form a clean
// prefix.
bool ShardRunner::simulate_chunk(std::int64_t k, const SamplingPlans::Cells* cells,
                                 HistoryScratch& scratch, ChunkOutput& out) {
  const std::int64_t batch = k / per_batch_;
  const ChunkSpec& cs = plan_.chunks[static_cast<std::size_t>(k % per_batch_)];
  const fragments::FragmentGroupSpec& group = sc_.groups[cs.group];
  const std::int64_t batch_first = batch * group.samples;
  const std::int64_t first = batch_first + cs.first;
  const Settings& st = sc_.settings;
  out = chunk_output(cs, first, group);
  // History h into `into`, with `scratch`; false when the run is cancelled.
  auto history = [&](std::int64_t h, HistoryScratch& hs, ChunkOutput& into) {
    if (cancelled()) return false;
    const bool record = st.record_trajectories && batch == (learner_ ? 1 : 0) &&
                        group_offset_[cs.group] + h < st.max_recorded_trajectories;
    const fragments::LaunchStratum ls =
        strata_.on() ? strata_.of(cs.group, h - batch_first, batch) : fragments::LaunchStratum{};
    simulate_history(ctx_, cs.group, h, record, hs, into, cells ? &(*cells)[cs.group] : nullptr,
                     strata_.on() ? &ls : nullptr);
    return true;
  };
  bool complete = true;
  // settings.profile times sections of one history; in lanes a section's clock would also run
  // while the other lanes compute, so a profiled run takes its histories one at a time.
  if (control_.serial_histories || st.profile || !kHistoryLanesBuilt) {
    for (std::int64_t h = first; h < first + cs.count && complete; ++h)
      complete = history(h, scratch, out);
  } else {
    complete = simulate_in_lanes(first, cs.count, history, out);
  }
  if (!complete) pipeline_.stop();
  return complete;
}

// The chunk's histories flight::kLanes at a time (core/run/lane_runner.h), each into its own
// piece of output, appended to `out` in history order. The runner, the lanes' scratch and the
// pieces are the worker thread's, kept between chunks and runs.
bool ShardRunner::simulate_in_lanes(
    std::int64_t first, std::int64_t count,
    const std::function<bool(std::int64_t, HistoryScratch&, ChunkOutput&)>& history,
    ChunkOutput& out) {
  struct Lanes {
    LaneRunner runner;
    HistoryScratch scratch[flight::kLanes];
    ChunkOutput pieces[LaneRunner::kWindow];  // history i's at i % kWindow
  };
  static thread_local Lanes lanes;
  // A cancelled or failed chunk leaves pieces unappended: none may reach the next chunk.
  for (ChunkOutput& piece : lanes.pieces) clear_histories(piece);
  auto piece = [&](std::int64_t i) -> ChunkOutput& {
    return lanes.pieces[i % LaneRunner::kWindow];
  };
  bool complete = true;
  lanes.runner.run(
      count,
      [&](std::int64_t i, int lane) {
        // Not `complete = complete && history(...)`: the history yields to the other lanes, and
        // a flag read before it would overwrite what they set meanwhile.
        if (history(first + i, lanes.scratch[lane], piece(i))) return true;
        complete = false;
        return false;
      },
      [&](std::int64_t i) { append_histories(out, piece(i)); });
  return complete;
}

// On the worker, after chunk k's histories: their tally pieces, as fold() will take them. A
// pilot's chunk is batch 0's with a learner: the learner's plan for batch 1 is published only
// after the pilot's boundary, so no later chunk is folded before it.
void ShardRunner::prefold(std::int64_t k, ChunkOutput& c, FoldScratch& s) const {
  const bool pilot = learner_ && k / per_batch_ == 0;
  if (!pilot || precision_.wants_pilot_density()) reducer_.prefold(c, s, pilot);
}

// Under the fold's lock, in chunk order (never after the pipeline is finished).
void ShardRunner::fold(ChunkOutput& c) {
  const bool pilot = learner_ && batches_ == 0;
  if (pilot != (learner_ && c.first_history < sc_.groups[c.group].samples))
    throw std::logic_error("a chunk folded as a pilot's that was not prefolded as one");
  if (learner_) learn(*learner_, c, sync_ != nullptr ? &learnt_ : nullptr);
  folded_ += c.count;
  if (pilot) {
    part_.pilot_histories += c.count;
    if (precision_.wants_pilot_density()) reducer_.fold_pilot(c);
  } else {
    if (control_.on_chunk) control_.on_chunk(c);
    reducer_.fold(c);
  }
  if (c.last_of_batch) end_batch(pilot);
}

// At a batch boundary: the precision targets decide whether the run ends here; if not, the
// importance learner's plan for the next batch is published.
void ShardRunner::end_batch(bool pilot) {
  double elapsed = std::chrono::duration<double>(Clock::now() - t_start_).count();
  if (sync_ && !exchange_batch(elapsed)) return;
  ++batches_;
  pilot_batches_ += pilot ? 1 : 0;
  const PartialRun& all = sync_ != nullptr ? global_ : part_;
  if (precision_.batch_done(batches_, batches_ - pilot_batches_,
                            all.histories_done + all.pilot_histories, elapsed)) {
    pipeline_.finish();
    plans_.abort();
  } else if (learner_) {
    if (pilot) {  // its density has placed the HFD ring (PrecisionControl::batch_done)
      part_.tally.clear();
      global_.tally.clear();
    }
    plans_.publish(
        batches_,
        drawable(learner_->plan(precision_.hfd_m(), precision_.ring_triangles()), strata_));
  }
}

// A divided run's batch boundary: hands this shard's batch (tally, counts, learner input) to the
// synchronizer and absorbs every shard's, merged, into global_ and the learner; `elapsed` becomes
// the longest shard's. False when the run stops instead (the batch stays in part_).
bool ShardRunner::exchange_batch(double& elapsed) {
  BatchState mine;
  mine.batch = batches_;
  mine.elapsed_s = elapsed;
  PartialRun& b = mine.part;
  b.shard_count = part_.shard_count;
  b.shards = part_.shards;
  b.outcome_histories = part_.outcome_histories;
  b.left_hazardous_histories = part_.left_hazardous_histories;
  b.histories_done = part_.histories_done;
  b.pilot_histories = part_.pilot_histories;
  b.tally = std::move(part_.tally);
  mine.learnt.push_back({shard_.index, std::move(learnt_)});
  std::optional<BatchState> all;
  try {
    all = sync_->exchange(mine);
  } catch (...) {
    part_.tally = std::move(b.tally);
    throw;
  }
  part_.tally = std::move(b.tally);
  learnt_ = std::move(mine.learnt.front().input);
  if (!all) {
    pipeline_.stop();
    plans_.abort();
    return false;
  }
  part_.tally.clear();
  learnt_.clear();
  part_.outcome_histories = {};
  part_.left_hazardous_histories = part_.histories_done = part_.pilot_histories = 0;
  absorb(*all);
  elapsed = all->elapsed_s;
  return true;
}

// Adds every shard's batch to global_ and, in shard order (for each group: the order of its
// histories in one process), to the learner.
void ShardRunner::absorb(const BatchState& all) {
  const PartialRun& b = all.part;
  if (all.batch != batches_ || b.shard_count != shard_.count ||
      static_cast<std::int64_t>(b.shards.size()) != shard_.count)
    throw std::runtime_error("a batch boundary without every shard's batch (batch " +
                             std::to_string(all.batch) + ", " + std::to_string(b.shards.size()) +
                             " of " + std::to_string(shard_.count) + " shards)");
  add_tallies(global_, b);
  if (learner_)
    for (const BatchState::Learnt& l : all.learnt) learner_->replay(l.input);
}

// A shard of a divided run that holds no history still takes part in every batch boundary.
void ShardRunner::idle_batches() {
  while (!pipeline_.finished() && !pipeline_.stopped()) {
    if (cancelled()) {
      pipeline_.stop();
      break;
    }
    end_batch(learner_ && batches_ == 0);
  }
}

// Counts a simulated chunk's histories and reports progress at most every progress_interval_s.
void ShardRunner::count_done(std::int64_t histories) {
  const std::int64_t done = histories_done_.fetch_add(histories) + histories;
  if (!control_.on_progress) return;
  const std::int64_t now =
      std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - t_start_).count();
  std::int64_t last = last_report_ns_.load();
  if (now - last >= report_every_ns_ && last_report_ns_.compare_exchange_strong(last, now))
    progress(done, static_cast<double>(now) * 1e-9);
}

void ShardRunner::progress(std::int64_t done, double elapsed_s) const {
  Progress p;
  p.histories_done = done;
  p.histories_total = total_;
  p.elapsed_s = elapsed_s;
  p.precision = precision_.report();
  control_.on_progress(p);
}

// The shard's partial result, once the workers have stopped.
PartialRun ShardRunner::finish() {
  PartialRun& part = part_;
  part.cancelled = !pipeline_.finished() && (cancelled() || pipeline_.stopped());
  part.tallied_batches = batches_ - pilot_batches_;
  if (learner_ && part.tallied_batches == 0) part.tally.clear();  // a pilot's density only
  // A shard without histories has no batch to fold (unless the shards run each batch together).
  const bool idle = plan_.chunks.empty() && sync_ == nullptr;
  part.batches = idle && !part.cancelled ? 1 : batches_;
  if (idle) part.tallied_batches = part.batches;
  if (sync_ != nullptr && shard_.index == 0) {  // every shard's completed batches
    add_tallies(part, global_);
  }
  part.stop_reason = part.cancelled ? StopReason::kCancelled : precision_.reason();
  part.precision = precision_.report();
  part.wall_s = std::chrono::duration<double>(Clock::now() - t_start_).count();
  part.threads = pipeline_.threads();
  if (control_.on_progress) progress(folded_, part.wall_s);
  return std::move(part);
}

PartialRun run_partial(const Scenario& sc, std::shared_ptr<const scene::Site> site,
                       const Shard& shard, const RunControl& control) {
  check_shard(sc, shard, control);
  ShardRunner runner(sc, std::move(site), shard, control);
  return runner.run();
}

}  // namespace fragsim::run
