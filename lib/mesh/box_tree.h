// A bounding-volume hierarchy over closed double-precision boxes, for the candidate
// pairs of mesh repair (self-intersection pairs, T-junction vertex/edge pairs). Boxes are
// min/max of input coordinates, which is exact, and the overlap test compares them
// exactly, so no overlapping pair is ever missed (the tree is a filter; every decision is
// made afterwards by an exact predicate).
//
// Median split of the box centres on the axis of largest spread, four boxes per leaf.
// The build and self_pairs_parallel run on TBB; node numbering and leaf order do not
// depend on the thread count, so neither do the pairs reported.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <numeric>
#include <utility>
#include <vector>

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

#include "lib/geom/vec.h"

namespace visgate::mesh {

struct Box3d {
  Vec3d lo, hi;
  void extend(const Vec3d& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  void extend(const Box3d& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
};

inline bool boxes_overlap(const Box3d& a, const Box3d& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

class BoxTree {
 public:
  explicit BoxTree(const std::vector<Box3d>& boxes) {
    const uint32_t n = uint32_t(boxes.size());
    if (n == 0) return;
    // Split keys: box centres rounded to float (they only steer the split; every box
    // keeps its exact bounds), packed with the index so that the partitioning moves
    // small records in place.
    std::vector<Item> items(n);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1 << 14), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i < r.end(); ++i) {
        const Vec3d c = (boxes[i].lo + boxes[i].hi) * 0.5;
        items[i] = Item{{float(c.x), float(c.y), float(c.z)}, i};
      }
    });
    std::map<uint32_t, uint32_t> memo;
    nodes_.resize(subtree_nodes(n, memo));
    build(boxes, items, 0, n, 0, memo);
    idx_.resize(n);
    leaf_boxes_.resize(n);
    tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, 1 << 14), [&](const tbb::blocked_range<uint32_t>& r) {
      for (uint32_t i = r.begin(); i < r.end(); ++i) {
        idx_[i] = items[i].idx;
        leaf_boxes_[i] = boxes[items[i].idx];  // leaf order: leaf scans read memory in sequence
      }
    });
  }

  // f(i) for every box i with may_meet(box i), visiting only nodes with may_meet(node
  // box). may_meet must be conservative: true for every box that holds a wanted element
  // and for every box containing such a box.
  template <class Pred, class F>
  void query_if(Pred&& may_meet, F&& f) const {
    if (nodes_.empty()) return;
    std::array<uint32_t, 2 * kMaxDepth> stack;
    size_t top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& nd = nodes_[stack[--top]];
      if (!may_meet(nd.box)) continue;
      if (nd.count > 0) {
        for (uint32_t i = nd.first; i < nd.first + nd.count; ++i)
          if (may_meet(leaf_boxes_[i])) f(idx_[i]);
      } else {
        stack[top++] = nd.first;
        stack[top++] = nd.second;
      }
    }
  }

  // f(i) for every box i overlapping q.
  template <class F>
  void query(const Box3d& q, F&& f) const {
    query_if([&](const Box3d& b) { return boxes_overlap(b, q); }, f);
  }

  // f(i, j) once for every unordered pair i != j of overlapping boxes.
  template <class F>
  void self_pairs(F&& f) const {
    if (nodes_.empty()) return;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0, 0}};
    traverse(stack, f);
  }

  // The same pairs, f(local, i, j) called concurrently from TBB worker threads with
  // local = locals.local() of the calling thread. The top of the traversal is expanded
  // breadth first into independent node pairs, which the workers then traverse depth
  // first.
  template <class Local, class F>
  void self_pairs_parallel(tbb::enumerable_thread_specific<Local>& locals, F&& f) const {
    if (nodes_.empty()) return;
    std::vector<std::pair<uint32_t, uint32_t>> frontier{{0, 0}}, next;
    {
      Local& mine = locals.local();
      auto g = [&](uint32_t i, uint32_t j) { f(mine, i, j); };
      while (frontier.size() < 4096) {
        next.clear();
        bool grew = false;
        for (auto [a, b] : frontier)
          if (expand(a, b, next, g)) grew = true;
        frontier.swap(next);
        if (!grew) break;
      }
    }
    tbb::parallel_for(tbb::blocked_range<size_t>(0, frontier.size(), 1), [&](const tbb::blocked_range<size_t>& r) {
      Local& mine = locals.local();
      auto g = [&](uint32_t i, uint32_t j) { f(mine, i, j); };
      std::vector<std::pair<uint32_t, uint32_t>> stack;
      for (size_t i = r.begin(); i < r.end(); ++i) {
        stack.assign(1, frontier[i]);
        traverse(stack, g);
      }
    });
  }

 private:
  static constexpr uint32_t kLeaf = 4;
  static constexpr size_t kMaxDepth = 64;  // median splits: depth <= log2(2^32 / kLeaf) + 1
  struct Node {
    Box3d box;
    uint32_t first = 0;   // leaf: first index into idx_; inner: left child
    uint32_t second = 0;  // inner: right child
    uint32_t count = 0;   // leaf: number of boxes; inner: 0
    uint32_t size = 0;    // boxes below
  };

  // Nodes of the subtree over m boxes (median splits: m/2 rounded down on the left).
  static uint32_t subtree_nodes(uint32_t m, std::map<uint32_t, uint32_t>& memo) {
    if (m <= kLeaf) return 1;
    auto it = memo.find(m);
    if (it != memo.end()) return it->second;
    const uint32_t s = 1 + subtree_nodes(m / 2, memo) + subtree_nodes(m - m / 2, memo);
    memo[m] = s;
    return s;
  }

  struct Item {
    float c[3];
    uint32_t idx;
  };

  // Builds the subtree over items[begin, end) as node `id`; its nodes are id and the
  // following subtree_nodes(end - begin) - 1 slots (left subtree first). Returns its box.
  Box3d build(const std::vector<Box3d>& boxes, std::vector<Item>& items, uint32_t begin, uint32_t end, uint32_t id,
              const std::map<uint32_t, uint32_t>& memo) {
    Node& nd = nodes_[id];
    nd.size = end - begin;
    if (end - begin <= kLeaf) {
      Box3d box = boxes[items[begin].idx];
      for (uint32_t i = begin + 1; i < end; ++i) box.extend(boxes[items[i].idx]);
      nd.box = box;
      nd.first = begin;
      nd.count = end - begin;
      return box;
    }
    // Median split of the centres on the axis of largest spread; ties broken by index,
    // so the split does not depend on nth_element's internals.
    float lo[3] = {items[begin].c[0], items[begin].c[1], items[begin].c[2]}, hi[3] = {lo[0], lo[1], lo[2]};
    for (uint32_t i = begin + 1; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], items[i].c[k]);
        hi[k] = std::max(hi[k], items[i].c[k]);
      }
    const int axis = hi[0] - lo[0] >= hi[1] - lo[1] ? (hi[0] - lo[0] >= hi[2] - lo[2] ? 0 : 2)
                                                      : (hi[1] - lo[1] >= hi[2] - lo[2] ? 1 : 2);
    const uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(items.begin() + begin, items.begin() + mid, items.begin() + end, [axis](const Item& x, const Item& y) {
      return x.c[axis] != y.c[axis] ? x.c[axis] < y.c[axis] : x.idx < y.idx;
    });
    const uint32_t left = id + 1;
    const uint32_t right = left + (mid - begin <= kLeaf ? 1 : memo.at(mid - begin));
    nd.first = left;
    nd.second = right;
    nd.count = 0;
    Box3d bl, br;
    if (end - begin >= (1u << 15)) {
      tbb::parallel_invoke([&] { bl = build(boxes, items, begin, mid, left, memo); },
                           [&] { br = build(boxes, items, mid, end, right, memo); });
    } else {
      bl = build(boxes, items, begin, mid, left, memo);
      br = build(boxes, items, mid, end, right, memo);
    }
    bl.extend(br);
    nodes_[id].box = bl;
    return bl;
  }

  template <class F>
  void leaf_pairs(const Node& na, const Node& nb, bool same, F& f) const {
    for (uint32_t i = na.first; i < na.first + na.count; ++i)
      for (uint32_t j = same ? i + 1 : nb.first; j < nb.first + nb.count; ++j)
        if (boxes_overlap(leaf_boxes_[i], leaf_boxes_[j])) f(idx_[i], idx_[j]);
  }

  // One step of the dual traversal of node pair (a, b): leaf pairs are reported, other
  // pairs push their children pairs onto `out`. Returns true when it pushed anything.
  template <class F>
  bool expand(uint32_t a, uint32_t b, std::vector<std::pair<uint32_t, uint32_t>>& out, F& f) const {
    const Node& na = nodes_[a];
    const Node& nb = nodes_[b];
    if (a == b) {
      if (na.count > 0) {
        leaf_pairs(na, na, true, f);
        return false;
      }
      out.push_back({na.first, na.first});
      out.push_back({na.second, na.second});
      out.push_back({na.first, na.second});
      return true;
    }
    if (!boxes_overlap(na.box, nb.box)) return false;
    if (na.count > 0 && nb.count > 0) {
      leaf_pairs(na, nb, false, f);
      return false;
    }
    if (nb.count > 0 || (na.count == 0 && na.size >= nb.size)) {
      out.push_back({na.first, b});
      out.push_back({na.second, b});
    } else {
      out.push_back({a, nb.first});
      out.push_back({a, nb.second});
    }
    return true;
  }

  template <class F>
  void traverse(std::vector<std::pair<uint32_t, uint32_t>>& stack, F& f) const {
    while (!stack.empty()) {
      auto [a, b] = stack.back();
      stack.pop_back();
      expand(a, b, stack, f);
    }
  }

  std::vector<uint32_t> idx_;
  std::vector<Box3d> leaf_boxes_;  // boxes in leaf order: leaf_boxes_[i] = box idx_[i]
  std::vector<Node> nodes_;
};

}  // namespace visgate::mesh
