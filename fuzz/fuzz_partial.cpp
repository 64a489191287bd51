// libFuzzer target: bytes as a shard's partial file, partial.fsp (formats/partial_file.h), decoded
// for a tiny site as `fragsim merge` and fragsim-mpi decode the pieces they are given; what
// decodes is merged with copies of itself and finished (core/run/partial.h).
//
// The file ends with the CRC-32 of its body, which random mutation would almost never keep
// right: the target recomputes it, so that the fuzzer explores the structure behind it (what a
// deliberately forged file, or a bug in the writer, could present). Passing: the bytes decode, or
// are refused with InputError; a decoded partial encodes to bytes that decode and encode back to
// themselves; merging it with a copy that shares its shards is refused; merging and finishing
// either succeed, with finite figures of the site's shape, or throw InputError.
//
// Seeds (fuzz/corpus/fuzz_partial/): `fragsim run --shard I/N` of kScenario (whole_1of1,
// middle_1of3, empty_5of20) and of kScenario with "stratified_launch":
// {"histories_per_stratum": 2} (stratified_2of3); every one of the same site, so of kBins bins.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "core/run/partial.h"
#include "formats/partial_file.h"
#include "fuzz/fuzz_support.h"

namespace {

using namespace fragsim;

// A 400 m plane of 4 x 4 cells (32 terrain triangles), one building, 8 histories.
constexpr const char* kScenario = R"json({
  "schema": "fragsim.scenario/1",
  "site": {
    "origin": {"crs": "local", "easting_m": 0, "northing_m": 0, "elevation_m": 0},
    "terrain": {"plane": {"elevation_m": 0, "extent_m": [-200, -200, 200, 200], "cell_m": 100},
                "material": "soil"},
    "materials": {
      "soil": {"friction": 0.9, "restitution": 0.2},
      "wall": {"friction": 0.5, "restitution": 0.3, "penetration": {"ke_per_area_j_per_m2": 2.0e5}}
    },
    "buildings": [{"id": "B1", "footprint_m": [[30, -20], [60, -20], [60, 20], [30, 20]],
                   "height_m": 10, "wall": "wall", "roof": "wall"}]
  },
  "atmosphere": {"model": "isa", "wind_mps": [0, 0, 0]},
  "gravity_mps2": 9.80665,
  "fragment_groups": [{
    "name": "spheres", "count": 100, "samples": 8,
    "frame": {"origin_m": [0, 0, 1], "yaw_deg": 0, "pitch_deg": 0, "roll_deg": 0,
              "velocity_mps": [0, 0, 0]},
    "shape": {"type": "sphere", "density_kg_m3": 7850},
    "mass_kg": {"dist": "uniform", "min": 0.01, "max": 0.2},
    "speed_mps": {"dist": "uniform", "min": 40, "max": 60},
    "direction": {"elevation_deg": [0, 30], "azimuth_deg": [-30, 30]},
    "cd": 0.47
  }],
  "settings": {"seed": 7, "threads": 1, "record_fragments": true, "record_trajectories": true,
               "max_recorded_trajectories": 1}
})json";

struct Tiny {
  run::Scenario scenario;
  std::shared_ptr<const scene::Site> site;
  std::size_t bins = 0;
};

const Tiny& tiny() {
  static const Tiny* const t = [] {
    auto* n = new Tiny;  // never destroyed: libFuzzer exits without running destructors
    n->scenario = api::parse_scenario_document_text(kScenario).scenario;
    n->site = api::validate_scenario(n->scenario);
    n->bins = run::tally_bins(n->scenario, *n->site).total;
    return n;
  }();
  return *t;
}

// finish() either refuses, or gives figures of the site's shape, every one finite; a cancelled
// partial gives its counts only (no caller writes a cancelled run's figures).
void finish_checked(run::PartialRun&& p) {
  const Tiny& t = tiny();
  run::RunResult r;
  try {
    r = run::finish(t.scenario, *t.site, std::move(p));
  } catch (const InputError&) {
    return;
  }
  if (r.cancelled) {
    if (!r.ptn_density_per_m2.empty() || !r.buildings.empty() || !r.fragments.empty())
      fuzz::fail("finish: figures of a cancelled run");
    if (r.histories_done < 0) fuzz::fail("finish: a cancelled run's count negative");
    return;
  }
  if (r.ptn_density_per_m2.size() != t.site->terrain_triangle_count() ||
      r.ptn_std_error_per_m2.size() != t.site->terrain_triangle_count() ||
      r.buildings.size() != t.site->buildings().size())
    fuzz::fail("finish: figures not of the site's shape");
  for (std::size_t k = 0; k < r.ptn_density_per_m2.size(); ++k)
    if (!std::isfinite(r.ptn_density_per_m2[k]) || !std::isfinite(r.ptn_std_error_per_m2[k]))
      fuzz::fail("finish: a PTN figure not finite");
  for (const auto& e : r.outcome_fragments)
    if (!std::isfinite(e.mean) || !std::isfinite(e.std_error))
      fuzz::fail("finish: an outcome figure not finite");
  if (!std::isfinite(r.hazardous_fragment_distance_m)) fuzz::fail("finish: HFD not finite");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  constexpr std::size_t kTrailer = formats::kPartialTrailerBytes;
  std::string bytes(fuzz::as_text(data, size));
  if (bytes.size() >= 8 + kTrailer)
    bytes.replace(
        bytes.size() - kTrailer, kTrailer,
        formats::partial_trailer(std::string_view(bytes).substr(0, bytes.size() - kTrailer)));
  const Tiny& t = tiny();
  formats::PartialIdentity id;
  run::PartialRun p;
  try {
    p = formats::decode_partial(bytes, t.bins, id, "fuzz.fsp");
  } catch (const InputError&) {
    return 0;
  }

  // What decodes encodes to bytes that decode and encode back to themselves (the first encoding
  // may differ from the input: a flag byte 2 reads as true, a mean bin listed twice as one).
  const std::string once = formats::encode_partial(p, id);
  formats::PartialIdentity id2;
  run::PartialRun again;
  try {
    again = formats::decode_partial(once, t.bins, id2, "fuzz.fsp");
  } catch (const InputError& e) {
    fuzz::fail(std::string("a decoded partial, encoded, does not decode: ") + e.what());
  }
  if (!(id2 == id) && !(std::isnan(id.samples_scale) && std::isnan(id2.samples_scale)))
    fuzz::fail("the identity changes through encode and decode");
  if (formats::encode_partial(again, id2) != once)
    fuzz::fail("encode(decode(encode(p))) != encode(p)");

  // A copy that shares a shard is refused.
  {
    run::PartialRun a = p, b = p;
    bool refused = false;
    try {
      run::merge(a, std::move(b));
    } catch (const InputError&) {
      refused = true;
    }
    if (!p.shards.empty() && !refused) fuzz::fail("merge accepted a shard twice");
  }

  // Merged with a copy of itself that claims no shard (its tallies and strata added again),
  // then finished as the whole split when it is small enough to list.
  {
    run::PartialRun a = p, b = p;
    b.shards.clear();
    try {
      run::merge(a, std::move(b));
    } catch (const InputError&) {
      return 0;
    }
    if (a.shard_count <= 64) {
      a.shards.clear();
      for (std::int64_t k = 0; k < a.shard_count; ++k) a.shards.push_back(k);
    }
    finish_checked(std::move(a));
  }
  // And finished alone.
  finish_checked(std::move(p));
  return 0;
}
