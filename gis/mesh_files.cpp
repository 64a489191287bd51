// Mesh file readers (mesh_files.h).
#include "gis/mesh_files.h"

#include <algorithm>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string_view>

#include "core/common/error.h"
#include "core/scene/validation.h"

namespace fragsim::gis {

namespace {

using Tri = std::array<std::uint32_t, 3>;

// Errors of one file: InputError(field, "<file>: [facet k: ]reason").
struct Reporter {
  std::string field, label;
  [[noreturn]] void fail(const std::string& reason) const {
    throw InputError(field, label + ": " + reason);
  }
  [[noreturn]] void fail_facet(std::size_t facet, const std::string& reason) const {
    fail("facet " + std::to_string(facet) + ": " + reason);
  }
};

std::string read_bytes(const std::string& path, const Reporter& r) {
  std::ifstream in(path, std::ios::binary);
  if (!in) r.fail("cannot be opened (" + std::string(std::strerror(errno)) + ")");
  std::ostringstream s;
  s << in.rdbuf();
  return std::move(s).str();
}

// Whitespace-separated words of a text, with the line each is on.
class Words {
 public:
  explicit Words(const std::string& text) : p_(text.data()), end_(text.data() + text.size()) {}
  bool done() {
    skip_space();
    return p_ == end_;
  }
  std::string_view next() {
    skip_space();
    const char* b = p_;
    while (p_ != end_ && !std::isspace(static_cast<unsigned char>(*p_))) ++p_;
    return {b, static_cast<std::size_t>(p_ - b)};
  }
  void skip_line() { (void)rest_of_line(); }
  // The rest of the current line, without its surrounding blanks.
  std::string_view rest_of_line() {
    while (p_ != end_ && *p_ != '\n' && std::isspace(static_cast<unsigned char>(*p_))) ++p_;
    const char* b = p_;
    while (p_ != end_ && *p_ != '\n') ++p_;
    const char* e = p_;
    while (e > b && std::isspace(static_cast<unsigned char>(e[-1]))) --e;
    return {b, static_cast<std::size_t>(e - b)};
  }

