#pragma once
// HDF5 C API helpers shared by the HDF5 files fragsim writes (results.h5, compare.h5, the VTKHDF
// files): handles that close themselves, errors as exceptions, C++ types to HDF5 types, and a
// file writer. Internal to formats/ and api/ (their .cpp files include it); callers use
// formats/results_h5.h and formats/vtkhdf.h.
//
// Every HDF5 call must hold hdf5_mutex(): the library Debian ships is not thread-safe.
#include <hdf5.h>

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

#include "formats/output_dir.h"

namespace fragsim::formats::h5 {

// The HDF5 library Debian ships is not built thread-safe: every call into it from this file is
// serialised (fragsimd reads results on request threads while a job writes its own file).
inline std::mutex& hdf5_mutex() {
  static std::mutex m;
  return m;
}

// ---- Handles and errors ----

// Silences HDF5's automatic error printing while an api call runs; failures become exceptions.
class QuietErrors {
 public:
  QuietErrors() {
    H5Eget_auto2(H5E_DEFAULT, &func_, &data_);
    H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  }
  ~QuietErrors() { H5Eset_auto2(H5E_DEFAULT, func_, data_); }
  QuietErrors(const QuietErrors&) = delete;
  QuietErrors& operator=(const QuietErrors&) = delete;

 private:
  H5E_auto2_t func_ = nullptr;
  void* data_ = nullptr;
};

class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t), const std::string& what) : id_(id), close_(close) {
    if (id_ < 0) throw std::runtime_error("HDF5: " + what);
  }
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  operator hid_t() const { return id_; }  // NOLINT: a handle is used where an id is expected

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

inline void check(herr_t status, const std::string& what) {
  if (status < 0) throw std::runtime_error("HDF5: " + what);
}

// Memory type and little-endian file type per C++ type.
template <class T>
struct H5Type;
template <>
struct H5Type<double> {
  static hid_t mem() { return H5T_NATIVE_DOUBLE; }
  static hid_t file() { return H5T_IEEE_F64LE; }
};
template <>
struct H5Type<std::uint8_t> {
  static hid_t mem() { return H5T_NATIVE_UINT8; }
  static hid_t file() { return H5T_STD_U8LE; }
};
template <>
struct H5Type<std::int32_t> {
  static hid_t mem() { return H5T_NATIVE_INT32; }
  static hid_t file() { return H5T_STD_I32LE; }
};
template <>
struct H5Type<std::uint32_t> {
  static hid_t mem() { return H5T_NATIVE_UINT32; }
  static hid_t file() { return H5T_STD_U32LE; }
};
template <>
struct H5Type<std::int64_t> {
  static hid_t mem() { return H5T_NATIVE_INT64; }
  static hid_t file() { return H5T_STD_I64LE; }
};
template <>
struct H5Type<std::uint64_t> {
  static hid_t mem() { return H5T_NATIVE_UINT64; }
  static hid_t file() { return H5T_STD_U64LE; }
};

// Fixed-length string type (UTF-8 unless told), null-padded; at least one byte (HDF5 has no
// empty type).
inline hid_t string_type(std::size_t size, H5T_cset_t cset = H5T_CSET_UTF8) {
  const hid_t t = H5Tcopy(H5T_C_S1);
  if (t < 0) return t;
  H5Tset_size(t, std::max<std::size_t>(size, 1));
  H5Tset_strpad(t, H5T_STR_NULLPAD);
  H5Tset_cset(t, cset);
  return t;
}

// ---- The in-memory file's image ----

