// Wedges scattered through the receiver tree (see wedge_scatter.h).
#include "lib/ssv/wedge_scatter.h"

#include <algorithm>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "lib/base/cpu_features.h"

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

void WedgeScatter::float_boxes(const ReceiverTree& tree) {
  const auto& nodes = tree.nodes();
  if (boxes_.size() == nodes.size()) return;
  boxes_.resize(nodes.size());
  for (size_t k = 0; k < nodes.size(); ++k) boxes_[k] = to_float_box(nodes[k].box);
}

namespace {

#if defined(__GNUC__) && defined(__x86_64__)
// Eight boxes' coordinates in lanes (lo.x .. hi.z).
struct BoxLanes {
  alignas(32) float c[6][8];
};

// The box range of plane p over each of the eight boxes (box_range per lane): the corner
// that minimises (maximises) n.x - d, chosen by the sign test n[k] >= 0 as there, then
// ((x + y) + z) - d; AVX2 alone has no fused multiply-add, so the same floats.
__attribute__((target("avx2"), always_inline)) inline void range_lanes(const Plane& p, const BoxLanes& b, __m256& lo,
                                                                       __m256& hi) {
  const __m256 nx = _mm256_set1_ps(p.n.x), ny = _mm256_set1_ps(p.n.y), nz = _mm256_set1_ps(p.n.z);
  const int lx = p.n.x >= 0.0f ? 0 : 3, ly = p.n.y >= 0.0f ? 1 : 4, lz = p.n.z >= 0.0f ? 2 : 5;
  const int hx = 3 - lx, hy = 5 - ly, hz = 7 - lz;  // the other corner's rows
  const __m256 d = _mm256_set1_ps(p.d);
  lo = _mm256_sub_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, _mm256_load_ps(b.c[lx])),
                                                 _mm256_mul_ps(ny, _mm256_load_ps(b.c[ly]))),
                                   _mm256_mul_ps(nz, _mm256_load_ps(b.c[lz]))),
                     d);
  hi = _mm256_sub_ps(_mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, _mm256_load_ps(b.c[hx])),
                                                 _mm256_mul_ps(ny, _mm256_load_ps(b.c[hy]))),
                                   _mm256_mul_ps(nz, _mm256_load_ps(b.c[hz]))),
                     d);
}

// classify_box's Outside test from the root's state (every plane active, no region side
// settled) for one wedge and eight boxes: bit i set when box i is Outside.
__attribute__((target("avx2"))) uint32_t outside_lanes(const Wedge& w, const BoxLanes& b, float eps,
                                                       bool use_region) {
  const __m256 peps = _mm256_set1_ps(eps), neps = _mm256_set1_ps(-eps);
  uint32_t out = 0;
  if (use_region && w.has_region) {
    // Section 4.2: front of both triangle planes or back of both (a side is front when
    // lo >= eps, else back when hi <= -eps).
    __m256 lo1, hi1, lo2, hi2;
    range_lanes(w.tri[0], b, lo1, hi1);
    range_lanes(w.tri[1], b, lo2, hi2);
    const uint32_t pos1 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(lo1, peps, _CMP_GE_OQ)));
    const uint32_t pos2 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(lo2, peps, _CMP_GE_OQ)));
    const uint32_t neg1 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi1, neps, _CMP_LE_OQ))) & ~pos1;
    const uint32_t neg2 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi2, neps, _CMP_LE_OQ))) & ~pos2;
    out = (pos1 & pos2) | (neg1 & neg2);
  }
  for (int i = 0; i < w.plane_count && out != 0xFFu; ++i) {
    __m256 lo, hi;
    range_lanes(w.planes[size_t(i)], b, lo, hi);
    out |= uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi, neps, _CMP_LT_OQ)));
  }
  return out;
}

