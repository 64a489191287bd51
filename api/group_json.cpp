// Fragment groups: frame, shape, distributions of mass, speed and spin, direction ranges, Cd,
// attitude.
#include "api/group_json.h"

#include <cctype>
#include <cmath>
#include <utility>

#include "api/limits.h"
#include "api/scenario_json.h"
#include "core/fragments/sampling.h"

namespace fragsim::api::detail {

namespace {

using fragments::Distribution;
using fragments::ShapeType;

constexpr double kInf = std::numeric_limits<double>::infinity();

constexpr std::pair<const char*, ShapeType> kShapes[] = {
    {"sphere", ShapeType::kSphere},       {"cuboid", ShapeType::kCuboid},
    {"ellipsoid", ShapeType::kEllipsoid}, {"cylinder", ShapeType::kCylinder},
    {"point", ShapeType::kPoint},         {"polyhedron", ShapeType::kPolyhedron},
};

constexpr std::pair<const char*, Distribution::Kind> kDistributions[] = {
    {"fixed", Distribution::Kind::kFixed},   {"uniform", Distribution::Kind::kUniform},
    {"normal", Distribution::Kind::kNormal}, {"lognormal", Distribution::Kind::kLognormal},
    {"table", Distribution::Kind::kTable},   {"mott", Distribution::Kind::kMott},
};

const char* shape_name(ShapeType s) {
  for (const auto& [name, type] : kShapes)
    if (type == s) return name;
  return "unknown";
}

const char* distribution_name(Distribution::Kind k) {
  for (const auto& [name, kind] : kDistributions)
    if (kind == k) return name;
  return "unknown";
}

// Dimensions a shape takes (group.h): sphere [diameter]; cuboid, ellipsoid [a, b, c];
// cylinder [diameter, length].
std::size_t shape_dimension_count(ShapeType s) {
  switch (s) {
    case ShapeType::kSphere: return 1;
    case ShapeType::kCylinder: return 2;
    case ShapeType::kCuboid:
    case ShapeType::kEllipsoid: return 3;
    case ShapeType::kPoint:
    case ShapeType::kPolyhedron: return 0;
  }
  return 0;
}

const char* shape_dimension_layout(ShapeType s) {
  switch (s) {
    case ShapeType::kSphere: return "[diameter]";
    case ShapeType::kCylinder: return "[diameter, length]";
    case ShapeType::kCuboid: return "[a, b, c] edge lengths";
    case ShapeType::kEllipsoid: return "[a, b, c] axis lengths";
    case ShapeType::kPoint:
    case ShapeType::kPolyhedron: return "[]";
  }
  return "[]";
}

// Distribution::validate returns "sigma: must be > 0" relative to the distribution, or a bare
// message. A leading field ("sigma", "values[2]") is appended to the path; "value" of a
// distribution written as a plain number is the number itself.
[[noreturn]] void fail_distribution(const std::string& path, const std::string& message,
                                    bool plain_number) {
  const auto colon = message.find(": ");
  if (colon != std::string::npos && colon > 0) {
    std::string field = message.substr(0, colon);
    const bool is_field = std::all_of(field.begin(), field.end(), [](char ch) {
      return std::isalnum(static_cast<unsigned char>(ch)) != 0 || ch == '_' || ch == '[' ||
             ch == ']' || ch == '.';
    });
    if (is_field) {
      // Core names the table's members after the struct fields; the document calls them
      // values and cdf.
      for (const auto& [core_name, key] :
           {std::pair<std::string, std::string>{"table_values", "values"}, {"table_cdf", "cdf"}}) {
        if (field.rfind(core_name, 0) == 0) field.replace(0, core_name.size(), key);
      }
      const std::string rest = message.substr(colon + 2);
      if (plain_number && field == "value") fail(path, rest);
      fail(field.front() == '[' ? path + field : path + "." + field, rest);
    }
  }
  fail(path, message);
}

void check_strictly_increasing(const std::vector<double>& v, const std::string& path) {
  for (std::size_t k = 1; k < v.size(); ++k)
    if (!(v[k] > v[k - 1]))
      fail(index_path(path, k), "must be strictly increasing (got " + format_number(v[k]) +
                                    " after " + format_number(v[k - 1]) + ")");
}

// A polyhedron: vertices_m (at least 4, at most limits::kMaxPolyhedronVertices, each coordinate
// within the dimension bound), optional density_kg_m3; its hull is built here, once.
fragments::ShapeSpec parse_polyhedron(const ObjectReader& o) {
  for (const char* key : {"dims_m", "aspect"})
    if (o.has(key))
      fail(o.at(key),
           "not used by a polyhedron (its size is vertices_m, or follows the mass with "
           "density_kg_m3)");
  const std::string vp = o.at("vertices_m");
  const Json& arr = read_array(o.require("vertices_m"), vp);
  if (arr.size() > limits::kMaxPolyhedronVertices)
    fail(vp, "at most " + std::to_string(limits::kMaxPolyhedronVertices) + " points (got " +
                 std::to_string(arr.size()) + ")");
  std::vector<Vec3> pts;
  pts.reserve(arr.size());
  for (std::size_t k = 0; k < arr.size(); ++k) {
    const std::string pk = index_path(vp, k);
    pts.push_back(read_vec3(arr[k], pk));
    check_abs_le(pts.back(), limits::kMaxDimension_m, pk);
  }
  std::optional<double> density;
  if (o.has("density_kg_m3")) {
    density = o.number("density_kg_m3");
    check_gt(*density, 0.0, o.at("density_kg_m3"));
    check_ge_le(*density, limits::kMinDensity_kg_m3, limits::kMaxDensity_kg_m3,
                o.at("density_kg_m3"));
  }
  fragments::ShapeSpec s = fragments::polyhedron_shape(std::move(pts), density, vp);
  // A fixed-size hull is a body of its own size: as small as the smallest dimension at least.
  const double size = std::cbrt(s.polyhedron->volume_m3());
  if (!density && size < limits::kMinDimension_m)
    fail(vp, "the hull is too small (volume^(1/3) " + format_number(size) +
                 " m, must be >= " + format_number(limits::kMinDimension_m) + ")");
  return s;
}

fragments::ShapeSpec parse_shape(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "shape");
  fragments::ShapeSpec s;
  const std::string type = o.string("type");
  bool known = false;
  for (const auto& [name, t] : kShapes) {
    if (type == name) {
      s.type = t;
      known = true;
    }
  }
  if (!known)
    fail(o.at("type"),
         "must be one of sphere, cuboid, ellipsoid, cylinder, point, polyhedron (got "
         "\"" +
             type + "\")");
  if (s.type == ShapeType::kPolyhedron) return parse_polyhedron(o);
  if (o.has("vertices_m")) fail(o.at("vertices_m"), "only used by a polyhedron");
  if (s.type == ShapeType::kPoint) {
    for (const char* key : {"dims_m", "density_kg_m3", "aspect"})
      if (o.has(key)) fail(o.at(key), "not used by a point mass (give the group's area_m2)");
    return s;
  }
  const std::size_t n = shape_dimension_count(s.type);
  const std::string layout = std::string("a ") + shape_name(s.type) + " takes " +
                             std::to_string(n) + " (" + shape_dimension_layout(s.type) + ")";
  const auto read_positive_list = [&](const char* key, double lo, double hi) {
    const std::string p = o.at(key);
    std::vector<double> v = read_numbers(o.require(key), p);
    if (v.size() != n)
      fail(p, "expected " + std::to_string(n) + " values, got " + std::to_string(v.size()) + "; " +
                  layout);
    for (std::size_t k = 0; k < v.size(); ++k) {
      check_gt(v[k], 0.0, index_path(p, k));
      check_ge_le(v[k], lo, hi, index_path(p, k));
    }
    return v;
  };
  if (o.has("dims_m") && o.has("density_kg_m3"))
    fail(path, "give either dims_m (fixed size) or density_kg_m3 (size from mass), not both");
  if (o.has("dims_m")) {
    s.dims_m = read_positive_list("dims_m", limits::kMinDimension_m, limits::kMaxDimension_m);
    if (o.has("aspect")) fail(o.at("aspect"), "only used with density_kg_m3");
  } else if (o.has("density_kg_m3")) {
    s.density_kg_m3 = o.number("density_kg_m3");
    check_gt(*s.density_kg_m3, 0.0, o.at("density_kg_m3"));
    check_ge_le(*s.density_kg_m3, limits::kMinDensity_kg_m3, limits::kMaxDensity_kg_m3,
                o.at("density_kg_m3"));
    if (o.has("aspect"))
      s.aspect = read_positive_list("aspect", limits::kMinAspect, limits::kMaxAspect);
  } else {
    fail(path, "needs dims_m (fixed size) or density_kg_m3 (size from mass)");
  }
  return s;
}

// An angle range [min, max] in degrees within [lo, hi].
std::pair<double, double> parse_range(const ObjectReader& o, const char* key, double lo, double hi,
                                      double max_span) {
  const std::string p = o.at(key);
  const auto v = read_vec2(o.require(key), p);
  check_in(v[0], lo, hi, index_path(p, 0));
  check_in(v[1], lo, hi, index_path(p, 1));
  if (!(v[0] <= v[1]))
    fail(p, "min must be <= max (got [" + format_number(v[0]) + ", " + format_number(v[1]) + "])");
  if (!(v[1] - v[0] <= max_span))
    fail(p, "span must be <= " + format_number(max_span) + " deg (got " +
                format_number(v[1] - v[0]) + ")");
  return {v[0], v[1]};
}

fragments::DirectionSpec parse_direction(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "direction");
  fragments::DirectionSpec d;
  if (o.has("elevation_deg"))
    std::tie(d.elevation_min_deg, d.elevation_max_deg) =
        parse_range(o, "elevation_deg", -90, 90, 180);
  if (o.has("azimuth_deg"))
    std::tie(d.azimuth_min_deg, d.azimuth_max_deg) =
        parse_range(o, "azimuth_deg", -kInf, kInf, 360);
  return d;
}

