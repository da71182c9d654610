// Wedges scattered through the receiver tree (see wedge_scatter.h).
#include "lib/ssv/wedge_scatter.h"

namespace visgate::ssv {

namespace {

AABB to_float_box(const AABBd& b) {
  // Outwards: the float box contains the exact one.
  AABB f;
  for (int k = 0; k < 3; ++k) {
    f.lo[k] = float(b.lo[k]);
    if (double(f.lo[k]) > b.lo[k]) f.lo[k] = std::nextafter(f.lo[k], -INFINITY);
    f.hi[k] = float(b.hi[k]);
    if (double(f.hi[k]) < b.hi[k]) f.hi[k] = std::nextafter(f.hi[k], INFINITY);
  }
  return f;
}

}  // namespace

std::vector<int32_t> WedgeScatter::batches(const ReceiverTree& tree, uint32_t max_receivers) {
  std::vector<int32_t> out;
  if (tree.nodes().empty()) return out;
  std::vector<int32_t> stack{0};
  while (!stack.empty()) {
    const int32_t id = stack.back();
    stack.pop_back();
    const auto& n = tree.nodes()[size_t(id)];
    if (n.end - n.begin <= max_receivers || n.left < 0) {
      out.push_back(id);
      continue;
    }
    stack.push_back(n.right);  // left first: tree order
    stack.push_back(n.left);
  }
  return out;
}

void WedgeScatter::build(const ReceiverTree& tree, int32_t batch, const std::vector<Wedge>& wedges, float eps,
                         bool use_region, const std::vector<uint8_t>& skip) {
  const auto& nodes = tree.nodes();
  const auto& ord = tree.order();
  const auto& root = nodes[size_t(batch)];
  first_ = root.begin;
  const uint32_t n = root.end - root.begin;
  pairs_.clear();
  if (boxes_.size() != nodes.size()) {  // the tree's float boxes, once
    boxes_.resize(nodes.size());
    for (size_t k = 0; k < nodes.size(); ++k) boxes_[k] = to_float_box(nodes[k].box);
  }
  struct Item {
    int32_t node;
    WedgeState s;
  };
  std::vector<Item> work;
  for (uint32_t w = 0; w < wedges.size(); ++w) {
    WedgeState s0;
    s0.wedge = w;
    s0.mask = uint16_t((1u << wedges[w].plane_count) - 1u);
    work.clear();
    work.push_back({batch, s0});
    while (!work.empty()) {
      Item it = work.back();
      work.pop_back();
      const auto& nd = nodes[size_t(it.node)];
      const BoxClass c = classify_box(wedges[w], it.s, boxes_[size_t(it.node)], eps, use_region);
      if (c == BoxClass::Outside) continue;
      if (c == BoxClass::Contains || nd.left < 0) {
        for (uint32_t p = nd.begin; p < nd.end; ++p)
          if (!skip[ord[p]]) pairs_.push_back({p, it.s});
        continue;
      }
      work.push_back({nd.right, it.s});
      work.push_back({nd.left, it.s});
    }
  }
  // Counting sort by position; within a position the wedge order is kept.
  start_.assign(size_t(n) + 1, 0);
  for (const Pair& q : pairs_) ++start_[q.pos - first_ + 1];
  for (uint32_t k = 0; k < n; ++k) start_[k + 1] += start_[k];
  items_.resize(pairs_.size());
  total_ += pairs_.size();
  std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
  for (const Pair& q : pairs_) items_[fill[q.pos - first_]++] = q.s;
}

}  // namespace visgate::ssv
