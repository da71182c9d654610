// OpenMesh-based soup importer (see mesh_io.h).
#include "lib/scene/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/IO/reader/OFFReader.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <map>
#include <numeric>
#include <mutex>
#include <sstream>

#include "lib/scene/mesh_text.h"
#include "lib/scene/ply.h"

namespace visgate {

namespace {

namespace OIO = OpenMesh::IO;
using OpenMesh::EdgeHandle;
using OpenMesh::FaceHandle;
using OpenMesh::HalfedgeHandle;
using OpenMesh::VertexHandle;

// Receives the readers' callbacks; keeps positions and faces, counts the rest.
class SoupImporter : public OIO::BaseImporter {
 public:
  PolygonSoup soup;
  std::string error;  // first problem seen
  // OBJ: the faces come from prescan_obj; OpenMesh's are counted (its reader asks for
  // n_faces and attaches texture coordinates to them) but not kept.
  bool faces_elsewhere = false;
  size_t faces_seen = 0;

  VertexHandle add_vertex(const OpenMesh::Vec3f& p) override {
    soup.vertices.emplace_back(double(p[0]), double(p[1]), double(p[2]));
    return VertexHandle(int(soup.vertices.size()) - 1);
  }
  VertexHandle add_vertex(const OpenMesh::Vec3d& p) override {
    soup.double_precision = true;
    soup.vertices.emplace_back(p[0], p[1], p[2]);
    return VertexHandle(int(soup.vertices.size()) - 1);
  }
  VertexHandle add_vertex() override {
    soup.vertices.emplace_back(0.0, 0.0, 0.0);
    return VertexHandle(int(soup.vertices.size()) - 1);
  }
  HalfedgeHandle add_edge(VertexHandle, VertexHandle) override { return HalfedgeHandle(); }
  FaceHandle add_face(const VHandles& idx) override {
    if (faces_elsewhere) return FaceHandle(int(faces_seen++));
    std::vector<uint32_t> f;
    f.reserve(idx.size());
    for (const auto& vh : idx) {
      if (!vh.is_valid() || size_t(vh.idx()) >= soup.vertices.size()) {
        if (error.empty())
          error = "face " + std::to_string(soup.faces.size()) + ": vertex index " + std::to_string(vh.idx()) +
                  " out of range (" + std::to_string(soup.vertices.size()) + " vertices)";
        return FaceHandle();
      }
      f.push_back(uint32_t(vh.idx()));
    }
    soup.faces.push_back(std::move(f));
    return FaceHandle(int(soup.faces.size()) - 1);
  }
  FaceHandle add_face(HalfedgeHandle) override { return FaceHandle(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec2f>& t) override { soup.texcoords += t.size(); }
  void add_face_texcoords(FaceHandle, VertexHandle, const std::vector<OpenMesh::Vec3f>& t) override { soup.texcoords += t.size(); }
  void set_face_texindex(FaceHandle, int) override {}
  void set_point(VertexHandle vh, const OpenMesh::Vec3f& p) override {
    if (vh.is_valid() && size_t(vh.idx()) < soup.vertices.size()) soup.vertices[vh.idx()] = Vec3d(p[0], p[1], p[2]);
  }
  void set_halfedge(VertexHandle, HalfedgeHandle) override {}
  void set_normal(VertexHandle, const OpenMesh::Vec3f&) override { ++soup.vertex_normals; }
  void set_normal(VertexHandle, const OpenMesh::Vec3d&) override { ++soup.vertex_normals; }
  void set_color(VertexHandle, const OpenMesh::Vec3uc&) override { ++soup.vertex_colors; }
  void set_color(VertexHandle, const OpenMesh::Vec4uc&) override { ++soup.vertex_colors; }
  void set_color(VertexHandle, const OpenMesh::Vec3f&) override { ++soup.vertex_colors; }
  void set_color(VertexHandle, const OpenMesh::Vec4f&) override { ++soup.vertex_colors; }
  void set_texcoord(VertexHandle, const OpenMesh::Vec2f&) override { ++soup.texcoords; }
  void set_status(VertexHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_next(HalfedgeHandle, HalfedgeHandle) override {}
  void set_face(HalfedgeHandle, FaceHandle) override {}
  void request_face_texcoords2D() override {}
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec2f&) override { ++soup.texcoords; }
  void set_texcoord(VertexHandle, const OpenMesh::Vec3f&) override { ++soup.texcoords; }
  void set_texcoord(HalfedgeHandle, const OpenMesh::Vec3f&) override { ++soup.texcoords; }
  void set_status(HalfedgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4uc&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec3f&) override {}
  void set_color(EdgeHandle, const OpenMesh::Vec4f&) override {}
  void set_status(EdgeHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void set_normal(FaceHandle, const OpenMesh::Vec3f&) override { ++soup.face_normals; }
  void set_normal(FaceHandle, const OpenMesh::Vec3d&) override { ++soup.face_normals; }
  void set_color(FaceHandle, const OpenMesh::Vec3uc&) override { ++soup.face_colors; }
  void set_color(FaceHandle, const OpenMesh::Vec4uc&) override { ++soup.face_colors; }
  void set_color(FaceHandle, const OpenMesh::Vec3f&) override { ++soup.face_colors; }
  void set_color(FaceHandle, const OpenMesh::Vec4f&) override { ++soup.face_colors; }
  void set_status(FaceHandle, const OpenMesh::Attributes::StatusInfo&) override {}
  void add_texture_information(int, std::string) override {}
  size_t n_vertices() const override { return soup.vertices.size(); }
  size_t n_faces() const override { return faces_elsewhere ? faces_seen : soup.faces.size(); }
  size_t n_edges() const override { return 0; }
};

// Strict pre-scan of what OpenMesh's readers do not check. Its OFF and ASCII readers
// ignore stream failures (a "nan" token or a truncated file leaves uninitialised values
// that may pass as coordinates or in-range indices), and its binary STL reader trusts
// the triangle count. Each returns an empty string when the file may be handed to
// OpenMesh, else a message naming the line and element; numbers are checked as
// mesh_text.h says.

// A count or an index: plain digits (an optional '+'; a stream read of an unsigned
// integer would wrap "-1" to 4294967295), at most `limit`.
bool count_number(const std::string& tok, uint64_t limit, uint64_t& out) {
  size_t i = tok.size() > 0 && tok[0] == '+' ? 1 : 0;
  if (i == tok.size() || tok.size() - i > 18) return false;
  out = 0;
  for (; i < tok.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(tok[i]))) return false;
    out = out * 10 + uint64_t(tok[i] - '0');
  }
  return out <= limit;
}

// OFF files are handed to OpenMesh in a canonical form that this pre-scan writes
// (`canonical`): OpenMesh's OFF reader takes the first line as the header and reads the
// counts and vertices token by token after it, so it silently reads "OFF 3 1 0" (counts
// on the header line, which many writers produce) as an empty mesh or as a huge vertex
// count (gigabytes), and it reads a '#' comment as a failed
// number, leaving counts uninitialised. The canonical text is the magic alone on line 1,
// "nv nf 0" on line 2, then every vertex and face line with comments and blank lines
// removed: exactly what was validated here.
// The words of `line` as `istream >> std::string` finds them (separated by the "C"
// locale's white space), without a stream per line; `toks` keeps its capacity.
void split_words(const std::string& line, std::vector<std::string>& toks) {
  size_t n = 0;
  const char* p = line.data();
  const char* end = p + line.size();
  auto space = [](char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\v' || c == '\f' || c == '\r'; };
  while (p < end) {
    while (p < end && space(*p)) ++p;
    if (p == end) break;
    const char* b = p;
    while (p < end && !space(*p)) ++p;
    if (n < toks.size()) toks[n].assign(b, p);
    else toks.emplace_back(b, p);
    ++n;
  }
  toks.resize(n);
}

std::string prescan_off(std::istream& in, std::string& canonical) {
  std::string line;
  size_t lineno = 0;
  std::vector<std::string> toks;
  auto next_line = [&]() -> bool {
    while (std::getline(in, line)) {
      ++lineno;
      auto hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      split_words(line, toks);
      if (!toks.empty()) return true;
    }
    return false;
  };
  if (!next_line()) return "empty file";
  std::string magic = toks[0];
  if (magic.find("OFF") == std::string::npos) return "line 1: missing OFF header";
  // Binary OFF is refused: OpenMesh 9's binary OFF reader ignores read failures and
  // sizes vectors from whatever it read (a 16-byte file can make it allocate and loop
  // for seconds; fuzz_mesh_files seeds).
  if (magic.find("BINARY") != std::string::npos || (toks.size() > 1 && toks[1] == "BINARY"))
    return "line " + std::to_string(lineno) + ": binary OFF is not supported (convert it to ASCII OFF, PLY or OBJ)";
  if (magic != "OFF" && magic != "COFF" && magic != "NOFF" && magic != "CNOFF" && magic != "STOFF" && magic != "NCOFF")
    // Other variants (4OFF, nOFF, "OFF:", ...) are refused: OpenMesh reads their counts
    // unchecked (a negative count loops).
    return "line " + std::to_string(lineno) + ": unsupported OFF header '" + magic.substr(0, 32) +
           "' (OFF, COFF, NOFF, CNOFF, NCOFF, STOFF)";
  toks.erase(toks.begin());
  if (toks.empty() && !next_line()) return "line " + std::to_string(lineno) + ": missing vertex and face counts";
  constexpr uint64_t kMaxCount = 100000000;
  uint64_t nv = 0, nf = 0;
  if (toks.size() < 2 || !count_number(toks[0], UINT64_MAX / 16, nv) || !count_number(toks[1], UINT64_MAX / 16, nf))
    return "line " + std::to_string(lineno) + ": bad vertex and face counts";
  if (nv > kMaxCount || nf > kMaxCount) return "line " + std::to_string(lineno) + ": counts exceed the limit 100000000";
  canonical = magic + "\n" + std::to_string(nv) + " " + std::to_string(nf) + " 0\n";
  // OpenMesh reads a vertex as 3 floats (3 more for the normal of NOFF/CNOFF) token by
  // token and then the rest of its line (colours, texture coordinates); a face as its
  // size and that many indices token by token, and the rest of the line only when the
  // header has face colours (C). So a vertex line needs its coordinates, and a face line
  // keeps exactly the tokens the reader will take: anything else would become the next
  // face (e.g. "0 2147483648 2 0": a face of size 0, then a size of 2^31 that OpenMesh
  // would push into a vector).
  const bool normals = magic.find('N') != std::string::npos, face_colours = magic.find('C') != std::string::npos;
  const size_t coords = normals ? 6 : 3;
  auto keep_line = [&](size_t n) {
    for (size_t k = 0; k < n; ++k) {
      if (k) canonical += ' ';
      canonical += toks[k];
    }
    canonical += '\n';
  };
  for (size_t v = 0; v < nv; ++v) {
    if (!next_line()) return "vertex " + std::to_string(v) + ": file ends early (" + std::to_string(nv) + " vertices announced)";
    if (toks.size() < coords)
      return "line " + std::to_string(lineno) + ": vertex " + std::to_string(v) + ": needs " + std::to_string(coords) +
             " numbers (coordinates" + (normals ? " and normal)" : ")");
    for (size_t k = 0; k < coords; ++k) {
      double x;
      if (!float_number(toks[k], x)) return number_error(toks[k], lineno, "vertex " + std::to_string(v));
    }
    keep_line(toks.size());
  }
  for (size_t f = 0; f < nf; ++f) {
    if (!next_line()) return "face " + std::to_string(f) + ": file ends early (" + std::to_string(nf) + " faces announced)";
    uint64_t k = 0;
    if (!count_number(toks[0], toks.size() - 1, k))
      return "line " + std::to_string(lineno) + ": face " + std::to_string(f) + ": bad vertex count";
    for (size_t q = 1; q <= size_t(k); ++q) {
      uint64_t idx;
      if (nv == 0 || !count_number(toks[q], nv - 1, idx))
        return "line " + std::to_string(lineno) + ": face " + std::to_string(f) + ": vertex index '" + toks[q].substr(0, 32) + "' out of range";
    }
    keep_line(face_colours ? toks.size() : size_t(k) + 1);
  }
  return {};
}

// Whether a decimal integer (optional '-', then digits) fits a 32-bit int, as
// `std::istream >> int` requires.
bool fits_int(const std::string& field) {
  const bool negative = field[0] == '-';
  size_t k = negative ? 1 : 0;
  while (k + 1 < field.size() && field[k] == '0') ++k;  // leading zeros do not count
  if (field.size() - k > 10) return false;
  const uint64_t v = std::stoull(field.substr(k));
  return v <= (negative ? 2147483648ull : 2147483647ull);
}

// The next three tokens of a vertex line (OBJ `v`, ASCII STL `vertex`) as coordinates
// OpenMesh's float reads accept, rounded as they round them; else a message naming the
// line and the vertex.
std::string three_coordinates(std::istringstream& ss, size_t lineno, size_t vertex, Vec3f& out) {
  for (int k = 0; k < 3; ++k) {
    std::string t;
    if (!(ss >> t)) return "line " + std::to_string(lineno) + ": vertex " + std::to_string(vertex) + ": needs 3 coordinates";
    double x;
    if (!float_number(t, x)) return number_error(t, lineno, "vertex " + std::to_string(vertex));
    out[k] = std::strtof(t.c_str(), nullptr);
  }
  return {};
}

// The faces of an OBJ file as the file states them (prescan_obj). OpenMesh's OBJ reader
// changes faces without a word: it removes every repeated vertex of a face (`f 1 2 1 3`
// becomes the triangle 1 2 3, `f 1 2 2` disappears, and an index out of range inside a
// face that disappears is never seen) and it reads on past a `#` (`f 1 2 3 # 4` became
// the quad 1 2 3 4). So OpenMesh reads the vertices and the attributes, and the faces
// come from here, one list of 0-based vertex indices per `f` line, repeats kept for the
// repair's report (`repeated_vertex_faces`, as for OFF and PLY).
struct ObjFaces {
  size_t vertices = 0;  // `v` lines, counted as OpenMesh counts them
  std::vector<std::vector<uint32_t>> faces;
};

std::string prescan_obj(std::istream& in, ObjFaces& out) {
  std::string line;
  size_t lineno = 0, vertices = 0, faces = 0;
  struct Ref { size_t line, face; int64_t index; std::string token; };
  std::vector<Ref> forward;  // references past the vertices read so far (legal OBJ): checked at the end
  while (std::getline(in, line)) {
    ++lineno;
    // OpenMesh trims " \t\r\n" and then skips a line that starts with any other
    // whitespace (form feed, vertical tab) as if it were a comment: a `v` line so hidden
    // would shift every later vertex index, so such a line is refused.
    const size_t first = line.find_first_not_of(" \t\r\n");
    if (first != std::string::npos && std::isspace(static_cast<unsigned char>(line[first])))
      return "line " + std::to_string(lineno) + ": starts with a form feed or vertical tab";
    std::istringstream ss(line);
    std::string kw;
    if (!(ss >> kw)) continue;
    if (kw == "v") {
      Vec3f p;
      if (auto err = three_coordinates(ss, lineno, vertices, p); !err.empty()) return err;
      ++vertices;
    } else if (kw == "f") {
      // Face references `v`, `v/vt`, `v//vn` or `v/vt/vn`, each an integer: OpenMesh 9's
      // OBJ reader asserts (`!vhandles.empty()`, OBJReader.cc:633) on a reference with an
      // empty vertex part such as `/1`, when that leaves the face without a vertex: it
      // reads every token of the line (a `#` does not end it) and skips those whose
      // vertex part is not a number. So a face needs a valid reference before any `#`
      // (`f   #4 /1(f0` asserted; `f #4 1 2 3` reads a triangle but is refused here too).
      // The reader takes each number as an int and skips one that does not fit, so a
      // reference out of int range counts as bad too (else the face is left without a
      // vertex before a `/1` and OpenMesh asserts).
      const size_t face = faces++;
      std::vector<uint32_t> idx;
      for (std::string t; ss >> t;) {
        if (t[0] == '#') break;
        size_t part = 0, start = 0;
        bool ok = true;
        std::string vertex_part;
        for (size_t k = 0; k <= t.size() && ok; ++k) {
          if (k < t.size() && t[k] != '/') continue;
          const std::string field = t.substr(start, k - start);
          const bool integer = !field.empty() && field.find_first_not_of("0123456789", field[0] == '-' ? 1 : 0) ==
                                                     std::string::npos && field != "-" && fits_int(field);
          // The vertex part is required; texture (part 1) and normal (part 2) may be empty.
          ok = part <= 2 && (integer || (part > 0 && field.empty()));
          if (part == 0) vertex_part = field;
          ++part;
          start = k + 1;
        }
        if (!ok)
          return "line " + std::to_string(lineno) + ": face " + std::to_string(face) + ": bad vertex reference '" +
                 t.substr(0, 32) + "'";
        // OBJ numbers vertices from 1; -k is the k-th vertex line before this one.
        const int64_t v = std::stoll(vertex_part);
        const int64_t resolved = v < 0 ? int64_t(vertices) + v : v - 1;
        if (v == 0 || resolved < 0)
          return "line " + std::to_string(lineno) + ": face " + std::to_string(face) + ": vertex index '" +
                 vertex_part + "' out of range (" + std::to_string(vertices) + " vertices before it)";
        if (size_t(resolved) >= vertices) forward.push_back({lineno, face, resolved, vertex_part});
        idx.push_back(uint32_t(resolved));
      }
      if (idx.empty()) return "line " + std::to_string(lineno) + ": face " + std::to_string(face) + ": no vertex references";
      out.faces.push_back(std::move(idx));
    }
  }
  for (const Ref& r : forward)
    if (size_t(r.index) >= vertices)
      return "line " + std::to_string(r.line) + ": face " + std::to_string(r.face) + ": vertex index '" + r.token +
             "' out of range (" + std::to_string(vertices) + " vertices)";
  out.vertices = vertices;
  return {};
}

// The facets of an STL file, three float positions each, in file order. OpenMesh's STL
// readers merge equal positions into one vertex and then drop every facet whose three
// vertices are not distinct, without a word, so a file's degenerate facets never
// reached the repair's report. OpenMesh still reads the vertices; the faces are rebuilt
// from these facets (read_polygon_file), degenerate ones included.
using StlFacets = std::vector<std::array<Vec3f, 3>>;

// ASCII STL as OpenMesh 9 reads it: after any line containing "outer" (or "OUTER") it
// takes the next three lines as vertices, skipping their first word and reading three
// floats, whatever they say; a failed read leaves the previous (first time:
// uninitialised) coordinates. So those three lines must be `vertex x y z`, and a line
// such as `solid outer_wall` that only looks like a loop is refused rather than read
// as one.
std::string prescan_ascii_stl(std::istream& in, StlFacets& facets) {
  std::string line;
  size_t lineno = 0, vertices = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (line.find("outer") == std::string::npos && line.find("OUTER") == std::string::npos) {
      std::istringstream ss(line);
      std::string kw;
      if (ss >> kw && kw == "vertex")
        return "line " + std::to_string(lineno) + ": vertex " + std::to_string(vertices) + " outside an 'outer loop'";
      continue;
    }
    std::array<Vec3f, 3> facet;
    for (int c = 0; c < 3; ++c) {
      if (!std::getline(in, line))
        return "facet " + std::to_string(facets.size()) + ": file ends inside its 'outer loop'";
      ++lineno;
      std::istringstream ss(line);
      std::string kw;
      if (!(ss >> kw) || kw != "vertex")
        return "line " + std::to_string(lineno) + ": facet " + std::to_string(facets.size()) +
               ": expected 'vertex x y z' (the line after 'outer loop' and the two after it are vertices)";
      if (auto err = three_coordinates(ss, lineno, vertices, facet[size_t(c)]); !err.empty()) return err;
      ++vertices;
    }
    facets.push_back(facet);
  }
  return {};
}

// PLY: the shared reader's strict checks (ply.h), every one of them, before OpenMesh
// reads the file.
std::string prescan_ply(const std::string& data) {
  ply::Header h;
  if (auto err = ply::read_header(data, h); !err.empty()) return err;
  return ply::read_body(data, h, nullptr);
}

// `canonical` receives the text to hand to OpenMesh instead of the file (OFF only).
std::string prescan_mesh_file(const std::string& path, const std::string& ext, std::string& canonical, ObjFaces& obj,
                              StlFacets& stl) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "cannot open file";
  if (ext == ".off") return prescan_off(in, canonical);
  if (ext == ".obj") return prescan_obj(in, obj);
  if (ext == ".ply") {
    std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return prescan_ply(data);
  }
  // STL: binary iff the size matches 84 + 50 n for the stored count n.
  std::error_code ec;
  uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return "cannot stat file";
  char head[84] = {};
  in.read(head, 84);
  uint32_t n = 0;  // binary STL's facet count
  std::memcpy(&n, head + 80, 4);
  const bool binary = in.gcount() == 84 && size == 84 + 50ull * n;
  if (binary) {
    // Binary STL: 84 header bytes, then per facet a normal, three vertices (12 floats,
    // little-endian as OpenMesh reads them on this host) and 2 attribute bytes.
    stl.reserve(n);
    char rec[50];
    for (uint32_t f = 0; f < n; ++f) {
      if (!in.read(rec, 50)) return "facet " + std::to_string(f) + ": file ends early";
      std::array<Vec3f, 3> facet;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) std::memcpy(&facet[size_t(c)][k], rec + 12 + 12 * c + 4 * k, 4);
      stl.push_back(facet);
    }
    return {};
  }
  if (std::string(head, head + std::min<size_t>(5, size_t(in.gcount()))) != "solid")
    return "neither ASCII STL ('solid' header) nor binary STL (size " + std::to_string(size) + " does not match the triangle count)";
  in.clear();
  in.seekg(0);
  return prescan_ascii_stl(in, stl);
}

