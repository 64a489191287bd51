#pragma once
// Terrain from triangle-mesh files (STL, OBJ, PLY: gis/mesh_files.h) as a site.terrain object of
// the scenario contract (docs/gis.md, "Mesh terrain"): the files' facets, mapped into the site's
// axes and welded, as a `mesh` terrain (which must then be a height surface), or resampled to a
// `grid` terrain; with a material per triangle.
#include <array>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/common/types.h"
#include "gis/mesh_files.h"

namespace fragsim::gis {

// Site axis k = sign[k] * file axis from[k] (a proper rotation: determinant +1).
struct AxisMap {
  std::array<int, 3> from{0, 1, 2};
  std::array<double, 3> sign{1, 1, 1};
  Vec3 apply(const Vec3& p) const {
    return Vec3(sign[0] * p[from[0]], sign[1] * p[from[1]], sign[2] * p[from[2]]);
  }
};

// "z_up" (the identity), "y_up" (= ["x", "-z", "y"]) or three of "x", "-x", "y", "-y", "z",
// "-z" (a leading "+" allowed). InputError(field, ...) for anything else or a mirror.
AxisMap parse_axes(const nlohmann::json& j, const std::string& field);

struct MeshSource {
  std::string path;                                      // resolved
  std::string material;                                  // the file's material
  std::map<std::string, std::string> material_by_group;  // group name -> material
};

struct MeshTerrainImport {
  std::vector<MeshSource> meshes;
  AxisMap axes;
  double weld_m = 1e-6;                  // vertices closer than this are merged
  std::optional<double> grid_spacing_m;  // resample to a grid terrain
  std::string field = "terrain";         // the import file's field, for errors
};

struct ImportedMeshTerrain {
  // {"material", "mesh" | "grid", "triangle_materials": {"names", "index"}}
  nlohmann::ordered_json terrain;
  std::vector<Vec2> outline_m;  // the plan bounding box, counter-clockwise
  std::size_t file_facets = 0;  // facets read (triangles, after splitting polygons)
  std::size_t vertices = 0, triangles = 0;
  int nx = 0, ny = 0;  // a grid's nodes (0 for a mesh)
  // Resampled: lattice nodes with no facet above them (outside the survey's outline). Not 0: the
  // terrain is a mesh of the lattice cells whose four corners are covered, not a grid.
  std::size_t uncovered_nodes = 0;
};

// Reads, maps and welds the files and checks the result, before anything is written: a mesh
// must be a height surface (no vertical facet, no two facets overlapping in plan); resampled,
// the cells whose four corners have mesh above them are kept (all: a grid).
// InputError("<field>.meshes[i]", "<file>: facet k: ...") naming the file and its facet (0-based).
ImportedMeshTerrain import_mesh_terrain(const MeshTerrainImport& spec);

// A scenario shape {"type": "polyhedron", "vertices_m": [...]}: the file's distinct vertices
// (those of its facets, welded at weld_m) after the axis map, centred on their mean.
nlohmann::ordered_json shape_from_mesh_file(const std::string& path, const AxisMap& axes,
                                            double weld_m);

}  // namespace fragsim::gis