// Bob Jenkins' lookup3 hash ("hashlittle", public domain, 2006), the checksum the HDF5 file format
// gives its version 2 and 3 superblocks (HDF5 File Format Specification 3.0, "Superblock",
// "Superblock Checksum"; H5_checksum_lookup3 in the library). Bytes taken as little-endian words.
inline std::uint32_t lookup3(const unsigned char* k, std::size_t length,
                             std::uint32_t initval = 0) {
  const auto rot = [](std::uint32_t x, int r) { return (x << r) | (x >> (32 - r)); };
  const auto word = [](const unsigned char* p, std::size_t n) {  // n <= 4 bytes, the rest 0
    std::uint32_t w = 0;
    for (std::size_t i = 0; i < n; ++i) w |= static_cast<std::uint32_t>(p[i]) << (8 * i);
    return w;
  };
  std::uint32_t a = 0xdeadbeefU + static_cast<std::uint32_t>(length) + initval, b = a, c = a;
  while (length > 12) {
    a += word(k, 4), b += word(k + 4, 4), c += word(k + 8, 4);
    a -= c, a ^= rot(c, 4), c += b;  // mix
    b -= a, b ^= rot(a, 6), a += c;
    c -= b, c ^= rot(b, 8), b += a;
    a -= c, a ^= rot(c, 16), c += b;
    b -= a, b ^= rot(a, 19), a += c;
    c -= b, c ^= rot(b, 4), b += a;
    k += 12, length -= 12;
  }
  if (length == 0) return c;
  a += word(k, std::min<std::size_t>(length, 4));
  if (length > 4) b += word(k + 4, std::min<std::size_t>(length - 4, 4));
  if (length > 8) c += word(k + 8, length - 8);
  c ^= b, c -= rot(b, 14);  // final
  a ^= c, a -= rot(c, 11);
  b ^= a, b -= rot(a, 25);
  c ^= b, c -= rot(b, 16);
  a ^= c, a -= rot(c, 4);
  b ^= a, b -= rot(a, 14);
  c ^= b, c -= rot(b, 24);
  return c;
}

// H5Fget_file_image of HDF5 1.10.8 (Debian 12) patches the image's version 2 superblock (its
// status flags) without recomputing the superblock's checksum, and no reader opens the image
// ("incorrect metadata checksum"). The checksum is recomputed here: 4 bytes little-endian after
// signature (8), version, sizes of offsets and lengths, flags (1 each), base, extension,
// end-of-file and root addresses (4 of the size of offsets).
inline void reseal_superblock(std::string& image, const std::string& name) {
  const auto* p = reinterpret_cast<unsigned char*>(image.data());
  if (image.size() < 12 || (p[8] != 2 && p[8] != 3))
    throw std::runtime_error("HDF5: the image of " + name + " has no version 2 or 3 superblock");
  const std::size_t covered = 12 + 4 * static_cast<std::size_t>(p[9]);
  if (image.size() < covered + 4) throw std::runtime_error("HDF5: a short image of " + name);
  const std::uint32_t sum = lookup3(p, covered);
  for (int i = 0; i < 4; ++i) image[covered + i] = static_cast<char>((sum >> (8 * i)) & 0xff);
}

// ---- Writer ----

// The deflate level of large fields: 1 (on the demo's results.h5, 1.2 % larger than level 4 and
// 0.1 s quicker to write; docs/benchmarks.md §4, stop 48).
inline constexpr int kDeflateLevel = 1;

// Whether deflating this field pays: its first values (at most 8,192), shuffled and deflated at
// kDeflateLevel, shrink by at least 10 %. Near-random doubles (a fragment's positions, velocities,
// times) shrink by 12-17 % over a whole field (so less over a probe) and are stored as they are.
bool worth_deflating(const void* data, std::size_t elements, std::size_t element_size);

