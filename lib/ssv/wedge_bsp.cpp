// Lazy wedge BSP (see wedge_bsp.h), paper 001 Figure 5.
#include "lib/ssv/wedge_bsp.h"

#include <algorithm>

#include "lib/base/check.h"

namespace visgate::ssv {

WedgeBsp::WedgeBsp(const std::vector<Wedge>& wedges, const AABB& bounds, float min_size, float eps, bool use_region)
    : wedges_(wedges), eps_(eps), use_region_(use_region), min_size_(min_size) {
  root_.box = bounds;
  std::vector<WedgeState> all;
  all.reserve(wedges.size());
  for (size_t i = 0; i < wedges.size(); ++i) {
    WedgeState s;
    s.wedge = uint32_t(i);
    s.mask = uint16_t((1u << wedges[i].plane_count) - 1u);
    if (classify_box(wedges[i], s, bounds, eps_, use_region_) != BoxClass::Outside) all.push_back(s);
  }
  root_.wedges = allocate(all.size());
  std::copy(all.begin(), all.end(), root_.wedges);
  root_.count = uint32_t(all.size());
  nodes_ = 1;
  entries_ = all.size();
}

WedgeState* WedgeBsp::allocate(size_t count) {
  std::lock_guard<std::mutex> guard(arena_lock_);
  return allocate_locked(count);
}

WedgeState* WedgeBsp::allocate_locked(size_t count) {
  if (chunks_.empty() || chunk_used_ + count > chunk_size_) {
    // Chunks grow geometrically from 256 entries to 16384: a small scene (fuzz inputs)
    // does not pay for zeroing 128 KB per light, a large one allocates rarely.
    const size_t next = chunks_.empty() ? size_t(256) : std::min(chunk_size_ * 2, size_t(1) << 14);
    chunk_size_ = std::max(count, next);
    chunks_.emplace_back(new WedgeState[chunk_size_]);
    chunk_used_ = 0;
    list_capacity_ += chunk_size_;
  }
  WedgeState* p = chunks_.back().get() + chunk_used_;
  chunk_used_ += count;
  return p;
}

WedgeBsp::~WedgeBsp() = default;

bool WedgeBsp::should_split(const Node& n, size_t wedges_above) const {
  if (n.count == 0) return false;
  if (max_component(n.box.extent()) < min_size_) return false;
  // Far from the origin the float midpoint stops separating the box's faces before the
  // minimum size is reached: a split that would not shrink the box is never made.
  const int axis = n.box.longest_axis();
  const float mid = 0.5f * (n.box.lo[axis] + n.box.hi[axis]);
  if (!(n.box.lo[axis] < mid && mid < n.box.hi[axis])) return false;
  // "fewer than 25% of the wedges above": stop when the leaf holds at most a quarter.
  if (double(n.count) <= 0.25 * double(wedges_above)) return false;
  return true;
}

// SPLIT-LEAF: wedges containing the node stay; the others go to the children they meet.
// Called with n.lock held and n still a leaf.
void WedgeBsp::split_leaf(Node& n) {
  const int axis = n.box.longest_axis();
  const float mid = 0.5f * (n.box.lo[axis] + n.box.hi[axis]);
  // Classify into per-thread scratch lists, then copy them into one exact-size span.
  thread_local std::vector<WedgeState> to_left, to_right, to_keep;
  to_left.clear();
  to_right.clear();
  to_keep.clear();
  const SplitBoxes halves = split_boxes(n.box, axis, mid);
  for (uint32_t k = 0; k < n.count; ++k) {
    const WedgeState& s = n.wedges[k];
    const Wedge& w = wedges_[s.wedge];
    // The state's masks describe n.box: a wedge with no active plane (and inside its
    // silhouette region) contains the node and stays in it.
    const bool region_in = !use_region_ || !w.has_region ||
                           ((s.region & kPos1) && (s.region & kNeg2)) || ((s.region & kNeg1) && (s.region & kPos2));
    if (s.mask == 0 && region_in) {
      to_keep.push_back(s);
      continue;
    }
    WedgeState sl, sr;
    BoxClass cl, cr;
    classify_split(w, s, halves, eps_, use_region_, sl, cl, sr, cr);
    if (cl != BoxClass::Outside) to_left.push_back(sl);
    if (cr != BoxClass::Outside) to_right.push_back(sr);
  }
  // One trip to the arenas per split: the node pair and the three lists.
  Node* pair;
  WedgeState* lists;
  const size_t total = to_left.size() + to_right.size() + to_keep.size();
  {
    std::lock_guard<std::mutex> guard(arena_lock_);
    pair = arena_.emplace_back().data();
    lists = allocate_locked(total);
    budget_charge_.set(memory_bytes() + 2 * sizeof(Node));
  }
  Node* left = pair;
  Node* right = pair + 1;
  left->box = n.box;
  right->box = n.box;
  left->box.hi[axis] = mid;
  right->box.lo[axis] = mid;
  auto store = [&](const std::vector<WedgeState>& v, WedgeState*& p, uint32_t& c) {
    p = lists;
    lists = std::copy(v.begin(), v.end(), lists);
    c = uint32_t(v.size());
  };
  store(to_left, left->wedges, left->count);
  store(to_right, right->wedges, right->count);
  store(to_keep, n.kept, n.kept_count);
  entries_.fetch_add(total - n.count, std::memory_order_relaxed);
  nodes_.fetch_add(2, std::memory_order_relaxed);
  n.axis = axis;
  n.mid = mid;
  n.child = pair;
  n.split.store(true, std::memory_order_release);
}

void WedgeBsp::query(const Vec3f& p, std::vector<WedgeState>& out) {
  Node* n = &root_;
  for (;;) {
    if (!n->split.load(std::memory_order_acquire)) {
      // A leaf: its list is final; the lock is needed only to split it.
      if (!should_split(*n, out.size())) {
        out.insert(out.end(), n->wedges, n->wedges + n->count);
        return;
      }
      std::unique_lock<std::mutex> guard(lock_of(n));
      if (!n->split.load(std::memory_order_relaxed)) split_leaf(*n);
    }
    // Internal node: the wedges containing it (their masks are 0).
    out.insert(out.end(), n->kept, n->kept + n->kept_count);
    n = (p[n->axis] <= n->mid) ? n->child : n->child + 1;
  }
}

void WedgeBsp::query(const Vec3f& p, std::vector<uint32_t>& out) {
  std::vector<WedgeState> states;
  query(p, states);
  for (const WedgeState& s : states) out.push_back(s.wedge);
}

size_t WedgeBsp::memory_bytes() const {
  return nodes_.load() * sizeof(Node) + list_capacity_ * sizeof(WedgeState) + wedges_.size() * sizeof(Wedge);
}

}  // namespace visgate::ssv
