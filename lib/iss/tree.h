// Receiver point and light sample trees of the ISS algorithm (paper 000 section 4.3,
// Figure 4.2), built lazily: SPLIT-NODE runs the first time a traversal needs a node's
// children. Points are kept in one permuted index array so that every node covers a
// contiguous range (no per-node point lists to copy). Each point has a box: a receiver's
// is the point itself, a light sample's is its jitter box (section 4.11); splits use box
// centres, node bounds are the union of the point boxes.
//
// Triangle bookkeeping: `inside` lists (sorted) every triangle that may intersect the
// node (conservative triangle_overlaps_aabb, filtered from the parent's list, so a
// triangle that touches a node is always in its list); `gone` lists the parent's
// triangles that do not intersect the node. Unlike Figure 4.2 the inside lists are kept
// after a split: sub-shaft construction asks "is this triangle in the other node" by
// membership rather than by re-testing geometry, which keeps the exclusion rule of
// section 4.4.2 exactly consistent with the gone lists.
#pragma once

#include <cstdint>
#include <deque>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/iss/shaft.h"
#include "lib/mesh/prepare.h"

namespace visgate::iss {

struct TreeNode {
  AABB box;
  int32_t left = -1, right = -1, parent = -1;
  uint32_t begin = 0, end = 0;  // range in PointTree::order
  std::vector<uint32_t> inside;  // sorted triangle indices that may intersect the node
  std::vector<uint32_t> gone;    // parent's triangles that do not intersect this node
  bool is_leaf = false;          // a real leaf: never split
  bool had_triangles = false;    // inside was non-empty (section 4.12)
  // Extension of section 4.12 (filled lazily by the traversal, iss_solver.cpp): when
  // every inside triangle has all of the node's points on one closed side of its plane,
  // `sides` holds those planes oriented so that the points are on the non-positive side,
  // `flat` those that contain every point (within the tolerance); sides_state 0 = not
  // computed, 1 = some triangle has points strictly on both sides, 2 = all one-sided.
  uint8_t sides_state = 0;
  std::vector<Plane4d> sides, flat;

  uint32_t size() const { return end - begin; }
  bool split_done() const { return left >= 0; }
  bool contains_triangle(uint32_t t) const;
};

class PointTree {
 public:
  // `boxes[i]` is the box of point i, `centers[i]` its split position.
  PointTree(std::vector<AABB> boxes, std::vector<Vec3f> centers, int max_points_in_leaf,
            const mesh::PreparedMesh& mesh, const std::vector<AABB>& triangle_boxes);

  TreeNode& node(int i) { return nodes_[size_t(i)]; }
  const TreeNode& node(int i) const { return nodes_[size_t(i)]; }
  int root() const { return 0; }
  // SPLIT-NODE (Figure 4.2). No-op for real leaves and already split nodes.
  void split(int i);
  const std::vector<uint32_t>& order() const { return order_; }
  size_t node_count() const { return nodes_.size(); }
  size_t memory_bytes() const;

 private:
  void finish_node(TreeNode& n, const std::vector<uint32_t>& parent_triangles);

  std::vector<AABB> boxes_;
  std::vector<Vec3f> centers_;
  std::vector<uint32_t> order_;
  std::deque<TreeNode> nodes_;
  int max_leaf_;
  const mesh::PreparedMesh& mesh_;
  const std::vector<AABB>& tri_boxes_;
  std::vector<double> scratch_area_;
  size_t list_bytes_ = 0;
};

}  // namespace visgate::iss
