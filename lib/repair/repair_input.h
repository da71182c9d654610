// What `visgate repair` would lose from its input ("attributes that cannot be
// kept are reported, not silently dropped"; "nothing the user gave is lost"), found by a
// scan of the file's own bytes next to the polygon soup that lib/scene/mesh_io read from
// them.
//
// 1. Attributes the soup does not keep (normals, colours, texture coordinates,
//    materials, groups, line and point elements, extra PLY properties and elements, STL
//    facet normals and attribute words) are counted by name.
// 2. Double-precision coordinates. OpenMesh's readers hand every coordinate over as a
//    float32. A file holds double data when its PLY vertex x, y or z property is double,
//    or when some text coordinate (OBJ, OFF, ASCII PLY) has more than 9 significant
//    digits and is not exactly a float32 (9 digits are what a float needs to round-trip,
//    so a writer of float data never needs more). Such coordinates are parsed here as
//    doubles (correctly rounded, strtod) and replace the reader's values, vertex by vertex
//    in file order; each replaced value must round to the reader's float, or the scan and
//    the reader disagree and the file is refused. STL readers merge equal float corners,
//    so double data in an ASCII STL cannot be kept: refused.
//
// The scan runs after read_polygon_file accepted the file, so it only meets what the
// reader's pre-scan allowed; it still checks every count and bound it relies on.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "lib/scene/mesh_io.h"

namespace visgate::mesh {

struct InputAudit {
  std::vector<std::pair<std::string, size_t>> not_kept;  // attribute -> count, nonzero only
  bool double_data = false;          // the file holds double coordinates (see above)
  size_t coordinates_restored = 0;   // vertices whose reader value (a float) was replaced
};

// Audits `bytes` (the content of `path` as decode_mesh_file decodes it, in the format
// soup.format or else the one its extension names) against `soup` (read from it) and
// restores double coordinates into `soup` (setting soup.double_precision). Errors name
// the file and the element.
Result<InputAudit> audit_input(const std::string& path, const std::string& bytes, PolygonSoup& soup);

}  // namespace visgate::mesh
