// OpenMesh-based soup importer (see mesh_io.h).
#include "lib/scene/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <cmath>
#include <filesystem>
#include <cstring>
#include <fstream>
#include <mutex>
#include <sstream>

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
  size_t n_faces() const override { return soup.faces.size(); }
  size_t n_edges() const override { return 0; }
};

// Strict pre-scan of what OpenMesh's readers do not check. Its OFF and ASCII readers
// ignore stream failures (a "nan" token or a truncated file leaves uninitialised values
// that may pass as coordinates or in-range indices), and its binary STL reader trusts
// the triangle count. Returns an empty string when the file may be handed to OpenMesh,
// else a message naming the line and element.
bool finite_number(const std::string& tok, double& out) {
  const char* b = tok.c_str();
  char* e = nullptr;
  out = std::strtod(b, &e);
  return e != b && *e == '\0' && std::isfinite(out);
}

std::string number_error(const std::string& tok, size_t line, const std::string& what) {
  double v = 0;
  const char* b = tok.c_str();
  char* e = nullptr;
  v = std::strtod(b, &e);
  if (e != b && *e == '\0' && !std::isfinite(v)) return "line " + std::to_string(line) + ": " + what + ": coordinate is NaN or infinite";
  return "line " + std::to_string(line) + ": " + what + ": not a number: '" + tok.substr(0, 32) + "'";
}

std::string prescan_off(std::istream& in) {
  std::string line;
  size_t lineno = 0;
  std::vector<std::string> toks;
  auto next_line = [&]() -> bool {
    while (std::getline(in, line)) {
      ++lineno;
      auto hash = line.find('#');
      if (hash != std::string::npos) line.resize(hash);
      std::istringstream ss(line);
      toks.clear();
      for (std::string t; ss >> t;) toks.push_back(t);
      if (!toks.empty()) return true;
    }
    return false;
  };
  if (!next_line()) return "empty file";
  std::string magic = toks[0];
  if (magic.find("OFF") == std::string::npos) return "line 1: missing OFF header";
  if (magic.find("BINARY") != std::string::npos || (toks.size() > 1 && toks[1] == "BINARY")) return {};
  if (magic != "OFF" && magic != "COFF" && magic != "NOFF" && magic != "CNOFF" && magic != "STOFF" && magic != "NCOFF")
    return {};  // variants (4OFF, nOFF) left to OpenMesh
  toks.erase(toks.begin());
  if (toks.empty() && !next_line()) return "line " + std::to_string(lineno) + ": missing vertex and face counts";
  double nv = 0, nf = 0;
  if (toks.size() < 2 || !finite_number(toks[0], nv) || !finite_number(toks[1], nf) || nv < 0 || nf < 0 ||
      nv != std::floor(nv) || nf != std::floor(nf))
    return "line " + std::to_string(lineno) + ": bad vertex and face counts";
  if (nv > 1e8 || nf > 1e8) return "line " + std::to_string(lineno) + ": counts exceed the limit 100000000";
  for (size_t v = 0; v < size_t(nv); ++v) {
    if (!next_line()) return "vertex " + std::to_string(v) + ": file ends early (" + std::to_string(size_t(nv)) + " vertices announced)";
    if (toks.size() < 3) return "line " + std::to_string(lineno) + ": vertex " + std::to_string(v) + ": needs 3 coordinates";
    for (int k = 0; k < 3; ++k) {
      double x;
      if (!finite_number(toks[k], x)) return number_error(toks[k], lineno, "vertex " + std::to_string(v));
    }
  }
  for (size_t f = 0; f < size_t(nf); ++f) {
    if (!next_line()) return "face " + std::to_string(f) + ": file ends early (" + std::to_string(size_t(nf)) + " faces announced)";
    double k = 0;
    if (!finite_number(toks[0], k) || k < 0 || k != std::floor(k) || toks.size() < size_t(k) + 1)
      return "line " + std::to_string(lineno) + ": face " + std::to_string(f) + ": bad vertex count";
    for (size_t q = 1; q <= size_t(k); ++q) {
      double idx;
      if (!finite_number(toks[q], idx) || idx < 0 || idx >= nv || idx != std::floor(idx))
        return "line " + std::to_string(lineno) + ": face " + std::to_string(f) + ": vertex index '" + toks[q].substr(0, 32) + "' out of range";
    }
  }
  return {};
}

