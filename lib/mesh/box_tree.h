// A bounding-volume hierarchy over closed double-precision boxes, for the candidate
// pairs of mesh repair (self-intersection pairs, T-junction vertex/edge pairs). Boxes are
// min/max of input coordinates, which is exact, and the overlap test compares them
// exactly, so no overlapping pair is ever missed (the tree is a filter; every decision is
// made afterwards by an exact predicate).
#pragma once

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

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
  explicit BoxTree(const std::vector<Box3d>& boxes) : boxes_(boxes) {
    idx_.resize(boxes.size());
    std::iota(idx_.begin(), idx_.end(), 0u);
    centers_.resize(boxes.size());
    for (size_t i = 0; i < boxes.size(); ++i) centers_[i] = (boxes[i].lo + boxes[i].hi) * 0.5;
    if (!boxes.empty()) {
      nodes_.reserve(4 * boxes.size() / kLeaf + 2);
      build(0, uint32_t(boxes.size()));
    }
  }

  // f(i) for every box i overlapping q.
  template <class F>
  void query(const Box3d& q, F&& f) const {
    if (nodes_.empty()) return;
    std::vector<uint32_t> stack{0};
    while (!stack.empty()) {
      const Node& n = nodes_[stack.back()];
      stack.pop_back();
      if (!boxes_overlap(n.box, q)) continue;
      if (n.count > 0) {
        for (uint32_t i = n.first; i < n.first + n.count; ++i)
          if (boxes_overlap(boxes_[idx_[i]], q)) f(idx_[i]);
      } else {
        stack.push_back(n.first);
        stack.push_back(n.second);
      }
    }
  }

  // f(i, j) once for every unordered pair i != j of overlapping boxes.
  template <class F>
  void self_pairs(F&& f) const {
    if (nodes_.empty()) return;
    std::vector<std::pair<uint32_t, uint32_t>> stack{{0, 0}};
    while (!stack.empty()) {
      auto [a, b] = stack.back();
      stack.pop_back();
      const Node& na = nodes_[a];
      const Node& nb = nodes_[b];
      if (a == b) {
        if (na.count > 0) {
          for (uint32_t i = na.first; i < na.first + na.count; ++i)
            for (uint32_t j = i + 1; j < na.first + na.count; ++j)
              if (boxes_overlap(boxes_[idx_[i]], boxes_[idx_[j]])) f(idx_[i], idx_[j]);
        } else {
          stack.push_back({na.first, na.first});
          stack.push_back({na.second, na.second});
          stack.push_back({na.first, na.second});
        }
        continue;
      }
      if (!boxes_overlap(na.box, nb.box)) continue;
      if (na.count > 0 && nb.count > 0) {
        for (uint32_t i = na.first; i < na.first + na.count; ++i)
          for (uint32_t j = nb.first; j < nb.first + nb.count; ++j)
            if (boxes_overlap(boxes_[idx_[i]], boxes_[idx_[j]])) f(idx_[i], idx_[j]);
      } else if (nb.count > 0 || (na.count == 0 && size_of(na) >= size_of(nb))) {
        stack.push_back({na.first, b});
        stack.push_back({na.second, b});
      } else {
        stack.push_back({a, nb.first});
        stack.push_back({a, nb.second});
      }
    }
  }

 private:
  static constexpr uint32_t kLeaf = 4;
  struct Node {
    Box3d box;
    uint32_t first = 0;   // leaf: first index into idx_; inner: left child
    uint32_t second = 0;  // inner: right child
    uint32_t count = 0;   // leaf: number of boxes; inner: 0
    uint32_t size = 0;   // boxes below
  };
  static uint32_t size_of(const Node& n) { return n.size; }

  uint32_t build(uint32_t begin, uint32_t end) {
    uint32_t id = uint32_t(nodes_.size());
    nodes_.push_back(Node{});
    Box3d box = boxes_[idx_[begin]], cbox{centers_[idx_[begin]], centers_[idx_[begin]]};
    for (uint32_t i = begin + 1; i < end; ++i) {
      box.extend(boxes_[idx_[i]]);
      cbox.extend(centers_[idx_[i]]);
    }
    nodes_[id].box = box;
    nodes_[id].size = end - begin;
    if (end - begin <= kLeaf) {
      nodes_[id].first = begin;
      nodes_[id].count = end - begin;
      return id;
    }
    // Median split of the box centres along the axis of largest spread.
    int axis = max_axis(cbox.hi - cbox.lo);
    uint32_t mid = begin + (end - begin) / 2;
    std::nth_element(idx_.begin() + begin, idx_.begin() + mid, idx_.begin() + end, [&](uint32_t x, uint32_t y) {
      return centers_[x][axis] < centers_[y][axis];
    });
    uint32_t left = build(begin, mid);
    uint32_t right = build(mid, end);
    nodes_[id].first = left;
    nodes_[id].second = right;
    nodes_[id].count = 0;
    return id;
  }

  const std::vector<Box3d>& boxes_;
  std::vector<uint32_t> idx_;
  std::vector<Vec3d> centers_;
  std::vector<Node> nodes_;
};

}  // namespace visgate::mesh
