// The partial file of a shard (formats/partial_file.h): encode -> decode -> encode is the identity,
// a decoded partial finishes to the bits of the original, and every kind of damage -- truncation,
// a flipped byte, another magic or version, a partial of another site, a count that lies under a
// valid checksum, open-stratum bins out of order, unknown codes -- is an InputError naming the
// file, decoded without a large allocation, never a crash or a wrong result.
#include "formats/partial_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <new>
#include <string>
#include <vector>

#include "api/sha256.h"
#include "api/test_support.h"
#include "core/common/error.h"
#include "core/run/partial.h"
#include "validation/scenario_fixtures.h"

// The largest single heap allocation while armed: a count that lies must not make the decoder
// allocate in proportion to it. Kept out of line (GCC 12 pairs an inlined `new` with `free` and
// warns, -Wmismatched-new-delete).
namespace {
std::atomic<bool> g_track_allocations{false};
std::atomic<std::size_t> g_largest_allocation{0};
}  // namespace
[[gnu::noinline]] void* operator new(std::size_t n) {
  if (g_track_allocations.load(std::memory_order_relaxed)) {
    std::size_t prev = g_largest_allocation.load(std::memory_order_relaxed);
    while (n > prev && !g_largest_allocation.compare_exchange_weak(prev, n)) {
    }
  }
  if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
  throw std::bad_alloc();
}
[[gnu::noinline]] void operator delete(void* p) noexcept {
  std::free(p);
}
[[gnu::noinline]] void operator delete(void* p, std::size_t) noexcept {
  std::free(p);
}
// The nothrow forms too (std::stable_sort's buffer): otherwise the library's nothrow new pairs
// with the free above, an alloc-dealloc mismatch under ASan.
[[gnu::noinline]] void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
  return std::malloc(n == 0 ? 1 : n);
}
[[gnu::noinline]] void operator delete(void* p, const std::nothrow_t&) noexcept {
  std::free(p);
}