// classify_box from the root's state for one wedge and eight leaf boxes, every plane at
// once: bit i of the result set when leaf i is Outside; for the others the state
// classify_box leaves (mask[i]: the planes whose box minimum is not >= -eps; region[i]:
// each triangle plane's side, front when lo >= eps, else back when hi <= -eps).
__attribute__((target("avx2"))) uint32_t leaf_states(const Wedge& w, const BoxLanes& b, float eps, bool use_region,
                                                     uint16_t* mask, uint8_t* region) {
  const __m256 peps = _mm256_set1_ps(eps), neps = _mm256_set1_ps(-eps);
  uint32_t out = 0, pos1 = 0, neg1 = 0, pos2 = 0, neg2 = 0;
  if (use_region && w.has_region) {
    __m256 lo1, hi1, lo2, hi2;
    range_lanes(w.tri[0], b, lo1, hi1);
    range_lanes(w.tri[1], b, lo2, hi2);
    pos1 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(lo1, peps, _CMP_GE_OQ)));
    pos2 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(lo2, peps, _CMP_GE_OQ)));
    neg1 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi1, neps, _CMP_LE_OQ))) & ~pos1;
    neg2 = uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi2, neps, _CMP_LE_OQ))) & ~pos2;
    out = (pos1 & pos2) | (neg1 & neg2);
  }
  uint32_t keep[kMaxWedgePlanes];  // per plane, the leaves whose box it does not contain
  for (int i = 0; i < w.plane_count && out != 0xFFu; ++i) {
    __m256 lo, hi;
    range_lanes(w.planes[size_t(i)], b, lo, hi);
    out |= uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(hi, neps, _CMP_LT_OQ)));
    keep[i] = ~uint32_t(_mm256_movemask_ps(_mm256_cmp_ps(lo, neps, _CMP_GE_OQ)));
  }
  for (uint32_t in = ~out & 0xFFu; in != 0; in &= in - 1) {
    const int l = __builtin_ctz(in);
    uint32_t m = 0;
    for (int i = 0; i < w.plane_count; ++i) m |= ((keep[i] >> l) & 1u) << i;
    mask[l] = uint16_t(m);
    region[l] = uint8_t(((pos1 >> l) & 1u ? kPos1 : 0) | ((neg1 >> l) & 1u ? kNeg1 : 0) | ((pos2 >> l) & 1u ? kPos2 : 0) |
                        ((neg2 >> l) & 1u ? kNeg2 : 0));
  }
  return out;
}
#endif

}  // namespace

void WedgeScatter::pass_batches(const ReceiverTree& tree, const std::vector<int32_t>& batches, size_t first,
                                const std::vector<Wedge>& wedges, float eps, bool use_region,
                                std::vector<std::vector<uint32_t>>& lists) {
  const size_t m = first < batches.size() ? std::min(kPassGroup, batches.size() - first) : 0;
  lists.resize(m);
  for (auto& list : lists) list.clear();
  float_boxes(tree);
#if defined(__GNUC__) && defined(__x86_64__)
  static_assert(kPassGroup == 8, "one AVX2 lane per batch");
  static const bool avx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
  if (avx2 && m > 0) {
    BoxLanes b;
    for (size_t l = 0; l < 8; ++l) {
      const AABB& box = boxes_[size_t(batches[first + (l < m ? l : 0)])];  // spare lanes repeat the first
      for (int k = 0; k < 3; ++k) {
        b.c[k][l] = box.lo[k];
        b.c[k + 3][l] = box.hi[k];
      }
    }
    for (uint32_t w = 0; w < wedges.size(); ++w) {
      const uint32_t outside = outside_lanes(wedges[w], b, eps, use_region);
      for (size_t l = 0; l < m; ++l)
        if (!(outside & (1u << l))) lists[l].push_back(w);
    }
    return;
  }
#endif
  (void)eps;
  (void)use_region;
  for (auto& list : lists) {
    list.resize(wedges.size());
    for (uint32_t w = 0; w < wedges.size(); ++w) list[w] = w;
  }
}

