#pragma once
// The site-plan hazard boundary (docs/gis.md, "Site-plan boundary"): what a reviewer draws on a
// site plan instead of the exact hazardous area (the union of every terrain triangle at or above
// the threshold, thousands of islands on a Monte Carlo density).
//
//  - sector envelope: per 10-degree HFD sector (core/run/hfd.h) an arc at the largest distance
//    from the HFD origin of any point of a hazardous triangle inside the sector, joined radially;
//    it contains every hazardous triangle and is never inside its sector's HFD arc. The same for
//    the field mean + 1 se (the upper end of the HFD band).
//  - smoothed contour: the exact area closed morphologically with a disc of a stated radius
//    (dilated, then eroded), holes filled, united with the exact area: it contains the exact
//    area, so its HFD is never shorter; the lengthening is measured and reported.
//
// All geometry is in the site's CRS coordinates (gis/results_file.h: input + site origin offset).
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <vector>

#include "core/common/types.h"
#include "gis/results_file.h"

class OGRMultiPolygon;

namespace fragsim::gis {

// A polygon: rings[0] is the outer ring (counter-clockwise), the others holes (clockwise); rings
// are closed implicitly (the first point is not repeated).
struct PlanPolygon {
  std::vector<std::vector<Vec2>> rings;
};
using PlanMultiPolygon = std::vector<PlanPolygon>;

struct PlanBoundaryOptions {
  // Closing radius of the smoothed contour; default (nullopt): 2 x the export's default raster
  // cell (default_cell), at least 1 m.
  std::optional<double> smoothing_m;
};

struct SectorEnvelope {
  PlanMultiPolygon polygon;      // empty when no triangle is hazardous
  std::vector<double> radius_m;  // 36: the arc's radius per sector (0: none hazardous)
  double max_radius_m = 0.0;     // the envelope's HFD (>= the field's HFD)
};

struct PlanBoundary {
  SectorEnvelope envelope;        // density >= threshold
  SectorEnvelope envelope_upper;  // density + se >= threshold
  PlanMultiPolygon smoothed;      // the smoothed contour of density >= threshold
  double smoothing_m = 0.0;       // the closing radius used
  double exact_hfd_m = 0.0;       // results.h5 /hfd/hazardous_fragment_distance_m
  double smoothed_hfd_m = 0.0;    // largest distance of the smoothed contour from the origin
  double smoothed_area_m2 = 0.0, exact_area_m2 = 0.0;
  Vec2 origin{0, 0};  // the HFD origin, plan
};

// Throws InputError("smoothing_m", ...) when smoothing_m is not finite and > 0.
PlanBoundary plan_boundary(const ResultsFile& r, const PlanBoundaryOptions& options = {});

// The polygons as OGR geometry (for the exports and the tests).
std::unique_ptr<OGRMultiPolygon> to_ogr(const PlanMultiPolygon& m);

// The boundary as the HTTP API answers it (docs/http-api.md, GET /v1/jobs/{id}/plan_boundary), in
// the run's input coordinates: the site's CRS coordinates minus `offset` (the site origin's
// easting and northing).
nlohmann::ordered_json plan_boundary_json(const PlanBoundary& b, const Vec2& offset);

}  // namespace fragsim::gis
