#include "formats/partial_file.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <type_traits>

#include "core/common/error.h"
#include "core/run/precision.h"

namespace fragsim::formats {

namespace {

constexpr std::string_view kMagic = "FSPART01";
// 2: the hazardous fragments that left the site (a count and kLeftSiteBins more tally bins), a
// precision target's `unmeetable` and `note`, stop reason targets_unmeetable.
// 3 (issue 23): outcome ground_step_cap (one more outcome count and tally bin, before the
// left-site bins); stats energy_rises, fast_contacts and fast_slides (three more counters); the
// density fields per PTN mechanism and per fragment group (core/run/attribution.h: 3 x
// triangles + kept groups x triangles more tally bins).
constexpr std::uint32_t kVersion = 3;
constexpr std::size_t kTrailer = kPartialTrailerBytes;

static_assert(std::endian::native == std::endian::little, "partial files are little-endian");

class Writer {
 public:
  template <class T>
  void put(T v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&v);
    out_.append(p, sizeof(T));
  }
  void put_string(std::string_view s) {
    put<std::uint64_t>(s.size());
    out_.append(s);
  }
  void put_sum(const tally::ExactSum& s) {
    for (const std::uint64_t l : s.limbs()) put(l);
  }
  void put_vec3(const Vec3& v) {
    put(v.x());
    put(v.y());
    put(v.z());
  }
  std::string take() { return std::move(out_); }

  // The shared field list of records (record_fields): written here, read by Reader.
  template <class T>
  void field(const T& v) {
    put(v);
  }
  void field(const Vec3& v) { put_vec3(v); }
  void field(const bool& b) { put(static_cast<std::uint8_t>(b)); }
  template <class E>
  void code(const E& e, int, const char*) {
    put(static_cast<std::uint8_t>(e));
  }

 private:
  std::string out_;
};

class Reader {
 public:
  Reader(std::string_view bytes, const std::string& what) : b_(bytes), what_(what) {}
  template <class T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  // A count of items of `item_bytes` each that must fit in the bytes left.
  std::uint64_t count(std::size_t item_bytes) {
    const auto n = get<std::uint64_t>();
    if (item_bytes > 0 && n > (b_.size() - pos_) / item_bytes) fail("a count exceeds the file");
    return n;
  }
  std::string get_string() {
    const std::uint64_t n = count(1);
    std::string s(b_.substr(pos_, n));
    pos_ += n;
    return s;
  }
  tally::ExactSum get_sum() {
    tally::ExactSum::Limbs l{};
    for (auto& x : l) x = get<std::uint64_t>();
    if (!tally::ExactSum::in_range(l)) fail("a sum out of range");
    return tally::ExactSum::from_limbs(l);
  }
  Vec3 get_vec3() {
    const double x = get<double>(), y = get<double>(), z = get<double>();
    return {x, y, z};
  }
  template <class T>
  void field(T& v) {
    v = get<T>();
  }
  void field(Vec3& v) { v = get_vec3(); }
  void field(bool& b) { b = get<std::uint8_t>() != 0; }
  // An enumeration of `count` values, stored as one byte.
  template <class E>
  void code(E& e, int count, const char* what) {
    const auto c = get<std::uint8_t>();
    if (c >= count) fail(std::string("an unknown ") + what);
    e = static_cast<E>(c);
  }
  bool at_end() const { return pos_ == b_.size(); }
  const std::string& what() const { return what_; }
  [[noreturn]] void fail(const std::string& why) const {
    throw InputError(what_, "not an intact partial file: " + why);
  }

