// Mesh file readers (gis/mesh_files.h): every format gives the file's facets, in its order, with
// its groups; a bad file is refused naming the file and the facet (0-based).
#include "gis/mesh_files.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "api/test_support.h"
#include "core/common/error.h"
#include "mesh_fixtures.h"

namespace fragsim::gis {
namespace {

namespace fs = std::filesystem;
using testing::MeshFixture;
using testing::MeshFormat;
using testing::write_mesh;

// A square pyramid (base 4 m x 4 m, apex 3 m up), its four faces in two groups.
MeshFixture pyramid() {
  return {{{0, 0, 0}, {4, 0, 0}, {4, 4, 0}, {0, 4, 0}, {2, 2, 3}},
          {{0, 1, 4}, {1, 2, 4}, {2, 3, 4}, {3, 0, 4}},
          {7, 7, 9, 9}};
}

class MeshFilesTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = api::testing::fresh_test_dir("fragsim_gis_mesh_files_"); }
  void TearDown() override { fs::remove_all(dir_); }

  // The error reading `path` ("<field>: <message>"), or "<no error>".
  static std::string error_of(const fs::path& path) {
    try {
      read_mesh_file(path.string(), "terrain.meshes[0]");
    } catch (const InputError& e) {
      return e.what();
    }
    return "<no error>";
  }

  fs::path dir_;
};

TEST_F(MeshFilesTest, EveryFormatGivesTheFacetsAndGroups) {
  const MeshFixture p = pyramid();
  for (const MeshFormat f : testing::kMeshFormats) {
    const fs::path path = write_mesh(dir_ / "pyramid", p, f);
    const MeshData m = read_mesh_file(path.string(), "f");
    SCOPED_TRACE(path.string());
    ASSERT_EQ(m.triangles.size(), 4u);
    for (std::size_t t = 0; t < 4; ++t) {
      EXPECT_EQ(m.facet[t], t);
      for (int k = 0; k < 3; ++k)
        for (int c = 0; c < 3; ++c)
          EXPECT_EQ(m.vertices[m.triangles[t][k]][c], p.vertices[p.triangles[t][k]][c]);  // exact
    }
    const FaceGroup& g0 = m.groups[m.group[0]];
    const FaceGroup& g3 = m.groups[m.group[3]];
    if (f == MeshFormat::kObj) {
      EXPECT_EQ(g0.group, "g7");
      EXPECT_EQ(g3.group, "g9");
    } else if (f == MeshFormat::kPlyAscii || f == MeshFormat::kPlyBinary) {
      EXPECT_EQ(g0.material, "7");
      EXPECT_EQ(g3.material, "9");
    } else {
      EXPECT_EQ(m.group[0], m.group[3]);  // STL: one solid
    }
  }
}

TEST_F(MeshFilesTest, ObjPolygonsAreFannedAndKeepTheirFaceNumber) {
  std::ofstream(dir_ / "quad.obj") << "o site\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
                                      "usemtl rock\nf 1 2 3\nf -4 -3 -2 -1\n";
  const MeshData m = read_mesh_file((dir_ / "quad.obj").string(), "f");
  ASSERT_EQ(m.triangles.size(), 3u);
  EXPECT_EQ(m.facet, (std::vector<std::uint32_t>{0, 1, 1}));
  EXPECT_EQ(m.groups[m.group[2]], (FaceGroup{"rock", "", "site"}));
  EXPECT_EQ(m.triangles[2], (std::array<std::uint32_t, 3>{0, 2, 3}));
}

TEST_F(MeshFilesTest, BadFilesAreRefusedNamingTheFileAndFacet) {
  MeshFixture p = pyramid();
  // Truncated: a binary STL cut inside facet 2, an ASCII STL inside facet 3, a PLY inside face 1.
  fs::path path = write_mesh(dir_ / "cut", p, MeshFormat::kStlBinary);
  fs::resize_file(path, 84 + 50 * 2 + 20);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: cut.stl: facet 2: truncated (the header says 4 facets, 284 bytes; "
            "the file has 204)");
  path = write_mesh(dir_ / "cut", p, MeshFormat::kStlAscii);
  fs::resize_file(path, fs::file_size(path) - 40);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: cut.stl: facet 3: truncated (the file ends inside the facet)");
  path = write_mesh(dir_ / "cut", p, MeshFormat::kPlyBinary);
  fs::resize_file(path, fs::file_size(path) - 3 * 17);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: cut.ply: facet 1: truncated (the file ends before it)");
  // A NaN vertex, a zero-area facet, an index out of range.
  p.vertices[2][1] = std::nan("");
  for (const MeshFormat f : {MeshFormat::kStlAscii, MeshFormat::kObj, MeshFormat::kPlyBinary}) {
    path = write_mesh(dir_ / "nan", p, f);
    EXPECT_EQ(error_of(path), "terrain.meshes[0]: nan" + path.extension().string() +
                                  ": facet 1: vertex (4, nan, 0) is not finite");
  }
  p = pyramid();
  p.vertices[4] = {2, 0, 0};  // the apex on the base's first edge: facet 0 has no area
  path = write_mesh(dir_ / "flat", p, MeshFormat::kObj);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: flat.obj: facet 0: zero-area facet (its vertices "
            "are on a line or repeated)");
  p = pyramid();
  p.triangles[3][1] = 5;
  path = write_mesh(dir_ / "range", p, MeshFormat::kPlyAscii);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: range.ply: facet 3: vertex index 5 out of range (vertices: 5)");
  path = write_mesh(dir_ / "range", p, MeshFormat::kObj);
  EXPECT_EQ(error_of(path),
            "terrain.meshes[0]: range.obj: facet 3: line 12: vertex index \"6\" "
            "out of range (vertices so far: 5)");
  std::ofstream(dir_ / "x.dxf") << "0\n";
  EXPECT_EQ(error_of(dir_ / "x.dxf"),
            "terrain.meshes[0]: x.dxf: unknown mesh format \".dxf\" (.stl, .obj or .ply)");
}

}  // namespace
}  // namespace fragsim::gis