fragments::CdSpec parse_cd(const Json& j, const std::string& path) {
  fragments::CdSpec cd;
  if (j.is_number()) {
    cd.constant = read_number(j, path);
    check_ge_le(cd.constant, 0.0, limits::kMaxDragCoefficient, path);
    return cd;
  }
  if (!j.is_object()) fail(path, "expected number or object, got " + json_type_name(j));
  const ObjectReader o(j, path, "cd_table");
  cd.mach = read_numbers(o.require("mach"), o.at("mach"));
  cd.cd = read_numbers(o.require("cd"), o.at("cd"));
  if (cd.mach.size() < 2)
    fail(o.at("mach"), "needs at least 2 points (got " + std::to_string(cd.mach.size()) + ")");
  if (cd.cd.size() != cd.mach.size())
    fail(o.at("cd"), "expected " + std::to_string(cd.mach.size()) +
                         " values (one per Mach number), got " + std::to_string(cd.cd.size()));
  for (std::size_t k = 0; k < cd.mach.size(); ++k) {
    check_ge_le(cd.mach[k], 0.0, limits::kMaxMach, index_path(o.at("mach"), k));
    check_gt_le(cd.cd[k], 0.0, limits::kMaxDragCoefficient, index_path(o.at("cd"), k));
  }
  check_strictly_increasing(cd.mach, o.at("mach"));
  cd.constant = cd.cd.front();  // unused with a table
  return cd;
}

