// The pieces of a divided run on a scenario (default: the bundled demo), for docs/cluster.md's
// model of many ranks: the size of a shard's partial, and the time to encode it (what a rank
// sends), decode it and merge it (what a receiving rank does per message), and to finish the
// merged whole (rank 0, once).
//
//   build/bench/bench_partial [scenario.json] [--shards P] [--samples-scale X]
//
// Shards are run in this process one after the other on all threads (their time is the run's,
// not measured here). Each timing is the best of 3.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <string>

#include "api/scenario_json.h"
#include "core/run/partial.h"
#include "formats/partial_file.h"

using namespace fragsim;
using Clock = std::chrono::steady_clock;

namespace {

template <class F>
double best_of_3(F f) {
  double best = 1e300;
  for (int k = 0; k < 3; ++k) {
    const auto t0 = Clock::now();
    f();
    best = std::min(best, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  std::string path = std::string(FRAGSIM_SOURCE_DIR) + "/examples/demo/scenario.json";
  std::int64_t shards = 8;
  double scale = 1.0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--shards") && i + 1 < argc)
      shards = std::atoll(argv[++i]);
    else if (!std::strcmp(argv[i], "--samples-scale") && i + 1 < argc)
      scale = std::atof(argv[++i]);
    else
      path = argv[i];
  }
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  api::ScenarioDocument doc = api::parse_scenario_document_text(text.str());
  run::Scenario& sc = doc.scenario;
  for (auto& g : sc.groups)
    g.samples = std::max<std::int64_t>(
        1, static_cast<std::int64_t>(static_cast<double>(g.samples) * scale));
  sc.settings.threads = 0;
  const auto site = scene::Site::build(sc.site);
  const run::TallyBins bins = run::tally_bins(sc, *site);
  std::printf("%s: %zu tally bins (%zu terrain triangles), %lld shards\n", path.c_str(), bins.total,
              site->terrain_triangle_count(), static_cast<long long>(shards));

  std::vector<std::string> bytes;
  const formats::PartialIdentity id{"bench", scale};
  double encode_s = 0.0, decode_s = 0.0, merge_s = 0.0;
  std::size_t total_bytes = 0;
  std::vector<run::PartialRun> parts;
  for (std::int64_t i = 0; i < shards; ++i) {
    run::PartialRun p = run::run_partial(sc, site, {i, shards});
    std::string b;
    encode_s += best_of_3([&] { b = formats::encode_partial(p, id); });
    formats::PartialIdentity got;
    decode_s +=
        best_of_3([&] { parts.push_back(formats::decode_partial(b, bins.total, got, "x")); });
    parts.resize(static_cast<std::size_t>(i) + 1);
    total_bytes += b.size();
    bytes.push_back(std::move(b));
  }
  // Sequential merge into one (rank 0 of a flat gather); copies from the decoded bytes so that
  // each timing starts from the same state.
  run::PartialRun whole;
  merge_s = best_of_3([&] {
    formats::PartialIdentity got;
    whole = formats::decode_partial(bytes[0], bins.total, got, "x");
    for (std::size_t k = 1; k < bytes.size(); ++k)
      run::merge(whole, formats::decode_partial(bytes[k], bins.total, got, "x"));
  });
  const double merge_only_s = merge_s - decode_s;
  // finish() consumes its partial: each timing decodes a copy of the whole first.
  const std::string whole_bytes = formats::encode_partial(whole, id);
  auto copy_of_whole = [&] {
    formats::PartialIdentity got;
    return formats::decode_partial(whole_bytes, bins.total, got, "x");
  };
  const double copy_s = best_of_3([&] { copy_of_whole(); });
  const double finish_s = best_of_3([&] { run::finish(sc, *site, copy_of_whole()); }) - copy_s;
  const auto n = static_cast<double>(shards);
  const double mib = static_cast<double>(total_bytes) / 1048576.0;
  std::printf("partials: %.2f MiB in all, %.2f MiB per shard on average; merged whole %.2f MiB\n",
              mib, mib / n, static_cast<double>(whole_bytes.size()) / 1048576.0);
  std::printf("encode: %.1f ms per shard (%.0f MiB/s)\n", 1e3 * encode_s / n, mib / encode_s);
  std::printf("decode: %.1f ms per shard (%.0f MiB/s)\n", 1e3 * decode_s / n, mib / decode_s);
  std::printf("merge (after decode): %.1f ms per shard\n", 1e3 * merge_only_s / (n - 1.0));
  std::printf("finish the merged whole: %.1f ms (after a decode of it: %.1f ms)\n", 1e3 * finish_s,
              1e3 * copy_s);
  return 0;
}
