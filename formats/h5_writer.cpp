#include "formats/h5_writer.h"

#include <zlib.h>

#include <algorithm>
#include <vector>

namespace fragsim::formats::h5 {

// The first kProbeElements values, shuffled as HDF5's shuffle filter does (byte k of every value,
// then byte k + 1, ...), deflated at the writer's level: kept compressed when that saves at least
// kMinSaving of them. The decision depends on the data alone, so a file's layout does too.
bool worth_deflating(const void* data, std::size_t elements, std::size_t element_size) {
  constexpr std::size_t kProbeElements = 8192;
  constexpr double kMinSaving = 0.20;
  const std::size_t n = std::min(elements, kProbeElements);
  const std::size_t bytes = n * element_size;
  if (bytes == 0) return false;
  const auto* in = static_cast<const unsigned char*>(data);
  std::vector<unsigned char> shuffled(bytes);
  for (std::size_t b = 0; b < element_size; ++b)
    for (std::size_t i = 0; i < n; ++i) shuffled[b * n + i] = in[i * element_size + b];
  uLongf out_size = compressBound(static_cast<uLong>(bytes));
  std::vector<unsigned char> out(out_size);
  if (compress2(out.data(), &out_size, shuffled.data(), static_cast<uLong>(bytes), kDeflateLevel) !=
      Z_OK)
    return false;
  return static_cast<double>(out_size) <= (1.0 - kMinSaving) * static_cast<double>(bytes);
}

}  // namespace fragsim::formats::h5
