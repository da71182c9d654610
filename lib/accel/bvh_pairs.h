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

template <class T, class F>
void leaf_pairs(const Bvh<T>& t, const typename Bvh<T>::Node& na, const typename Bvh<T>::Node& nb, bool same, F& f) {
  for (uint32_t i = na.first; i < na.first + na.count; ++i)
    for (uint32_t j = same ? i + 1 : nb.first; j < nb.first + nb.count; ++j)
      if (t.item_box(i).overlaps(t.item_box(j))) f(t.item(i), t.item(j));
}

// One step of the dual traversal of node pair (a, b): leaf pairs are reported, other
// pairs push their children pairs onto `out` (the larger node is split). Returns true
// when it pushed anything.
template <class T, class F>
bool expand(const Bvh<T>& t, uint32_t a, uint32_t b, std::vector<NodePair>& out, F& f) {
  const auto& na = t.node(a);
  const auto& nb = t.node(b);
  if (a == b) {
    if (t.is_leaf(na)) {
      leaf_pairs(t, na, na, true, f);
      return false;
    }
    out.push_back({t.left(a), t.left(a)});
    out.push_back({t.right(a), t.right(a)});
    out.push_back({t.left(a), t.right(a)});
    return true;
  }
  if (!na.box.overlaps(nb.box)) return false;
  if (t.is_leaf(na) && t.is_leaf(nb)) {
    leaf_pairs(t, na, nb, false, f);
    return false;
  }
  if (t.is_leaf(nb) || (!t.is_leaf(na) && na.count >= nb.count)) {
    out.push_back({t.left(a), b});
    out.push_back({t.right(a), b});
  } else {
    out.push_back({a, t.left(b)});
    out.push_back({a, t.right(b)});
  }
  return true;
}

template <class T, class F>
void traverse(const Bvh<T>& t, std::vector<NodePair>& stack, F& f) {
  while (!stack.empty()) {
    const auto [a, b] = stack.back();
    stack.pop_back();
    expand(t, a, b, stack, f);
  }
}

}  // namespace pairs_detail

// f(i, j) once for every unordered pair i != j of items with overlapping boxes.
template <class T, class F>
void self_pairs(const Bvh<T>& t, F&& f) {
  if (t.empty()) return;
  std::vector<pairs_detail::NodePair> stack{{0, 0}};
  pairs_detail::traverse(t, stack, f);
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
    while (frontier.size() < 4096) {
      next.clear();
      bool grew = false;
      for (auto [a, b] : frontier)
        if (pairs_detail::expand(t, a, b, next, g)) grew = true;
      frontier.swap(next);
      if (!grew) break;
    }
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
    Local& mine = locals.local();
    auto g = [&](uint32_t i, uint32_t j) { f(mine, i, j); };
    std::vector<pairs_detail::NodePair> stack;
    for (size_t i = r.begin(); i < r.end(); ++i) {
      stack.assign(1, frontier[i]);
      pairs_detail::traverse(t, stack, g);
    }
  });
}

}  // namespace visgate::accel
