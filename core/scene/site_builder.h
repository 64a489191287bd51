#pragma once
// Builds a Site from a SiteSpec (internal to core/scene). SiteBuilder is Site's friend; its steps
// live in the .cpp file of their topic:
//   site_builder.cpp      build(): order of the steps, frames, bounds, the Embree scene
//   material.cpp          build_materials()
//   terrain_builder.cpp   build_terrain()
//   building_builder.cpp  build_buildings()
#include <cstdint>
#include <map>
#include <memory>
#include <string>

#include "core/scene/site.h"

namespace fragsim::scene {

using MaterialIds = std::map<std::string, std::uint16_t>;

class SiteBuilder {
 public:
  static std::shared_ptr<const Site> build(const SiteSpec& spec);

  // Validates every material and numbers them in name order.
  static MaterialIds build_materials(Site& site, const SiteSpec& spec);
  // Validates and meshes the terrain, sets the local origin, normals, areas and the 2-D index.
  static void build_terrain(Site& site, const SiteSpec& spec, const MaterialIds& ids);
  // The plane and grid forms are lattices: cell counts, origin and cell size for the cell index.
  struct Lattice {
    int ncx = 0, ncy = 0;
    Vec2 origin{0, 0};  // local
    Vec2 cell{0, 0};
  };
  // Each form of site.terrain.geometry (field `f`): validated, meshed in the local frame.
  static Lattice build_plane_terrain(Site& site, const PlaneTerrainSpec& plane,
                                     const std::string& f);
  static Lattice build_grid_terrain(Site& site, const GridTerrainSpec& grid, const std::string& f);
  static void build_mesh_terrain(Site& site, const MeshSpec& mesh, const std::string& f);
  // Each terrain triangle's material (TerrainSpec: zones, then triangle_material, then the base
  // material); needs the 2-D index.
  static void build_terrain_materials(Site& site, const TerrainSpec& terrain,
                                      const MaterialIds& ids);
  // Per-triangle areas, upward unit normals and planes, and the terrain's bounds.
  static void build_terrain_facets(Site& site);
  // Site::terrain_boundary_triangles(): from the cell counts of a lattice, from the edges shared
  // by one triangle only (vertices matched by position) of a mesh (lattice.ncx == 0).
  static void build_terrain_boundary(Site& site, const Lattice& lattice);
  // Validates and meshes the buildings (needs the terrain for default base elevations).
  static void build_buildings(Site& site, const SiteSpec& spec, const MaterialIds& ids);
  // Creates the Embree device and scene.
  static void build_embree(Site& site);
};

// Looks up a material name; throws InputError(field, "unknown material ...") if absent.
std::uint16_t material_id(const MaterialIds& ids, const std::string& name,
                          const std::string& field);

}  // namespace fragsim::scene
