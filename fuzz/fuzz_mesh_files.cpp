// fuzz_mesh_files: the mesh file importer (lib/scene/mesh_io.h: OpenMesh's OBJ, OFF, PLY
// and STL readers feeding the polygon-soup importer, DESIGN section 6). The first byte
// picks the extension (its value mod 4: .obj, .off, .ply, .stl); the remaining bytes are
// written to a per-process temporary file that read_polygon_file then reads. Malformed
// files must give an Error value, never a crash, hang, leak or exception. A file that
// reads must yield only finite vertices and in-range face indices, and triangulate()
// must either succeed with in-range triangles or fail cleanly.
//
// OpenMesh is third-party: a crash inside its readers is reported and stored as an open
// finding (corpus/fuzz/open/fuzz_mesh_files/), not guarded against here.
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "lib/scene/mesh_io.h"

namespace {

[[noreturn]] void fail(const std::string& what) {
  std::fprintf(stderr, "fuzz_mesh_files: %s\n", what.c_str());
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace visgate;
  if (size < 1) return 0;
  static const char* const kExt[] = {".obj", ".off", ".ply", ".stl"};
  const std::string path = (std::filesystem::temp_directory_path() /
                            ("visgate-fuzz-mesh-" + std::to_string(::getpid()) + kExt[data[0] % 4]))
                               .string();
  {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    if (!f) return 0;
    if (size > 1) std::fwrite(data + 1, 1, size - 1, f);
    std::fclose(f);
  }
  auto soup = read_polygon_file(path);
  std::remove(path.c_str());
  if (!soup) return 0;

  for (size_t i = 0; i < soup->vertices.size(); ++i) {
    const Vec3d& v = soup->vertices[i];
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z))
      fail("vertex " + std::to_string(i) + " is not finite after a successful read");
  }
  for (size_t f = 0; f < soup->faces.size(); ++f)
    for (uint32_t i : soup->faces[f])
      if (i >= soup->vertices.size()) fail("face " + std::to_string(f) + " index out of range after a successful read");
  size_t shorts = 0;
  auto tri = triangulate(*soup, path, &shorts);
  if (!tri) return 0;
  for (const auto& t : tri->triangles)
    for (uint32_t i : t)
      if (i >= tri->vertices.size()) fail("triangle index out of range after triangulate");
  for (const auto& v : tri->vertices)
    if (!is_finite(v)) fail("non-finite float vertex after triangulate");
  return 0;
}
