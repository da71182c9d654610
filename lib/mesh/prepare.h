// Mesh preparation exactly as paper 000 section 4.2: weld vertices with equal positions,
// discard triangles with two equal vertices, find neighbours only across edges whose
// facing is consistent, and give every edge a unique label with a double-edge flag.
//
// Edge k of a triangle runs from vertex k to vertex k+1 (mod 3). Two triangles are
// neighbours across an edge iff exactly two triangles use that (undirected) edge and they
// traverse it in opposite directions; the edge then has one label shared by both and is
// a double edge. Every other incidence keeps a label of its own and is a single edge:
// - two triangles traversing the edge in the same direction (opposite facings: the
//   paper's "two identical edges with different edge labels remain at the join");
// - three or more triangles on one edge (non-manifold): none of them are neighbours
//   across it. This is deterministic and conservative: every such edge stays a potential
//   silhouette for the methods that use labels.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "lib/scene/scene.h"

namespace visgate::mesh {

struct PreparedTriangle {
  std::array<uint32_t, 3> v{};           // vertex indices (welded)
  std::array<int32_t, 3> neighbors{-1, -1, -1};  // neighbour across edge k, or -1
  std::array<uint32_t, 3> edge_labels{};  // label of edge k
  uint32_t source = 0;                   // index of the triangle in the input soup
};

struct PreparedMesh {
  std::vector<Vec3f> vertex_pos;
  std::vector<PreparedTriangle> triangles;
  std::vector<uint8_t> is_double_edge;  // per edge label

  size_t edge_count() const { return is_double_edge.size(); }
  Vec3f corner(size_t t, int k) const { return vertex_pos[triangles[t].v[k]]; }
};

struct PrepareCounts {
  size_t input_vertices = 0, welded_vertices = 0;  // welded: vertices merged away
  size_t input_triangles = 0, degenerate_removed = 0;
  size_t double_edges = 0, single_edges = 0;
  size_t inconsistent_joins = 0;  // edges with two same-direction triangles
  size_t nonmanifold_edges = 0;   // edges with three or more triangles
};

// Welds vertices with identical positions (-0 and +0 are equal), in first-use order as
// Figure 4.1 does; unused input vertices are dropped. Returns the number merged away.
size_t weld_vertices(const TriangleSoup& in, std::vector<Vec3f>& pos, std::vector<std::array<uint32_t, 3>>& tris);
// Removes triangles with two equal vertex indices; `source` is filtered alongside.
// Returns the number removed.
size_t remove_degenerate(std::vector<std::array<uint32_t, 3>>& tris, std::vector<uint32_t>& source);
// Fills neighbours, edge labels and double-edge flags; counts what it found. Labels
// follow the order of the undirected edges (smaller index, larger index), then (triangle,
// k). Throws std::length_error past 2^32 / 3 triangles (the labels are 32-bit).
void compute_neighbors_and_labels(PreparedMesh& m, PrepareCounts& counts);

// The whole of section 4.2, in expected time linear in the soup's size (a hash table of
// positions, a counting sort of the edges).
PreparedMesh prepare_mesh(const TriangleSoup& soup, PrepareCounts* counts = nullptr);

// Checks every invariant: indices in range, no repeated vertex in a triangle, no two
// equal vertex positions, neighbour symmetry with opposite traversal and shared label,
// labels in range and used by exactly one triangle (single) or two neighbours (double).
// Returns an empty string when valid, else the first violation.
std::string validate(const PreparedMesh& m);

}  // namespace visgate::mesh