std::string prescan_obj(std::istream& in) {
  std::string line;
  size_t lineno = 0, vertices = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ss(line);
    std::string kw;
    if (!(ss >> kw)) continue;
    if (kw == "v") {
      for (int k = 0; k < 3; ++k) {
        std::string t;
        if (!(ss >> t)) return "line " + std::to_string(lineno) + ": vertex " + std::to_string(vertices) + ": needs 3 coordinates";
        double x;
        if (!finite_number(t, x)) return number_error(t, lineno, "vertex " + std::to_string(vertices));
      }
      ++vertices;
    }
  }
  return {};
}

std::string prescan_ascii_stl(std::istream& in) {
  std::string line;
  size_t lineno = 0, vertices = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ss(line);
    std::string kw;
    if (!(ss >> kw) || kw != "vertex") continue;
    for (int k = 0; k < 3; ++k) {
      std::string t;
      if (!(ss >> t)) return "line " + std::to_string(lineno) + ": vertex " + std::to_string(vertices) + ": needs 3 coordinates";
      double x;
      if (!finite_number(t, x)) return number_error(t, lineno, "vertex " + std::to_string(vertices));
    }
    ++vertices;
  }
  return {};
}

std::string prescan_ascii_ply(std::istream& in) {
  std::string line;
  size_t lineno = 0;
  bool ascii = false, body = false;
  while (std::getline(in, line)) {
    ++lineno;
    if (!body) {
      if (line.rfind("format ascii", 0) == 0) ascii = true;
      if (line.rfind("end_header", 0) == 0) {
        if (!ascii) return {};
        body = true;
      }
      continue;
    }
    std::istringstream ss(line);
    for (std::string t; ss >> t;) {
      double x;
      if (!finite_number(t, x)) return number_error(t, lineno, "element data");
    }
  }
  if (!body) return "missing end_header";
  return {};
}

std::string prescan_mesh_file(const std::string& path, const std::string& ext) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return "cannot open file";
  if (ext == ".off") return prescan_off(in);
  if (ext == ".obj") return prescan_obj(in);
  if (ext == ".ply") return prescan_ascii_ply(in);
  // STL: binary iff the size matches 84 + 50 n for the stored count n.
  std::error_code ec;
  uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) return "cannot stat file";
  char head[84] = {};
  in.read(head, 84);
  bool binary = false;
  if (in.gcount() == 84) {
    uint32_t n;
    std::memcpy(&n, head + 80, 4);
    binary = size == 84 + 50ull * n;
  }
  if (binary) return {};
  if (std::string(head, head + std::min<size_t>(5, size_t(in.gcount()))) != "solid")
    return "neither ASCII STL ('solid' header) nor binary STL (size " + std::to_string(size) + " does not match the triangle count)";
  in.clear();
  in.seekg(0);
  return prescan_ascii_stl(in);
}

std::mutex& io_mutex() {
  static std::mutex m;  // OpenMesh's IOManager and log streams are process-global
  return m;
}

}  // namespace

Result<PolygonSoup> read_polygon_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::exists(path, ec)) return Error{path + ": file not found"};
  if (fs::is_directory(path, ec)) return Error{path + ": is a directory"};
  std::string ext = fs::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".obj" && ext != ".off" && ext != ".ply" && ext != ".stl")
    return Error{path + ": unsupported mesh format '" + ext + "' (OBJ, OFF, PLY, STL)"};

  if (auto pre = prescan_mesh_file(path, ext); !pre.empty()) return Error{path + ": " + pre};

  SoupImporter imp;
  bool ok = false;
  {
    std::lock_guard<std::mutex> lock(io_mutex());
    omerr().disable();
    omlog().disable();
    omout().disable();
    OIO::Options opt = OIO::Options::Default;
    try {
      ok = OIO::IOManager().read(path, imp, opt);
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
  return std::move(imp.soup);
}

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