void WedgeScatter::build(const ReceiverTree& tree, int32_t batch, const std::vector<Wedge>& wedges, float eps,
                         bool use_region, const std::vector<uint8_t>& skip, const std::vector<uint32_t>* passed) {
  const auto& nodes = tree.nodes();
  const auto& ord = tree.order();
  const auto& root = nodes[size_t(batch)];
  first_ = root.begin;
  const uint32_t n = root.end - root.begin;
  pairs_.clear();
  float_boxes(tree);
  struct Item {
    int32_t node;
    WedgeState s;
  };
  std::vector<Item> work;
  size_t count = passed ? passed->size() : wedges.size();
#if defined(__GNUC__) && defined(__x86_64__)
  static const bool avx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
  if (passed && avx2 && eps > 0.0f) {
    count = 0;  // no walks
    // The walk's pairs depend on the leaves alone (eps > 0): a box range's float ends
    // only move inwards with the box, so a node is Outside when its parent is, a plane
    // that contains (or a region side settled for) the parent does so for the node, and
    // a Contains node's leaves are all Contains with its state. So a receiver gets the
    // wedge exactly when its leaf is not Outside, with the state classify_box leaves
    // there from the root's state: eight leaves per AVX2 step, every plane at once.
    std::vector<int32_t> leaves;
    work.clear();
    work.push_back({batch, WedgeState{}});
    while (!work.empty()) {  // the batch's leaves in tree order
      const int32_t id = work.back().node;
      work.pop_back();
      const auto& nd = nodes[size_t(id)];
      if (nd.left < 0) {
        leaves.push_back(id);
        continue;
      }
      work.push_back({nd.right, WedgeState{}});
      work.push_back({nd.left, WedgeState{}});
    }
    std::vector<BoxLanes> groups((leaves.size() + 7) / 8);
    // The boxes around each group's leaves, eight groups per step: a wedge whose
    // Outside test excludes one excludes each of its leaves (same argument).
    std::vector<BoxLanes> hulls((groups.size() + 7) / 8);
    for (size_t k = 0; k < groups.size() * 8; ++k) {
      const AABB& box = boxes_[size_t(leaves[k < leaves.size() ? k : 0])];  // spare lanes repeat the first
      for (int a = 0; a < 3; ++a) {
        groups[k / 8].c[a][k % 8] = box.lo[a];
        groups[k / 8].c[a + 3][k % 8] = box.hi[a];
      }
    }
    for (size_t g = 0; g < hulls.size() * 8; ++g) {
      const size_t src = g < groups.size() ? g : 0;
      for (int a = 0; a < 3; ++a) {
        float lo = groups[src].c[a][0], hi = groups[src].c[a + 3][0];
        for (int l = 1; l < 8; ++l) {
          lo = std::min(lo, groups[src].c[a][l]);
          hi = std::max(hi, groups[src].c[a + 3][l]);
        }
        hulls[g / 8].c[a][g % 8] = lo;
        hulls[g / 8].c[a + 3][g % 8] = hi;
      }
    }
    uint16_t mask[8];
    uint8_t region[8];
    uint32_t hull_out = 0;
    for (const uint32_t w : *passed)
      for (size_t g = 0; g < groups.size(); ++g) {
        if (g % 8 == 0) hull_out = outside_lanes(wedges[w], hulls[g / 8], eps, use_region);
        if (hull_out & (1u << (g % 8))) continue;
        const size_t m = std::min<size_t>(8, leaves.size() - 8 * g);
        const uint32_t outside = leaf_states(wedges[w], groups[g], eps, use_region, mask, region);
        for (uint32_t in = ~outside & ((1u << m) - 1u); in != 0; in &= in - 1) {
          const int l = __builtin_ctz(in);
          WedgeState s;
          s.wedge = w;
          s.mask = mask[l];
          s.region = region[l];
          const auto& nd = nodes[size_t(leaves[8 * g + size_t(l)])];
          for (uint32_t p = nd.begin; p < nd.end; ++p)
            if (!skip[ord[p]]) pairs_.push_back({p, s});
        }
      }
  }
#endif
  for (size_t q = 0; q < count; ++q) {
    const uint32_t w = passed ? (*passed)[q] : uint32_t(q);
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