 private:
  void skip_space() {
    while (p_ != end_ && std::isspace(static_cast<unsigned char>(*p_))) ++p_;
  }
  const char* p_;
  const char* end_;
};

// A number word ("nan" and "inf" are numbers here: the facet check names them).
bool parse_number(std::string_view w, double& x) {
  if (w.empty() || w.size() > 64) return false;
  char buf[65];
  std::memcpy(buf, w.data(), w.size());
  buf[w.size()] = '\0';
  char* end = nullptr;
  x = std::strtod(buf, &end);
  return end == buf + w.size();
}

// ---------------------------------------------------------------------------------------------
// STL

void read_stl_ascii(const std::string& text, const Reporter& r, MeshData& m) {
  Words w(text);
  std::size_t facet = 0;
  const auto expect = [&](std::string_view want) {
    const std::string_view got = w.next();
    if (got.empty() || (got != want && w.done()))  // the end, or a word cut by it
      r.fail_facet(facet, "truncated (the file ends inside the facet)");
    if (got != want)
      r.fail_facet(facet,
                   "expected \"" + std::string(want) + "\", got \"" + std::string(got) + "\"");
  };
  const auto number = [&]() {
    const std::string_view t = w.next();
    if (t.empty()) r.fail_facet(facet, "truncated (the file ends inside the facet)");
    double x = 0;
    if (!parse_number(t, x)) r.fail_facet(facet, "\"" + std::string(t) + "\" is not a number");
    return x;
  };
  std::uint32_t group = 0;
  bool in_solid = false;
  while (!w.done()) {
    const std::string_view t = w.next();
    if (t == "solid") {
      if (in_solid) r.fail_facet(facet, "\"solid\" inside a solid (no \"endsolid\" before it)");
      in_solid = true;
      m.groups.push_back({"", std::string(w.rest_of_line()), ""});  // the solid's name
      group = static_cast<std::uint32_t>(m.groups.size() - 1);
    } else if (t == "endsolid") {
      in_solid = false;
      w.skip_line();
    } else if (t == "facet") {
      if (!in_solid) r.fail_facet(facet, "\"facet\" outside a \"solid\"");
      expect("normal");
      for (int k = 0; k < 3; ++k) (void)number();
      expect("outer");
      expect("loop");
      Tri tri{};
      for (int k = 0; k < 3; ++k) {
        expect("vertex");
        const double x = number(), y = number(), z = number();
        tri[k] = static_cast<std::uint32_t>(m.vertices.size());
        m.vertices.emplace_back(x, y, z);
      }
      expect("endloop");
      expect("endfacet");
      m.triangles.push_back(tri);
      m.facet.push_back(static_cast<std::uint32_t>(facet));
      m.group.push_back(group);
      ++facet;
    } else if (!in_solid) {
      r.fail("expected \"solid\" or the end of the file, got \"" + std::string(t) + "\"");
    } else {
      r.fail_facet(facet, "expected \"facet\" or \"endsolid\", got \"" + std::string(t) + "\"");
    }
  }
  if (in_solid) r.fail("truncated (no \"endsolid\" after facet " + std::to_string(facet) + ")");
}

float le_float(const char* p) {
  float f = 0;
  std::memcpy(&f, p, 4);  // little-endian host (x86-64, aarch64): checked in read_mesh_file
  return f;
}

void read_stl_binary(const std::string& bytes, const Reporter& r, MeshData& m) {
  std::uint32_t n = 0;
  std::memcpy(&n, bytes.data() + 80, 4);
  const std::uint64_t need = 84 + 50 * static_cast<std::uint64_t>(n);
  if (bytes.size() < need)
    r.fail_facet((bytes.size() - 84) / 50, "truncated (the header says " + std::to_string(n) +
                                               " facets, " + std::to_string(need) +
                                               " bytes; the file has " +
                                               std::to_string(bytes.size()) + ")");
  if (bytes.size() > need)
    r.fail("has " + std::to_string(bytes.size() - need) + " bytes after its " + std::to_string(n) +
           " facets (the header's count): not a binary STL, or a damaged one");
  m.groups.push_back({});
  m.vertices.reserve(3 * static_cast<std::size_t>(n));
  m.triangles.reserve(n);
  for (std::uint32_t f = 0; f < n; ++f) {
    const char* p = bytes.data() + 84 + 50 * static_cast<std::size_t>(f) + 12;
    Tri tri{};
    for (int k = 0; k < 3; ++k, p += 12) {
      tri[k] = static_cast<std::uint32_t>(m.vertices.size());
      m.vertices.emplace_back(le_float(p), le_float(p + 4), le_float(p + 8));
    }
    m.triangles.push_back(tri);
    m.facet.push_back(f);
    m.group.push_back(0);
  }
}

// Binary when the size is 84 + 50 n for the header's n (even if the header begins with "solid",
// as some exporters write it); ASCII when the file begins with "solid"; otherwise a binary STL
// whose size does not match its count (truncated).
void read_stl(const std::string& bytes, const Reporter& r, MeshData& m) {
  if (bytes.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, bytes.data() + 80, 4);
    if (bytes.size() == 84 + 50 * static_cast<std::uint64_t>(n))
      return read_stl_binary(bytes, r, m);
  }
  std::size_t k = 0;
  while (k < bytes.size() && std::isspace(static_cast<unsigned char>(bytes[k]))) ++k;
  if (bytes.compare(k, 5, "solid") == 0) return read_stl_ascii(bytes, r, m);
  if (bytes.size() < 84) r.fail("truncated (shorter than a binary STL's 84-byte header)");
  read_stl_binary(bytes, r, m);
}

// ---------------------------------------------------------------------------------------------
// OBJ

// A face's vertex reference ("7", "7/1", "7//3", "-1/..."): the 0-based vertex index, or -1 when
// out of range.
std::int64_t obj_index(std::string_view w, std::size_t nv) {
  const std::string_view head = w.substr(0, w.find('/'));
  double x = 0;
  if (!parse_number(head, x) || x != std::floor(x) || x == 0) return -1;
  const auto i = static_cast<std::int64_t>(x);
  const std::int64_t k = i > 0 ? i - 1 : static_cast<std::int64_t>(nv) + i;
  return k >= 0 && k < static_cast<std::int64_t>(nv) ? k : -1;
}

std::vector<std::string_view> line_words(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t k = 0;
  while (k < line.size()) {
    while (k < line.size() && std::isspace(static_cast<unsigned char>(line[k]))) ++k;
    const std::size_t b = k;
    while (k < line.size() && !std::isspace(static_cast<unsigned char>(line[k]))) ++k;
    if (k > b) out.push_back(line.substr(b, k - b));
  }
  return out;
}

std::string rest_of(std::string_view line, std::string_view keyword) {
  std::string_view s = line.substr(line.find(keyword) + keyword.size());
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return std::string(s);
}

void read_obj(const std::string& text, const Reporter& r, MeshData& m) {
  FaceGroup current;
  std::map<std::pair<std::string, std::pair<std::string, std::string>>, std::uint32_t> group_ids;
  std::size_t face = 0, line_no = 0, pos = 0;
  while (pos < text.size()) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    const std::string_view line(text.data() + pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    const auto w = line_words(line);
    if (w.empty() || w[0][0] == '#') continue;
    const std::string where = "line " + std::to_string(line_no) + ": ";
    if (w[0] == "v") {
      if (w.size() < 4) r.fail(where + "a vertex needs 3 coordinates (truncated?)");
      double c[3];
      for (int k = 0; k < 3; ++k)
        if (!parse_number(w[k + 1], c[k]))
          r.fail(where + "\"" + std::string(w[k + 1]) + "\" is not a number");
      m.vertices.emplace_back(c[0], c[1], c[2]);
    } else if (w[0] == "f") {
      if (w.size() < 4) r.fail_facet(face, where + "a face needs at least 3 vertices");
      std::vector<std::uint32_t> idx;
      for (std::size_t k = 1; k < w.size(); ++k) {
        const std::int64_t i = obj_index(w[k], m.vertices.size());
        if (i < 0)
          r.fail_facet(face, where + "vertex index \"" + std::string(w[k]) +
                                 "\" out of range (vertices so far: " +
                                 std::to_string(m.vertices.size()) + ")");
        idx.push_back(static_cast<std::uint32_t>(i));
      }
      const auto key =
          std::make_pair(current.material, std::make_pair(current.group, current.object));
      auto [it, fresh] = group_ids.emplace(key, static_cast<std::uint32_t>(m.groups.size()));
      if (fresh) m.groups.push_back(current);
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) {  // a polygon: a fan of triangles
        m.triangles.push_back({idx[0], idx[k], idx[k + 1]});
        m.facet.push_back(static_cast<std::uint32_t>(face));
        m.group.push_back(it->second);
      }
      ++face;
    } else if (w[0] == "g") {
      current.group = rest_of(line, "g");
    } else if (w[0] == "o") {
      current.object = rest_of(line, "o");
    } else if (w[0] == "usemtl") {
      current.material = rest_of(line, "usemtl");
    }  // vt, vn, s, mtllib, l, p, ...: not geometry of a surface, ignored
  }
}

