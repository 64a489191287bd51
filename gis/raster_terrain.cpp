// Terrain from a GDAL raster (raster_terrain.h). The raster is brought into memory as one band of
// doubles in the site's CRS (cut to the window, reprojected or resampled when asked), its nodata
// cells are refused or filled, and its cell centres become the terrain's vertices: a grid when
// the raster is north-up with square cells, a mesh of two triangles per cell otherwise.
#include "gis/raster_terrain.h"

#include <gdal_alg.h>
#include <gdal_utils.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "core/common/error.h"
#include "gis/gdal_support.h"

namespace fragsim::gis {

namespace {

using GeoTransform = std::array<double, 6>;

// x, y of the centre of cell (col, row): GDAL's geotransform maps pixel corners.
Vec2 cell_centre(const GeoTransform& gt, double col, double row) {
  return {gt[0] + (col + 0.5) * gt[1] + (row + 0.5) * gt[2],
          gt[3] + (col + 0.5) * gt[4] + (row + 0.5) * gt[5]};
}

std::string format_double(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

// Arguments of a GDAL utility, kept alive as a char* array.
class Args {
 public:
  Args& add(const std::string& a) {
    strings_.push_back(a);
    return *this;
  }
  char** argv() {
    ptrs_.clear();
    for (auto& s : strings_) ptrs_.push_back(s.data());
    ptrs_.push_back(nullptr);
    return ptrs_.data();
  }

 private:
  std::vector<std::string> strings_;
  std::vector<char*> ptrs_;
};

std::string wkt_of(const OGRSpatialReference& srs) {
  char* wkt = nullptr;
  srs.exportToWkt(&wkt);
  std::string out = wkt != nullptr ? wkt : "";
  CPLFree(wkt);
  return out;
}

// The raster's CRS: its own, or the import file's source_crs when it has none.
OGRSpatialReference source_srs(GDALDataset& ds, const TerrainImport& spec) {
  if (!spec.source_crs.empty()) return crs_from_text(spec.source_crs, "terrain.source_crs");
  const OGRSpatialReference* own = ds.GetSpatialRef();
  if (own == nullptr || own->IsEmpty())
    throw InputError("terrain.path", spec.path +
                                         ": the raster has no coordinate reference system; give "
                                         "terrain.source_crs (e.g. \"EPSG:32611\")");
  OGRSpatialReference srs(*own);
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

// The cells of `ds` whose centres fall in the window, as GDALTranslate -srcwin arguments.
std::array<int, 4> source_window(GDALDataset& ds, const GeoTransform& gt,
                                 const std::array<double, 4>& w, const std::string& path) {
  GeoTransform inv{};
  if (!GDALInvGeoTransform(const_cast<double*>(gt.data()), inv.data()))
    throw InputError("terrain.path", path + ": the raster's geotransform cannot be inverted");
  double cmin = std::numeric_limits<double>::infinity(), rmin = cmin;
  double cmax = -cmin, rmax = -cmin;
  for (const double x : {w[0], w[2]}) {
    for (const double y : {w[1], w[3]}) {
      const double c = inv[0] + x * inv[1] + y * inv[2] - 0.5;  // in cell-centre units
      const double r = inv[3] + x * inv[4] + y * inv[5] - 0.5;
      cmin = std::min(cmin, c), cmax = std::max(cmax, c);
      rmin = std::min(rmin, r), rmax = std::max(rmax, r);
    }
  }
  const double cols = ds.GetRasterXSize(), rows = ds.GetRasterYSize();
  const double c0 = std::max(0.0, std::ceil(cmin)), c1 = std::min(cols - 1, std::floor(cmax));
  const double r0 = std::max(0.0, std::ceil(rmin)), r1 = std::min(rows - 1, std::floor(rmax));
  if (!(c1 - c0 >= 1 && r1 - r0 >= 1))
    throw InputError("terrain.window_m",
                     "holds fewer than 2 x 2 cell centres of " + path + " (the raster covers " +
                         format_double(std::min(cell_centre(gt, 0, 0).x(),
                                                cell_centre(gt, cols - 1, rows - 1).x())) +
                         " ... " +
                         format_double(std::max(cell_centre(gt, 0, 0).x(),
                                                cell_centre(gt, cols - 1, rows - 1).x())) +
                         " in x)");
  return {static_cast<int>(c0), static_cast<int>(r0), static_cast<int>(c1 - c0 + 1),
          static_cast<int>(r1 - r0 + 1)};
}

// One band of `src` copied to memory as doubles (GDALTranslate), cut to a window if given.
GDALDatasetUniquePtr copy_to_memory(GDALDataset& src, const TerrainImport& spec,
                                    const std::optional<std::array<int, 4>>& srcwin) {
  Args a;
  // -unscale applies the band's scale and offset (elevations stored as scaled integers).
  a.add("-of").add("MEM").add("-ot").add("Float64").add("-unscale");
  a.add("-b").add(std::to_string(spec.band));
  if (srcwin) {
    a.add("-srcwin");
    for (const int v : *srcwin) a.add(std::to_string(v));
  }
  GdalErrorCapture errors;
  GDALTranslateOptions* options = GDALTranslateOptionsNew(a.argv(), nullptr);
  int usage_error = 0;
  GDALDatasetH out = GDALTranslate("", GDALDataset::ToHandle(&src), options, &usage_error);
  GDALTranslateOptionsFree(options);
  if (out == nullptr)
    throw InputError("terrain.path", spec.path + ": cannot be read (" + errors.text() + ")");
  return GDALDatasetUniquePtr(GDALDataset::FromHandle(out));
}

// The band reprojected and/or resampled into memory (GDALWarp). Cells that no source cell
// covers are NaN, which is then the band's nodata value.
GDALDatasetUniquePtr warp_to_memory(GDALDataset& src, const TerrainImport& spec,
                                    const OGRSpatialReference& from,
                                    const OGRSpatialReference& to) {
  // The band alone first: warp works on every band of its input.
  GDALDatasetUniquePtr band = copy_to_memory(src, spec, std::nullopt);
  Args a;
  a.add("-of").add("MEM").add("-ot").add("Float64").add("-dstnodata").add("nan");
  a.add("-s_srs").add(wkt_of(from)).add("-t_srs").add(wkt_of(to));
  a.add("-r").add(spec.resampling);
  if (spec.spacing_m)
    a.add("-tr").add(format_double(*spec.spacing_m)).add(format_double(*spec.spacing_m));
  if (spec.window_m) {
    a.add("-te");
    for (const double v : *spec.window_m) a.add(format_double(v));
  }
  if (spec.spacing_m && !spec.window_m) a.add("-tap");
  GdalErrorCapture errors;
  GDALWarpAppOptions* options = GDALWarpAppOptionsNew(a.argv(), nullptr);
  if (options == nullptr)
    throw InputError(
        "terrain.resampling",
        "\"" + spec.resampling + "\" is not a GDAL resampling method (" + errors.text() + ")");
  GDALDatasetH in = GDALDataset::ToHandle(band.get());
  int usage_error = 0;
  GDALDatasetH out = GDALWarp("", nullptr, 1, &in, options, &usage_error);
  GDALWarpAppOptionsFree(options);
  if (out == nullptr)
    throw InputError("terrain.path",
                     spec.path + ": cannot be reprojected or resampled (" + errors.text() + ")");
  return GDALDatasetUniquePtr(GDALDataset::FromHandle(out));
}

// Metres per unit of the band's values ("m", "ft", "US survey foot"; none means metres).
double vertical_unit_m(GDALRasterBand& band, const std::string& path) {
  std::string unit = band.GetUnitType() != nullptr ? band.GetUnitType() : "";
  std::transform(unit.begin(), unit.end(), unit.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (unit.empty() || unit == "m" || unit == "metre" || unit == "meter" || unit == "metres" ||
      unit == "meters")
    return 1.0;
  if (unit == "ft" || unit == "foot" || unit == "feet") return 0.3048;  // international foot
  if (unit == "us survey foot" || unit == "ftus" || unit == "us-ft") return 1200.0 / 3937.0;
  throw InputError("terrain.path", path + ": elevations are in \"" + unit +
                                       "\", which fragsim does not convert (metres or feet)");
}

struct Band {
  std::vector<double> z;  // row-major as in the raster: z[row * cols + col]
  int cols = 0, rows = 0;
  std::vector<bool> missing;
  std::int64_t missing_count = 0;
};

Band read_band(GDALDataset& ds, const std::string& path) {
  GDALRasterBand* b = ds.GetRasterBand(1);
  Band out;
  out.cols = ds.GetRasterXSize();
  out.rows = ds.GetRasterYSize();
  out.z.resize(static_cast<std::size_t>(out.cols) * static_cast<std::size_t>(out.rows));
  if (b->RasterIO(GF_Read, 0, 0, out.cols, out.rows, out.z.data(), out.cols, out.rows, GDT_Float64,
                  0, 0) != CE_None)
    throw InputError("terrain.path", path + ": cannot read its cells");
  int has_nodata = 0;
  const double nodata = b->GetNoDataValue(&has_nodata);
  out.missing.resize(out.z.size());
  for (std::size_t k = 0; k < out.z.size(); ++k) {
    const bool miss = !std::isfinite(out.z[k]) || (has_nodata && out.z[k] == nodata);
    out.missing[k] = miss;
    out.missing_count += miss;
  }
  return out;
}

void fill_nodata(GDALDataset& ds, const Band& band, const std::string& path) {
  GdalErrorCapture errors;
  const double reach = std::max(band.cols, band.rows);  // far enough to reach every cell
  if (GDALFillNodata(GDALRasterBand::ToHandle(ds.GetRasterBand(1)), nullptr, reach, 0, 0, nullptr,
                     nullptr, nullptr) != CE_None)
    throw InputError("terrain.nodata",
                     path + ": nodata cells cannot be filled (" + errors.text() + ")");
}

std::string cell_text(const GeoTransform& gt, int col, int row) {
  const Vec2 p = cell_centre(gt, col, row);
  return "column " + std::to_string(col) + ", row " + std::to_string(row) + " at (" +
         format_double(p.x()) + ", " + format_double(p.y()) + ")";
}

bool is_grid(const GeoTransform& gt) {
  return gt[2] == 0.0 && gt[4] == 0.0 &&
         std::abs(std::abs(gt[1]) - std::abs(gt[5])) <= 1e-12 * std::abs(gt[1]);
}

// North-up with square cells: vertex (i, j) of the grid (j from the south) is the centre of the
// cell at column i (or cols-1-i if x runs west) and row rows-1-j (or j if y runs north).
nlohmann::ordered_json grid_terrain(const Band& b, const GeoTransform& gt) {
  const bool flip_x = gt[1] < 0, flip_y = gt[5] < 0;
  std::vector<double> z(b.z.size());
  for (int j = 0; j < b.rows; ++j) {
    const int row = flip_y ? b.rows - 1 - j : j;
    for (int i = 0; i < b.cols; ++i) {
      const int col = flip_x ? b.cols - 1 - i : i;
      z[static_cast<std::size_t>(j) * b.cols + i] =
          b.z[static_cast<std::size_t>(row) * b.cols + col];
    }
  }
  const Vec2 sw = cell_centre(gt, flip_x ? b.cols - 1 : 0, flip_y ? b.rows - 1 : 0);
  return {{"origin_m", {sw.x(), sw.y()}},
          {"spacing_m", std::abs(gt[1])},
          {"nx", b.cols},
          {"ny", b.rows},
          {"elevation_m", std::move(z)}};
}

// Any other geotransform (rotated, rectangular cells): cell centres as vertices, two triangles
// per cell, counter-clockwise seen from above.
nlohmann::ordered_json mesh_terrain(const Band& b, const GeoTransform& gt) {
  auto vertices = nlohmann::ordered_json::array();
  for (int row = 0; row < b.rows; ++row)
    for (int col = 0; col < b.cols; ++col) {
      const Vec2 p = cell_centre(gt, col, row);
      vertices.push_back({p.x(), p.y(), b.z[static_cast<std::size_t>(row) * b.cols + col]});
    }
  const double det = gt[1] * gt[5] - gt[2] * gt[4];  // < 0: columns x rows turn clockwise
  auto triangles = nlohmann::ordered_json::array();
  const auto id = [&](int col, int row) { return std::int64_t{row} * b.cols + col; };
  for (int row = 0; row + 1 < b.rows; ++row)
    for (int col = 0; col + 1 < b.cols; ++col) {
      const std::int64_t a = id(col, row), bb = id(col + 1, row), c = id(col + 1, row + 1),
                         d = id(col, row + 1);
      if (det < 0) {
        triangles.push_back({a, d, c});
        triangles.push_back({a, c, bb});
      } else {
        triangles.push_back({a, bb, c});
        triangles.push_back({a, c, d});
      }
    }
  return {{"vertices_m", std::move(vertices)}, {"triangles", std::move(triangles)}};
}

std::vector<Vec2> outline(const GeoTransform& gt, int cols, int rows) {
  std::vector<Vec2> p = {cell_centre(gt, 0, 0), cell_centre(gt, cols - 1, 0),
                         cell_centre(gt, cols - 1, rows - 1), cell_centre(gt, 0, rows - 1)};
  double area2 = 0;
  for (std::size_t k = 0; k < 4; ++k) {
    const Vec2& a = p[k];
    const Vec2& b = p[(k + 1) % 4];
    area2 += a.x() * b.y() - b.x() * a.y();
  }
  if (area2 < 0) std::reverse(p.begin(), p.end());
  return p;
}

}  // namespace

ImportedTerrain import_terrain(const TerrainImport& spec) {
  GDALDatasetUniquePtr src = open_raster(spec.path, "terrain.path");
  if (spec.band < 1 || spec.band > src->GetRasterCount())
    throw InputError("terrain.band", "must be in [1, " + std::to_string(src->GetRasterCount()) +
                                         "] (" + spec.path + " has " +
                                         std::to_string(src->GetRasterCount()) + " bands)");
  const double unit_m = vertical_unit_m(*src->GetRasterBand(spec.band), spec.path);
  ImportedTerrain out;
  const OGRSpatialReference from = source_srs(*src, spec);
  out.srs = spec.crs.empty() ? from : crs_from_text(spec.crs, "terrain.crs");
  require_projected_metres(out.srs, spec.crs.empty() ? spec.path : "terrain.crs",
                           spec.crs.empty() ? "terrain.path" : "terrain.crs",
                           "Give terrain.crs, a projected CRS in metres such as the site's UTM "
                           "zone (e.g. \"EPSG:32611\"), to reproject the raster into it.");

  GeoTransform gt{};
  if (src->GetGeoTransform(gt.data()) != CE_None)
    throw InputError("terrain.path", spec.path + ": the raster has no geotransform");
  const bool warp = spec.spacing_m || !from.IsSame(&out.srs);
  GDALDatasetUniquePtr mem =
      warp ? warp_to_memory(*src, spec, from, out.srs)
           : copy_to_memory(*src, spec,
                            spec.window_m
                                ? std::optional(source_window(*src, gt, *spec.window_m, spec.path))
                                : std::nullopt);
  mem->GetGeoTransform(gt.data());
  Band band = read_band(*mem, spec.path);
  if (band.cols < 2 || band.rows < 2)
    throw InputError("terrain.path", spec.path + ": needs at least 2 x 2 cells (has " +
                                         std::to_string(band.cols) + " x " +
                                         std::to_string(band.rows) + ")");
  if (band.missing_count == static_cast<std::int64_t>(band.z.size()))
    throw InputError("terrain.path", spec.path + ": every cell is nodata" +
                                         (spec.window_m ? " in the window" : ""));
  if (band.missing_count > 0) {
    if (spec.nodata == TerrainImport::Nodata::kRefuse) {
      const auto first = static_cast<int>(
          std::find(band.missing.begin(), band.missing.end(), true) - band.missing.begin());
      throw InputError("terrain.nodata",
                       spec.path + ": " + std::to_string(band.missing_count) +
                           " cells have no data (the first: " +
                           cell_text(gt, first % band.cols, first / band.cols) +
                           "); give \"nodata\": \"fill\" to interpolate them, or a window_m "
                           "without them");
    }
    fill_nodata(*mem, band, spec.path);
    out.filled_cells = band.missing_count;
    band = read_band(*mem, spec.path);
    if (band.missing_count > 0)
      throw InputError("terrain.nodata", spec.path + ": " + std::to_string(band.missing_count) +
                                             " nodata cells remain after filling");
  }
  for (double& z : band.z) z *= unit_m;
  out.nx = band.cols;
  out.ny = band.rows;
  out.as_grid = is_grid(gt);
  out.outline_m = outline(gt, band.cols, band.rows);
  out.terrain = nlohmann::ordered_json::object();
  out.terrain[out.as_grid ? "grid" : "mesh"] =
      out.as_grid ? grid_terrain(band, gt) : mesh_terrain(band, gt);
  out.terrain["material"] = spec.material;
  return out;
}

}  // namespace fragsim::gis
