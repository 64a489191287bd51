// Material zones from an OGR polygon layer (vector_zones.h).
#include "gis/vector_zones.h"

#include <ogrsf_frmts.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "core/common/error.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

using OJson = nlohmann::ordered_json;

// The ring's vertices without the closing repeat and consecutive duplicates (closer than 1 um).
std::vector<std::array<double, 2>> ring_points(const OGRLinearRing& ring) {
  std::vector<std::array<double, 2>> out;
  const auto same = [](const std::array<double, 2>& p, const std::array<double, 2>& q) {
    return std::hypot(p[0] - q[0], p[1] - q[1]) <= 1e-6;
  };
  for (int k = 0; k < ring.getNumPoints(); ++k) {
    const std::array<double, 2> p{ring.getX(k), ring.getY(k)};
    if (out.empty() || !same(p, out.back())) out.push_back(p);
  }
  while (out.size() > 1 && same(out.front(), out.back())) out.pop_back();
  return out;
}

OGRLayer* pick_layer(GDALDataset& ds, const ZonesImport& spec) {
  if (ds.GetLayerCount() == 0) throw InputError("zones.path", spec.path + ": has no vector layer");
  if (spec.layer.empty()) return ds.GetLayer(0);
  if (OGRLayer* l = ds.GetLayerByName(spec.layer.c_str())) return l;
  std::string names;
  for (int k = 0; k < ds.GetLayerCount(); ++k)
    names += std::string(k ? ", " : "") + "\"" + ds.GetLayer(k)->GetName() + "\"";
  throw InputError("zones.layer",
                   spec.path + ": no layer \"" + spec.layer + "\" (its layers: " + names + ")");
}

std::unique_ptr<OGRCoordinateTransformation> transform_for(OGRLayer& layer, const ZonesImport& spec,
                                                           const OGRSpatialReference& site_srs,
                                                           const std::string& where) {
  if (site_srs.IsEmpty()) return nullptr;  // a site without a CRS: coordinates as they are
  OGRSpatialReference from;
  if (!spec.source_crs.empty()) {
    from = crs_from_text(spec.source_crs, "zones.source_crs");
  } else if (const OGRSpatialReference* own = layer.GetSpatialRef()) {
    from = *own;
    from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  } else {
    throw InputError(
        "zones.path",
        where + ": the layer has no coordinate reference system; give zones.source_crs");
  }
  if (from.IsSame(&site_srs)) return nullptr;
  GdalErrorCapture errors;
  std::unique_ptr<OGRCoordinateTransformation> t(
      OGRCreateCoordinateTransformation(&from, &site_srs));
  if (!t)
    throw InputError("zones.path", where + ": cannot be reprojected from " + crs_label(from) +
                                       " to " + crs_label(site_srs) + " (" + errors.text() + ")");
  return t;
}

}  // namespace

OJson import_zones(const ZonesImport& spec, const OGRSpatialReference& site_srs,
                   const std::vector<std::string>& materials) {
  GDALDatasetUniquePtr ds = open_vector(spec.path, "zones.path");
  OGRLayer* layer = pick_layer(*ds, spec);
  const std::string where = spec.path + ", layer \"" + layer->GetName() + "\"";
  if (layer->GetLayerDefn()->GetFieldIndex(spec.material_attribute.c_str()) < 0)
    throw InputError("zones.material_attribute",
                     where + ": no attribute \"" + spec.material_attribute + "\"");
  const auto transform = transform_for(*layer, spec, site_srs, where);
  OJson zones = OJson::array();
  layer->ResetReading();
  for (auto& feature : *layer) {
    const std::string fid = where + ": feature " + std::to_string(feature->GetFID());
    const int k = feature->GetFieldIndex(spec.material_attribute.c_str());
    const std::string material =
        feature->IsFieldSetAndNotNull(k) ? feature->GetFieldAsString(k) : "";
    if (std::find(materials.begin(), materials.end(), material) == materials.end())
      throw InputError("zones", fid + ": material \"" + material +
                                    "\" is not a key of materials (nor \"hard\" or \"soft\")");
    OGRGeometry* g = feature->GetGeometryRef();
    if (g == nullptr) throw InputError("zones", fid + ": has no geometry");
    std::unique_ptr<OGRGeometry> geom(g->clone());
    if (geom->hasCurveGeometry()) geom.reset(geom->getLinearGeometry());
    if (transform && geom->transform(transform.get()) != OGRERR_NONE)
      throw InputError("zones", fid + ": cannot be reprojected into the site's CRS");
    std::vector<const OGRPolygon*> parts;
    const auto type = wkbFlatten(geom->getGeometryType());
    if (type == wkbPolygon) {
      parts.push_back(geom->toPolygon());
    } else if (type == wkbMultiPolygon) {
      for (const OGRPolygon* p : *geom->toMultiPolygon()) parts.push_back(p);
    } else {
      throw InputError(
          "zones", fid + ": is a " + std::string(OGRGeometryTypeToName(type)) + ", not a polygon");
    }
    for (std::size_t p = 0; p < parts.size(); ++p) {
      const std::string part = parts.size() > 1 ? " (part " + std::to_string(p + 1) + ")" : "";
      if (parts[p]->getNumInteriorRings() > 0)
        throw InputError("zones", fid + part +
                                      ": has a hole (interior ring); zones have none: give the "
                                      "hole its own zone after this one (a later zone wins)");
      const auto ring = ring_points(*parts[p]->getExteriorRing());
      if (ring.size() < 3)
        throw InputError("zones", fid + part + ": fewer than 3 distinct vertices");
      OJson poly = OJson::array();
      for (const auto& q : ring) poly.push_back({q[0], q[1]});
      zones.push_back({{"material", material}, {"polygon_m", std::move(poly)}});
    }
  }
  return zones;
}

}  // namespace fragsim::gis