// ---------------------------------------------------------------------------------------------
// PLY

struct PlyProperty {
  std::string name, type, count_type;  // count_type non-empty: a list
};
struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

std::size_t ply_size(const std::string& t) {
  static const std::map<std::string, std::size_t> sizes = {
      {"char", 1},  {"uchar", 1},   {"int8", 1},   {"uint8", 1},  {"short", 2}, {"ushort", 2},
      {"int16", 2}, {"uint16", 2},  {"int", 4},    {"uint", 4},   {"int32", 4}, {"uint32", 4},
      {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  const auto it = sizes.find(t);
  return it == sizes.end() ? 0 : it->second;
}

bool ply_integer(const std::string& t) {
  return t != "float" && t != "float32" && t != "double" && t != "float64";
}

double ply_value(const char* p, const std::string& t) {
  const auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof v);
    return static_cast<double>(v);
  };
  if (t == "char" || t == "int8") return get(std::int8_t{});
  if (t == "uchar" || t == "uint8") return get(std::uint8_t{});
  if (t == "short" || t == "int16") return get(std::int16_t{});
  if (t == "ushort" || t == "uint16") return get(std::uint16_t{});
  if (t == "int" || t == "int32") return get(std::int32_t{});
  if (t == "uint" || t == "uint32") return get(std::uint32_t{});
  if (t == "float" || t == "float32") return get(float{});
  return get(double{});
}

