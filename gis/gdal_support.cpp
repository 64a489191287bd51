// GDAL/OGR plumbing (gdal_support.h).
#include "gis/gdal_support.h"

#include <cpl_error.h>
#include <ogr_srs_api.h>

#include <cmath>
#include <memory>
#include <mutex>

#include "core/common/error.h"

namespace fragsim::gis {

void ensure_gdal_registered() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

GdalErrorCapture::GdalErrorCapture() {
  CPLPushErrorHandlerEx(&GdalErrorCapture::handler, this);
}

GdalErrorCapture::~GdalErrorCapture() {
  CPLPopErrorHandler();
}

void CPL_STDCALL GdalErrorCapture::handler(CPLErr level, CPLErrorNum, const char* message) {
  if (level < CE_Warning || message == nullptr) return;  // debug output
  auto* self = static_cast<GdalErrorCapture*>(CPLGetErrorHandlerUserData());
  if (self != nullptr) self->messages_.emplace_back(message);
}

std::string GdalErrorCapture::text() const {
  std::string out;
  for (const auto& m : messages_) out += (out.empty() ? "" : "; ") + m;
  return out;
}

namespace {

GDALDatasetUniquePtr open_dataset(const std::string& path, const std::string& field,
                                  unsigned int kind, const char* what) {
  ensure_gdal_registered();
  GdalErrorCapture errors;
  GDALDatasetUniquePtr ds(
      GDALDataset::Open(path.c_str(), kind | GDAL_OF_READONLY | GDAL_OF_VERBOSE_ERROR));
  if (!ds) {
    const std::string why = errors.text();
    throw InputError(
        field, path + ": cannot be opened as a " + what + (why.empty() ? "" : " (" + why + ")"));
  }
  return ds;
}

}  // namespace

GDALDatasetUniquePtr open_raster(const std::string& path, const std::string& field) {
  return open_dataset(path, field, GDAL_OF_RASTER, "raster");
}

GDALDatasetUniquePtr open_vector(const std::string& path, const std::string& field) {
  return open_dataset(path, field, GDAL_OF_VECTOR, "vector dataset");
}

OGRSpatialReference crs_from_text(const std::string& text, const std::string& field) {
  ensure_gdal_registered();
  GdalErrorCapture errors;
  OGRSpatialReference srs;
  if (text.empty() || srs.SetFromUserInput(text.c_str()) != OGRERR_NONE)
    throw InputError(field, "\"" + text + "\" is not a coordinate reference system PROJ knows" +
                                (errors.text().empty() ? "" : " (" + errors.text() + ")"));
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

std::string crs_name(const OGRSpatialReference& srs) {
  const char* authority = srs.GetAuthorityName(nullptr);
  const char* code = srs.GetAuthorityCode(nullptr);
  if (authority != nullptr && code != nullptr) return std::string(authority) + ":" + code;
  // A CRS read from a .prj or a GeoTIFF key set often carries no code: PROJ's identification,
  // kept only when it is certain (confidence 100 %: the same definition).
  int count = 0;
  int* confidence = nullptr;
  OGRSpatialReferenceH* matches = srs.FindMatches(nullptr, &count, &confidence);
  std::string name;
  for (int k = 0; k < count && name.empty(); ++k) {
    const auto* m = OGRSpatialReference::FromHandle(matches[k]);
    if (confidence[k] >= 100 && m->GetAuthorityName(nullptr) && m->GetAuthorityCode(nullptr))
      name = std::string(m->GetAuthorityName(nullptr)) + ":" + m->GetAuthorityCode(nullptr);
  }
  OSRFreeSRSArray(matches);
  CPLFree(confidence);
  if (!name.empty()) return name;
  char* wkt = nullptr;
  const char* options[] = {"FORMAT=WKT2_2019", nullptr};
  srs.exportToWkt(&wkt, options);
  std::string out = wkt != nullptr ? wkt : "";
  CPLFree(wkt);
  return out;
}

std::string crs_label(const OGRSpatialReference& srs) {
  const char* name = srs.GetName();
  return name != nullptr && *name != '\0' ? name : "an unnamed CRS";
}

void require_projected_metres(const OGRSpatialReference& srs, const std::string& what,
                              const std::string& field, const std::string& fix) {
  if (srs.IsGeographic())
    throw InputError(field, what + " is in " + crs_label(srs) +
                                ", a geographic CRS (degrees); fragsim needs a projected CRS in "
                                "metres. " +
                                fix);
  if (!srs.IsProjected())
    throw InputError(field, what + " is in " + crs_label(srs) +
                                ", not a projected CRS; fragsim needs a projected CRS in metres. " +
                                fix);
  const double unit_m = srs.GetLinearUnits();
  if (std::abs(unit_m - 1.0) > 1e-12)
    throw InputError(field, what + " is in " + crs_label(srs) + ", whose unit is " +
                                std::to_string(unit_m) +
                                " m, not the metre; fragsim's coordinates are metres. " + fix);
}

std::function<bool(std::vector<double>&, std::vector<double>&)> wgs84_converter(
    const std::string& crs) {
  ensure_gdal_registered();
  GdalErrorCapture quiet;
  OGRSpatialReference from;
  if (crs.empty() || from.SetFromUserInput(crs.c_str()) != OGRERR_NONE) return {};
  from.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  OGRSpatialReference to;
  to.importFromEPSG(4326);
  to.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  std::shared_ptr<OGRCoordinateTransformation> tr(OGRCreateCoordinateTransformation(&from, &to));
  if (!tr) return {};
  return [tr](std::vector<double>& x, std::vector<double>& y) {
    // At most 2^26 terrain vertices (core/scene/site_limits.h): within int.
    if (x.size() != y.size() || x.size() > static_cast<std::size_t>(INT32_MAX)) return false;
    return tr->Transform(static_cast<int>(x.size()), x.data(), y.data(), nullptr, nullptr) == TRUE;
  };
}

}  // namespace fragsim::gis
