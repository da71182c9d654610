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
  size_t memory_bytes() const { return nodes_.capacity() * sizeof(Node) + index_.capacity() * sizeof(uint32_t); }

 private:
  struct Node {
    AABB box;
    uint32_t first = 0;  // leaf: first index in index_; inner: right child (left is this + 1)
    uint32_t count = 0;  // leaf: triangle count; inner: 0
  };
  std::vector<Node> nodes_;
  std::vector<uint32_t> index_;
};

}  // namespace visgate::plucker