// Reads values one by one from the body, ASCII or binary little-endian.
class PlyBody {
 public:
  PlyBody(const std::string& bytes, std::size_t start, bool binary, const Reporter& r)
      : bytes_(bytes),
        pos_(start),
        binary_(binary),
        r_(r),
        text_(binary ? std::string() : bytes.substr(start)),
        words_(text_) {}
  // One value of type t; `what` names the element and its index for a truncated file.
  double value(const std::string& t, const std::string& what) {
    if (!binary_) {
      const std::string_view w = words_.next();
      if (w.empty()) r_.fail(what + ": truncated (the file ends before it)");
      double x = 0;
      if (!parse_number(w, x)) r_.fail(what + ": \"" + std::string(w) + "\" is not a number");
      return x;
    }
    const std::size_t n = ply_size(t);
    if (pos_ + n > bytes_.size()) r_.fail(what + ": truncated (the file ends before it)");
    const double x = ply_value(bytes_.data() + pos_, t);
    pos_ += n;
    return x;
  }

 private:
  const std::string& bytes_;
  std::size_t pos_;
  bool binary_;
  const Reporter& r_;
  std::string text_;  // the body of the ASCII form
  Words words_;
};

std::vector<PlyElement> read_ply_header(const std::string& bytes, const Reporter& r, bool& binary,
                                        std::size_t& body) {
  const std::size_t end = bytes.find("end_header");
  if (bytes.compare(0, 3, "ply") != 0) r.fail("not a PLY file (no \"ply\" at its start)");
  if (end == std::string::npos) r.fail("truncated (no \"end_header\")");
  body = bytes.find('\n', end);
  body = body == std::string::npos ? bytes.size() : body + 1;
  std::vector<PlyElement> elements;
  std::istringstream header(bytes.substr(0, end));
  std::string line;
  bool has_format = false;
  while (std::getline(header, line)) {
    std::istringstream ls(line);
    std::string kw;
    ls >> kw;
    if (kw == "format") {
      std::string f;
      ls >> f;
      if (f != "ascii" && f != "binary_little_endian")
        r.fail("PLY format \"" + f + "\" is not supported (ascii or binary_little_endian)");
      binary = f == "binary_little_endian";
      has_format = true;
    } else if (kw == "element") {
      PlyElement e;
      ls >> e.name >> e.count;
      if (!ls) r.fail("bad header line \"" + line + "\"");
      elements.push_back(e);
    } else if (kw == "property") {
      if (elements.empty()) r.fail("a property before any element in the header");
      PlyProperty p;
      ls >> p.type;
      if (p.type == "list") ls >> p.count_type >> p.type;
      ls >> p.name;
      if (!ls || ply_size(p.type) == 0 || (!p.count_type.empty() && ply_size(p.count_type) == 0))
        r.fail("bad header line \"" + line + "\"");
      elements.back().properties.push_back(p);
    }
  }
  if (!has_format) r.fail("no \"format\" line in the header");
  return elements;
}

