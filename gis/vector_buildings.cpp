// Buildings from an OGR vector layer (vector_buildings.h).
#include "gis/vector_buildings.h"

#include <ogrsf_frmts.h>

#include <cmath>
#include <memory>
#include <set>

#include "core/common/error.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

using Ring = std::vector<std::array<double, 2>>;
using OJson = nlohmann::ordered_json;

// Rings closer than this (m) are the same vertex; a footprint smaller than kMinArea_m2 is
// degenerate (a slip of the digitiser, not a building).
constexpr double kSameVertex_m = 1e-6;
constexpr double kMinArea_m2 = 0.01;
constexpr std::size_t kProblemsListed = 50;

double ring_area(const Ring& r) {
  double a2 = 0;
  for (std::size_t k = 0; k < r.size(); ++k) {
    const auto& p = r[k];
    const auto& q = r[(k + 1) % r.size()];
    a2 += p[0] * q[1] - q[0] * p[1];
  }
  return 0.5 * a2;
}

// The ring's vertices without the closing repeat and without consecutive duplicates.
Ring ring_points(const OGRLinearRing& ring) {
  Ring out;
  for (int k = 0; k < ring.getNumPoints(); ++k) {
    const std::array<double, 2> p{ring.getX(k), ring.getY(k)};
    if (!out.empty() && std::hypot(p[0] - out.back()[0], p[1] - out.back()[1]) <= kSameVertex_m)
      continue;
    out.push_back(p);
  }
  while (out.size() > 1 &&
         std::hypot(out[0][0] - out.back()[0], out[0][1] - out.back()[1]) <= kSameVertex_m)
    out.pop_back();
  return out;
}

// Inside or on the convex outline (counter-clockwise).
bool inside_outline(const std::vector<Vec2>& outline, double x, double y) {
  for (std::size_t k = 0; k < outline.size(); ++k) {
    const Vec2& a = outline[k];
    const Vec2& b = outline[(k + 1) % outline.size()];
    if ((b.x() - a.x()) * (y - a.y()) - (b.y() - a.y()) * (x - a.x()) < 0) return false;
  }
  return true;
}

std::string xy_text(const std::array<double, 2>& p) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "(%.3f, %.3f)", p[0], p[1]);
  return buf;
}

class LayerImporter {
 public:
  LayerImporter(const BuildingsImport& spec, const OGRSpatialReference& site_srs,
                const std::vector<Vec2>& outline)
      : spec_(spec), outline_(outline), ds_(open_vector(spec.path, "buildings.path")) {
    layer_ = pick_layer();
    check_attributes();
    set_up_transform(site_srs);
  }

  OJson run() {
    OJson buildings = OJson::array();
    std::int64_t features = 0;
    layer_->ResetReading();
    for (auto& feature : *layer_) {
      ++features;
      add_feature(*feature, buildings);
    }
    if (!problems_.empty()) throw_problems(features);
    return buildings;
  }

 private:
  std::string where() const { return spec_.path + ", layer \"" + layer_->GetName() + "\""; }

  OGRLayer* pick_layer() {
    if (ds_->GetLayerCount() == 0)
      throw InputError("buildings.path", spec_.path + ": has no vector layer");
    if (spec_.layer.empty()) return ds_->GetLayer(0);
    if (OGRLayer* l = ds_->GetLayerByName(spec_.layer.c_str())) return l;
    std::string names;
    for (int k = 0; k < ds_->GetLayerCount(); ++k)
      names += std::string(k ? ", " : "") + "\"" + ds_->GetLayer(k)->GetName() + "\"";
    throw InputError("buildings.layer",
                     spec_.path + ": no layer \"" + spec_.layer + "\" (its layers: " + names + ")");
  }

  void check_attribute(const std::string& name, const char* field) {
    if (name.empty() || layer_->GetLayerDefn()->GetFieldIndex(name.c_str()) >= 0) return;
    std::string names;
    OGRFeatureDefn* defn = layer_->GetLayerDefn();
    for (int k = 0; k < defn->GetFieldCount(); ++k)
      names += std::string(k ? ", " : "") + "\"" + defn->GetFieldDefn(k)->GetNameRef() + "\"";
    throw InputError(std::string("buildings.") + field,
                     where() + ": no attribute \"" + name +
                         "\" (its attributes: " + (names.empty() ? "none" : names) + ")");
  }