std::mutex& io_mutex() {
  static std::mutex m;  // OpenMesh's IOManager and log streams are process-global
  return m;
}

// Binary STL: 84 header bytes and 50 per facet, as its count says.
bool binary_stl_size(const std::string& data) {
  if (data.size() < 84) return false;
  uint32_t n = 0;
  std::memcpy(&n, data.data() + 80, 4);
  return data.size() == 84 + 50ull * n;
}

// Format from content, for files without an extension: PLY and OFF by their magic, STL
// by its binary size or `solid`, OBJ by its first keyword.
std::string sniff_format(const std::string& data) {
  if (binary_stl_size(data)) return ".stl";
  std::istringstream in(data.substr(0, 4096));
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream ss(line);
    std::string kw;
    if (!(ss >> kw) || kw[0] == '#') continue;
    if (kw == "ply") return ".ply";
    if (kw.find("OFF") != std::string::npos) return ".off";
    if (kw == "solid") return ".stl";
    if (kw == "v" || kw == "vn" || kw == "vt" || kw == "f" || kw == "o" || kw == "g" || kw == "mtllib" ||
        kw == "usemtl" || kw == "s" || kw == "l" || kw == "p")
      return ".obj";
    return "";
  }
  return "";
}

// Levenshtein distance of two short words.
size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  std::iota(row.begin(), row.end(), size_t(0));
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diag = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