void read_ply(const std::string& bytes, const Reporter& r, MeshData& m) {
  bool binary = false;
  std::size_t start = 0;
  const std::vector<PlyElement> elements = read_ply_header(bytes, r, binary, start);
  PlyBody body(bytes, start, binary, r);
  std::map<long long, std::uint32_t> group_ids;
  bool saw_vertex = false, saw_face = false;
  for (const PlyElement& e : elements) {
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    saw_vertex |= is_vertex;
    saw_face |= is_face;
    int slot = -1;  // the face's material slot: its first integer scalar property
    for (std::size_t k = 0; is_face && slot < 0 && k < e.properties.size(); ++k)
      if (e.properties[k].count_type.empty() && ply_integer(e.properties[k].type))
        slot = static_cast<int>(k);
    for (std::size_t i = 0; i < e.count; ++i) {
      const std::string what = (is_face ? "facet " : e.name + " ") + std::to_string(i);
      double xyz[3] = {NAN, NAN, NAN};
      std::vector<std::uint32_t> idx;
      long long group = 0;
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (p.count_type.empty()) {
          const double x = body.value(p.type, what);
          if (is_vertex && (p.name == "x" || p.name == "y" || p.name == "z"))
            xyz[p.name[0] - 'x'] = x;
          if (static_cast<int>(k) == slot) group = static_cast<long long>(x);
          continue;
        }
        const double n = body.value(p.count_type, what);
        for (double j = 0; j < n; ++j) {
          const double v = body.value(p.type, what);
          if (is_face && (p.name == "vertex_indices" || p.name == "vertex_index")) {
            if (!(v >= 0 && v < static_cast<double>(m.vertices.size())))
              r.fail_facet(i, "vertex index " + std::to_string(static_cast<long long>(v)) +
                                  " out of range (vertices: " + std::to_string(m.vertices.size()) +
                                  ")");
            idx.push_back(static_cast<std::uint32_t>(v));
          }
        }
      }
      if (is_vertex) m.vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
      if (!is_face) continue;
      if (idx.size() < 3) r.fail_facet(i, "a face needs at least 3 vertices");
      auto [it, fresh] = group_ids.emplace(group, static_cast<std::uint32_t>(m.groups.size()));
      if (fresh) m.groups.push_back({slot >= 0 ? std::to_string(group) : "", "", ""});
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
        m.triangles.push_back({idx[0], idx[k], idx[k + 1]});
        m.facet.push_back(static_cast<std::uint32_t>(i));
        m.group.push_back(it->second);
      }
    }
  }
  if (!saw_vertex || !saw_face) r.fail("a PLY mesh needs a \"vertex\" and a \"face\" element");
}

// The facets' vertices are finite and span an area.
void check_facets(const MeshData& m, const Reporter& r) {
  if (m.triangles.empty()) r.fail("has no facets");
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    for (const auto v : tri) {
      const Vec3& p = m.vertices[v];
      if (!p.allFinite()) {
        std::ostringstream s;
        s << "vertex (" << p.x() << ", " << p.y() << ", " << p.z() << ") is not finite";
        r.fail_facet(m.facet[t], s.str());
      }
    }
    if (scene::detail::is_zero_area(m.vertices[tri[0]], m.vertices[tri[1]], m.vertices[tri[2]]))
      r.fail_facet(m.facet[t], "zero-area facet (its vertices are on a line or repeated)");
  }
}

std::string lower_extension(const std::string& path) {
  std::string e = std::filesystem::path(path).extension().string();
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  return e;
}

}  // namespace

std::string file_label(const std::string& path) {
  return std::filesystem::path(path).filename().string();
}

MeshData read_mesh_file(const std::string& path, const std::string& field) {
  static_assert(std::endian::native == std::endian::little, "binary STL/PLY readers assume it");
  const Reporter r{field, file_label(path)};
  const std::string ext = lower_extension(path);
  if (ext != ".stl" && ext != ".obj" && ext != ".ply")
    r.fail("unknown mesh format \"" + ext + "\" (.stl, .obj or .ply)");
  const std::string bytes = read_bytes(path, r);
  MeshData m;
  if (ext == ".stl") {
    read_stl(bytes, r, m);
  } else if (ext == ".obj") {
    read_obj(bytes, r, m);
  } else {
    read_ply(bytes, r, m);
  }
  check_facets(m, r);
  return m;
}

}  // namespace fragsim::gis
