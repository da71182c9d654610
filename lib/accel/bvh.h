// One bounding-volume hierarchy over axis-aligned boxes (float or double), shared by the
// methods' and the repair's acceleration queries: ISS's box and shaft queries over the
// triangle boxes (lib/iss/triangle_bvh.h, paper 000 sections 4.3 and 4.8), Plücker's
// occluder candidates per shaft (lib/plucker/triangle_tree.h, paper 002 section 4.4) and
// repair's candidate pairs (lib/mesh/box_tree.h, with lib/accel/bvh_pairs.h).
//
// Shape: every inner node halves its items, the left child taking floor(n / 2), down to
// leaves of at most leaf_size items. The shape thus depends on the item count and the leaf
// size only; the build rule decides which items go left:
//  - Split::MortonHalves: one stable radix sort of the box centres' Morton codes (10 bits
//    per axis over the centres' box), then halving of that order. Linear time.
//  - Split::MedianAxis: at each node, the median of the centres on the axis of their
//    largest spread, ties broken by item index (so the halves, and the order in which
//    nth_element leaves each range, depend on the keys only). O(n log n), tighter boxes.
// A centre is computed in T and rounded to float: it only orders the items.
//
// Guarantee: a node's box is the exact union (min/max) of its items' boxes, so a
// traversal whose predicate is conservative (true for every box that contains a box the
// caller wants) reaches every wanted item. Items come back in traversal order (right
// subtree first); callers needing index order sort. Boxes must not hold NaN (the scene
// and mesh readers reject it): min/max unions would drop or keep it by argument order.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "lib/base/check.h"
#include "lib/geom/aabb.h"

namespace visgate::accel {

enum class Split : uint8_t {
  MortonHalves,  // ISS: cheap to build once per solve
  MedianAxis,    // Plücker (many shaft queries per build) and repair (pair traversals)
};

// Where the users differ. item_boxes keeps a copy of every item's box in leaf order, for
// queries and pair traversals that test items (item_box()); off, they are not stored.
struct BuildRule {
  Split split = Split::MedianAxis;
  uint32_t leaf_size = 4;
  bool item_boxes = false;
};

template <class T>
class Bvh {
 public:
  using Box = AABBT<T>;
  // Pre-order layout: the left child of inner node i is i + 1.
  struct Node {
    Box box;
    uint32_t first = 0;  // leaf: first position in leaf order; inner: the right child
    uint32_t count = 0;  // items below (a leaf iff count <= leaf_size)
  };
  // Deep enough for any uint32 item count: halving gives depth <= 33, and a depth-first
  // traversal that pushes both children holds at most depth + 1 nodes.
  static constexpr size_t kMaxStack = 64;

  Bvh() = default;
  // boxes[i] is item i's box; boxes need not outlive the tree.
  Bvh(const std::vector<Box>& boxes, const BuildRule& rule);

  // The tree restricted to some of its items: keep[item] is the item's index in the new
  // tree, or kDropped. The leaf order is src's with the dropped items left out; empty
  // subtrees are pruned, a node left with one nonempty child is replaced by that child,
  // and a subtree left with at most leaf_size items becomes one leaf (its items in src's
  // leaf order). A node that keeps all its items keeps its box (the same bits); the
  // others take the union of their children's new boxes, and a changed leaf the union
  // of box_of(new item) over its items in order, so every box is still the exact union
  // (min/max) of its items' boxes when box_of gives the boxes src was built on. The
  // halving shape above no longer holds (inner nodes have more than leaf_size items,
  // leaves at most leaf_size, pre-order layout, depth at most src's). Linear in src's
  // nodes; with nothing dropped, a copy. item_boxes are not kept.
  static constexpr uint32_t kDropped = UINT32_MAX;
  static Bvh restricted(const Bvh& src, std::span<const uint32_t> keep, const std::function<Box(uint32_t)>& box_of);

  bool empty() const { return nodes_.empty(); }
  size_t node_count() const { return nodes_.size(); }
  size_t item_count() const { return order_.size(); }
  // Nodes, item order and (if kept) item boxes.
  size_t memory_bytes() const {
    return nodes_.size() * sizeof(Node) + order_.size() * sizeof(uint32_t) + item_boxes_.size() * sizeof(Box);
  }

  const Node& node(uint32_t i) const { return nodes_[i]; }
  bool is_leaf(const Node& n) const { return n.count <= leaf_size_; }
  uint32_t left(uint32_t i) const { return i + 1; }
  uint32_t right(uint32_t i) const { return nodes_[i].first; }
  // The item at a leaf-order position, and its box (BuildRule::item_boxes only).
  uint32_t item(uint32_t pos) const { return order_[pos]; }
  const Box& item_box(uint32_t pos) const { return item_boxes_[pos]; }
  std::span<const uint32_t> leaf_items(const Node& leaf) const { return {order_.data() + leaf.first, leaf.count}; }
  // Whole arrays, for traversals that keep them in locals (bvh_pairs.h).
  uint32_t leaf_size() const { return leaf_size_; }
  std::span<const uint32_t> order() const { return order_; }
  std::span<const Box> item_boxes() const { return item_boxes_; }

  // leaf(node) for every leaf whose box, and every ancestor's box, passes enter(box).
  template <class Enter, class Leaf>
  void for_each_leaf(Enter&& enter, Leaf&& leaf) const {
    walk([&](const Box& b, bool) { return enter(b); },
         [&](const Node& nd) {
           leaf(nd);
           return false;
         });
  }
  // for_each_leaf's traversal (the same order) with each node's leafness passed to
  // enter(box, is_leaf), until leaf(node) returns true.
  template <class Enter, class Leaf>
  void walk(Enter&& enter, Leaf&& leaf) const {
    if (nodes_.empty()) return;
    std::array<uint32_t, kMaxStack> stack;
    size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const uint32_t i = stack[--top];
      const Node& nd = nodes_[i];
      const bool is_leaf_node = is_leaf(nd);
      if (!enter(nd.box, is_leaf_node)) continue;
      if (is_leaf_node) {
        if (leaf(nd)) return;
        continue;
      }
      stack[top++] = i + 1;
      stack[top++] = nd.first;
    }
  }

  // f(item) for every item whose box passes may_meet and lies in a leaf reached with it
  // (BuildRule::item_boxes only).
  template <class Pred, class F>
  void query_if(Pred&& may_meet, F&& f) const {
    for_each_leaf(may_meet, [&](const Node& nd) {
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k)
        if (may_meet(item_boxes_[k])) f(order_[k]);
    });
  }

 private:
  struct Key;

  uint32_t leaf_size_ = 1;
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;  // leaf order -> item
  std::vector<Box> item_boxes_;  // leaf order; empty unless BuildRule::item_boxes
};

extern template class Bvh<float>;
extern template class Bvh<double>;

}  // namespace visgate::accel