 private:
  void need(std::size_t n) const {
    if (b_.size() - pos_ < n) fail("it ends early");
  }
  std::string_view b_;
  std::string what_;
  std::size_t pos_ = 0;
};

constexpr std::size_t kSumBytes = 8 * tally::ExactSum::kLimbs;

void put_bins(Writer& w, const tally::ExactBins& bins) {
  w.put<std::uint64_t>(bins.bins().size());
  for (std::size_t k = 0; k < bins.bins().size(); ++k) {
    w.put(bins.bins()[k]);
    w.put_sum(bins.sums()[k]);
  }
}

tally::ExactBins get_bins(Reader& r, std::size_t size) {
  tally::ExactBins bins(size);
  const std::uint64_t n = r.count(4 + kSumBytes);
  for (std::uint64_t k = 0; k < n; ++k) {
    const auto bin = r.get<std::uint32_t>();
    if (bin >= size) r.fail("a bin beyond the tally");
    if (bins.touched(bin)) r.fail("a bin listed twice");
    bins.add(bin, r.get_sum());
  }
  return bins;
}

void put_tally(Writer& w, const tally::StratifiedTally& t) {
  w.put<std::uint64_t>(t.size());
  w.put<std::uint32_t>(static_cast<std::uint32_t>(t.partitions()));
  put_bins(w, t.mean_sums());
  for (std::size_t k = 0; k < t.partitions(); ++k) put_bins(w, t.variance_sums(k));
  const auto open = t.open_strata();
  w.put<std::uint64_t>(open.size());
  for (const auto& [key, st] : open) {
    w.put(key.partition);
    w.put(key.group);
    w.put(key.batch);
    w.put(key.index);
    w.put(st.size);
    w.put(st.n);
    w.put<std::uint64_t>(st.entries.size());
    for (const auto& e : st.entries) {
      w.put(e.bin);
      w.put_sum(e.s);
      w.put_sum(e.q);
    }
  }
}

// The tally's shape must be the site's (checked before anything of its size is allocated).
tally::StratifiedTally get_tally(Reader& r, std::size_t expected_bins) {
  const auto size = r.get<std::uint64_t>();
  const auto partitions = r.get<std::uint32_t>();
  if (size != expected_bins)
    throw InputError(r.what(), "a partial of another site: " + std::to_string(size) +
                                   " tally bins, the scenario's site has " +
                                   std::to_string(expected_bins));
  if (partitions < 1 || partitions > 2) r.fail("a tally of an impossible shape");
  return tally::StratifiedTally(size, static_cast<int>(partitions));
}

std::map<tally::StratumKey, tally::OpenStratum> get_open(Reader& r, std::size_t size,
                                                         std::uint32_t partitions) {
  std::map<tally::StratumKey, tally::OpenStratum> open;
  const std::uint64_t n = r.count(4 * 8);
  for (std::uint64_t k = 0; k < n; ++k) {
    tally::StratumKey key;
    key.partition = r.get<std::uint32_t>();
    key.group = r.get<std::uint32_t>();
    key.batch = r.get<std::int64_t>();
    key.index = r.get<std::int64_t>();
    tally::OpenStratum st;
    st.size = r.get<std::int64_t>();
    st.n = r.get<std::int64_t>();
    if (key.partition >= partitions || st.n < 1 || st.n >= st.size) r.fail("a bad open stratum");
    const std::uint64_t entries = r.count(4 + 2 * kSumBytes);
    st.entries.resize(entries);
    for (auto& e : st.entries) {
      e.bin = r.get<std::uint32_t>();
      if (e.bin >= size) r.fail("a bin beyond the tally");
      e.s = r.get_sum();
      e.q = r.get_sum();
    }
    for (std::size_t i = 1; i < st.entries.size(); ++i)
      if (st.entries[i - 1].bin >= st.entries[i].bin) r.fail("open stratum bins out of order");
    if (!open.emplace(key, std::move(st)).second) r.fail("an open stratum twice");
  }
  return open;
}

void put_stats(Writer& w, const run::RunStats& s) {
  for (const auto m : run::RunStats::counters()) w.put(s.*m);
}

run::RunStats get_stats(Reader& r) {
  run::RunStats s;
  for (const auto m : run::RunStats::counters()) s.*m = r.get<std::int64_t>();
  return s;
}

// The last check of a settings.precision run's targets (a run of one shard: --shard 0/1).
void put_precision(Writer& w, const run::PrecisionReport* p) {
  w.put(static_cast<std::uint8_t>(p != nullptr));
  if (p == nullptr) return;
  w.put(p->batches);
  w.put(p->histories);
  w.put<std::uint64_t>(p->targets.size());
  for (const run::TargetStatus& t : p->targets) {
    w.put_string(t.figure);
    w.put_string(t.building);
    w.put_string(t.basis);
    w.put(t.value);
    w.put(t.allowed);
    w.put(static_cast<std::uint8_t>(t.met));
    w.put(static_cast<std::uint8_t>(t.unmeetable));
    w.put_string(t.note);
    w.put(t.histories_needed);
  }
  w.put(static_cast<std::uint8_t>(p->all_met));
  w.put(static_cast<std::uint8_t>(p->any_unmeetable));
  w.put(p->histories_needed);
  w.put(p->eta_s);
  w.put(p->decay_exponent);
}

std::shared_ptr<const run::PrecisionReport> get_precision(Reader& r) {
  if (r.get<std::uint8_t>() == 0) return nullptr;
  auto p = std::make_shared<run::PrecisionReport>();
  p->batches = r.get<std::int64_t>();
  p->histories = r.get<std::int64_t>();
  const std::uint64_t n = r.count(4 * 8 + 3 * 8 + 2);
  for (std::uint64_t k = 0; k < n; ++k) {
    run::TargetStatus t;
    t.figure = r.get_string();
    t.building = r.get_string();
    t.basis = r.get_string();
    t.value = r.get<double>();
    t.allowed = r.get<double>();
    t.met = r.get<std::uint8_t>() != 0;
    t.unmeetable = r.get<std::uint8_t>() != 0;
    t.note = r.get_string();
    t.histories_needed = r.get<double>();
    p->targets.push_back(std::move(t));
  }
  p->all_met = r.get<std::uint8_t>() != 0;
  p->any_unmeetable = r.get<std::uint8_t>() != 0;
  p->histories_needed = r.get<double>();
  p->eta_s = r.get<double>();
  p->decay_exponent = r.get<double>();
  return p;
}

// A fragment record's fields, in file order; `io` is a Writer (const record) or a Reader.
constexpr std::size_t kRecordBytes = 250;  // their encoded size (tested: a record round trip)
template <class IO, class Record>
void record_fields(IO& io, Record& f) {
  io.field(f.group);
  io.field(f.history);
  io.field(f.weight);
  io.field(f.mass_kg);
  io.field(f.area_m2);
  io.field(f.launch_position_m);
  io.field(f.launch_velocity_mps);
  io.code(f.outcome, run::kOutcomeCount, "outcome");
  io.field(f.end_time_s);
  io.field(f.end_position_m);
  io.field(f.end_velocity_mps);
  io.field(f.first_impact_time_s);
  io.field(f.first_impact_position_m);
  io.field(f.first_impact_velocity_mps);
  io.field(f.impact_angle_deg);
  io.field(f.impact_ke_j);
  io.field(f.building);
  io.field(f.surface);
  io.field(f.penetrated);
  io.field(f.residual_ke_j);
  io.field(f.bounces);
  io.field(f.ground_impacts);
  io.field(f.takeoffs);
  io.field(f.ground_path_m);
}

// Point i of a trajectory, in file order.
template <class IO, class Trajectory>
void point_fields(IO& io, Trajectory& t, std::size_t i) {
  io.field(t.t_s[i]);
  io.field(t.position_m[i]);
  io.field(t.velocity_mps[i]);
  io.code(t.event[i], run::kTrajectoryEventCount, "trajectory event");
}

void put_trajectory(Writer& w, const run::TrajectoryRecord& t) {
  w.put(t.group);
  w.put(t.history);
  w.put<std::uint64_t>(t.t_s.size());
  for (std::size_t i = 0; i < t.t_s.size(); ++i) point_fields(w, t, i);
}

run::TrajectoryRecord get_trajectory(Reader& r) {
  run::TrajectoryRecord t;
  t.group = r.get<std::uint32_t>();
  t.history = r.get<std::uint64_t>();
  const std::uint64_t n = r.count(7 * 8 + 1);
  t.t_s.resize(n);
  t.position_m.resize(n);
  t.velocity_mps.resize(n);
  t.event.resize(n);
  for (std::size_t i = 0; i < n; ++i) point_fields(r, t, i);
  return t;
}

}  // namespace