namespace fragsim::formats {
namespace {

namespace fs = std::filesystem;
using run::PartialRun;

constexpr std::size_t kTrailer = kPartialTrailerBytes;  // CRC-32 of the body, hex
const std::string kWhat = "shards/part-1.fsp";

// ---- The scenarios: a flat plane with a building, a few hundred histories in two groups ----

run::Scenario small_scenario(bool stratified) {
  run::Scenario sc = validation::flat_site_scenario(300.0, 20.0);  // 1800 terrain triangles
  validation::add_wall_and_roof(sc, 2.0e5);
  sc.site.buildings = {validation::box_building("b", 30, -15, 50, 15, 10.0)};
  auto g = validation::mixed_sphere_group(Vec3(0, 0, 1.0), 0.2, 60.0, 500.0, 240);
  g.direction.azimuth_min_deg = -45.0;
  g.direction.azimuth_max_deg = 45.0;
  auto g2 = g;
  g2.samples = 131;
  g2.count = 120.0;
  sc.groups = {g, g2};
  sc.settings.threads = 2;
  sc.settings.record_fragments = true;
  sc.settings.record_trajectories = true;
  sc.settings.max_recorded_trajectories = 100;  // shard 1 of 3 has group 0's 80..99
  if (stratified) {
    run::StratifiedLaunchSettings strat;
    strat.histories_per_stratum = 7;  // strata cut by the shard boundaries
    sc.settings.stratified_launch = strat;
  }
  return sc;
}

// A scenario, its site and the partials of its three shards.
struct Case {
  run::Scenario sc;
  std::shared_ptr<const scene::Site> site;
  std::size_t bins = 0;
  std::vector<PartialRun> shards;  // 0, 1, 2 of 3
  PartialRun whole;                // shard 0 of 1: every stratum closed
  // Shard 1 of 3 holds the middle of every group: without stratified launch (a group's batch is
  // one stratum) all its sums are in open strata; with it, in closed and open ones.
  const PartialRun& middle() const { return shards[1]; }
};

const Case& make_case(bool stratified) {
  static Case* const cases = new Case[2];  // built once; never destroyed
  Case& c = cases[stratified ? 1 : 0];
  if (c.site) return c;
  c.sc = small_scenario(stratified);
  c.site = scene::Site::build(c.sc.site);
  c.bins = run::tally_bins(c.sc, *c.site).total;
  for (std::int64_t i = 0; i < 3; ++i) {
    c.sc.settings.threads = 1 + static_cast<int>(i % 2);
    c.shards.push_back(run::run_partial(c.sc, c.site, run::Shard{i, 3}));
  }
  c.sc.settings.threads = 2;
  c.whole = run::run_partial(c.sc, c.site, run::Shard{0, 1});
  return c;
}

const PartialIdentity kIdentity{api::sha256_hex("the scenario file"), 0.25};

// ---- Bytes ----

std::string body_of(std::string_view bytes) {
  return std::string(bytes.substr(0, bytes.size() - kTrailer));
}
std::string with_trailer(const std::string& body) {
  return body + partial_trailer(body);
}
template <class T>
T read_at(const std::string& s, std::size_t offset) {
  T v;
  std::memcpy(&v, s.data() + offset, sizeof(T));
  return v;
}
template <class T>
void write_at(std::string& s, std::size_t offset, T v) {
  ASSERT_LE(offset + sizeof(T), s.size());
  std::memcpy(s.data() + offset, &v, sizeof(T));
}

// A partial without records and trajectories: its body ends with their two zero counts. The
// bytes before a section do not depend on what follows it, so offsets found on a stripped
// partial hold in the whole one.
PartialRun stripped(const PartialRun& p) {
  PartialRun s = p;
  s.records.clear();
  s.trajectories.clear();
  return s;
}
PartialRun with_tally(const PartialRun& p, tally::ExactBins mean, std::vector<tally::ExactBins> var,
                      std::map<tally::StratumKey, tally::OpenStratum> open) {
  PartialRun s = stripped(p);
  s.tally.restore(std::move(mean), std::move(var), std::move(open));
  return s;
}
std::vector<tally::ExactBins> empty_variance(const PartialRun& p) {
  return std::vector<tally::ExactBins>(p.tally.partitions(), tally::ExactBins(p.tally.size()));
}

// Offsets in the body of the counts a lying file would alter.
struct Offsets {
  std::size_t identity = 12;  // the scenario digest's length (after magic and version)
  std::size_t shard_count = 0, shard_list = 0;
  std::size_t tally = 0;      // u64 bins, u32 partitions
  std::size_t mean_bins = 0;  // u64 count, then (u32 bin, 40-byte sum) entries
  std::size_t open = 0;       // u64 count, then the strata
  std::size_t records = 0;    // u64 count
  std::size_t trajectories = 0;
};
Offsets offsets_of(const PartialRun& p) {
  Offsets o;
  o.shard_count = o.identity + 8 + kIdentity.scenario_sha256.size() + 8;
  o.shard_list = o.shard_count + 8;
  const std::size_t parts = p.tally.partitions();
  // Empty tally: bins, partitions, mean count, a count per partition, open, records, trajectories.
  const std::string empty = body_of(encode_partial(
      with_tally(p, tally::ExactBins(p.tally.size()), empty_variance(p), {}), kIdentity));
  o.mean_bins = empty.size() - 8 * (parts + 4);
  o.tally = o.mean_bins - 12;
  std::vector<tally::ExactBins> var;
  for (std::size_t k = 0; k < parts; ++k) var.push_back(p.tally.variance_sums(k));
  const std::string closed =
      body_of(encode_partial(with_tally(p, p.tally.mean_sums(), var, {}), kIdentity));
  o.open = closed.size() - 24;
  o.records = body_of(encode_partial(stripped(p), kIdentity)).size() - 16;
  PartialRun no_trajectories = p;
  no_trajectories.trajectories.clear();
  o.trajectories = body_of(encode_partial(no_trajectories, kIdentity)).size() - 8;
  return o;
}

// ---- Decoding damaged bytes ----

struct Decoded {
  bool input_error = false;
  std::string field, message;  // of the InputError, or what went wrong instead
  std::size_t largest_allocation = 0;
};

// Runs `step`, which returns what it reached ("<decoded>", ...) or throws: how it ended.
template <class Step>
Decoded ending_of(Step step) {
  Decoded r;
  try {
    r.message = step();
  } catch (const InputError& e) {
    r.input_error = true;
    r.field = e.field();
    r.message = e.message();
  } catch (const std::exception& e) {
    r.message = std::string("<not an InputError> ") + e.what();
  }
  return r;
}

Decoded decode_damaged(std::string_view bytes, std::size_t bins) {
  g_largest_allocation = 0;
  g_track_allocations = true;
  Decoded r = ending_of([&] {
    PartialIdentity id;
    (void)decode_partial(bytes, bins, id, kWhat);
    return std::string("<decoded>");
  });
  g_track_allocations = false;
  r.largest_allocation = g_largest_allocation;
  return r;
}

// An InputError naming kWhat whose message contains `expected`, decoded without an allocation
// larger than `max_allocation`.
void expect_refused(std::string_view bytes, std::size_t bins, const std::string& expected,
                    std::size_t max_allocation = std::size_t{8} << 20) {
  const Decoded r = decode_damaged(bytes, bins);
  EXPECT_TRUE(r.input_error) << r.message;
  EXPECT_EQ(r.field, kWhat);
  EXPECT_NE(r.message.find(expected), std::string::npos)
      << "\"" << r.message << "\" does not say \"" << expected << "\"";
  EXPECT_LE(r.largest_allocation, max_allocation);
}

// ---- Comparing results bit for bit ----

template <class T>
bool same_bits(const std::vector<T>& a, const std::vector<T>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(T)) == 0;
}
template <class T>  // doubles and Estimates (two doubles): no padding
bool same_bits(const T& a, const T& b) {
  return std::memcmp(&a, &b, sizeof(T)) == 0;
}

// Records and trajectories compared through their encoding (every field, bit for bit).
std::string records_bytes(const run::RunResult& r) {
  PartialRun p;
  p.records = r.fragments;
  p.trajectories = r.trajectories;
  return encode_partial(p, {});
}

void expect_same_result(const run::RunResult& a, const run::RunResult& b) {
  EXPECT_TRUE(same_bits(a.ptn_density_per_m2, b.ptn_density_per_m2));
  EXPECT_TRUE(same_bits(a.ptn_std_error_per_m2, b.ptn_std_error_per_m2));
  EXPECT_TRUE(same_bits(a.max_ptn_density_per_m2, b.max_ptn_density_per_m2));
  EXPECT_EQ(a.max_ptn_triangle, b.max_ptn_triangle);
  EXPECT_TRUE(same_bits(a.hazardous_fragment_distance_m, b.hazardous_fragment_distance_m));
  EXPECT_TRUE(same_bits(a.hfd_lower_m, b.hfd_lower_m));
  EXPECT_TRUE(same_bits(a.hfd_upper_m, b.hfd_upper_m));
  EXPECT_EQ(
      std::memcmp(a.hfd_by_sector_m.data(), b.hfd_by_sector_m.data(), sizeof a.hfd_by_sector_m), 0);
  ASSERT_EQ(a.buildings.size(), b.buildings.size());
  for (std::size_t i = 0; i < a.buildings.size(); ++i) {
    const run::BuildingResult &x = a.buildings[i], &y = b.buildings[i];
    EXPECT_EQ(x.id, y.id);
    EXPECT_TRUE(same_bits(x.impacts, y.impacts)) << i;
    EXPECT_TRUE(same_bits(x.penetrations, y.penetrations)) << i;
    for (std::size_t s = 0; s < scene::kSurfaceTypeCount; ++s) {
      EXPECT_TRUE(same_bits(x.impacts_by_surface[s], y.impacts_by_surface[s])) << i << " " << s;
      EXPECT_TRUE(same_bits(x.penetrations_by_surface[s], y.penetrations_by_surface[s]))
          << i << " " << s;
    }
    EXPECT_TRUE(same_bits(x.residual_ke_j, y.residual_ke_j)) << i;
  }
  for (int o = 0; o < run::kOutcomeCount; ++o)
    EXPECT_TRUE(same_bits(a.outcome_fragments[static_cast<std::size_t>(o)],
                          b.outcome_fragments[static_cast<std::size_t>(o)]))
        << o;
  EXPECT_EQ(a.outcome_histories, b.outcome_histories);
  EXPECT_EQ(a.samples, b.samples);
  EXPECT_EQ(a.histories_done, b.histories_done);
  EXPECT_EQ(a.batches, b.batches);
  EXPECT_EQ(a.cancelled, b.cancelled);
  EXPECT_EQ(a.stop_reason, b.stop_reason);
  EXPECT_EQ(std::memcmp(&a.stats, &b.stats, sizeof a.stats), 0);
  EXPECT_EQ(a.fragments.size(), b.fragments.size());
  EXPECT_EQ(a.trajectories.size(), b.trajectories.size());
  EXPECT_TRUE(records_bytes(a) == records_bytes(b)) << "records or trajectories differ";
}

PartialRun round_trip(const PartialRun& p, std::size_t bins) {
  PartialIdentity id;
  PartialRun q = decode_partial(encode_partial(p, kIdentity), bins, id, kWhat);
  EXPECT_EQ(id, kIdentity);
  return q;
}

// Shards 2, 0, 1 merged and finished.
run::RunResult merged(const Case& c, std::vector<PartialRun> shards) {
  PartialRun all = std::move(shards[2]);
  run::merge(all, std::move(shards[0]));
  run::merge(all, std::move(shards[1]));
  return run::finish(c.sc, *c.site, std::move(all));
}

class PartialFile : public ::testing::TestWithParam<bool> {
 protected:
  const Case& c() const { return make_case(GetParam()); }
};

// The cases are what the test is about: records, trajectories, open strata in every partition.
TEST_P(PartialFile, TheMiddleShardHasRecordsTrajectoriesAndOpenStrata) {
  const PartialRun& p = c().middle();
  EXPECT_EQ(p.tally.partitions(), GetParam() ? 2u : 1u);
  EXPECT_GT(p.histories_done, 100);
  EXPECT_FALSE(p.records.empty());
  EXPECT_FALSE(p.trajectories.empty());
  if (GetParam()) {
    EXPECT_GT(p.tally.mean_sums().bins().size(), 10u);
  }
  std::vector<bool> open_in(p.tally.partitions(), false);
  for (const auto& [key, st] : p.tally.open_strata()) {
    open_in[key.partition] = true;
    EXPECT_LT(st.n, st.size);
  }
  for (std::size_t k = 0; k < open_in.size(); ++k) EXPECT_TRUE(open_in[k]) << k;
  EXPECT_TRUE(c().whole.tally.open_strata().empty());
  EXPECT_GT(c().whole.tally.mean_sums().bins().size(), 10u);
  const run::RunResult whole = run::run(c().sc, c().site);
  EXPECT_GT(whole.buildings[0].impacts.mean, 0.0);
  EXPECT_GT(whole.max_ptn_density_per_m2, 0.0);
}

TEST_P(PartialFile, EncodeDecodeEncodeGivesTheSameBytes) {
  for (const PartialRun& p : c().shards) {
    const std::string once = encode_partial(p, kIdentity);
    PartialIdentity id;
    const PartialRun back = decode_partial(once, c().bins, id, kWhat);
    EXPECT_EQ(id, kIdentity);
    const std::string twice = encode_partial(back, id);
    EXPECT_EQ(once.size(), twice.size());
    EXPECT_TRUE(once == twice) << "shard " << p.shards[0];
    EXPECT_EQ(back.shards, p.shards);
    EXPECT_EQ(back.shard_count, 3);
    EXPECT_EQ(back.histories_done, p.histories_done);
    EXPECT_EQ(back.tally.open_strata().size(), p.tally.open_strata().size());
  }
}

TEST_P(PartialFile, DecodedShardsFinishToTheBitsOfTheOriginals) {
  const run::RunResult original = merged(c(), c().shards);
  std::vector<PartialRun> decoded;
  for (const PartialRun& p : c().shards) decoded.push_back(round_trip(p, c().bins));
  const run::RunResult from_files = merged(c(), std::move(decoded));
  expect_same_result(original, from_files);
  // ... and both the bits of the whole run in one process.
  expect_same_result(run::run(c().sc, c().site), from_files);
  // A whole run's partial (one shard of one) finishes alone.
  const PartialRun one = run::run_partial(c().sc, c().site, run::Shard{0, 1});
  expect_same_result(run::finish(c().sc, *c().site, PartialRun(one)),
                     run::finish(c().sc, *c().site, round_trip(one, c().bins)));
}

// Cut anywhere, with the original trailer (the checksum fails) or a trailer recomputed over the
// cut body (the structure fails): an InputError either way.
TEST_P(PartialFile, TruncationAtAnyLengthIsRefused) {
  const std::string bytes = encode_partial(c().middle(), kIdentity);
  const std::string body = body_of(bytes);
  std::vector<std::size_t> lengths;
  for (std::size_t n = 0; n < 400 && n < bytes.size(); ++n) lengths.push_back(n);
  for (std::size_t n = 400; n < bytes.size(); n += 173) lengths.push_back(n);
  for (std::size_t n = bytes.size() - 200; n < bytes.size(); ++n) lengths.push_back(n);
  int bad = 0;
  for (const std::size_t n : lengths) {
    const Decoded r = decode_damaged(std::string_view(bytes).substr(0, n), c().bins);
    if ((!r.input_error || r.field != kWhat) && ++bad <= 5)
      ADD_FAILURE() << "cut at " << n << " of " << bytes.size() << ": " << r.message;
  }
  // The body cut, its checksum recomputed: the structure tells.
  std::vector<std::size_t> body_lengths;
  for (std::size_t n = 8; n < 300; ++n) body_lengths.push_back(n);
  for (std::size_t n = 300; n < body.size(); n += 97) body_lengths.push_back(n);
  for (std::size_t n = body.size() - 300; n < body.size(); ++n) body_lengths.push_back(n);
  for (const std::size_t n : body_lengths) {
    const Decoded r = decode_damaged(with_trailer(body.substr(0, n)), c().bins);
    if ((!r.input_error || r.field != kWhat ||
         r.message.find("not an intact partial file") == std::string::npos) &&
        ++bad <= 10)
      ADD_FAILURE() << "body cut at " << n << " of " << body.size() << ": " << r.message;
  }
  EXPECT_EQ(bad, 0) << "of " << lengths.size() + body_lengths.size() << " lengths";
}

TEST_P(PartialFile, AFlippedByteFailsTheChecksum) {
  const std::string bytes = encode_partial(c().middle(), kIdentity);
  int bad = 0, tried = 0;
  for (std::size_t pos = 0; pos < bytes.size(); pos += (pos < 256 ? 1 : 127)) {
    for (const int mask : {0x01, 0x80, 0xff}) {
      std::string damaged = bytes;
      damaged[pos] = static_cast<char>(damaged[pos] ^ mask);
      ++tried;
      const Decoded r = decode_damaged(damaged, c().bins);
      const char* expected = pos < 8 ? "no FSPART01 header" : "checksum does not match";
      if ((!r.input_error || r.field != kWhat || r.message.find(expected) == std::string::npos) &&
          ++bad <= 5)
        ADD_FAILURE() << "byte " << pos << " ^ " << mask << ": " << r.message;
    }
  }
  EXPECT_EQ(bad, 0) << "of " << tried << " flips";
}

TEST_P(PartialFile, WrongMagicVersionOrShapeIsRefused) {
  const std::string bytes = encode_partial(c().middle(), kIdentity);
  const std::size_t bins = c().bins;
  expect_refused("", bins, "not a partial file");
  expect_refused("FSPART01", bins, "not a partial file");
  std::string magic = bytes;
  magic[7] = '2';  // FSPART02
  expect_refused(magic, bins, "not a partial file (no FSPART01 header)");
  expect_refused("PK\x03\x04" + bytes.substr(4), bins, "no FSPART01 header");
  std::string body = body_of(bytes);
  std::string version = body;
  // 1: before the site-boundary tallies; 2: before issue 23's outcome, counters and fields.
  for (const std::uint32_t v : {1u, 2u, 4u}) {
    write_at<std::uint32_t>(version, 8, v);
    expect_refused(with_trailer(version), bins, "an unknown version");
  }
  const Offsets o = offsets_of(c().middle());
  ASSERT_EQ(read_at<std::uint64_t>(body, o.tally), bins);
  ASSERT_EQ(read_at<std::uint32_t>(body, o.tally + 8), c().middle().tally.partitions());
  for (const std::uint32_t partitions : {0u, 3u, 0xffffffffu}) {
    std::string shape = body;
    write_at(shape, o.tally + 8, partitions);
    expect_refused(with_trailer(shape), bins, "a tally of an impossible shape");
  }
  // Trailing bytes under a valid checksum.
  expect_refused(with_trailer(body + std::string(1, '\0')), bins, "bytes after its end");
}

// The partial of another site: the tally's bin count is checked before anything of its size is
// allocated, so even a file claiming 2^60 bins costs nothing.
TEST_P(PartialFile, APartialOfAnotherSiteIsRefused) {
  const std::string bytes = encode_partial(c().middle(), kIdentity);
  run::Scenario other = c().sc;
  std::get<scene::PlaneTerrainSpec>(other.site.terrain.geometry).cell_m = 30.0;
  const std::size_t other_bins = run::tally_bins(other, *scene::Site::build(other.site)).total;
  ASSERT_NE(other_bins, c().bins);
  expect_refused(bytes, other_bins, "a partial of another site");
  expect_refused(bytes, c().bins + 1, "a partial of another site");
  std::string body = body_of(bytes);
  write_at<std::uint64_t>(body, offsets_of(c().middle()).tally, std::uint64_t{1} << 60);
  expect_refused(with_trailer(body), c().bins, "a partial of another site: 1152921504606846976");
}

// A count altered and the checksum recomputed (only a deliberately forged file does that): each is
// refused without an allocation of the size the count claims.
void expect_lying_counts_refused(const PartialRun& p, std::size_t bins) {
  const std::string body = body_of(encode_partial(p, kIdentity));
  const Offsets o = offsets_of(p);
  struct Lie {
    std::string name;
    std::size_t offset;
    std::uint64_t truth;
  };
  std::vector<Lie> lies = {
      {"identity", o.identity, kIdentity.scenario_sha256.size()},
      {"shard list", o.shard_list, p.shards.size()},
      {"mean bins", o.mean_bins, p.tally.mean_sums().bins().size()},
      {"variance bins", o.mean_bins + 8 + p.tally.mean_sums().bins().size() * 44,
       p.tally.variance_sums(0).bins().size()},
      {"open strata", o.open, p.tally.open_strata().size()},
      {"records", o.records, p.records.size()},
      {"trajectories", o.trajectories, p.trajectories.size()}};
  if (!p.tally.open_strata().empty())  // after the first stratum's key, size and n
    lies.push_back({"open stratum entries", o.open + 8 + 24 + 16,
                    p.tally.open_strata().begin()->second.entries.size()});
  if (!p.trajectories.empty())  // after the first trajectory's group and history
    lies.push_back({"trajectory points", o.trajectories + 8 + 4 + 8, p.trajectories[0].t_s.size()});
  for (const Lie& lie : lies) {
    // The offsets found are where the counts are.
    ASSERT_EQ(read_at<std::uint64_t>(body, lie.offset), lie.truth) << lie.name;
    for (const std::uint64_t count :
         {std::numeric_limits<std::uint64_t>::max(), std::uint64_t{1} << 62, std::uint64_t{1} << 40,
          std::uint64_t{body.size()}, lie.truth + 1}) {
      SCOPED_TRACE(lie.name + " count " + std::to_string(count) + " (truth " +
                   std::to_string(lie.truth) + ")");
      std::string forged = body;
      write_at(forged, lie.offset, count);
      // A count one too large shifts what follows: any InputError then.
      expect_refused(with_trailer(forged), bins,
                     count == lie.truth + 1 ? "" : "not an intact partial file: a count exceeds");
    }
  }
}

TEST_P(PartialFile, ACountThatLiesUnderAValidChecksumIsRefusedWithoutAHugeAllocation) {
  {
    SCOPED_TRACE("shard 1 of 3");
    expect_lying_counts_refused(c().middle(), c().bins);
  }
  {
    SCOPED_TRACE("shard 0 of 1");
    expect_lying_counts_refused(c().whole, c().bins);
  }
}

// The decoder's checks of what it reads, on partials encoded with a broken field (the encoder
// writes what it is given).
TEST_P(PartialFile, OpenStratumBinsOutOfOrderAreRefused) {
  const PartialRun& p = c().middle();
  std::vector<tally::ExactBins> var;
  for (std::size_t k = 0; k < p.tally.partitions(); ++k) var.push_back(p.tally.variance_sums(k));
  auto open = p.tally.open_strata();
  auto it = std::find_if(open.begin(), open.end(),
                         [](const auto& kv) { return kv.second.entries.size() >= 2; });
  ASSERT_NE(it, open.end());
  // A tally keeps its open strata sorted by bin, so a file out of order is made by patching the
  // bins of one written in order: a partial with that stratum alone, whose entries (bin u32,
  // then S and Q, 40 bytes each) follow the open count and the stratum's 48-byte header.
  const std::map<tally::StratumKey, tally::OpenStratum> one{*it};
  const std::string in_order =
      body_of(encode_partial(with_tally(p, p.tally.mean_sums(), var, one), kIdentity));
  const std::size_t first_bin = offsets_of(p).open + 8 + 48, entry = 4 + 2 * 40;
  const std::size_t last_bin = first_bin + (it->second.entries.size() - 1) * entry;
  ASSERT_EQ(read_at<std::uint32_t>(in_order, first_bin), it->second.entries[0].bin);
  ASSERT_EQ(read_at<std::uint32_t>(in_order, last_bin), it->second.entries.back().bin);
  {
    std::string swapped = in_order;
    write_at(swapped, first_bin, it->second.entries.back().bin);
    write_at(swapped, last_bin, it->second.entries[0].bin);
    expect_refused(with_trailer(swapped), c().bins, "open stratum bins out of order");
  }
  {
    std::string twice = in_order;
    write_at(twice, first_bin + entry, it->second.entries[0].bin);
    expect_refused(with_trailer(twice), c().bins, "open stratum bins out of order");
  }
  {
    auto beyond = open;
    beyond.find(it->first)->second.entries.back().bin = static_cast<std::uint32_t>(c().bins);
    expect_refused(encode_partial(with_tally(p, p.tally.mean_sums(), var, beyond), kIdentity),
                   c().bins, "a bin beyond the tally");
  }
  for (const auto& [n, size] : std::vector<std::pair<std::int64_t, std::int64_t>>{
           {0, 5}, {5, 5}, {6, 5}, {-1, 5}, {1, -3}}) {
    auto bad = open;
    bad.find(it->first)->second.n = n;
    bad.find(it->first)->second.size = size;
    expect_refused(encode_partial(with_tally(p, p.tally.mean_sums(), var, bad), kIdentity),
                   c().bins, "a bad open stratum");
  }
  {
    auto other_partition = open;
    auto st = other_partition.begin()->second;
    tally::StratumKey key = other_partition.begin()->first;
    key.partition = static_cast<std::uint32_t>(p.tally.partitions());
    other_partition.emplace(key, st);
    expect_refused(
        encode_partial(with_tally(p, p.tally.mean_sums(), var, other_partition), kIdentity),
        c().bins, "a bad open stratum");
  }
}

TEST_P(PartialFile, UnknownCodesAndBadFieldsAreRefused) {
  const PartialRun& p = c().middle();
  const std::size_t bins = c().bins;
  for (const int outcome : {run::kOutcomeCount, 0x80, 0xff}) {
    PartialRun bad = p;
    bad.records[bad.records.size() / 2].outcome = static_cast<run::Outcome>(outcome);
    expect_refused(encode_partial(bad, kIdentity), bins, "an unknown outcome");
  }
  for (const int event : {run::kTrajectoryEventCount, 0xff}) {
    PartialRun bad = p;
    bad.trajectories.back().event.back() = static_cast<run::TrajectoryEvent>(event);
    expect_refused(encode_partial(bad, kIdentity), bins, "an unknown trajectory event");
  }
  for (const int reason : {run::kStopReasonCount, 0xff}) {
    PartialRun bad = p;
    bad.stop_reason = static_cast<run::StopReason>(reason);
    expect_refused(encode_partial(bad, kIdentity), bins, "a bad stop reason");
  }
  for (const std::int64_t left : {std::int64_t{-1}, p.outcome_histories[3] + 1}) {
    PartialRun bad = p;  // outcome 3: left_site
    bad.left_hazardous_histories = left;
    expect_refused(encode_partial(bad, kIdentity), bins, "hazardous fragments leaving the site");
  }
  for (const std::int64_t count : {std::int64_t{0}, std::int64_t{-1}, run::kMaxShards + 1}) {
    PartialRun bad = p;
    bad.shard_count = count;
    bad.shards = {};
    expect_refused(encode_partial(bad, kIdentity), bins, "a bad shard count");
  }
  for (const std::vector<std::int64_t>& shards :
       std::vector<std::vector<std::int64_t>>{{3}, {-1}, {2, 1}, {1, 1}, {0, 1, 2, 3}}) {
    PartialRun bad = p;
    bad.shards = shards;
    expect_refused(encode_partial(bad, kIdentity), bins, "a bad shard list");
  }
  {  // a mean bin beyond the tally, forged into the bytes of a partial with closed strata
    std::string body = body_of(encode_partial(c().whole, kIdentity));
    const std::size_t first_bin = offsets_of(c().whole).mean_bins + 8;
    ASSERT_LT(read_at<std::uint32_t>(body, first_bin), bins);
    for (const std::uint32_t bin : {static_cast<std::uint32_t>(bins), 0xffffffffu}) {
      write_at(body, first_bin, bin);
      expect_refused(with_trailer(body), bins, "a bin beyond the tally");
    }
  }
}

// What `fragsim merge` does with the three shards, some replaced by forged bytes: decode, merge,
// finish. Forged values that decode must still end in an InputError, never in another exception,
// an overflow (undefined behaviour; wrapped figures in a release build) or a result.
Decoded merge_pipeline(const Case& c, const std::map<std::size_t, std::string>& forged) {
  return ending_of([&] {
    std::vector<PartialRun> parts;
    for (std::size_t i = 0; i < c.shards.size(); ++i) {
      PartialIdentity id;
      const auto f = forged.find(i);
      parts.push_back(
          decode_partial(f != forged.end() ? f->second : encode_partial(c.shards[i], kIdentity),
                         c.bins, id, kWhat));
    }
    // As `fragsim merge` does: a refused merge names the file being merged in.
    PartialRun all = std::move(parts[0]);
    for (std::size_t i = 1; i < parts.size(); ++i) {
      try {
        run::merge(all, std::move(parts[i]));
      } catch (const InputError& e) {
        throw InputError(kWhat, e.message());
      }
    }
    const run::RunResult result = run::finish(c.sc, *c.site, std::move(all));
    return "<finished: histories_done " + std::to_string(result.histories_done) + ">";
  });
}

// A sum is a 320-bit number kept within +-2^158 (core/tally/exact_sum.h): a file whose sum is out
// of that range, or whose sums leave it when added, can only be forged; it is bad input (exit 2
// naming the file), not an internal error. The decoder's std::overflow_error escaped it.
TEST_P(PartialFile, ASumOutOfRangeIsAnInputError) {
  constexpr std::uint64_t kOutOfRange = std::uint64_t{1} << 62;  // top bits 01: beyond 2^158
  constexpr std::uint64_t kLarge = std::uint64_t{3} << 60;       // 1.5 * 2^157: in range
  const PartialRun& whole = c().whole;
  const std::string body = body_of(encode_partial(whole, kIdentity));
  const std::size_t first = offsets_of(whole).mean_bins + 8;  // u32 bin, 5 limbs
  ASSERT_GE(whole.tally.mean_sums().bins().size(), 2u);
  {  // a mean sum out of range
    std::string forged = body;
    write_at(forged, first + 4 + 32, kOutOfRange);
    expect_refused(with_trailer(forged), c().bins, "");
  }
  {  // a mean bin listed twice with sums in range whose total is not
    std::string forged = body;
    write_at(forged, first + 4 + 32, kLarge);
    write_at(forged, first + 44, read_at<std::uint32_t>(forged, first));
    write_at(forged, first + 44 + 4 + 32, kLarge);
    expect_refused(with_trailer(forged), c().bins, "");
  }
  // An open stratum's sum out of range: refused when read or when merged.
  auto with_open_sum = [&](std::size_t shard, const tally::StratumKey& key, std::uint32_t bin,
                           std::uint64_t top) {
    const PartialRun& p = c().shards[shard];
    std::vector<tally::ExactBins> var;
    for (std::size_t k = 0; k < p.tally.partitions(); ++k) var.push_back(p.tally.variance_sums(k));
    auto open = p.tally.open_strata();
    auto& entries = open.at(key).entries;
    entries = {{bin, tally::ExactSum::from_limbs({0, 0, 0, 0, top}), tally::ExactSum{}}};
    return encode_partial(with_tally(p, p.tally.mean_sums(), var, open), kIdentity);
  };
  const auto middle_open = c().middle().tally.open_strata();
  const auto& [key, st] = *middle_open.begin();
  ASSERT_TRUE(c().shards[0].tally.open_strata().count(key));
  const std::uint32_t bin = st.entries[0].bin;
  {
    SCOPED_TRACE("an open stratum's sum out of range");
    const Decoded r = merge_pipeline(c(), {{1, with_open_sum(1, key, bin, kOutOfRange)}});
    EXPECT_TRUE(r.input_error) << r.message;
    EXPECT_EQ(r.field, kWhat) << r.message;
  }
  {
    SCOPED_TRACE("the pieces of an open stratum with sums in range whose total is not");
    const Decoded r = merge_pipeline(
        c(), {{0, with_open_sum(0, key, bin, kLarge)}, {1, with_open_sum(1, key, bin, kLarge)}});
    EXPECT_TRUE(r.input_error) << r.message;
    EXPECT_EQ(r.field, kWhat) << r.message;
  }
  {
    // A cancelled partial's open strata are closed by finish(): a forged one whose variance term
    // leaves the range threw std::overflow_error out of finish() (found by fuzz_partial).
    SCOPED_TRACE("a cancelled partial's open stratum whose variance leaves the range");
    PartialRun p = c().middle();
    std::vector<tally::ExactBins> var;
    for (std::size_t k = 0; k < p.tally.partitions(); ++k) var.push_back(p.tally.variance_sums(k));
    auto open = p.tally.open_strata();
    tally::OpenStratum& forged = open.at(key);
    ASSERT_GT(forged.size, 2);
    forged.n = 2;  // variance term 2 Q = 3 * 2^158
    forged.entries = {{bin, tally::ExactSum{}, tally::ExactSum::from_limbs({0, 0, 0, 0, kLarge})}};
    p = with_tally(p, p.tally.mean_sums(), var, open);
    p.cancelled = true;
    p.stop_reason = run::StopReason::kCancelled;
    const Decoded r = ending_of([&] {
      PartialIdentity id;
      PartialRun d = decode_partial(encode_partial(p, kIdentity), c().bins, id, kWhat);
      (void)run::finish(c().sc, *c().site, std::move(d));
      return std::string("<finished>");
    });
    EXPECT_TRUE(r.input_error) << r.message;
    EXPECT_EQ(r.field, "shards") << r.message;
  }
}

// Counts no shard can have (negative, or so large that adding the shards' overflows) are refused
// by the decoder or the merge. They were read as they were: merged, they overflowed (undefined
// behaviour, found by fuzz_partial under UBSan; a release build wraps them into the summary).
TEST_P(PartialFile, CountsNoShardCanHaveAreRefused) {
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  struct Forgery {
    const char* name;
    void (*apply)(PartialRun&);
  };
  const Forgery forgeries[] = {
      {"histories_done -1", [](PartialRun& p) { p.histories_done = -1; }},
      {"histories_done max", [](PartialRun& p) { p.histories_done = kMax; }},
      {"an outcome count -5", [](PartialRun& p) { p.outcome_histories[0] = -5; }},
      {"an outcome count max", [](PartialRun& p) { p.outcome_histories[3] = kMax; }},
      {"pilot_histories max", [](PartialRun& p) { p.pilot_histories = kMax; }},
      {"tallied_batches max", [](PartialRun& p) { p.tallied_batches = kMax; }},
      {"batches -1", [](PartialRun& p) { p.batches = -1; }},
      {"threads -1", [](PartialRun& p) { p.threads = -1; }},
      {"threads max", [](PartialRun& p) { p.threads = std::numeric_limits<int>::max(); }},
      {"a stat max", [](PartialRun& p) { p.stats.integrator_steps = kMax; }},
  };
  for (const Forgery& f : forgeries) {
    SCOPED_TRACE(f.name);
    PartialRun forged = c().middle();
    f.apply(forged);
    const Decoded r = merge_pipeline(c(), {{1, encode_partial(forged, kIdentity)}});
    EXPECT_TRUE(r.input_error) << r.message;
    EXPECT_EQ(r.field, kWhat) << r.message;
  }
}

// The file functions: written and read back; a missing file or a directory is an InputError
// naming the path.
TEST_P(PartialFile, FilesRoundTripAndUnreadableOnesNameThePath) {
  const fs::path dir =
      fs::temp_directory_path() / ("fragsim_partial_file_test_" + std::to_string(::getpid()) +
                                   (GetParam() ? "_stratified" : "_plain"));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const fs::path file = dir / "partial.fsp";
  write_partial_file(file, c().middle(), kIdentity);
  PartialIdentity id;
  const PartialRun back = read_partial_file(file, c().bins, id);
  EXPECT_EQ(id, kIdentity);
  EXPECT_TRUE(encode_partial(back, id) == encode_partial(c().middle(), kIdentity));
  EXPECT_EQ(api::testing::read_text(file), encode_partial(c().middle(), kIdentity));
  for (const fs::path& bad : {dir / "missing.fsp", dir}) {
    try {
      (void)read_partial_file(bad, c().bins, id);
      ADD_FAILURE() << bad << " was read";
    } catch (const InputError& e) {
      EXPECT_EQ(e.field(), bad.string()) << e.what();
      EXPECT_NE(e.message().find(bad == dir ? "a directory" : "cannot read"), std::string::npos)
          << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << bad << ": not an InputError: " << e.what();
    }
  }
  fs::remove_all(dir);
}

// A divided precision run's batch state (fragsim-mpi's exchange): the batch's partial, the
// elapsed time and the learner's input round-trip to the same bytes; a truncated state, or
// learner input of a shard not in the batch, is an InputError.
TEST_P(PartialFile, BatchStatesRoundTripAndDamageIsAnError) {
  run::BatchState b;
  b.batch = 3;
  b.elapsed_s = 1.25;
  b.part = c().middle();
  b.part.records.clear();
  b.part.trajectories.clear();
  run::LearnerInput in;
  in.group = {0, 1};
  in.cell = {5, 7};
  in.likelihood_ratio = {0.5, 2.0};
  in.building = {-1, 0};
  in.contributed = {1, 0};
  in.entries_end = {2, 2};
  in.bin = {10, 11};
  in.x = {0.25, 1e-9};
  b.learnt.push_back({1, in});
  const std::string once = encode_batch(b, kIdentity);
  PartialIdentity id;
  const run::BatchState back = decode_batch(once, c().bins, id, kWhat);
  EXPECT_EQ(id, kIdentity);
  EXPECT_EQ(back.batch, 3);
  EXPECT_EQ(back.elapsed_s, 1.25);
  ASSERT_EQ(back.learnt.size(), 1u);
  EXPECT_EQ(back.learnt[0].shard, 1);
  EXPECT_EQ(back.learnt[0].input.x, in.x);
  EXPECT_EQ(back.learnt[0].input.entries_end, in.entries_end);
  EXPECT_EQ(back.part.histories_done, b.part.histories_done);
  EXPECT_TRUE(encode_batch(back, id) == once);
  EXPECT_THROW((void)decode_batch(once.substr(0, once.size() - 3), c().bins, id, kWhat),
               InputError);
  b.learnt[0].shard = 2;  // the middle shard is shard 1
  EXPECT_THROW((void)decode_batch(encode_batch(b, kIdentity), c().bins, id, kWhat), InputError);
}

INSTANTIATE_TEST_SUITE_P(Tallies, PartialFile, ::testing::Bool(),
                         [](const ::testing::TestParamInfo<bool>& i) {
                           return i.param ? "StratifiedLaunch" : "OnePartition";
                         });

}  // namespace
}  // namespace fragsim::formats