fragments::FrameSpec parse_frame(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "frame");
  fragments::FrameSpec f;
  f.origin_m = read_position(o.require("origin_m"), o.at("origin_m"));
  f.yaw_deg = o.number_or("yaw_deg", 0.0);
  f.pitch_deg = o.number_or("pitch_deg", 0.0);
  f.roll_deg = o.number_or("roll_deg", 0.0);
  f.velocity_mps = o.vec3_or("velocity_mps", Vec3::Zero());
  check_abs_le(f.velocity_mps, limits::kMaxFrameSpeed_mps, o.at("velocity_mps"));
  return f;
}

// "random" (the default: uniformly random, Shoemake) or {yaw_deg, pitch_deg, roll_deg}, each
// optional and, like the frame's angles, any finite number of degrees.
std::optional<fragments::AttitudeSpec> parse_attitude(const Json& j, const std::string& path) {
  if (j.is_string()) {
    if (j.get<std::string>() != "random")
      fail(path, "must be \"random\" or an object {yaw_deg, pitch_deg, roll_deg} (got \"" +
                     j.get<std::string>() + "\")");
    return std::nullopt;
  }
  if (!j.is_object()) fail(path, "expected string or object, got " + json_type_name(j));
  const ObjectReader o(j, path, "attitude");
  fragments::AttitudeSpec a;
  a.yaw_deg = o.number_or("yaw_deg", 0.0);
  a.pitch_deg = o.number_or("pitch_deg", 0.0);
  a.roll_deg = o.number_or("roll_deg", 0.0);
  return a;
}