// PLY header lines whose keyword the format does not know become comments (as other
// readers skip them), each with a warning naming its line. A keyword within two edits of
// a known one (`elemnt`) is a typo that would drop an element or a property and misread
// the body: it stays, for prescan_ply to refuse.
void soften_ply_header(std::string& data, std::vector<std::string>& warnings, bool& changed) {
  size_t pos = 0, lineno = 0;
  while (pos < data.size() && lineno < ply::kMaxHeaderLines) {
    const size_t nl = data.find('\n', pos);
    const size_t end = nl == std::string::npos ? data.size() : nl;
    ++lineno;
    std::istringstream ss(data.substr(pos, end - pos));
    std::string kw;
    ss >> kw;
    if (kw == "end_header") return;
    static const char* kKnown[] = {"ply", "format", "element", "property", "comment", "obj_info", "end_header"};
    bool known = kw.empty() || lineno == 1;
    for (const char* k : kKnown) known = known || edit_distance(kw.substr(0, 16), k) <= 2;
    if (!known) {
      std::string text = data.substr(pos, end - pos);
      if (!text.empty() && text.back() == '\r') text.pop_back();
      warnings.push_back("line " + std::to_string(lineno) + ": unknown PLY header line '" + text.substr(0, 64) +
                         "' ignored");
      data.insert(pos, "comment ");
      changed = true;
      pos = data.find('\n', pos);
      if (pos == std::string::npos) return;
      ++pos;
      continue;
    }
    if (nl == std::string::npos) return;
    pos = nl + 1;
  }
}

