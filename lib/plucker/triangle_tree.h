// A bounding-volume hierarchy over the scene's triangles for occluder selection (paper
// 002 section 4.4, implementation details: Haines' shaft per receiver group and light).
// Without it every group tested every triangle against its shaft: on `rooms` (26k
// triangles, 27 lights, 64 groups) that was 45M shaft tests per solve.
//
// Guarantee: conservative. A node is skipped only when Shaft::culls_box says its box
// misses the shaft; the box translated to a light's local frame (coordinates relative to
// an origin, rounded once per corner) still contains every triangle vertex translated and
// rounded the same way, because rounding is monotonic (fl(lo - o) <= fl(v - o) for
// lo <= v). So the triangles reported are a superset of those the per-triangle test
// keeps, and they are reported in increasing index order (the order of a plain scan, so
// the solver's results do not depend on the tree).
#pragma once

#include <cstdint>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/plucker/shaft.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

class TriangleTree {
 public:
  explicit TriangleTree(const TriangleSoup& mesh);

  // Appends to `out` (cleared first), in increasing order, the index of every triangle
  // whose leaf box is not culled by the shaft; the shaft is in local coordinates
  // relative to `origin`. Callers still test each triangle.
  void candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out) const;

  size_t node_count() const { return nodes_.size(); }
  size_t memory_bytes() const {
    return nodes_.capacity() * sizeof(Node) + index_.capacity() * sizeof(uint32_t) + quads_.capacity() * sizeof(Quad);
  }

  // Coplanar pairs for occluder merging (plucker_solver.cpp shade_group). Two triangles
  // that share an edge (the same two vertex positions, exactly), lie exactly in one plane
  // (orient3d exact) and form a strictly convex quadrilateral (exact 2D orientations in
  // the plane's dominant projection, which preserves them for coplanar points) block
  // exactly the segments their union, that quadrilateral, blocks: one convex occluder of
  // 4 edges for two of 3, without the shared diagonal, whose node planes cut fragments
  // that come out visible on both sides (the surfaces of columns, rooms and most meshes
  // are made of such pairs). Matched greedily in triangle order, each triangle in at most
  // one pair. Empty meshes and meshes without pairs store nothing.
  int32_t partner(uint32_t t) const { return quads_.empty() ? -1 : quads_[t].partner; }
  // For t with a partner: the quadrilateral's corners, in the orientation of one of the
  // two (the same for both).
  void quad(const TriangleSoup& mesh, uint32_t t, Vec3f out[4]) const;

 private:
  void find_quads(const TriangleSoup& mesh);
  struct Node {
    AABB box;
    uint32_t first = 0;  // leaf: first index in index_; inner: right child (left is this + 1)
    uint32_t count = 0;  // leaf: triangle count; inner: 0
  };
  std::vector<Node> nodes_;
  std::vector<uint32_t> index_;
  struct Quad {
    int32_t partner = -1;
    uint8_t edge = 0;  // the shared edge is t's corners edge, edge + 1
    uint8_t apex = 0;  // the partner's corner off that edge
    bool base = false; // edge and apex are as seen from this triangle (else from the partner)
  };
  std::vector<Quad> quads_;  // empty when no pair exists
};

}  // namespace visgate::plucker
