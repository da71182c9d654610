// Mesh writers (see mesh_write.h).
#include "lib/repair/mesh_write.h"

#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>

#include "lib/scene/json_exact.h"

namespace visgate::mesh {

namespace {

// Appends `v` with `digits` significant digits in %g style (std::to_chars is correctly
// rounded, so 9 digits round-trip any float32 and 17 any double).
inline void put_num(std::string& out, double v, int digits) {
  char buf[40];
  auto r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, digits);
  out.append(buf, r.ptr);
}

inline void put_uint(std::string& out, uint64_t v) {
  char buf[24];
  auto r = std::to_chars(buf, buf + sizeof(buf), v);
  out.append(buf, r.ptr);
}

// A coordinate: float data (digits == 0, every value exactly a float) in the shortest
// decimal that reads back to the same float, so a file's "0.262933" stays "0.262933";
// double data with `digits` significant digits.
inline void put_coord(std::string& out, double v, int digits) {
  if (digits > 0) return put_num(out, v, digits);
  char buf[40];
  auto r = std::to_chars(buf, buf + sizeof(buf), float(v));
  out.append(buf, r.ptr);
}

void put_xyz(std::string& out, const Vec3d& p, int digits) {
  put_coord(out, p.x, digits);
  out.push_back(' ');
  put_coord(out, p.y, digits);
  out.push_back(' ');
  put_coord(out, p.z, digits);
}

// The body OFF and PLY share: a vertex per line, then "3 a b c" per triangle (0-based).
void put_off_body(std::string& out, const IndexedMesh& m, int digits) {
  for (const auto& p : m.vertices) {
    put_xyz(out, p, digits);
    out.push_back('\n');
  }
  for (const auto& t : m.triangles) {
    out += "3 ";
    put_uint(out, t[0]);
    out.push_back(' ');
    put_uint(out, t[1]);
    out.push_back(' ');
    put_uint(out, t[2]);
    out.push_back('\n');
  }
}

// Facet normal for STL (informative only; readers recompute it), in double.
Vec3d facet_normal(const IndexedMesh& m, const std::array<uint32_t, 3>& t) {
  Vec3d n = cross(m.vertices[t[1]] - m.vertices[t[0]], m.vertices[t[2]] - m.vertices[t[0]]);
  double l = length(n);
  return l > 0 && std::isfinite(l) ? n / l : Vec3d(0, 0, 0);
}

void put_le32(std::string& out, uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(char((v >> (8 * i)) & 0xff));
}
void put_f32(std::string& out, float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  put_le32(out, u);
}

}  // namespace

Result<MeshFormat> format_from_path(const std::string& path, bool stl_ascii) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext == ".obj") return MeshFormat::Obj;
  if (ext == ".off") return MeshFormat::Off;
  if (ext == ".ply") return MeshFormat::Ply;
  if (ext == ".stl") return stl_ascii ? MeshFormat::StlAscii : MeshFormat::StlBinary;
  return Error{path + ": unsupported output format '" + ext + "' (OBJ, OFF, PLY, STL)"};
}

Result<std::string> encode_mesh(const IndexedMesh& m, MeshFormat f, const std::string& path) {
  // Float data only when every coordinate is exactly a float, whatever the flag says:
  // the shortest-float form would round anything else.
  bool doubles = m.double_precision;
  for (size_t i = 0; i < m.vertices.size() && !doubles; ++i)
    for (int a = 0; a < 3; ++a) doubles = doubles || double(float(m.vertices[i][a])) != m.vertices[i][a];
  const int digits = doubles ? 17 : 0;  // 0: shortest float
  std::string out;
  const size_t nv = m.vertices.size(), nt = m.triangles.size();
  switch (f) {
    case MeshFormat::Obj: {
      out.reserve(nv * 40 + nt * 24 + 64);
      out += "# written by visgate repair\n";
      for (const auto& p : m.vertices) {
        out += "v ";
        put_xyz(out, p, digits);
        out.push_back('\n');
      }
      for (const auto& t : m.triangles) {
        out += "f ";
        put_uint(out, uint64_t(t[0]) + 1);
        out.push_back(' ');
        put_uint(out, uint64_t(t[1]) + 1);
        out.push_back(' ');
        put_uint(out, uint64_t(t[2]) + 1);
        out.push_back('\n');
      }
      break;
    }
    case MeshFormat::Off: {
      out.reserve(nv * 40 + nt * 24 + 64);
      out += "OFF\n";
      put_uint(out, nv);
      out.push_back(' ');
      put_uint(out, nt);
      out += " 0\n";
      put_off_body(out, m, digits);
      break;
    }
    case MeshFormat::Ply: {
      out.reserve(nv * 40 + nt * 24 + 256);
      const char* type = doubles ? "double" : "float";
      out += "ply\nformat ascii 1.0\ncomment written by visgate repair\nelement vertex ";
      put_uint(out, nv);
      out += std::string("\nproperty ") + type + " x\nproperty " + type + " y\nproperty " + type + " z\n";
      out += "element face ";
      put_uint(out, nt);
      out += "\nproperty list uchar int vertex_indices\nend_header\n";
      put_off_body(out, m, digits);
      break;
    }
    case MeshFormat::StlAscii: {
      out.reserve(nt * 200 + 64);
      out += "solid visgate\n";
      for (const auto& t : m.triangles) {
        out += "facet normal ";
        put_xyz(out, facet_normal(m, t), 9);  // a double, informative only
        out += "\nouter loop\n";
        for (int k = 0; k < 3; ++k) {
          out += "vertex ";
          put_xyz(out, m.vertices[t[size_t(k)]], digits);
          out.push_back('\n');
        }
        out += "endloop\nendfacet\n";
      }
      out += "endsolid visgate\n";
      break;
    }
    case MeshFormat::StlBinary: {
      // Binary STL is float32 by format: refuse anything that would be rounded.
      for (size_t i = 0; i < nv; ++i) {
        const Vec3d& p = m.vertices[i];
        for (int a = 0; a < 3; ++a)
          if (double(float(p[a])) != p[a])
            return Error{path + ": vertex " + std::to_string(i) +
                         ": coordinate is not exactly a float32, which binary STL would round "
                         "(write .ply, .obj, .off or ASCII STL instead)"};
      }
      if (nt > 0xffffffffull) return Error{path + ": too many triangles for binary STL"};
      out.reserve(84 + nt * 50);
      std::string header = "binary STL written by visgate repair";
      header.resize(80, ' ');
      out += header;
      put_le32(out, uint32_t(nt));
      for (const auto& t : m.triangles) {
        Vec3d n = facet_normal(m, t);
        put_f32(out, float(n.x));
        put_f32(out, float(n.y));
        put_f32(out, float(n.z));
        for (int k = 0; k < 3; ++k) {
          const Vec3d& p = m.vertices[t[size_t(k)]];
          put_f32(out, float(p.x));
          put_f32(out, float(p.y));
          put_f32(out, float(p.z));
        }
        out.push_back('\0');
        out.push_back('\0');
      }
      break;
    }
  }
  return out;
}

Status write_mesh_file(const IndexedMesh& m, MeshFormat f, const std::string& path) {
  auto bytes = encode_mesh(m, f, path);
  if (!bytes) return bytes.error();
  return write_file_atomic(path, *bytes);
}

}  // namespace visgate::mesh