Result<PolygonSoup> read_soup(const std::string& path, const std::string& read_path, const std::string& ext);

}  // namespace

Result<DecodedMeshFile> decode_mesh_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error{path + ": file not found"};
  if (fs::is_directory(path, ec)) return Error{path + ": is a directory"};
  DecodedMeshFile d;
  {
    std::ifstream in(path, std::ios::binary | std::ios::ate);
    if (!in) return Error{path + ": cannot open file"};
    const std::streamoff size = in.tellg();
    if (size < 0) return Error{path + ": cannot read file"};
    d.bytes.resize(size_t(size));
    in.seekg(0);
    if (!in.read(d.bytes.data(), size)) return Error{path + ": read error"};
  }
  if (d.bytes.empty()) return Error{path + ": empty file (no faces)"};
  std::string ext = fs::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  const bool binary_stl = (ext == ".stl" || ext.empty()) && binary_stl_size(d.bytes);
  const std::string& b = d.bytes;
  if (!binary_stl && b.size() >= 3 && b.compare(0, 3, "\xEF\xBB\xBF") == 0) {
    d.bytes.erase(0, 3);
    d.changed = true;
  } else if (!binary_stl && b.size() >= 2 && (b.compare(0, 2, "\xFF\xFE") == 0 || b.compare(0, 2, "\xFE\xFF") == 0)) {
    const bool le = b[0] == '\xFF';
    if (b.size() % 2 != 0) return Error{path + ": UTF-16 text (byte-order mark) with an odd number of bytes"};
    std::string text;
    text.reserve(b.size() / 2);
    for (size_t i = 2; i < b.size(); i += 2) {
      const unsigned lo = static_cast<unsigned char>(b[le ? i : i + 1]), hi = static_cast<unsigned char>(b[le ? i + 1 : i]);
      const unsigned u = hi << 8 | lo;
      if (u >= 0x80) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "%04X", u);
        return Error{path + ": UTF-16 text (byte-order mark): character " + std::to_string(i / 2 - 1) + " is U+" + hex +
                     ", not ASCII (save the file as ASCII or UTF-8)"};
      }
      text.push_back(char(u));
    }
    d.bytes = std::move(text);
    d.changed = true;
  }
  if (ext.empty()) {
    ext = sniff_format(d.bytes);
    if (ext.empty()) return Error{path + ": no extension, and the content is not OBJ, OFF, PLY or STL"};
  } else if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl") {
    return Error{path + ": unsupported mesh format '" + ext + "' (OBJ, OFF, PLY, STL)"};
  }
  d.format = ext;
  if (ext == ".ply") soften_ply_header(d.bytes, d.warnings, d.changed);
  return d;
}

