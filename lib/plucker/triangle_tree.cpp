// Triangle hierarchy for occluder selection; see triangle_tree.h.
#include "lib/plucker/triangle_tree.h"

#include <algorithm>

#include "lib/geom/check.h"

namespace visgate::plucker {

namespace {
constexpr uint32_t kLeafSize = 4;
}

TriangleTree::TriangleTree(const TriangleSoup& mesh) {
  const size_t n = mesh.size();
  index_.resize(n);
  std::vector<AABB> tri_box(n);
  std::vector<Vec3f> centre(n);
  for (size_t t = 0; t < n; ++t) {
    index_[t] = uint32_t(t);
    AABB b;
    for (int k = 0; k < 3; ++k) b.extend(mesh.corner(t, k));
    tri_box[t] = b;
    centre[t] = (b.lo + b.hi) * 0.5f;
  }
  if (n == 0) return;
  nodes_.reserve(2 * (n / kLeafSize + 1));
  // Median split on the longest axis of the centres, built with an explicit stack of
  // (node, first, count).
  struct Item {
    uint32_t node, first, count;
  };
  std::vector<Item> stack;
  nodes_.emplace_back();
  stack.push_back({0, 0, uint32_t(n)});
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    AABB box, cbox;
    for (uint32_t k = it.first; k < it.first + it.count; ++k) {
      box.extend(tri_box[index_[k]]);
      cbox.extend(centre[index_[k]]);
    }
    nodes_[it.node].box = box;
    if (it.count <= kLeafSize) {
      nodes_[it.node].first = it.first;
      nodes_[it.node].count = it.count;
      continue;
    }
    int axis = max_axis(cbox.extent());
    uint32_t half = it.count / 2;
    auto b = index_.begin() + it.first;
    std::nth_element(b, b + half, b + it.count, [&](uint32_t x, uint32_t y) {
      float cx = centre[x][axis], cy = centre[y][axis];
      return cx < cy || (cx == cy && x < y);
    });
    uint32_t left = uint32_t(nodes_.size());
    nodes_.emplace_back();
    uint32_t right = uint32_t(nodes_.size());
    nodes_.emplace_back();
    // Inner node: first = right child, the left child is right - 1.
    nodes_[it.node].first = right;
    nodes_[it.node].count = 0;
    stack.push_back({right, it.first + half, it.count - half});
    stack.push_back({left, it.first, half});
  }
}

void TriangleTree::candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& nd = nodes_[stack[--top]];
    if (shaft.culls_box(nd.box.lo - origin, nd.box.hi - origin)) continue;
    if (nd.count > 0) {
      out.insert(out.end(), index_.begin() + nd.first, index_.begin() + nd.first + nd.count);
      continue;
    }
    VG_CHECK(top + 2 <= 64);  // median splits: depth <= log2(n) + 1
    stack[top++] = nd.first;      // right
    stack[top++] = nd.first - 1;  // left
  }
  std::sort(out.begin(), out.end());
}

}  // namespace visgate::plucker