// Builds the file in memory (HDF5's core driver, no backing store) and writes it out in one piece
// at close(). HDF5 1.10 cannot survive a file whose writes fail: an H5Fclose that fails for a full
// disk leaves the file's id valid over freed memory, and the next call on it, or the library's
// own clean-up at exit, crashes (seen with Debian 12's 1.10.8, docs/operations.md). Here HDF5
// never writes to disk; write_new_file() reserves the whole size first, and a full disk becomes a
// StorageFullError naming the path and the bytes. Peak memory at close: twice the file's size.
// The image's superblock checksum is mended (reseal_superblock) before it is written.
class Writer {
 public:
  explicit Writer(const std::filesystem::path& path) : path_(path), name_(path.string()) {
    const Handle fcpl(H5Pcreate(H5P_FILE_CREATE), H5Pclose, "property list");
    check(H5Pset_attr_phase_change(fcpl, 0, 0), "dense attribute storage");
    const Handle fapl(H5Pcreate(H5P_FILE_ACCESS), H5Pclose, "property list");
    check(H5Pset_libver_bounds(fapl, H5F_LIBVER_V18, H5F_LIBVER_V18), "format version bounds");
    check(H5Pset_fapl_core(fapl, kImageIncrement, 0), "in-memory file driver");
    std::error_code ec;
    if (std::filesystem::exists(path_, ec))
      throw std::runtime_error("HDF5: cannot create " + name_ + ": it exists");
    file_ = H5Fcreate(name_.c_str(), H5F_ACC_EXCL, fcpl, fapl);
    if (file_ < 0) throw std::runtime_error("HDF5: cannot create " + name_);
  }
  ~Writer() {
    if (file_ >= 0) H5Fclose(file_);  // memory only: nothing reaches the disk
  }
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // Writes the file: HDF5 flushes into its image, the image is copied out and the in-memory file
  // closed, then the copy is written to the path.
  void close() {
    const hid_t f = file_;
    file_ = -1;
    std::string image;
    try {
      check(H5Fflush(f, H5F_SCOPE_GLOBAL), "flushing " + name_);
      const ssize_t size = H5Fget_file_image(f, nullptr, 0);
      if (size < 0) throw std::runtime_error("HDF5: the image of " + name_);
      image.resize(static_cast<std::size_t>(size));
      if (H5Fget_file_image(f, image.data(), image.size()) != size)
        throw std::runtime_error("HDF5: copying the image of " + name_);
      reseal_superblock(image, name_);
    } catch (...) {
      H5Fclose(f);
      throw;
    }
    check(H5Fclose(f), "closing " + name_);
    write_new_file(path_, image);
  }

  hid_t file() const { return file_; }

  Handle group(const std::string& path) {
    return Handle(H5Gcreate2(file_, path.c_str(), H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT), H5Gclose,
                  "cannot create group " + path + " in " + name_);
  }

  // rows x cols (cols == 0: a 1-D dataset of `rows`; rows == 0 with scalar: a scalar).
  template <class T>
  void dataset(const std::string& path, const T* data, std::size_t rows, std::size_t cols = 0) {
    write(path, H5Type<T>::mem(), H5Type<T>::file(), data, rows, cols, false);
  }
  template <class T>
  void dataset(const std::string& path, const std::vector<T>& v) {
    dataset(path, v.data(), v.size());
  }
  template <class T>
  void scalar(const std::string& path, T value) {
    write(path, H5Type<T>::mem(), H5Type<T>::file(), &value, 1, 0, true);
  }
  void strings(const std::string& path, const std::vector<std::string>& values) {
    std::size_t width = 1;
    for (const auto& s : values) width = std::max(width, s.size());
    std::vector<char> buffer(values.size() * width, '\0');
    for (std::size_t k = 0; k < values.size(); ++k)
      std::copy(values[k].begin(), values[k].end(), buffer.begin() + static_cast<long>(k * width));
    const Handle type(string_type(width), H5Tclose, "string type");
    write(path, type, type, buffer.data(), values.size(), 0, false);
  }