Result<PolygonSoup> read_polygon_file(const std::string& path) {
  auto d = decode_mesh_file(path);
  if (!d) return d.error();
  return read_polygon_file(path, *d);
}

Result<PolygonSoup> read_polygon_file(const std::string& path, const DecodedMeshFile& decoded) {
  namespace fs = std::filesystem;
  const DecodedMeshFile* d = &decoded;
  if (!d->changed && !fs::path(path).extension().empty()) {
    auto soup = read_soup(path, path, d->format);
    if (soup) soup->format = d->format;
    return soup;
  }
  // Decoded text or an extension-less file: the readers take it from a temporary file
  // with the format's extension.
  static std::atomic<uint64_t> serial{0};
  std::error_code ec;
  const fs::path tmp = fs::temp_directory_path(ec) / ("visgate-mesh-" + std::to_string(::getpid()) + "-" +
                                                     std::to_string(serial++) + d->format);
  {
    std::ofstream out(tmp, std::ios::binary);
    out.write(d->bytes.data(), std::streamsize(d->bytes.size()));
    if (!out) {
      fs::remove(tmp, ec);
      return Error{path + ": cannot write a temporary file in " + tmp.parent_path().string()};
    }
  }
  auto soup = read_soup(path, tmp.string(), d->format);
  fs::remove(tmp, ec);
  if (soup) {
    soup->format = d->format;
    soup->warnings = d->warnings;
  }
  return soup;
}

