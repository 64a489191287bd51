#pragma once
// Mesh files written by the tests: one mesh (vertices, triangles, a group per triangle) as ASCII
// or binary STL, OBJ, or ASCII or binary little-endian PLY.
#include <array>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace fragsim::gis::testing {

enum class MeshFormat { kStlAscii, kStlBinary, kObj, kPlyAscii, kPlyBinary };
inline const std::vector<MeshFormat> kMeshFormats = {MeshFormat::kStlAscii, MeshFormat::kStlBinary,
                                                     MeshFormat::kObj, MeshFormat::kPlyAscii,
                                                     MeshFormat::kPlyBinary};

inline const char* extension(MeshFormat f) {
  return f == MeshFormat::kObj                                         ? ".obj"
         : (f == MeshFormat::kPlyAscii || f == MeshFormat::kPlyBinary) ? ".ply"
                                                                       : ".stl";
}

struct MeshFixture {
  std::vector<std::array<double, 3>> vertices;
  std::vector<std::array<int, 3>> triangles;
  std::vector<int> group;  // per triangle (OBJ: "g g<k>"; PLY: an int property); empty: none
};

inline std::string num(double x) {
  char b[40];
  std::snprintf(b, sizeof b, "%.17g", x);
  return b;
}

template <class T>
void put(std::ofstream& out, T v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
}

// Writes `m` as `path` (+ the format's extension) and returns the path written.
inline std::filesystem::path write_mesh(const std::filesystem::path& stem, const MeshFixture& m,
                                        MeshFormat f) {
  if (!m.group.empty() && m.group.size() != m.triangles.size())
    throw std::logic_error("mesh fixture: one group per triangle, or none");
  std::filesystem::path path = stem;
  path += extension(f);
  std::ofstream out(path, std::ios::binary);
  const auto& v = m.vertices;
  switch (f) {
    case MeshFormat::kStlAscii:
      out << "solid test\n";
      for (const auto& t : m.triangles) {
        out << "facet normal 0 0 0\nouter loop\n";
        for (const int k : t)
          out << "vertex " << num(v[k][0]) << " " << num(v[k][1]) << " " << num(v[k][2]) << "\n";
        out << "endloop\nendfacet\n";
      }
      out << "endsolid test\n";
      break;
    case MeshFormat::kStlBinary: {
      const char header[80] = "binary STL written by the fragsim tests";
      out.write(header, 80);
      put(out, static_cast<std::uint32_t>(m.triangles.size()));
      for (const auto& t : m.triangles) {
        for (int k = 0; k < 3; ++k) put(out, 0.0f);
        for (const int k : t)
          for (int c = 0; c < 3; ++c) put(out, static_cast<float>(v[k][c]));
        put(out, std::uint16_t{0});
      }
      break;
    }
    case MeshFormat::kObj:
      out << "# test mesh\n";
      for (const auto& p : v)
        out << "v " << num(p[0]) << " " << num(p[1]) << " " << num(p[2]) << "\n";
      for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        if (!m.group.empty() && (t == 0 || m.group[t] != m.group[t - 1]))
          out << "g g" << m.group[t] << "\n";
        out << "f " << m.triangles[t][0] + 1 << "/" << m.triangles[t][0] + 1 << " "
            << m.triangles[t][1] + 1 << " " << m.triangles[t][2] + 1 << "\n";
      }
      break;
    case MeshFormat::kPlyAscii:
    case MeshFormat::kPlyBinary: {
      const bool bin = f == MeshFormat::kPlyBinary;
      out << "ply\nformat " << (bin ? "binary_little_endian" : "ascii") << " 1.0\n"
          << "comment test mesh\nelement vertex " << v.size()
          << "\nproperty double x\nproperty double y\nproperty double z\n"
          << "element face " << m.triangles.size() << "\nproperty list uchar int vertex_indices\n"
          << (m.group.empty() ? "" : "property int material\n") << "end_header\n";
      for (const auto& p : v) {
        if (bin) {
          for (int c = 0; c < 3; ++c) put(out, p[c]);
        } else {
          out << num(p[0]) << " " << num(p[1]) << " " << num(p[2]) << "\n";
        }
      }
      for (std::size_t t = 0; t < m.triangles.size(); ++t) {
        if (bin) {
          put(out, std::uint8_t{3});
          for (const int k : m.triangles[t]) put(out, static_cast<std::int32_t>(k));
          if (!m.group.empty()) put(out, static_cast<std::int32_t>(m.group[t]));
        } else {
          out << "3 " << m.triangles[t][0] << " " << m.triangles[t][1] << " " << m.triangles[t][2];
          if (!m.group.empty()) out << " " << m.group[t];
          out << "\n";
        }
      }
      break;
    }
  }
  return path;
}

}  // namespace fragsim::gis::testing
