#pragma once
// GIS fixtures made in the tests with GDAL itself: small GeoTIFFs with a known geotransform, CRS
// and nodata, and GeoPackage layers of footprints with attributes.
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogrsf_frmts.h>

#include <array>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "gis/gdal_support.h"

namespace fragsim::gis::testing {

struct RasterFixture {
  int cols = 5, rows = 4;
  std::array<double, 6> geotransform{452000, 10, 0, 3839040, 0, -10};
  std::string crs = "EPSG:32611";  // "" = none
  std::optional<double> nodata;
  std::string unit;  // the band's unit type
  double scale = 1.0, offset = 0.0;
  GDALDataType type = GDT_Float64;
  std::function<double(int col, int row)> z = [](int col, int row) {
    return 400 + col + 0.5 * row;
  };
};

inline void write_geotiff(const std::filesystem::path& path, const RasterFixture& f) {
  ensure_gdal_registered();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(drv, nullptr);
  GDALDatasetUniquePtr ds(drv->Create(path.c_str(), f.cols, f.rows, 1, f.type, nullptr));
  ASSERT_TRUE(ds);
  auto gt = f.geotransform;
  ds->SetGeoTransform(gt.data());
  if (!f.crs.empty()) {
    OGRSpatialReference srs;
    srs.SetFromUserInput(f.crs.c_str());
    ds->SetSpatialRef(&srs);
  }
  GDALRasterBand* b = ds->GetRasterBand(1);
  if (f.nodata) b->SetNoDataValue(*f.nodata);
  if (!f.unit.empty()) b->SetUnitType(f.unit.c_str());
  if (f.scale != 1.0 || f.offset != 0.0) {
    b->SetScale(f.scale);
    b->SetOffset(f.offset);
  }
  std::vector<double> v(static_cast<std::size_t>(f.cols) * f.rows);
  for (int r = 0; r < f.rows; ++r)
    for (int c = 0; c < f.cols; ++c) v[static_cast<std::size_t>(r) * f.cols + c] = f.z(c, r);
  ASSERT_EQ(
      b->RasterIO(GF_Write, 0, 0, f.cols, f.rows, v.data(), f.cols, f.rows, GDT_Float64, 0, 0),
      CE_None);
}

struct FeatureFixture {
  std::string wkt;  // the geometry, in the layer's CRS
  std::vector<std::pair<std::string, std::optional<std::string>>> attributes;  // null: unset
};

// A layer "footprints" (or `layer`) with string attributes `fields` and the features given.
inline void write_layer(const std::filesystem::path& path, const std::string& crs,
                        const std::vector<std::string>& fields,
                        const std::vector<FeatureFixture>& features,
                        const std::string& driver = "GPKG",
                        const std::string& layer = "footprints") {
  ensure_gdal_registered();
  GDALDriver* drv = GetGDALDriverManager()->GetDriverByName(driver.c_str());
  ASSERT_NE(drv, nullptr);
  GDALDatasetUniquePtr ds(drv->Create(path.c_str(), 0, 0, 0, GDT_Unknown, nullptr));
  ASSERT_TRUE(ds);
  OGRSpatialReference srs;
  srs.SetFromUserInput(crs.c_str());
  OGRLayer* l = ds->CreateLayer(layer.c_str(), crs.empty() ? nullptr : &srs, wkbUnknown, nullptr);
  ASSERT_NE(l, nullptr);
  for (const auto& name : fields) {
    OGRFieldDefn fd(name.c_str(), OFTString);
    ASSERT_EQ(l->CreateField(&fd), OGRERR_NONE);
  }
  for (const auto& ff : features) {
    OGRFeature feature(l->GetLayerDefn());
    OGRGeometry* g = nullptr;
    ASSERT_EQ(OGRGeometryFactory::createFromWkt(ff.wkt.c_str(), nullptr, &g), OGRERR_NONE)
        << ff.wkt;
    feature.SetGeometryDirectly(g);
    for (const auto& [k, v] : ff.attributes) {
      if (v) {
        feature.SetField(k.c_str(), v->c_str());
      } else {
        feature.SetFieldNull(feature.GetFieldIndex(k.c_str()));
      }
    }
    ASSERT_EQ(l->CreateFeature(&feature), OGRERR_NONE);
  }
}

}  // namespace fragsim::gis::testing
