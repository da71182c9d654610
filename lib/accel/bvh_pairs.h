// Pairs of overlapping item boxes in one hierarchy (lib/accel/bvh.h), by a dual
// traversal: the candidate pairs of mesh repair (self-intersections, lib/mesh/box_tree.h).
// The tree must keep its item boxes (BuildRule::item_boxes).
//
// Guarantee: every unordered pair of distinct items whose closed boxes overlap is
// reported exactly once, no other pair; a pair of node boxes is skipped only when the
// boxes are disjoint, which is exact. The serial order is fixed by the tree; the parallel
// traversal reports the same pairs in an order that depends on the scheduling.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "lib/accel/bvh.h"

namespace visgate::accel {

namespace pairs_detail {

using NodePair = std::pair<uint32_t, uint32_t>;

// The dual traversal with the tree's arrays held in locals: the callback cannot change
// them, so the leaf scans need not reload them after every call.
template <class T, class F>
struct PairWalk {
  using Node = typename Bvh<T>::Node;
  const Bvh<T>& t;
  const AABBT<T>* box;    // item boxes in leaf order
  const uint32_t* item;   // leaf order -> item
  uint32_t leaf_size;
  F& f;

  PairWalk(const Bvh<T>& tree, F& fn)
      : t(tree), box(tree.item_boxes().data()), item(tree.order().data()), leaf_size(tree.leaf_size()), f(fn) {}

  bool is_leaf(const Node& n) const { return n.count <= leaf_size; }

  void leaf_pairs(const Node& na, const Node& nb, bool same) const {
    for (uint32_t i = na.first; i < na.first + na.count; ++i) {
      const AABBT<T> bi = box[i];
      for (uint32_t j = same ? i + 1 : nb.first; j < nb.first + nb.count; ++j)
        if (bi.overlaps(box[j])) f(item[i], item[j]);
    }
  }

  // One step for node pair (a, b): leaf pairs are reported, other pairs push their
  // children pairs onto `out` (the larger node is split). True when it pushed anything.
  bool expand(uint32_t a, uint32_t b, std::vector<NodePair>& out) const {
    const Node& na = t.node(a);
    const Node& nb = t.node(b);
    if (a == b) {
      if (is_leaf(na)) {
        leaf_pairs(na, na, true);
        return false;
      }
      out.push_back({a + 1, a + 1});
      out.push_back({na.first, na.first});
      out.push_back({a + 1, na.first});
      return true;
    }
    if (!na.box.overlaps(nb.box)) return false;
    const bool la = is_leaf(na), lb = is_leaf(nb);
    if (la && lb) {
      leaf_pairs(na, nb, false);
      return false;
    }
    if (lb || (!la && na.count >= nb.count)) {
      out.push_back({a + 1, b});
      out.push_back({na.first, b});
    } else {
      out.push_back({a, b + 1});
      out.push_back({a, nb.first});
    }
    return true;
  }

  void traverse(std::vector<NodePair>& stack) const {
    while (!stack.empty()) {
      const auto [a, b] = stack.back();
      stack.pop_back();
      expand(a, b, stack);
    }
  }
};

}  // namespace pairs_detail

// f(i, j) once for every unordered pair i != j of items with overlapping boxes.
template <class T, class F>
void self_pairs(const Bvh<T>& t, F&& f) {
  if (t.empty()) return;
  std::vector<pairs_detail::NodePair> stack{{0, 0}};
  pairs_detail::PairWalk<T, F>(t, f).traverse(stack);
}

// The same pairs, f(local, i, j) called concurrently from TBB worker threads with
// local = locals.local() of the calling thread. The top of the traversal is expanded
// breadth first into independent node pairs, which the workers then traverse depth first.
template <class T, class Local, class F>
void self_pairs_parallel(const Bvh<T>& t, tbb::enumerable_thread_specific<Local>& locals, F&& f) {
  if (t.empty()) return;
  std::vector<pairs_detail::NodePair> frontier{{0, 0}}, next;
  {
    Local& mine = locals.local();
    auto g = [&](uint32_t i, uint32_t j) { f(mine, i, j); };
    const pairs_detail::PairWalk<T, decltype(g)> walk(t, g);
    while (frontier.size() < 4096) {
      next.clear();
      bool grew = false;
      for (auto [a, b] : frontier)
        if (walk.expand(a, b, next)) grew = true;
      frontier.swap(next);
      if (!grew) break;
    }
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
    Local& mine = locals.local();
    auto g = [&](uint32_t i, uint32_t j) { f(mine, i, j); };
    const pairs_detail::PairWalk<T, decltype(g)> walk(t, g);
    std::vector<pairs_detail::NodePair> stack;
    for (size_t i = r.begin(); i < r.end(); ++i) {
      stack.assign(1, frontier[i]);
      walk.traverse(stack);
    }
  });
}

}  // namespace visgate::accel
