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
//
// FIND-SPLIT-PLANE (section 4.3): above 1024 points the midpoint of the longest side, as
// in the thesis; otherwise the split between two distinct centres on any axis that
// minimises the thesis's N_left A_left + N_right A_right with two changes. A is the area
// of the box grown by the point spacing (tree.cpp: no strips of collinear points), and
// each side's term is multiplied by (1 + B_side), B_side the number of the node's large
// inside triangles (box at least half the node's extent on an axis where the node has
// extent) whose box meets that side's box. Section 4.4.2 excludes a triangle that meets
// a node from every blocker surface of that node's shafts, so a node with points on
// both sides of a wall never has a shaft blocked by that wall; the factor makes splits
// follow walls (on rooms both faces of a wall: the receivers buried in the wall become
// nodes of their own, whose shafts the wall's faces block). The thesis notes that no
// work went into this metric and that better ones may exist. Only the tree's shape
// depends on it, never a guarantee.
#pragma once

#include <cstdint>
#include <deque>
#include <utility>
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
  // Extension of section 4.12 (filled lazily by the traversal, empty_shaft.cpp): when
  // every inside triangle has all of the node's points on one closed side of its plane,
  // `sides` holds those planes oriented so that the points are on the non-positive side,
  // `flat` those that contain every point (within the tolerance); sides_state 0 = not
  // computed, 1 = some triangle has points strictly on both sides, 2 = all one-sided.
  uint8_t sides_state = 0;
  std::vector<ConservativePlane> sides, flat;

  uint32_t size() const { return end - begin; }
  bool split_done() const { return left >= 0; }
  bool contains_triangle(uint32_t t) const;
};

class PointTree {
 public:
  // `boxes[i]` is the box of point i, `centers[i]` its split position. The root's
  // inside list is filtered from `root_candidates` (sorted; every triangle whose box
  // meets the root box must be in it) or, when null, from every triangle.
  PointTree(std::vector<AABB> boxes, std::vector<Vec3f> centers, int max_points_in_leaf,
            const mesh::PreparedMesh& mesh, const std::vector<AABB>& triangle_boxes,
            const std::vector<uint32_t>* root_candidates = nullptr, int packet_order_max = 0);
  // Box of a set of point boxes (the root box a tree over them will have).
  static AABB bounds_of(const std::vector<AABB>& boxes);

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
  // Nodes of at most this many points get their points ordered for Embree packets
  // (order_for_packets), as every leaf does: the traversal may treat a node above the
  // leaf size as a leaf (light_split, traversal.h) and cast its rays as one fan, and an
  // unordered fan cost 14% more Embree instructions on rooms. Never below max_leaf_.
  int packet_max_;
  const mesh::PreparedMesh& mesh_;
  const std::vector<AABB>& tri_boxes_;
  std::vector<AABB> scratch_pre_, scratch_suf_;
  std::vector<uint32_t> scratch_cl_, scratch_cr_, big_, scratch_axis_ord_[3];
  std::vector<std::pair<float, uint32_t>> scratch_keyed_;
  size_t list_bytes_ = 0;
};

}  // namespace visgate::iss