std::string partial_trailer(std::string_view body) {
  const uLong crc = crc32_z(0L, reinterpret_cast<const Bytef*>(body.data()), body.size());
  char hex[9];
  std::snprintf(hex, sizeof hex, "%08lx", static_cast<unsigned long>(crc & 0xffffffffUL));
  return std::string(hex, 8);
}

std::string encode_partial(const run::PartialRun& p, const PartialIdentity& id) {
  Writer w;
  for (const char c : kMagic) w.put(c);
  w.put(kVersion);
  w.put_string(id.scenario_sha256);
  w.put(id.samples_scale);
  w.put(p.shard_count);
  w.put<std::uint64_t>(p.shards.size());
  for (const std::int64_t s : p.shards) w.put(s);
  w.put(p.histories_done);
  w.put(p.pilot_histories);
  w.put(p.batches);
  w.put(p.tallied_batches);
  w.put(static_cast<std::uint8_t>(p.cancelled));
  w.put(static_cast<std::uint8_t>(p.stop_reason));
  for (const std::int64_t n : p.outcome_histories) w.put(n);
  w.put(p.left_hazardous_histories);
  put_stats(w, p.stats);
  for (const double s : {p.integration_s, p.geometry_s, p.tally_s, p.wall_s}) w.put(s);
  w.put(static_cast<std::int32_t>(p.threads));
  put_precision(w, p.precision.get());
  put_tally(w, p.tally);
  w.put<std::uint64_t>(p.records.size());
  for (const auto& f : p.records) record_fields(w, f);
  w.put<std::uint64_t>(p.trajectories.size());
  for (const auto& t : p.trajectories) put_trajectory(w, t);
  std::string bytes = w.take();
  bytes += partial_trailer(bytes);
  return bytes;
}

