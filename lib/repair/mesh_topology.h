// Combinatorial structure of a triangle mesh for repair (internal to lib/repair): the
// edge table, neighbours across two-face edges, boundary loops, vertex fans and duplicate
// faces. Decided on vertex indices alone, so exact by construction.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

#include "lib/base/union_find.h"

namespace visgate::mesh {

constexpr uint32_t kNone = 0xffffffffu;
using Tri = std::array<uint32_t, 3>;

// The key of the undirected edge {a, b}: (min << 32) | max.
inline uint64_t edge_key(uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a); }

// ---------------------------------------------------------------------------------------
// Edge table: every (undirected) edge of the active triangles, grouped.

struct EdgeRec {
  uint64_t key;   // edge_key of its ends
  uint32_t tri;
  uint8_t k;      // edge k runs from corner k to corner k+1
  uint8_t fwd;    // 1 when the triangle traverses it from min to max
};

struct EdgeTable {
  std::vector<EdgeRec> recs;      // sorted by key, then triangle
  std::vector<uint32_t> start;    // group g is recs[start[g], start[g+1])
  std::vector<uint32_t> tri_edge;  // 3t + k -> group, kNone for inactive triangles

  size_t groups() const { return start.empty() ? 0 : start.size() - 1; }
  uint32_t size(size_t g) const { return start[g + 1] - start[g]; }
  uint32_t lo(size_t g) const { return uint32_t(recs[start[g]].key >> 32); }
  uint32_t hi(size_t g) const { return uint32_t(recs[start[g]].key & 0xffffffffu); }
};

// The edges of the triangles with (*active)[t] set (all when `active` is null).
EdgeTable build_edges(const std::vector<Tri>& tris, const std::vector<uint8_t>* active, size_t nverts);

// Neighbour across each edge of a triangle when exactly two triangles use it (kNone
// otherwise), and whether the two traverse it in the same direction.
struct Adjacency {
  std::vector<uint32_t> nb;   // 3t + k
  std::vector<uint8_t> same;  // 3t + k
};

Adjacency build_adjacency(const EdgeTable& e, size_t ntris);

// ---------------------------------------------------------------------------------------
// Boundary loops: walks of the boundary edges (edges with one face), undirected so that
// loops of non-orientable patches are found too.

struct Loop {
  std::vector<uint32_t> verts;   // closed: edge i joins verts[i] and verts[i+1 mod n]
  std::vector<uint32_t> groups;  // edge group of edge i
  bool closed = true;            // false: a chain that ended at a dead end
};

std::vector<Loop> boundary_loops(const EdgeTable& e);

// Fans around vertices: corners (3t + k) joined across two-face edges at their shared
// vertex. A vertex with more than one fan is non-manifold (a bowtie), and so is every end
// of a non-manifold edge (faces across it are never joined).
UnionFind corner_fans(const std::vector<Tri>& tris, const EdgeTable& e);

// ---------------------------------------------------------------------------------------
// Duplicate faces.

// Sorted vertex triple, the key of duplicate detection.
inline std::array<uint32_t, 3> sorted3(const Tri& t) {
  std::array<uint32_t, 3> s = t;
  std::sort(s.begin(), s.end());
  return s;
}
// Same cyclic order (same orientation) for two triangles on the same vertex set.
inline bool same_orientation(const Tri& a, const Tri& b) {
  for (int r = 0; r < 3; ++r)
    if (a[0] == b[size_t(r)] && a[1] == b[size_t((r + 1) % 3)] && a[2] == b[size_t((r + 2) % 3)]) return true;
  return false;
}

// Marks later copies of an active face: dup[t] = 1 (same orientation as the first),
// 2 (opposite), 0 otherwise.
std::vector<uint8_t> find_duplicates(const std::vector<Tri>& tris, const std::vector<uint8_t>& active, size_t nverts);

}  // namespace visgate::mesh
