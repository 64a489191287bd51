#pragma once
// GDAL/OGR plumbing shared by gis/: registration, GDAL's error messages captured (not printed),
// datasets opened with errors that name the file, coordinate reference systems.
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <functional>
#include <string>
#include <vector>

namespace fragsim::gis {

// GDALAllRegister, once per process (thread-safe).
void ensure_gdal_registered();

// While alive, GDAL's error messages on this thread are collected instead of printed to stderr,
// so that they can go into the error fragsim reports (GEOS validity reasons, driver messages).
class GdalErrorCapture {
 public:
  GdalErrorCapture();
  ~GdalErrorCapture();
  GdalErrorCapture(const GdalErrorCapture&) = delete;
  GdalErrorCapture& operator=(const GdalErrorCapture&) = delete;

  // The messages so far joined by "; " ("" when none); clear() forgets them.
  std::string text() const;
  void clear() { messages_.clear(); }

 private:
  static void CPL_STDCALL handler(CPLErr level, CPLErrorNum number, const char* message);
  std::vector<std::string> messages_;
};

// Opens a raster or a vector dataset read-only. InputError(field, "<path>: <GDAL's reason>")
// when the file is missing, unreadable or of no format GDAL knows.
GDALDatasetUniquePtr open_raster(const std::string& path, const std::string& field);
GDALDatasetUniquePtr open_vector(const std::string& path, const std::string& field);

// A CRS from what a user writes ("EPSG:32611", a WKT, a PROJ string), GIS axis order (x =
// easting). InputError(field, ...) when PROJ does not understand it.
OGRSpatialReference crs_from_text(const std::string& text, const std::string& field);

// "EPSG:32611" when the CRS is identified by an EPSG code, otherwise its WKT2.
std::string crs_name(const OGRSpatialReference& srs);

// The CRS's own name for messages ("WGS 84 / UTM zone 11N").
std::string crs_label(const OGRSpatialReference& srs);

// A site's CRS must be projected with metres as its unit: fragsim's coordinates are metres.
// InputError(field, "<what> is in <label>, a geographic CRS (degrees) ...<fix>") otherwise.
void require_projected_metres(const OGRSpatialReference& srs, const std::string& what,
                              const std::string& field, const std::string& fix);

// The PTN GeoJSON's converter (api/ptn_json.h): site coordinates in `crs` to WGS 84 longitude,
// latitude. An empty function when `crs` is not a CRS PROJ knows.
std::function<bool(std::vector<double>& x, std::vector<double>& y)> wgs84_converter(
    const std::string& crs);

}  // namespace fragsim::gis
