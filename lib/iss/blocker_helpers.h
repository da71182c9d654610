// Small helpers shared by the blocker operations (blockers.h), internal to lib/iss:
// the mesh's corners in double, a lexicographic order of points, the union-find over
// patch or surface indices (lib/base/union_find.h), and compaction of a surface's raw
// edges.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "lib/base/union_find.h"
#include "lib/iss/blockers.h"

namespace visgate::iss {

inline Vec3d corner_d(const mesh::PreparedMesh& m, uint32_t t, int k) { return to_double(m.corner(t, k)); }

inline bool lex_less(const Vec3d& a, const Vec3d& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

// Removes raw edges with no neighbour and renumbers the edge references.
void compact_raw(Surface& s, Workspace& ws);

}  // namespace visgate::iss
