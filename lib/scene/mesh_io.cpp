// OpenMesh-based soup importer (see mesh_io.h).
#include "lib/scene/mesh_io.h"

#include <OpenMesh/Core/IO/IOManager.hh>
#include <OpenMesh/Core/IO/MeshIO.hh>
#include <OpenMesh/Core/IO/importer/BaseImporter.hh>
#include <OpenMesh/Core/System/omstream.hh>
#include <cmath>
#include <filesystem>
#include <mutex>

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