  void check_attributes() {
    if (spec_.height_attribute.empty() && !spec_.default_height_m)
      throw InputError("buildings", "give height_attribute, default_height_m or both");
    check_attribute(spec_.id_attribute, "id_attribute");
    check_attribute(spec_.height_attribute, "height_attribute");
    check_attribute(spec_.base_elevation_attribute, "base_elevation_attribute");
    check_attribute(spec_.wall_attribute, "wall_attribute");
    check_attribute(spec_.roof_attribute, "roof_attribute");
    check_attribute(spec_.window_attribute, "window_attribute");
  }

  void set_up_transform(const OGRSpatialReference& site_srs) {
    OGRSpatialReference from;
    if (!spec_.source_crs.empty()) {
      from = crs_from_text(spec_.source_crs, "buildings.source_crs");
    } else if (const OGRSpatialReference* own = layer_->GetSpatialRef()) {
      from = *own;
      from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    } else {
      throw InputError("buildings.path", where() +
                                             ": the layer has no coordinate reference system; "
                                             "give buildings.source_crs");
    }
    if (from.IsSame(&site_srs)) return;
    GdalErrorCapture errors;
    transform_.reset(OGRCreateCoordinateTransformation(&from, &site_srs));
    if (!transform_)
      throw InputError("buildings.path", where() + ": cannot be reprojected from " +
                                             crs_label(from) + " to " + crs_label(site_srs) + " (" +
                                             errors.text() + ")");
  }

  // The attribute's value as text, or "" when not named, absent or null.
  std::string text_of(OGRFeature& f, const std::string& attribute) const {
    if (attribute.empty()) return "";
    const int k = f.GetFieldIndex(attribute.c_str());
    return k >= 0 && f.IsFieldSetAndNotNull(k) ? f.GetFieldAsString(k) : "";
  }

  std::optional<double> number_of(OGRFeature& f, const std::string& attribute) const {
    const std::string t = text_of(f, attribute);
    if (t.empty()) return std::nullopt;
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (end == t.c_str() || *end != '\0' || !std::isfinite(v))
      throw std::invalid_argument("attribute \"" + attribute + "\" is \"" + t + "\", not a number");
    return v;
  }

  std::string label(OGRFeature& f) const {
    std::string s = "feature " + std::to_string(f.GetFID());
    if (const std::string id = text_of(f, spec_.id_attribute); !id.empty())
      s += " (id \"" + id + "\")";
    return s;
  }

  void add_feature(OGRFeature& f, OJson& buildings) {
    try {
      add_parts(f, buildings);
    } catch (const std::invalid_argument& e) {  // a problem of this feature
      problems_.push_back(label(f) + ": " + e.what());
    }
  }

  std::unique_ptr<OGRGeometry> geometry_of(OGRFeature& f) {
    const OGRGeometry* g = f.GetGeometryRef();
    if (g == nullptr || g->IsEmpty()) throw std::invalid_argument("has no geometry");
    std::unique_ptr<OGRGeometry> geom(g->hasCurveGeometry() ? g->getLinearGeometry() : g->clone());
    geom->flattenTo2D();
    const auto type = wkbFlatten(geom->getGeometryType());
    if (type != wkbPolygon && type != wkbMultiPolygon)
      throw std::invalid_argument(std::string("is a ") + geom->getGeometryName() +
                                  ", not a polygon");
    GdalErrorCapture errors;
    if (!geom->IsValid())
      throw std::invalid_argument("invalid polygon" +
                                  (errors.text().empty() ? "" : ": " + errors.text()));
    if (transform_ && geom->transform(transform_.get()) != OGRERR_NONE)
      throw std::invalid_argument("cannot be reprojected into the site's CRS");
    return geom;
  }

