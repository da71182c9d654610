// Static triangle-box hierarchy for ISS's whole-mesh queries (see triangle_bvh.h).
#include "lib/iss/triangle_bvh.h"

#include <algorithm>
#include <numeric>

namespace visgate::iss {

namespace {

constexpr uint32_t kLeafSize = 8;

// 10 bits of x spread to every third bit.
uint32_t spread_bits(uint32_t x) {
  x &= 0x3ffu;
  x = (x | (x << 16)) & 0x030000ffu;
  x = (x | (x << 8)) & 0x0300f00fu;
  x = (x | (x << 4)) & 0x030c30c3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

}  // namespace

TriangleBvh::TriangleBvh(const std::vector<AABB>& triangle_boxes) : boxes_(triangle_boxes) {
  size_t n = boxes_.size();
  if (n == 0) return;
  // Morton order of the box centres (10 bits per axis over the centres' box), by a
  // stable LSD radix sort from index order, so equal codes stay in index order.
  AABB cb;
  for (const AABB& b : boxes_) cb.extend(b.center());
  Vec3f ext = cb.extent();
  std::vector<uint32_t> code(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3f c = boxes_[i].center();
    uint32_t q[3];
    for (int a = 0; a < 3; ++a) {
      float f = ext[a] > 0 ? (c[a] - cb.lo[a]) / ext[a] : 0.0f;
      q[a] = uint32_t(std::min(1023.0f, std::max(0.0f, f * 1024.0f)));
    }
    code[i] = (spread_bits(q[0]) << 2) | (spread_bits(q[1]) << 1) | spread_bits(q[2]);
  }
  index_.resize(n);
  std::iota(index_.begin(), index_.end(), 0u);
  std::vector<uint32_t> tmp(n), count(1u << 10);
  for (int pass = 0; pass < 3; ++pass) {
    int shift = 10 * pass;
    std::fill(count.begin(), count.end(), 0u);
    for (uint32_t i : index_) ++count[(code[i] >> shift) & 1023u];
    uint32_t sum = 0;
    for (uint32_t& c : count) {
      uint32_t v = c;
      c = sum;
      sum += v;
    }
    for (uint32_t i : index_) tmp[count[(code[i] >> shift) & 1023u]++] = i;
    index_.swap(tmp);
  }
  // Balanced hierarchy over the sorted order: halve ranges down to kLeafSize; children
  // are created after their parent, so one backward pass fills the boxes.
  nodes_.reserve(2 * (n / kLeafSize + 1));
  nodes_.push_back(Node{AABB{}, 0, uint32_t(n)});
  for (size_t ni = 0; ni < nodes_.size(); ++ni) {
    uint32_t first = nodes_[ni].first, cnt = nodes_[ni].count;
    if (cnt <= kLeafSize) continue;
    uint32_t half = cnt / 2, left = uint32_t(nodes_.size());
    nodes_.push_back(Node{AABB{}, first, half});
    nodes_.push_back(Node{AABB{}, first + half, cnt - half});
    nodes_[ni].first = left;
    nodes_[ni].count = 0;
  }
  for (size_t ni = nodes_.size(); ni-- > 0;) {
    Node& nd = nodes_[ni];
    AABB b;
    if (nd.count > 0) {
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) b.extend(boxes_[index_[k]]);
    } else {
      b = nodes_[nd.first].box;
      b.extend(nodes_[nd.first + 1].box);
    }
    nd.box = b;
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
