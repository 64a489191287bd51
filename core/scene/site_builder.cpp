// Site::build: the order of the build steps, the frames, the bounds and the Embree scene.
#include "core/scene/site_builder.h"

#include <stdexcept>

#include "core/scene/embree_scene.h"
#include "core/scene/site_limits.h"
#include "core/scene/validation.h"

namespace fragsim::scene {

namespace {

// Geometry ids in the Embree scene (site.h: terrain 0, absent for a plane; buildings 1).
constexpr unsigned kTerrainGeomId = 0;
constexpr unsigned kBuildingGeomId = 1;

void validate_origin(const SiteOrigin& o) {
  detail::require_finite(o.easting_m, "site.origin.easting_m");
  detail::require_finite(o.northing_m, "site.origin.northing_m");
  detail::require_finite(o.elevation_m, "site.origin.elevation_m");
}

}  // namespace

std::shared_ptr<const Site> Site::build(const SiteSpec& spec) {
  return SiteBuilder::build(spec);
}

std::shared_ptr<const Site> SiteBuilder::build(const SiteSpec& spec) {
  std::unique_ptr<Site> site(new Site());  // ~Site releases whatever Embree objects exist
  if (spec.origin) validate_origin(*spec.origin);
  check_site_limits(spec);  // before anything is sized from the spec
  site->origin_ = spec.origin;
  const MaterialIds ids = build_materials(*site, spec);
  build_terrain(*site, spec, ids);  // sets local_origin_
  // Altitude above sea level of local z: input z = 0 is at origin.elevation_m (site_spec.h).
  site->altitude_offset_m_ =
      site->local_origin_.z() + (spec.origin ? spec.origin->elevation_m : 0.0);
  build_buildings(*site, spec, ids);
  site->bounds_ = site->terrain_bounds_;
  if (!site->buildings_.empty()) site->bounds_.extend(site->buildings_bounds_);
  build_embree(*site);
  return std::shared_ptr<const Site>(site.release());
}

void SiteBuilder::build_embree(Site& site) {
  site.embree_log_ = std::make_unique<EmbreeErrorLog>();
  site.device_ = embree::new_device(site.embree_log_.get());
  site.scene_ = embree::new_scene(site.device_);
  // A plane's terrain is intersected analytically (Site::intersect), so it stays out of the BVH.
  if (!site.terrain_is_plane_) {
    embree::attach_triangles(site.device_, site.scene_, kTerrainGeomId, site.terrain_vertices_,
                             site.terrain_triangles_, kQueryTerrain);
    site.terrain_geom_ = kTerrainGeomId;
  }
  if (!site.building_triangles_.empty()) {
    std::vector<std::array<std::uint32_t, 3>> tris(site.building_triangles_.size());
    for (std::size_t t = 0; t < tris.size(); ++t) tris[t] = site.building_triangles_[t].v;
    embree::attach_triangles(site.device_, site.scene_, kBuildingGeomId, site.building_vertices_,
                             tris, kQueryBuildings);
    site.building_geom_ = kBuildingGeomId;
  }
  embree::commit(site.scene_);
  if (site.embree_log_->count() > 0)
    throw std::runtime_error("building the Embree scene: " + site.embree_log_->first_message());
}

}  // namespace fragsim::scene
