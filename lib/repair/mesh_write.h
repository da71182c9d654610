// Triangle mesh writers for OBJ, OFF, PLY (ASCII) and STL (binary and ASCII), used by
// `visgate repair` (DESIGN section 7). Coordinates round-trip bit for bit (DESIGN
// section 2): float data is written in the shortest decimal that reads back to the same
// float (at most 9 significant digits, std::to_chars), double data with 17, and
// binary STL (float32 by format) refuses coordinates that are not exactly floats.
// Files are written through write_file_atomic: nothing is left behind on failure.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "lib/geom/vec.h"
#include "lib/base/result.h"

namespace visgate::mesh {

enum class MeshFormat { Obj, Off, Ply, StlBinary, StlAscii };

struct IndexedMesh {
  std::vector<Vec3d> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;
  bool double_precision = false;  // false: every coordinate is exactly a float32
};

// Format from the file extension (.obj .off .ply .stl); `stl_ascii` picks ASCII STL.
Result<MeshFormat> format_from_path(const std::string& path, bool stl_ascii);
// The file's bytes. Fails (naming `path` and the vertex) only for binary STL when a
// coordinate is not exactly representable as float32.
Result<std::string> encode_mesh(const IndexedMesh& m, MeshFormat f, const std::string& path);
// encode_mesh then write_file_atomic.
Status write_mesh_file(const IndexedMesh& m, MeshFormat f, const std::string& path);

}  // namespace visgate::mesh