namespace {

// Reads `read_path` as format `ext`; errors name `path`.
Result<PolygonSoup> read_soup(const std::string& path, const std::string& read_path, const std::string& ext) {
  namespace fs = std::filesystem;
  std::error_code ec;
  std::string canonical;
  ObjFaces obj;
  StlFacets stl;
  if (auto pre = prescan_mesh_file(read_path, ext, canonical, obj, stl); !pre.empty()) return Error{path + ": " + pre};

  SoupImporter imp;
  imp.faces_elsewhere = ext == ".obj" || ext == ".stl";
  bool ok = false;
  {
    std::lock_guard<std::mutex> lock(io_mutex());
    omerr().disable();
    omlog().disable();
    omout().disable();
    OIO::Options opt = OIO::Options::Default;
    try {
      if (ext == ".off") {
        // OpenMesh's own OFF reader on the canonical text (see prescan_off). The reader
        // takes its options (colours, normals, texture coordinates) from the header line
        // in can_u_read, whose stream form is private: it is given a one-line file
        // holding the canonical header, then read() parses the canonical text.
        static std::atomic<uint64_t> serial{0};
        const fs::path head = fs::temp_directory_path(ec) / ("visgate-off-header-" + std::to_string(::getpid()) + "-" +
                                                             std::to_string(serial++) + ".off");
        {
          std::ofstream h(head, std::ios::binary);
          h << canonical.substr(0, canonical.find('\n') + 1);
          if (!h) return Error{path + ": cannot write a temporary file in " + head.parent_path().string()};
        }
        std::istringstream body(std::move(canonical));  // no second copy of a large file
        ok = OIO::OFFReader().can_u_read(head.string()) && OIO::OFFReader().read(body, imp, opt);
        fs::remove(head, ec);
      } else {
        ok = OIO::IOManager().read(read_path, imp, opt);
      }
    } catch (const std::exception& e) {
      return Error{path + ": cannot read mesh: " + e.what()};
    }
  }
  if (!imp.error.empty()) return Error{path + ": " + imp.error};
  if (!ok) return Error{path + ": malformed or unreadable mesh file"};
  for (size_t i = 0; i < imp.soup.vertices.size(); ++i) {
    const Vec3d& v = imp.soup.vertices[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      return Error{path + ": vertex " + std::to_string(i) + ": coordinate is NaN or infinite"};
  }
  if (ext == ".stl") {
    // OpenMesh's own merge (STLReader.cc CmpVec with eps FLT_MIN: coordinates within
    // FLT_MIN are equal), first position wins, so every facet corner finds the vertex
    // OpenMesh made for it.
    struct Cmp {
      bool operator()(const Vec3f& a, const Vec3f& b) const {
        const float eps = std::numeric_limits<float>::min();
        if (std::fabs(a.x - b.x) <= eps) {
          if (std::fabs(a.y - b.y) <= eps) return a.z < b.z - eps;
          return a.y < b.y - eps;
        }
        return a.x < b.x - eps;
      }
    };
    std::map<Vec3f, uint32_t, Cmp> index;
    for (size_t i = 0; i < imp.soup.vertices.size(); ++i) index.emplace(Vec3f(imp.soup.vertices[i]), uint32_t(i));
    imp.soup.faces.clear();
    imp.soup.faces.reserve(stl.size());
    for (size_t f = 0; f < stl.size(); ++f) {
      std::vector<uint32_t> face;
      for (const Vec3f& p : stl[f]) {
        auto it = index.find(p);
        if (it == index.end()) return Error{path + ": facet " + std::to_string(f) + ": a corner OpenMesh did not read"};
        face.push_back(it->second);
      }
      imp.soup.faces.push_back(std::move(face));
    }
  }
  if (ext == ".obj") {
    if (imp.soup.vertices.size() != obj.vertices)
      return Error{path + ": OpenMesh read " + std::to_string(imp.soup.vertices.size()) + " vertices, the file has " +
                   std::to_string(obj.vertices) + " vertex lines"};
    imp.soup.faces = std::move(obj.faces);
  }
  return std::move(imp.soup);
}

}  // namespace

Result<TriangleSoup> triangulate(const PolygonSoup& soup, const std::string& origin, size_t* short_faces) {
  TriangleSoup out;
  out.vertices.reserve(soup.vertices.size());
  for (size_t i = 0; i < soup.vertices.size(); ++i) {
    Vec3f f(soup.vertices[i]);
    if (!is_finite(f)) return Error{origin + ": vertex " + std::to_string(i) + ": coordinate overflows float32"};
    out.vertices.push_back(f);
  }
  size_t shorts = 0;
  for (const auto& f : soup.faces) {
    if (f.size() < 3) { ++shorts; continue; }
    for (size_t k = 1; k + 1 < f.size(); ++k) out.triangles.push_back({f[0], f[k], f[k + 1]});
  }
  if (short_faces) *short_faces = shorts;
  return out;
}

}  // namespace visgate
