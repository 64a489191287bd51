// gzip of fragsimd's text answers (server/compression.h): which clients get it, which bodies, and
// that the bytes inflate back to the body.
#include "server/compression.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <random>
#include <string>

namespace fragsim::server {
namespace {

std::string gunzip(const std::string& data) {
  z_stream z{};
  EXPECT_EQ(inflateInit2(&z, 15 + 16), Z_OK);
  std::string out;
  char buf[65536];
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
  z.avail_in = static_cast<uInt>(data.size());
  int rc = Z_OK;
  while (rc == Z_OK) {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof buf;
    rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof buf - z.avail_out);
  }
  EXPECT_EQ(rc, Z_STREAM_END);
  inflateEnd(&z);
  return out;
}

TEST(Compression, AcceptEncodingIsReadAsRfc9110Has) {
  for (const char* yes : {"gzip", "gzip, deflate, br, zstd", "br;q=1.0, GZIP;q=0.5", "x-gzip", "*",
                          " deflate , gzip ", "gzip;q=0.001"})
    EXPECT_TRUE(accepts_gzip(yes)) << yes;
  for (const char* no : {"", "br", "identity", "deflate, br", "gzip;q=0", "gzip; q=0.000", "gzipx",
                         "*;q=0", "br, gzip;Q=0"})
    EXPECT_FALSE(accepts_gzip(no)) << no;
}

TEST(Compression, OnlyTextIsCompressed) {
  for (const char* yes : {"application/json", "text/html; charset=utf-8", "text/javascript",
                          "text/plain; version=0.0.4", "application/yaml", "Application/JSON"})
    EXPECT_TRUE(compressible(yes)) << yes;
  for (const char* no : {"application/x-hdf5", "application/vnd.fragsim.scene", "image/tiff",
                         "application/octet-stream", "application/geo+json", ""})
    EXPECT_FALSE(compressible(no)) << no;
}

TEST(Compression, GzipInflatesBackToTheBody) {
  std::string text;
  for (int k = 0; k < 20000; ++k)
    text += "{\"density_per_m2\": " + std::to_string(k * 0.001) + "},";
  const std::string z = gzip(text);
  EXPECT_LT(z.size(), text.size() / 4);
  EXPECT_EQ(static_cast<unsigned char>(z[0]), 0x1f);  // the gzip magic
  EXPECT_EQ(static_cast<unsigned char>(z[1]), 0x8b);
  EXPECT_EQ(gunzip(z), text);
  // Incompressible bytes and the empty body round-trip too.
  std::mt19937 rng(7);
  std::string noise(100000, '\0');
  for (char& c : noise) c = static_cast<char>(rng());
  EXPECT_EQ(gunzip(gzip(noise)), noise);
  EXPECT_EQ(gunzip(gzip("")), "");
}

}  // namespace
}  // namespace fragsim::server
