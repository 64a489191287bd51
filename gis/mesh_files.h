#pragma once
// Triangle-mesh files as surveys deliver them (docs/gis.md, "Mesh terrain"): STL (ASCII and
// binary), Wavefront OBJ, PLY (ASCII and binary little-endian). No GDAL here: plain readers.
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/types.h"

namespace fragsim::gis {

// The names a face carries, tried in this order when a material is looked up by group: OBJ's
// `usemtl`, `g` and `o`; an STL `solid` name is a group; a PLY face's integer property is the
// material slot (its value as decimal text).
struct FaceGroup {
  std::string material, group, object;
  bool operator==(const FaceGroup&) const = default;
};

struct MeshData {
  std::vector<Vec3> vertices;  // the file's own coordinates
  std::vector<std::array<std::uint32_t, 3>> triangles;
  std::vector<std::uint32_t> facet;  // per triangle: the file's facet (face), 0-based
  std::vector<std::uint32_t> group;  // per triangle: index into `groups`
  std::vector<FaceGroup> groups;
};

// Reads the file by its extension (.stl, .obj, .ply; any case). Refuses, with
// InputError(field, "<path>: facet <k>: <reason>") or "<path>: <reason>": an unknown extension,
// a truncated or malformed file, a facet with a vertex index out of range, a vertex that is not
// finite (NaN, inf) or a facet of zero area (core/scene/validation.h's test).
MeshData read_mesh_file(const std::string& path, const std::string& field);

// The file's name for messages (its last path component).
std::string file_label(const std::string& path);

}  // namespace fragsim::gis
