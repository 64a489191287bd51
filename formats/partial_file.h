#pragma once
// The partial result of a shard (core/run/partial.h) as bytes and as a file, "partial.fsp"
// (docs/cluster.md, "The partial file"): the exact tally sums, the open strata, counts, records
// and recorded trajectories, with the scenario's digest, so that `fragsim merge` and fragsim-mpi
// can check that every piece belongs to the same run.
//
// Layout, little-endian: "FSPART01", u32 version, the identity (scenario SHA-256, samples scale),
// the partial, and a trailer: the CRC-32 (zlib's, 8 hex digits) of everything before it, against
// accidental damage in transfer or storage (3.5 GB/s here; a SHA-256 took 75 % of the codec's
// time at 219 MB/s, and guards no better against a forger, who can recompute either). The
// reader checks the trailer, every count against the bytes left, every code and range, so a
// truncated, damaged or forged file is an error naming the file, never a wrong result.
#include <cmath>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/run/partial.h"

namespace fragsim::formats {

// What a partial must share with the others it is merged with.
struct PartialIdentity {
  std::string scenario_sha256;  // of the scenario file's bytes as read
  double samples_scale = 1.0;   // --samples-scale (1 without)
  friend bool operator==(const PartialIdentity&, const PartialIdentity&) = default;
};

// The trailer of a body (what encode_partial appends): tests and fuzzers forge with it.
inline constexpr std::size_t kPartialTrailerBytes = 8;
std::string partial_trailer(std::string_view body);

std::string encode_partial(const run::PartialRun& partial, const PartialIdentity& identity);
// Throws InputError(`what`, ...) for bytes that are not a whole, intact partial, or a partial
// whose tally has not `tally_bins` bins (run::tally_bins(scenario, site).total of the scenario and
// its site).
run::PartialRun decode_partial(std::string_view bytes, std::size_t tally_bins,
                               PartialIdentity& identity, const std::string& what);

// A shard's state at a batch boundary of a divided settings.precision run (core/run/partial.h,
// BatchState), as fragsim-mpi's ranks exchange it (bytes, never a file): "FSBATCH1", the batch,
// the elapsed time, the encoded partial of the batch's tally and counts, and the importance
// learner's input per shard. Decoding checks it as a partial file is checked.
std::string encode_batch(const run::BatchState& state, const PartialIdentity& identity);
run::BatchState decode_batch(std::string_view bytes, std::size_t tally_bins,
                             PartialIdentity& identity, const std::string& what);

// A file (callers stage it in an OutputDir, so no half-written partial.fsp is ever seen).
void write_partial_file(const std::filesystem::path& path, const run::PartialRun& partial,
                        const PartialIdentity& identity);
run::PartialRun read_partial_file(const std::filesystem::path& path, std::size_t tally_bins,
                                  PartialIdentity& identity);

}  // namespace fragsim::formats
