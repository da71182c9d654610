// The lazy Plücker-space BSP, paper 002 Algorithm 1; see bsp.h.
#include "lib/plucker/bsp.h"

#include <array>

#include "lib/geom/check.h"

namespace visgate::plucker {

LazyBsp::LazyBsp(const Vec3f* light, int m, std::vector<Occluder> occluders, uint64_t seed, const Vec3f* receivers,
                 int nr)
    : light_(light, light + m), occ_(std::move(occluders)), recv_(receivers, receivers + nr), rng_(seed) {
  // vvset of each occluder against the light (section 3.3): the directions l_j - o_i.
  vvbegin_.reserve(occ_.size());
  for (const Occluder& o : occ_) {
    VG_CHECK(o.n >= 3 && o.n <= kMaxOccluderVertices);
    vvbegin_.push_back(uint32_t(vvdir_.size()));
    for (int i = 0; i < o.n; ++i)
      for (int j = 0; j < m; ++j) vvdir_.push_back(light_[size_t(j)] - o.v[i]);
    rvbegin_.push_back(uint32_t(rvdir_.size()));
    for (const Vec3f& c : recv_)
      for (int j = 0; j < o.n; ++j) rvdir_.push_back(o.v[j] - c);
  }
  reset();
  counters_.nodes_created = 1;
}

Orientation LazyBsp::orientation(uint32_t id, const Vec3f& a, const Vec3f& b) const {
  const Occluder& q = occ_[id];
  Orientation s = vvset_orientation(q.v, q.n, vvdir_.data() + vvbegin_[id], int(light_.size()), a, b);
  if (s != Orientation::Mixed || recv_.empty()) return s;
  return vvset_orientation(recv_.data(), int(recv_.size()), rvdir_.data() + rvbegin_[id], q.n, a, b);
}

void LazyBsp::reset() {
  // One undefined leaf holding every occluder (Algorithm 1: "It starts with all the
  // occluders associated to a single undefined leaf").
  lists_.resize(occ_.size());
  for (size_t k = 0; k < occ_.size(); ++k) lists_[k] = uint32_t(k);
  nodes_.resize(1);
  nodes_[0] = Node{};
  nodes_[0].occ_begin = 0;
  nodes_[0].occ_count = uint32_t(occ_.size());
}

size_t LazyBsp::memory_bytes() const {
  return nodes_.capacity() * sizeof(Node) + lists_.capacity() * sizeof(uint32_t) + occ_.capacity() * sizeof(Occluder) +
         (vvdir_.capacity() + rvdir_.capacity()) * sizeof(Vec3f) +
         (vvbegin_.capacity() + rvbegin_.capacity()) * sizeof(uint32_t) +
         (work_.capacity() + cur_.capacity() + pos_.capacity() + neg_.capacity()) * sizeof(Vec3f) +
         stack_.capacity() * sizeof(Work);
}

void LazyBsp::develop(int32_t leaf) {
  ++counters_.developments;
  // Copy the leaf's list: the lists arena grows below.
  const Node& lf = nodes_[size_t(leaf)];
  list_scratch_.assign(lists_.begin() + lf.occ_begin, lists_.begin() + lf.occ_begin + lf.occ_count);
  // Line 31: random occluder, seeded (reproducible).
  size_t pick = size_t(rng_.below(list_scratch_.size()));
  uint32_t ro = list_scratch_[pick];
  const Occluder& o = occ_[ro];
  int k = o.n;

  // Line 32: replace the leaf by bsp(ro); the leaf's slot becomes its root, so the
  // parent's child index stays valid. Visible leaves get a scratch list index in
  // occ_begin until the insertions below are done.
  new_leaves_.clear();
  auto add_node = [&](Kind kind) {
    nodes_.emplace_back();
    nodes_.back().kind = kind;
    ++counters_.nodes_created;
    if (kind == kLeaf) {
      nodes_.back().occ_begin = uint32_t(new_leaves_.size());
      new_leaves_.push_back(int32_t(nodes_.size() - 1));
    }
    return int32_t(nodes_.size() - 1);
  };
  auto set_inner = [&](int32_t id, int m, int32_t left, int32_t right) {
    Node& in = nodes_[size_t(id)];
    in.kind = kInner;
    in.a = o.v[m];
    in.b = o.v[(m + 1) % k];
    in.left = left;
    in.right = right;
    in.occ_begin = in.occ_count = 0;
  };
  // Positive chain: edges 0..k-1, left = positive continues, right = visible, the left
  // child of the last edge is the invisible class (the lines stabbing ro).
  std::array<int32_t, kMaxOccluderVertices> pchain{};
  pchain[0] = leaf;
  for (int m = 1; m < k; ++m) pchain[size_t(m)] = add_node(kInner);
  int32_t neg_root = -1;
  if (o.two_sided) {
    // Negative chain for the first edge's right side: edges 1..k-1, right = negative
    // continues, left = visible, the right child of the last is the second invisible
    // class (ro stabbed in the other direction).
    std::array<int32_t, kMaxOccluderVertices> nchain{};
    for (int m = 1; m < k; ++m) nchain[size_t(m)] = add_node(kInner);
    for (int m = 1; m < k; ++m) {
      int32_t vis = add_node(kLeaf);
      int32_t next = (m + 1 < k) ? nchain[size_t(m + 1)] : add_node(kInvisible);
      set_inner(nchain[size_t(m)], m, vis, next);
    }
    neg_root = nchain[1];
  }
  for (int m = 0; m < k; ++m) {
    int32_t right = (m == 0 && neg_root >= 0) ? neg_root : add_node(kLeaf);
    int32_t left = (m + 1 < k) ? pchain[size_t(m + 1)] : add_node(kInvisible);
    set_inner(pchain[size_t(m)], m, left, right);
  }

  // Lines 33-35: insertOccluder(root of bsp(ro), q) for every other occluder q (lines
  // 1-13): positive goes left, negative right, mixed both; leaves store q unless
  // invisible. bsp(ro) is at most 2k - 1 nodes deep; walked with an explicit stack.
  for (size_t s = 0; s < new_leaves_.size(); ++s) leaf_lists_[s].clear();
  int32_t walk[4 * kMaxOccluderVertices];
  for (uint32_t id : list_scratch_) {
    if (id == ro) continue;
    int top = 0;
    walk[top++] = leaf;
    while (top > 0) {
      const Node& nd = nodes_[size_t(walk[--top])];
      if (nd.kind == kInvisible) continue;  // line 3: nothing stored in invisible classes
      if (nd.kind == kLeaf) {
        leaf_lists_[nd.occ_begin].push_back(id);
        continue;
      }
      ++counters_.insert_tests;
      Orientation s = orientation(id, nd.a, nd.b);
      if (s != Orientation::Negative) walk[top++] = nd.left;
      if (s != Orientation::Positive) walk[top++] = nd.right;
    }
  }
  for (int32_t id : new_leaves_) {
    Node& vis = nodes_[size_t(id)];
    const std::vector<uint32_t>& l = leaf_lists_[vis.occ_begin];
    vis.occ_begin = uint32_t(lists_.size());
    vis.occ_count = uint32_t(l.size());
    lists_.insert(lists_.end(), l.begin(), l.end());
  }
}

void LazyBsp::query(const Vec3f& r, FragmentList& out) {
  out.clear();
  work_.assign(light_.begin(), light_.end());
  stack_.clear();
  stack_.push_back(Work{0, 0, uint32_t(light_.size())});
  while (!stack_.empty()) {
    Work w = stack_.back();
    stack_.pop_back();
    cur_.assign(work_.begin() + w.begin, work_.begin() + w.begin + w.count);
    int32_t node = w.node;
    for (;;) {
      const Node& nd = nodes_[size_t(node)];
      if (nd.kind == kInner) {
        // Lines 17-27: position of the fragment against makePlane(xyz, hyperplane).
        SplitResult s = split_fragment(r, nd.a, nd.b, cur_.data(), int(cur_.size()), pos_, neg_);
        if (s == SplitResult::Positive) {
          node = nd.left;
        } else if (s == SplitResult::Negative) {
          node = nd.right;
        } else if (s == SplitResult::OnLine) {
          ++counters_.on_line;
          node = nd.right;
        } else if (s == SplitResult::ZeroArea) {
          ++counters_.zero_area;
          break;
        } else {
          // Line 25, with the right piece on the explicit stack.
          ++counters_.splits;
          int32_t right = nd.right;
          if (!neg_.empty()) {
            stack_.push_back(Work{right, uint32_t(work_.size()), uint32_t(neg_.size())});
            work_.insert(work_.end(), neg_.begin(), neg_.end());
          } else {
            ++counters_.zero_area;
          }
          if (pos_.empty()) {
            ++counters_.zero_area;
            break;
          }
          cur_.swap(pos_);
          node = nd.left;
        }
        continue;
      }
      if (nd.kind == kInvisible) break;  // line 29: invisible class, discarded
      if (nd.occ_count == 0) {           // line 29: visible class, returned
        out.add(cur_.data(), cur_.size());
        break;
      }
      develop(node);  // lines 31-35, then continue from the root of bsp(ro)
    }
  }
}

}  // namespace visgate::plucker