Json attitude_json(const std::optional<fragments::AttitudeSpec>& a) {
  if (!a) return "random";
  return {{"yaw_deg", a->yaw_deg}, {"pitch_deg", a->pitch_deg}, {"roll_deg", a->roll_deg}};
}

Json vec3_json(const Vec3& v) {
  return Json::array({v.x(), v.y(), v.z()});
}

}  // namespace

Distribution parse_distribution(const Json& j, const std::string& path, double phys_lo,
                                double phys_hi) {
  Distribution d;
  const bool plain = j.is_number();
  if (plain) {
    d = Distribution::fixed(read_number(j, path));
  } else {
    if (!j.is_object()) fail(path, "expected number or object, got " + json_type_name(j));
    const auto it = j.find("dist");
    if (it == j.end()) fail(child_path(path, "dist"), "is required");
    const std::string kind = read_string(*it, child_path(path, "dist"));
    bool known = false;
    for (const auto& [name, k] : kDistributions) {
      if (kind == name) {
        d.kind = k;
        known = true;
      }
    }
    if (!known)
      fail(child_path(path, "dist"),
           "must be one of fixed, uniform, normal, lognormal, table, mott (got \"" + kind + "\")");
    const ObjectReader o(j, path, "dist_" + kind);
    const auto bounds = [&] {
      if (const auto v = o.optional_number("min")) {
        d.min = *v;
        d.has_min = true;
      }
      if (const auto v = o.optional_number("max")) {
        d.max = *v;
        d.has_max = true;
      }
    };
    switch (d.kind) {
      case Distribution::Kind::kFixed: d.value = o.number("value"); break;
      case Distribution::Kind::kUniform:
        d.min = o.number("min");
        d.max = o.number("max");
        d.has_min = d.has_max = true;
        break;
      case Distribution::Kind::kNormal:
        d.mean = o.number("mean");
        d.sigma = o.number("sigma");
        bounds();
        break;
      case Distribution::Kind::kLognormal:
        d.median = o.number("median");
        d.sigma_ln = o.number("sigma_ln");
        bounds();
        break;
      case Distribution::Kind::kTable:
        d.table_values = read_numbers(o.require("values"), o.at("values"));
        d.table_cdf = read_numbers(o.require("cdf"), o.at("cdf"));
        break;
      case Distribution::Kind::kMott:
        d.mu = o.number("mu");
        bounds();
        break;
    }
  }
  if (const std::string problem = d.validate(phys_lo, phys_hi); !problem.empty())
    fail_distribution(path, problem, plain);
  return d;
}

Json distribution_to_json(const Distribution& d) {
  const auto with_bounds = [&](Json j) {
    if (d.has_min) j["min"] = d.min;
    if (d.has_max) j["max"] = d.max;
    return j;
  };
  switch (d.kind) {
    case Distribution::Kind::kFixed: return d.value;
    case Distribution::Kind::kUniform: return {{"dist", "uniform"}, {"min", d.min}, {"max", d.max}};
    case Distribution::Kind::kNormal:
      return with_bounds({{"dist", "normal"}, {"mean", d.mean}, {"sigma", d.sigma}});
    case Distribution::Kind::kLognormal:
      return with_bounds({{"dist", "lognormal"}, {"median", d.median}, {"sigma_ln", d.sigma_ln}});
    case Distribution::Kind::kTable:
      return {{"dist", "table"}, {"values", d.table_values}, {"cdf", d.table_cdf}};
    case Distribution::Kind::kMott: return with_bounds({{"dist", "mott"}, {"mu", d.mu}});
  }
  return {{"dist", distribution_name(d.kind)}};
}