  void add_parts(OGRFeature& f, OJson& buildings) {
    const std::unique_ptr<OGRGeometry> geom = geometry_of(f);
    std::vector<const OGRPolygon*> parts;
    if (wkbFlatten(geom->getGeometryType()) == wkbPolygon) {
      parts.push_back(geom->toPolygon());
    } else {
      for (const OGRPolygon* p : *geom->toMultiPolygon()) parts.push_back(p);
    }
    std::string id = text_of(f, spec_.id_attribute);
    if (id.empty()) id = std::to_string(f.GetFID());
    OJson common = attributes(f);
    for (std::size_t k = 0; k < parts.size(); ++k) {
      const std::string part_id = parts.size() == 1 ? id : id + "-" + std::to_string(k + 1);
      if (!ids_.insert(part_id).second)
        throw std::invalid_argument("duplicate id \"" + part_id + "\"");
      OJson b = OJson::object();
      b["id"] = part_id;
      add_rings(*parts[k], b);
      for (const auto& item : common.items()) b[item.key()] = item.value();
      buildings.push_back(std::move(b));
    }
  }

  void add_rings(const OGRPolygon& poly, OJson& b) {
    const Ring outer = ring_points(*poly.getExteriorRing());
    if (outer.size() < 3 || std::abs(ring_area(outer)) < kMinArea_m2)
      throw std::invalid_argument("degenerate footprint (area " +
                                  std::to_string(std::abs(ring_area(outer))) + " m2)");
    for (std::size_t k = 0; k < outer.size(); ++k)
      if (!inside_outline(outline_, outer[k][0], outer[k][1]))
        throw std::invalid_argument("lies outside the terrain (vertex " + std::to_string(k) +
                                    " at " + xy_text(outer[k]) + ")");
    b["footprint_m"] = outer;
    OJson holes = OJson::array();
    for (int h = 0; h < poly.getNumInteriorRings(); ++h) {
      const Ring hole = ring_points(*poly.getInteriorRing(h));
      if (hole.size() < 3 || std::abs(ring_area(hole)) < kMinArea_m2)
        throw std::invalid_argument("degenerate hole " + std::to_string(h) + " (area " +
                                    std::to_string(std::abs(ring_area(hole))) + " m2)");
      holes.push_back(hole);
    }
    if (!holes.empty()) b["holes_m"] = std::move(holes);
  }

  OJson attributes(OGRFeature& f) {
    OJson a = OJson::object();
    std::optional<double> height = number_of(f, spec_.height_attribute);
    if (!height) height = spec_.default_height_m;
    if (!height)
      throw std::invalid_argument("attribute \"" + spec_.height_attribute +
                                  "\" is null and no default_height_m is given");
    if (!(*height > 0))
      throw std::invalid_argument("height " + std::to_string(*height) + " m: must be > 0");
    a["height_m"] = *height;
    if (const auto base = number_of(f, spec_.base_elevation_attribute))
      a["base_elevation_m"] = *base;
    const auto material = [&](const std::string& attribute, const std::string& fallback) {
      const std::string v = text_of(f, attribute);
      return v.empty() ? fallback : v;
    };
    a["wall"] = material(spec_.wall_attribute, spec_.wall);
    a["roof"] = material(spec_.roof_attribute, spec_.roof);
    if (const std::string w = material(spec_.window_attribute, spec_.window); !w.empty())
      a["window"] = w;
    return a;
  }

  [[noreturn]] void throw_problems(std::int64_t features) const {
    std::string msg = where() + ": " + std::to_string(problems_.size()) + " of " +
                      std::to_string(features) + " features cannot be imported:";
    for (std::size_t k = 0; k < problems_.size() && k < kProblemsListed; ++k)
      msg += "\n  " + problems_[k];
    if (problems_.size() > kProblemsListed)
      msg += "\n  ... and " + std::to_string(problems_.size() - kProblemsListed) + " more";
    throw InputError("buildings", msg);
  }

  const BuildingsImport& spec_;
  const std::vector<Vec2>& outline_;
  GDALDatasetUniquePtr ds_;
  OGRLayer* layer_ = nullptr;
  std::unique_ptr<OGRCoordinateTransformation> transform_;
  std::set<std::string> ids_;
  std::vector<std::string> problems_;
};

}  // namespace

OJson import_buildings(const BuildingsImport& spec, const OGRSpatialReference& site_srs,
                       const std::vector<Vec2>& terrain_outline_m) {
  return LayerImporter(spec, site_srs, terrain_outline_m).run();
}

}  // namespace fragsim::gis
