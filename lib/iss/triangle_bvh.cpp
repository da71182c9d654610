// Static triangle-box hierarchy for ISS's whole-mesh queries (see triangle_bvh.h).
#include "lib/iss/triangle_bvh.h"

#include <algorithm>
#include <numeric>

namespace visgate::iss {

namespace {

constexpr uint32_t kLeafSize = 8;

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<AABB>& triangle_boxes) : boxes_(triangle_boxes) {
  index_.resize(boxes_.size());
  std::iota(index_.begin(), index_.end(), 0u);
  if (index_.empty()) return;
  nodes_.reserve(2 * (index_.size() / kLeafSize + 1));
  nodes_.push_back(Node{AABB{}, 0, uint32_t(index_.size())});
  // Top-down median splits on the longest axis of the centre box, with an explicit
  // stack of nodes still to be split (count > 0 marks a node holding the range).
  std::vector<uint32_t> stack{0};
  while (!stack.empty()) {
    uint32_t ni = stack.back();
    stack.pop_back();
    uint32_t first = nodes_[ni].first, count = nodes_[ni].count;
    AABB box, centres;
    for (uint32_t k = first; k < first + count; ++k) {
      box.extend(boxes_[index_[k]]);
      centres.extend(boxes_[index_[k]].center());
    }
    nodes_[ni].box = box;
    if (count <= kLeafSize) continue;
    int ax = centres.longest_axis();
    uint32_t mid = first + count / 2;
    std::nth_element(index_.begin() + first, index_.begin() + mid, index_.begin() + first + count,
                     [&](uint32_t a, uint32_t b) {
                       float ca = boxes_[a].lo[ax] + boxes_[a].hi[ax], cb = boxes_[b].lo[ax] + boxes_[b].hi[ax];
                       return ca != cb ? ca < cb : a < b;
                     });
    uint32_t left = uint32_t(nodes_.size());
    nodes_.push_back(Node{AABB{}, first, mid - first});
    nodes_.push_back(Node{AABB{}, mid, first + count - mid});
    nodes_[ni].first = left;
    nodes_[ni].count = 0;
    stack.push_back(left);
    stack.push_back(left + 1);
  }
}

template <class Pred>
void TriangleBvh::collect(Pred&& visit, bool test_leaf_triangles, std::vector<uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  uint32_t stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& n = nodes_[stack[--top]];
    if (!visit(n.box)) continue;
    if (n.count > 0) {
      for (uint32_t k = n.first; k < n.first + n.count; ++k)
        if (!test_leaf_triangles || visit(boxes_[index_[k]])) out.push_back(index_[k]);
      continue;
    }
    stack[top++] = n.first;
    stack[top++] = n.first + 1;
  }
  std::sort(out.begin(), out.end());
}

void TriangleBvh::query_box(const AABB& box, std::vector<uint32_t>& out) const {
  collect([&](const AABB& b) { return b.overlaps(box); }, true, out);
}

void TriangleBvh::query_shaft(const ShaftGeometry& g, std::vector<uint32_t>& out) const {
  // The triangles of a visited leaf are returned untested: every consumer tests each
  // triangle against the shaft itself, so a second (box) test would only cost.
  collect([&](const AABB& b) { return g.may_intersect_box(to_aabbd(b)); }, false, out);
}

}  // namespace visgate::iss