fragments::FragmentGroupSpec parse_fragment_group(const Json& j, const std::string& path) {
  const ObjectReader o(j, path, "fragment_group");
  fragments::FragmentGroupSpec g;
  g.name = o.string("name");
  if (g.name.empty()) fail(o.at("name"), "must not be empty");
  g.count = o.number("count");
  check_gt_le(g.count, 0.0, limits::kMaxCount, o.at("count"));
  g.samples = o.integer("samples", 1, kMaxSamplesPerGroup);
  g.frame = parse_frame(o.require("frame"), o.at("frame"));
  g.shape = parse_shape(o.require("shape"), o.at("shape"));
  // The physical ranges sample_fragment samples with: a mass is > 0, a speed >= 0.
  g.mass_kg = parse_distribution(o.require("mass_kg"), o.at("mass_kg"), fragments::kMassRange.lo,
                                 fragments::kMassRange.hi);
  g.speed_mps = parse_distribution(o.require("speed_mps"), o.at("speed_mps"),
                                   fragments::kSpeedRange.lo, fragments::kSpeedRange.hi);
  if (const Json* d = o.find("direction")) g.direction = parse_direction(*d, o.at("direction"));
  g.cd = parse_cd(o.require("cd"), o.at("cd"));
  g.area_m2 = o.optional_number("area_m2");
  if (g.area_m2) check_gt_le(*g.area_m2, 0.0, limits::kMaxArea_m2, o.at("area_m2"));
  if (g.shape.type == ShapeType::kPoint && !g.area_m2)
    fail(o.at("area_m2"), "is required for shape type point");
  if (const Json* s = o.find("spin_radps"))
    g.spin_radps = parse_distribution(*s, o.at("spin_radps"), fragments::kSpinRange.lo,
                                      fragments::kSpinRange.hi);
  if (const Json* a = o.find("attitude")) g.attitude = parse_attitude(*a, o.at("attitude"));
  return g;
}

Json fragment_group_to_json(const fragments::FragmentGroupSpec& g) {
  Json shape = {{"type", shape_name(g.shape.type)}};
  if (!g.shape.dims_m.empty()) shape["dims_m"] = g.shape.dims_m;
  if (g.shape.density_kg_m3) shape["density_kg_m3"] = *g.shape.density_kg_m3;
  if (!g.shape.aspect.empty()) shape["aspect"] = g.shape.aspect;
  if (g.shape.type == ShapeType::kPolyhedron) {
    Json v = Json::array();
    for (const Vec3& p : g.shape.vertices_m) v.push_back(vec3_json(p));
    shape["vertices_m"] = std::move(v);
  }
  Json cd = g.cd.mach.empty() ? Json(g.cd.constant) : Json{{"mach", g.cd.mach}, {"cd", g.cd.cd}};
  Json out = {
      {"name", g.name},
      {"count", g.count},
      {"samples", g.samples},
      {"frame",
       {{"origin_m", vec3_json(g.frame.origin_m)},
        {"yaw_deg", g.frame.yaw_deg},
        {"pitch_deg", g.frame.pitch_deg},
        {"roll_deg", g.frame.roll_deg},
        {"velocity_mps", vec3_json(g.frame.velocity_mps)}}},
      {"shape", std::move(shape)},
      {"mass_kg", distribution_to_json(g.mass_kg)},
      {"speed_mps", distribution_to_json(g.speed_mps)},
      {"direction",
       {{"elevation_deg", {g.direction.elevation_min_deg, g.direction.elevation_max_deg}},
        {"azimuth_deg", {g.direction.azimuth_min_deg, g.direction.azimuth_max_deg}}}},
      {"cd", std::move(cd)},
      {"spin_radps", distribution_to_json(g.spin_radps)},
      {"attitude", attitude_json(g.attitude)},
  };
  if (g.area_m2) out["area_m2"] = *g.area_m2;
  return out;
}

}  // namespace fragsim::api::detail
