// Lazy wedge BSP (see wedge_bsp.h), paper 001 Figure 5.
#include "lib/ssv/wedge_bsp.h"

#include "lib/geom/check.h"

namespace visgate::ssv {

WedgeBsp::WedgeBsp(const std::vector<Wedge>& wedges, const AABB& bounds, float eps, bool use_region)
    : wedges_(wedges), eps_(eps), use_region_(use_region) {
  root_.box = bounds;
  // Minimum node size: 1/200 of the scene's longest side (section 4.1).
  min_size_ = max_component(bounds.extent()) / 200.0f;
  root_.wedges.reserve(wedges.size());
  for (size_t i = 0; i < wedges.size(); ++i) {
    WedgeState s;
    s.wedge = uint32_t(i);
    s.mask = uint16_t((1u << wedges[i].plane_count) - 1u);
    if (classify_box(wedges[i], s, bounds, eps_, use_region_) != BoxClass::Outside) root_.wedges.push_back(s);
  }
  nodes_ = 1;
  entries_ = root_.wedges.size();
}

WedgeBsp::~WedgeBsp() = default;

bool WedgeBsp::should_split(const Node& n, size_t wedges_above) const {
  if (n.wedges.empty()) return false;
  if (max_component(n.box.extent()) < min_size_) return false;
  // Far from the origin the float midpoint stops separating the box's faces before the
  // minimum size is reached: a split that would not shrink the box is never made.
  const int axis = n.box.longest_axis();
  const float mid = 0.5f * (n.box.lo[axis] + n.box.hi[axis]);
  if (!(n.box.lo[axis] < mid && mid < n.box.hi[axis])) return false;
  // "fewer than 25% of the wedges above": stop when the leaf holds at most a quarter.
  if (double(n.wedges.size()) <= 0.25 * double(wedges_above)) return false;
  return true;
}

// SPLIT-LEAF: wedges containing the node stay; the others go to the children they meet.
// Called with n.lock held and n still a leaf.
void WedgeBsp::split_leaf(Node& n) {
  int axis = n.box.longest_axis();
  float mid = 0.5f * (n.box.lo[axis] + n.box.hi[axis]);
  Node* pair;
  {
    std::lock_guard<std::mutex> guard(arena_lock_);
    pair = arena_.emplace_back().data();
  }
  Node* left = pair;
  Node* right = pair + 1;
  left->box = n.box;
  right->box = n.box;
  left->box.hi[axis] = mid;
  right->box.lo[axis] = mid;
  std::vector<WedgeState> kept;
  for (const WedgeState& s : n.wedges) {
    const Wedge& w = wedges_[s.wedge];
    // The state's masks describe n.box: a wedge with no active plane (and inside its
    // silhouette region) contains the node.
    bool region_in = !use_region_ || !w.has_region ||
                     ((s.region & kPos1) && (s.region & kNeg2)) || ((s.region & kNeg1) && (s.region & kPos2));
    if (s.mask == 0 && region_in) {
      kept.push_back(s);
      continue;
    }
    WedgeState sl = s, sr = s;
    if (classify_box(w, sl, left->box, eps_, use_region_) != BoxClass::Outside) left->wedges.push_back(sl);
    if (classify_box(w, sr, right->box, eps_, use_region_) != BoxClass::Outside) right->wedges.push_back(sr);
  }
  entries_ += kept.size() + left->wedges.size() + right->wedges.size();
  entries_ -= n.wedges.size();
  nodes_ += 2;
  n.wedges = std::move(kept);
  n.axis = axis;
  n.mid = mid;
  n.child = pair;
  n.split.store(true, std::memory_order_release);
}

void WedgeBsp::query(const Vec3f& p, std::vector<uint32_t>& out) {
  Node* n = &root_;
  for (;;) {
    if (!n->split.load(std::memory_order_acquire)) {
      std::unique_lock<std::mutex> guard(lock_of(n));
      if (!n->split.load(std::memory_order_relaxed)) {
        if (!should_split(*n, out.size())) {
          for (const WedgeState& s : n->wedges) out.push_back(s.wedge);
          return;
        }
        split_leaf(*n);
      }
    }
    // Internal node: its list (wedges containing the node) is final.
    for (const WedgeState& s : n->wedges) out.push_back(s.wedge);
    n = (p[n->axis] <= n->mid) ? n->child : n->child + 1;
  }
}

size_t WedgeBsp::memory_bytes() const {
  return nodes_.load() * sizeof(Node) + entries_.load() * sizeof(WedgeState) +
         wedges_.size() * sizeof(Wedge);
}

}  // namespace visgate::ssv
