// Input audit (see repair_input.h).
#include "lib/repair/repair_input.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <map>

#include "lib/scene/ply.h"

namespace visgate::mesh {

namespace {

// Counts by name, kept in first-seen order.
class Counts {
 public:
  void add(const std::string& name, size_t n = 1) {
    if (n == 0) return;
    for (auto& [k, v] : list_)
      if (k == name) {
        v += n;
        return;
      }
    list_.push_back({name, n});
  }
  std::vector<std::pair<std::string, size_t>> take() { return std::move(list_); }

 private:
  std::vector<std::pair<std::string, size_t>> list_;
};

// Splits [b, e) into whitespace-separated tokens.
void tokens(const char* b, const char* e, std::vector<std::string_view>& out) {
  out.clear();
  while (b < e) {
    while (b < e && (*b == ' ' || *b == '\t' || *b == '\r' || *b == '\f' || *b == '\v')) ++b;
    const char* s = b;
    while (b < e && !(*b == ' ' || *b == '\t' || *b == '\r' || *b == '\f' || *b == '\v')) ++b;
    if (b > s) out.emplace_back(s, size_t(b - s));
  }
}

// Significant digits of a decimal number token: mantissa digits from the first non-zero
// one on (trailing zeros count: the writer put them there).
size_t significant_digits(std::string_view t) {
  size_t n = 0;
  bool started = false;
  for (char c : t) {
    if (c == 'e' || c == 'E') break;
    if (c < '0' || c > '9') continue;
    if (c != '0') started = true;
    if (started) ++n;
  }
  return n;
}

// Correctly rounded double and float values of a decimal token (false when it is not
// one: the reader's pre-scan accepted the file, so this is the scan's own check).
bool parse_number(std::string_view t, double& d, float& f) {
  const char* b = t.data();
  const char* e = t.data() + t.size();
  if (b < e && *b == '+') ++b;  // from_chars takes no leading '+'
  auto rd = std::from_chars(b, e, d);
  auto rf = std::from_chars(b, e, f);
  return rd.ec == std::errc() && rd.ptr == e && rf.ec == std::errc() && rf.ptr == e;
}

// A coordinate token that carries more than a float32: not exactly a float and written
// with more than the 9 significant digits a float needs.
bool double_token(std::string_view t, double d) { return double(float(d)) != d && significant_digits(t) > 9; }

struct Line {
  const char* b;
  const char* e;
};

// Lines of `bytes` (without the newline), `hash` cutting comments when set.
template <class F>
void for_lines(const std::string& bytes, bool hash, F&& f) {
  const char* p = bytes.data();
  const char* end = p + bytes.size();
  size_t lineno = 0;
  while (p < end) {
    const char* nl = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
    const char* le = nl ? nl : end;
    const char* ce = le;
    if (hash) {
      const char* h = static_cast<const char*>(std::memchr(p, '#', size_t(le - p)));
      if (h) ce = h;
    }
    ++lineno;
    if (!f(Line{p, ce}, lineno)) return;
    p = nl ? nl + 1 : end;
  }
}

// Vertex coordinates read by the scan: the double value and the float the reader took.
struct Coords {
  std::vector<std::array<double, 3>> d;
  std::vector<std::array<float, 3>> f;
  bool double_data = false;
};

std::string at_line(size_t line) { return "line " + std::to_string(line) + ": "; }

// Reads three coordinate tokens into `c`; `text_rule` applies the 9-digit rule.
std::string take_coords(const std::vector<std::string_view>& tok, size_t first, size_t line, Coords& c, bool text_rule) {
  std::array<double, 3> d{};
  std::array<float, 3> f{};
  for (int k = 0; k < 3; ++k) {
    if (first + size_t(k) >= tok.size() || !parse_number(tok[first + size_t(k)], d[size_t(k)], f[size_t(k)]))
      return at_line(line) + "vertex " + std::to_string(c.d.size()) + ": coordinate not readable by the audit";
    if (text_rule && double_token(tok[first + size_t(k)], d[size_t(k)])) c.double_data = true;
  }
  c.d.push_back(d);
  c.f.push_back(f);
  return {};
}

std::string audit_obj(const std::string& bytes, Counts& n, Coords& c) {
  std::vector<std::string_view> tok;
  std::string err;
  static const std::map<std::string_view, const char*> kNames = {
      {"vn", "vertex_normals"}, {"vt", "texcoords"}, {"vp", "parameter_vertices"}, {"usemtl", "materials"},
      {"mtllib", "material_libraries"}, {"g", "groups"}, {"o", "objects"}, {"s", "smoothing_groups"},
      {"l", "line_elements"}, {"p", "point_elements"}};
  for_lines(bytes, true, [&](Line l, size_t line) {
    tokens(l.b, l.e, tok);
    if (tok.empty()) return true;
    const std::string_view kw = tok[0];
    if (kw == "v") {
      err = take_coords(tok, 1, line, c, true);
      if (!err.empty()) return false;
      if (tok.size() >= 7) n.add("vertex_colors");
      else if (tok.size() == 5) n.add("vertex_weights");
    } else if (kw == "f") {
      // Corner references v/vt/vn: the texture and normal indices are not kept.
      for (size_t i = 1; i < tok.size(); ++i)
        if (tok[i].find('/') != std::string_view::npos) {
          n.add("face_corner_references");
          break;
        }
    } else if (auto it = kNames.find(kw); it != kNames.end()) {
      n.add(it->second);
    } else {
      n.add("other_statements");
    }
    return true;
  });
  return err;
}

std::string audit_off(const std::string& bytes, Counts& n, Coords& c) {
  std::vector<std::string_view> tok;
  std::string err, magic;
  uint64_t nv = 0, nf = 0;
  int state = 0;  // 0 header, 1 counts, 2 vertices, 3 faces, 4 done
  uint64_t seen = 0;
  auto counts = [&](size_t from, size_t line) {
    if (tok.size() < from + 2) {
      err = at_line(line) + "vertex and face counts not readable by the audit";
      return false;
    }
    auto r1 = std::from_chars(tok[from].data(), tok[from].data() + tok[from].size(), nv);
    auto r2 = std::from_chars(tok[from + 1].data(), tok[from + 1].data() + tok[from + 1].size(), nf);
    if (r1.ec != std::errc() || r2.ec != std::errc()) {
      err = at_line(line) + "vertex and face counts not readable by the audit";
      return false;
    }
    state = nv > 0 ? 2 : (nf > 0 ? 3 : 4);
    return true;
  };
  for_lines(bytes, true, [&](Line l, size_t line) {
    tokens(l.b, l.e, tok);
    if (tok.empty()) return true;
    switch (state) {
      case 0:
        magic = std::string(tok[0]);
        state = 1;
        if (tok.size() > 1) return counts(1, line);
        return true;
      case 1:
        return counts(0, line);
      case 2:
        err = take_coords(tok, 0, line, c, true);
        if (!err.empty()) return false;
        if (++seen == nv) {
          seen = 0;
          state = nf > 0 ? 3 : 4;
        }
        return true;
      case 3: {
        uint64_t k = 0;
        std::from_chars(tok[0].data(), tok[0].data() + tok[0].size(), k);
        if (tok.size() > k + 1) n.add("face_colors");
        if (++seen == nf) state = 4;
        return true;
      }
      default:
        return false;
    }
  });
  if (magic.find('N') != std::string::npos) n.add("vertex_normals", size_t(nv));
  if (magic.find('C') != std::string::npos) n.add("vertex_colors", size_t(nv));
  if (magic.find("ST") != std::string::npos) n.add("texcoords", size_t(nv));
  return err;
}

// Where a PLY property's values go in the report.
std::string ply_attribute(const std::string& elem, const std::string& prop) {
  static const char* kNormals[] = {"nx", "ny", "nz"};
  static const char* kColours[] = {"red", "green", "blue", "alpha", "r", "g", "b", "a", "diffuse_red", "diffuse_green",
                                   "diffuse_blue", "diffuse_alpha"};
  static const char* kTex[] = {"u", "v", "s", "t", "texture_u", "texture_v", "texture_s", "texture_t", "texcoord"};
  for (const char* k : kNormals)
    if (prop == k) return elem == "vertex" ? "vertex_normals" : elem + "_normals";
  for (const char* k : kColours)
    if (prop == k) return elem == "vertex" ? "vertex_colors" : elem + "_colors";
  for (const char* k : kTex)
    if (prop == k) return elem == "face" ? "face_texcoords" : "texcoords";
  return "ply_property " + elem + "." + prop;
}

// PLY through the shared parser (lib/scene/ply.h), which the reader's pre-scan ran on
// the same bytes: attributes from the header, coordinates from the body walk.
std::string audit_ply(const std::string& bytes, Counts& n, Coords& c) {
  ply::Header h;
  if (!ply::read_header(bytes, h).empty()) return "PLY header not readable by the audit";
  for (const ply::Element& e : h.elements) {
    if (e.name == "vertex" || e.name == "face") {
      // One count per item and attribute (nx, ny, nz are one normal).
      std::vector<std::string> seen;
      for (const ply::Property& p : e.props) {
        if (e.name == "vertex" && (p.name == "x" || p.name == "y" || p.name == "z")) continue;
        if (e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index")) continue;
        const std::string a = ply_attribute(e.name, p.name);
        if (std::find(seen.begin(), seen.end(), a) != seen.end()) continue;
        seen.push_back(a);
        n.add(a, size_t(e.count));
      }
    } else {
      n.add("ply_element " + e.name, size_t(e.count));
    }
  }
  // Vertex coordinates, in file order: element `ei`'s items start at row first[ei].
  // Missing axes stay 0.
  const size_t none = size_t(-1);
  std::vector<size_t> first(h.elements.size(), none);
  for (size_t ei = 0; ei < h.elements.size(); ++ei) {
    const ply::Element& e = h.elements[ei];
    if (e.name != "vertex") continue;
    first[ei] = c.d.size();
    c.d.resize(c.d.size() + size_t(e.count), {0, 0, 0});
    c.f.resize(c.f.size() + size_t(e.count), {0, 0, 0});
    for (const ply::Property& p : e.props)
      if ((p.name == "x" || p.name == "y" || p.name == "z") && p.type->size == 8 && !p.type->integer)
        c.double_data = true;
  }
  const bool ascii = h.format == ply::Format::Ascii;
  auto visit = [&](const ply::Scalar& v) -> std::string {
    if (first[v.element] == none) return {};
    const std::string& name = h.elements[v.element].props[v.property].name;
    const size_t k = name == "x" ? 0 : (name == "y" ? 1 : (name == "z" ? 2 : none));
    if (k == none) return {};
    const size_t row = first[v.element] + size_t(v.item);
    if (!ascii) {
      c.d[row][k] = v.value;
      c.f[row][k] = float(v.value);
    } else if (!parse_number(v.token, c.d[row][k], c.f[row][k])) {
      return at_line(v.line) + "vertex " + std::to_string(v.item) + ": coordinate not readable by the audit";
    }
    return {};
  };
  if (auto err = ply::read_body(bytes, h, visit); !err.empty()) return err + " (audit)";
  return {};
}

std::string audit_stl(const std::string& bytes, Counts& n) {
  // Binary iff the size matches 84 + 50 n (the reader's own rule).
  if (bytes.size() >= 84) {
    uint32_t count;
    std::memcpy(&count, bytes.data() + 80, 4);
    if (bytes.size() == 84 + 50ull * count) {
      size_t attrs = 0, normals = 0;
      for (uint32_t t = 0; t < count; ++t) {
        const char* f = bytes.data() + 84 + 50ull * t;
        float nrm[3];
        std::memcpy(nrm, f, 12);
        normals += nrm[0] != 0 || nrm[1] != 0 || nrm[2] != 0;
        attrs += f[48] != 0 || f[49] != 0;
      }
      n.add("face_normals", normals);
      n.add("facet_attribute_words", attrs);
      return {};
    }
  }
  std::vector<std::string_view> tok;
  std::string err;
  size_t vertex = 0;
  for_lines(bytes, false, [&](Line l, size_t line) {
    tokens(l.b, l.e, tok);
    if (tok.size() >= 5 && tok[0] == "facet" && tok[1] == "normal") {
      double d;
      float f;
      bool nonzero = false;
      for (size_t k = 2; k < 5; ++k) nonzero |= parse_number(tok[k], d, f) && d != 0;
      if (nonzero) n.add("face_normals");
    } else if (!tok.empty() && tok[0] == "vertex") {
      for (size_t k = 1; k < 4 && k < tok.size(); ++k) {
        double d;
        float f;
        if (parse_number(tok[k], d, f) && double_token(tok[k], d)) {
          err = at_line(line) + "vertex " + std::to_string(vertex) + ": coordinate '" + std::string(tok[k].substr(0, 40)) +
                "' has more precision than float32, and STL is read as float32 (corners are merged by their float "
                "positions), so it cannot be kept: convert the file to PLY or OBJ";
          return false;
        }
      }
      ++vertex;
    }
    return true;
  });
  return err;
}

}  // namespace

Result<InputAudit> audit_input(const std::string& path, const std::string& bytes, PolygonSoup& soup) {
  std::string ext = soup.format;
  if (ext.empty()) {
    ext = std::filesystem::path(path).extension().string();
    for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  }
  Counts n;
  Coords c;
  std::string err;
  if (ext == ".obj") err = audit_obj(bytes, n, c);
  else if (ext == ".off") err = audit_off(bytes, n, c);
  else if (ext == ".ply") err = audit_ply(bytes, n, c);
  else if (ext == ".stl") err = audit_stl(bytes, n);
  else return Error{path + ": unsupported mesh format '" + ext + "'"};
  if (!err.empty()) return Error{path + ": " + err};
  InputAudit a;
  a.not_kept = n.take();
  if (!c.double_data) return a;
  // Double data: the reader's floats are replaced by the exact doubles, vertex by vertex.
  if (c.d.size() != soup.vertices.size())
    return Error{path + ": the audit found " + std::to_string(c.d.size()) + " vertices, the reader " +
                 std::to_string(soup.vertices.size()) + ": cannot keep the double coordinates"};
  // The reader's value is the float nearest the decimal (strtof) or, where it reads a
  // double first, the float nearest that double; either must match.
  for (size_t i = 0; i < c.d.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (double(c.f[i][size_t(k)]) != soup.vertices[i][k] && double(float(c.d[i][size_t(k)])) != soup.vertices[i][k])
        return Error{path + ": vertex " + std::to_string(i) + ": the audit and the reader disagree on coordinate " +
                     std::to_string(k) + ": cannot keep the double coordinates"};
  a.double_data = true;
  for (size_t i = 0; i < c.d.size(); ++i) {
    const Vec3d d(c.d[i][0], c.d[i][1], c.d[i][2]);
    if (!(d == soup.vertices[i])) ++a.coordinates_restored;
    soup.vertices[i] = d;
  }
  soup.double_precision = true;
  return a;
}

}  // namespace visgate::mesh