run::PartialRun decode_partial(std::string_view bytes, std::size_t tally_bins, PartialIdentity& id,
                               const std::string& what) {
  if (bytes.size() < kMagic.size() + kTrailer || bytes.substr(0, kMagic.size()) != kMagic)
    throw InputError(what, "not a partial file (no FSPART01 header)");
  const std::string_view body = bytes.substr(0, bytes.size() - kTrailer);
  if (partial_trailer(body) != bytes.substr(bytes.size() - kTrailer))
    throw InputError(what, "not an intact partial file: its checksum does not match");
  Reader r(body.substr(kMagic.size()), what);
  if (r.get<std::uint32_t>() != kVersion) r.fail("an unknown version");
  id.scenario_sha256 = r.get_string();
  id.samples_scale = r.get<double>();
  run::PartialRun p;
  p.shard_count = r.get<std::int64_t>();
  if (p.shard_count < 1 || p.shard_count > run::kMaxShards) r.fail("a bad shard count");
  const std::uint64_t shards = r.count(8);
  for (std::uint64_t k = 0; k < shards; ++k) {
    p.shards.push_back(r.get<std::int64_t>());
    if (p.shards.back() < 0 || p.shards.back() >= p.shard_count ||
        (k > 0 && p.shards[k - 1] >= p.shards[k]))
      r.fail("a bad shard list");
  }
  p.histories_done = r.get<std::int64_t>();
  p.pilot_histories = r.get<std::int64_t>();
  p.batches = r.get<std::int64_t>();
  p.tallied_batches = r.get<std::int64_t>();
  // Counts a run can have: every later sum of them (merge, finish) stays far from overflow.
  constexpr std::int64_t kMaxCount = std::int64_t{1} << 48;
  auto count_ok = [&](std::int64_t n) { return n >= 0 && n <= kMaxCount; };
  if (!count_ok(p.histories_done) || !count_ok(p.pilot_histories) || !count_ok(p.batches) ||
      p.tallied_batches < 0 || p.tallied_batches > p.batches || p.batches > 1'000'000)
    r.fail("impossible history or batch counts");
  p.cancelled = r.get<std::uint8_t>() != 0;
  const auto reason = r.get<std::uint8_t>();
  if (reason >= run::kStopReasonCount) r.fail("a bad stop reason");
  p.stop_reason = static_cast<run::StopReason>(reason);
  std::int64_t outcomes = 0;
  for (std::int64_t& n : p.outcome_histories) {
    n = r.get<std::int64_t>();
    if (!count_ok(n)) r.fail("impossible outcome counts");
    outcomes += n;
  }
  if (outcomes != p.histories_done) r.fail("outcome counts that do not add up to the histories");
  p.left_hazardous_histories = r.get<std::int64_t>();
  const auto left = static_cast<std::size_t>(run::Outcome::kLeftSite);
  if (p.left_hazardous_histories < 0 || p.left_hazardous_histories > p.outcome_histories[left])
    r.fail("an impossible count of hazardous fragments leaving the site");
  p.stats = get_stats(r);
  for (const auto m : run::RunStats::counters())
    if (p.stats.*m < 0 || p.stats.*m > (std::int64_t{1} << 56)) r.fail("impossible statistics");
  for (double* s : {&p.integration_s, &p.geometry_s, &p.tally_s, &p.wall_s}) *s = r.get<double>();
  p.threads = r.get<std::int32_t>();
  if (p.threads < 1 || p.threads > 1'000'000) r.fail("an impossible thread count");
  p.precision = get_precision(r);
  p.tally = get_tally(r, tally_bins);
  tally::ExactBins mean = get_bins(r, p.tally.size());
  std::vector<tally::ExactBins> var;
  for (std::size_t k = 0; k < p.tally.partitions(); ++k) var.push_back(get_bins(r, p.tally.size()));
  auto open = get_open(r, p.tally.size(), static_cast<std::uint32_t>(p.tally.partitions()));
  p.tally.restore(std::move(mean), std::move(var), std::move(open));
  const std::uint64_t records = r.count(kRecordBytes);  // bounds the allocation by the file
  p.records.resize(records);
  for (run::FragmentRecord& f : p.records) record_fields(r, f);
  const std::uint64_t trajectories = r.count(1);
  for (std::uint64_t k = 0; k < trajectories; ++k) p.trajectories.push_back(get_trajectory(r));
  if (!r.at_end()) r.fail("bytes after its end");
  return p;
}