  template <class T>
  void attribute(hid_t object, const char* name, T value) {
    const Handle space(H5Screate(H5S_SCALAR), H5Sclose, "dataspace");
    const Handle attr(H5Acreate2(object, name, H5Type<T>::file(), space, H5P_DEFAULT, H5P_DEFAULT),
                      H5Aclose, std::string("cannot create attribute ") + name);
    check(H5Awrite(attr, H5Type<T>::mem(), &value), std::string("writing attribute ") + name);
  }
  void attribute(hid_t object, const char* name, const std::string& value) {
    const Handle type(string_type(value.size()), H5Tclose, "string type");
    const Handle space(H5Screate(H5S_SCALAR), H5Sclose, "dataspace");
    const Handle attr(H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                      std::string("cannot create attribute ") + name);
    std::vector<char> buffer(std::max<std::size_t>(value.size(), 1), '\0');
    std::copy(value.begin(), value.end(), buffer.begin());
    check(H5Awrite(attr, type, buffer.data()), std::string("writing attribute ") + name);
  }
  void attribute(hid_t object, const char* name, const char* value) {
    attribute(object, name, std::string(value));
  }
  // A 1-D array attribute of 64-bit integers.
  void attribute(hid_t object, const char* name, const std::vector<std::int64_t>& values) {
    const hsize_t n = values.size();
    const Handle space(H5Screate_simple(1, &n, nullptr), H5Sclose, "dataspace");
    const Handle attr(H5Acreate2(object, name, H5T_STD_I64LE, space, H5P_DEFAULT, H5P_DEFAULT),
                      H5Aclose, std::string("cannot create attribute ") + name);
    check(H5Awrite(attr, H5T_NATIVE_INT64, values.data()),
          std::string("writing attribute ") + name);
  }
  // A fixed-length ASCII string attribute (formats that name their types so, e.g. VTKHDF).
  void ascii_attribute(hid_t object, const char* name, const std::string& value) {
    const Handle type(string_type(value.size(), H5T_CSET_ASCII), H5Tclose, "string type");
    const Handle space(H5Screate(H5S_SCALAR), H5Sclose, "dataspace");
    const Handle attr(H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT), H5Aclose,
                      std::string("cannot create attribute ") + name);
    check(H5Awrite(attr, type, value.c_str()), std::string("writing attribute ") + name);
  }
  // Attribute on a dataset by path.
  void dataset_attribute(const std::string& path, const char* name, const std::string& value) {
    const Handle d(H5Dopen2(file_, path.c_str(), H5P_DEFAULT), H5Dclose, "cannot open " + path);
    attribute(d, name, value);
  }

 private:
  void write(const std::string& path, hid_t mem_type, hid_t file_type, const void* data,
             std::size_t rows, std::size_t cols, bool is_scalar) {
    const int rank = cols == 0 ? 1 : 2;
    const hsize_t dims[2] = {rows, cols};
    const Handle space(is_scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(rank, dims, nullptr),
                       H5Sclose, "dataspace for " + path);
    const Handle dcpl(H5Pcreate(H5P_DATASET_CREATE), H5Pclose, "property list");
    // Large fields are chunked and compressed (shuffle + deflate) when a probe of their first
    // values shows it pays (worth_deflating); both filters are deterministic, and readers see the
    // same values either way. Level 1, and no deflate of near-random doubles (a fragment's
    // positions, velocities, times: 1.12-1.17 x at most): docs/benchmarks.md §4, stop 48.
    const std::size_t elements = rows * std::max<std::size_t>(cols, 1);
    if (!is_scalar && elements >= kCompressElements && H5Zfilter_avail(H5Z_FILTER_DEFLATE) > 0 &&
        worth_deflating(data, elements, H5Tget_size(mem_type))) {
      const std::size_t width = std::max<std::size_t>(cols, 1);
      const hsize_t chunk[2] = {
          std::min<hsize_t>(rows, std::max<std::size_t>(1, kChunkElements / width)), cols};
      check(H5Pset_chunk(dcpl, rank, chunk), "chunking " + path);
      check(H5Pset_shuffle(dcpl), "shuffle filter for " + path);
      check(H5Pset_deflate(dcpl, kDeflateLevel), "deflate filter for " + path);
    }
    const Handle dset(
        H5Dcreate2(file_, path.c_str(), file_type, space, H5P_DEFAULT, dcpl, H5P_DEFAULT), H5Dclose,
        "cannot create dataset " + path + " in " + name_);
    if (elements > 0)
      check(H5Dwrite(dset, mem_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data), "writing " + path);
  }

  static constexpr std::size_t kCompressElements = 1 << 16;
  static constexpr std::size_t kChunkElements = 1 << 16;
  static constexpr std::size_t kImageIncrement = 4 << 20;  // the in-memory file grows by 4 MiB
  std::filesystem::path path_;
  std::string name_;
  hid_t file_ = -1;
};

}  // namespace fragsim::formats::h5
