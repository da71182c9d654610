// Small helpers shared by the blocker operations (blockers.h), internal to lib/iss:
// the mesh's corners in double, a lexicographic order of points, a union-find over
// patch or surface indices, and compaction of a surface's raw edges.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "lib/iss/blockers.h"

namespace visgate::iss {

inline Vec3d corner_d(const mesh::PreparedMesh& m, uint32_t t, int k) { return to_double(m.corner(t, k)); }

inline bool lex_less(const Vec3d& a, const Vec3d& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

inline int32_t uf_find(std::vector<int32_t>& uf, int32_t i) {
  while (uf[size_t(i)] != i) {
    uf[size_t(i)] = uf[size_t(uf[size_t(i)])];
    i = uf[size_t(i)];
  }
  return i;
}

inline void uf_union(std::vector<int32_t>& uf, int32_t a, int32_t b) {
  a = uf_find(uf, a);
  b = uf_find(uf, b);
  if (a != b) uf[size_t(std::max(a, b))] = std::min(a, b);
}

// Removes raw edges with no neighbour and renumbers the edge references.
void compact_raw(Surface& s, Workspace& ws);

}  // namespace visgate::iss