namespace {

constexpr std::string_view kBatchMagic = "FSBATCH1";

template <class T>
void put_array(Writer& w, const std::vector<T>& v) {
  w.put<std::uint64_t>(v.size());
  for (const T& x : v) w.put(x);
}

template <class T>
std::vector<T> get_array(Reader& r) {
  std::vector<T> v(r.count(sizeof(T)));
  for (T& x : v) x = r.get<T>();
  return v;
}

void put_learner_input(Writer& w, const run::LearnerInput& in) {
  put_array(w, in.group);
  put_array(w, in.cell);
  put_array(w, in.likelihood_ratio);
  put_array(w, in.building);
  put_array(w, in.contributed);
  put_array(w, in.entries_end);
  put_array(w, in.bin);
  put_array(w, in.x);
}

// The ranges of the values are checked where they are replayed (DirectionLearner::replay).
run::LearnerInput get_learner_input(Reader& r) {
  run::LearnerInput in;
  in.group = get_array<std::uint32_t>(r);
  in.cell = get_array<std::uint32_t>(r);
  in.likelihood_ratio = get_array<double>(r);
  in.building = get_array<std::int32_t>(r);
  in.contributed = get_array<std::uint8_t>(r);
  in.entries_end = get_array<std::uint32_t>(r);
  in.bin = get_array<std::uint16_t>(r);
  in.x = get_array<double>(r);
  return in;
}

}  // namespace

std::string encode_batch(const run::BatchState& b, const PartialIdentity& id) {
  Writer w;
  for (const char c : kBatchMagic) w.put(c);
  w.put(b.batch);
  w.put(b.elapsed_s);
  w.put_string(encode_partial(b.part, id));
  w.put<std::uint64_t>(b.learnt.size());
  for (const auto& l : b.learnt) {
    w.put(l.shard);
    put_learner_input(w, l.input);
  }
  return w.take();
}

run::BatchState decode_batch(std::string_view bytes, std::size_t tally_bins, PartialIdentity& id,
                             const std::string& what) {
  if (bytes.substr(0, kBatchMagic.size()) != kBatchMagic)
    throw InputError(what, "not a batch state (no FSBATCH1 header)");
  Reader r(bytes.substr(kBatchMagic.size()), what);
  run::BatchState b;
  b.batch = r.get<std::int64_t>();
  b.elapsed_s = r.get<double>();
  if (b.batch < 0 || b.batch > 1'000'000 || !(b.elapsed_s >= 0.0)) r.fail("a bad batch");
  b.part = decode_partial(r.get_string(), tally_bins, id, what);
  const std::uint64_t learnt = r.count(8 + 8 * 8);
  for (std::uint64_t k = 0; k < learnt; ++k) {
    run::BatchState::Learnt l;
    l.shard = r.get<std::int64_t>();
    if (std::find(b.part.shards.begin(), b.part.shards.end(), l.shard) == b.part.shards.end() ||
        (k > 0 && b.learnt.back().shard >= l.shard))
      r.fail("learner input of a shard not in the batch, or out of order");
    l.input = get_learner_input(r);
    b.learnt.push_back(std::move(l));
  }
  if (!r.at_end()) r.fail("bytes after its end");
  return b;
}

void write_partial_file(const std::filesystem::path& path, const run::PartialRun& partial,
                        const PartialIdentity& identity) {
  const std::string bytes = encode_partial(partial, identity);
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  f.close();
  if (!f) throw std::runtime_error("cannot write " + path.string());
}

run::PartialRun read_partial_file(const std::filesystem::path& path, std::size_t tally_bins,
                                  PartialIdentity& identity) {
  if (std::error_code ec; std::filesystem::is_directory(path, ec))  // reading one throws
    throw InputError(path.string(), "a directory, not a partial file");
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path.string(), "cannot read the partial file");
  std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  if (f.bad()) throw InputError(path.string(), "cannot read the partial file");
  return decode_partial(bytes, tally_bins, identity, path.string());
}

}  // namespace fragsim::formats
