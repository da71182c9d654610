// Build of the shared hierarchy; see bvh.h.
#include "lib/accel/bvh.h"

#include "lib/geom/morton.h"

#include <algorithm>
#include <array>
#include <cstddef>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include <tbb/parallel_for.h>
#include <tbb/parallel_invoke.h>

namespace visgate::accel {

namespace {

// Below these sizes the TBB overhead exceeds the work; above, the key pass and the two
// halves of a node run in parallel. The tree does not depend on the thread count.
constexpr uint32_t kParallelGrain = 1u << 14;
constexpr uint32_t kParallelSubtree = 1u << 15;

// Nodes of the subtrees by depth: halving (floor(m / 2) on the left) gives the nodes at
// depth d floor(n / 2^d) or ceil(n / 2^d) items, i.e. q_d = n >> d or q_d + 1.
class SubtreeNodes {
 public:
  SubtreeNodes(uint32_t n, uint32_t leaf) {
    for (uint32_t q = n; q > 0; q /= 2) q_.push_back(q);
    q_.push_back(0);
    count_.resize(q_.size());
    count_.back() = {1, 1};
    for (size_t d = q_.size() - 1; d-- > 0;)
      for (uint32_t k = 0; k < 2; ++k) {
        const uint32_t m = q_[d] + k;
        count_[d][k] = m <= leaf ? 1 : 1 + of(d + 1, m / 2) + of(d + 1, m - m / 2);
      }
  }
  // Nodes of a subtree of m items at depth d.
  uint32_t of(size_t d, uint32_t m) const { return count_[d][m == q_[d] ? 0 : 1]; }

 private:
  std::vector<uint32_t> q_;
  std::vector<std::array<uint32_t, 2>> count_;
};

// AABBT::extend's union of boxes given in order: lo = std::min(lo, x), hi = std::max(hi, x)
// (the running bound kept on ties), so the same bits, zeros' signs included.
template <class T>
class BoxUnion {
 public:
  explicit BoxUnion(const AABBT<T>& b) : box_(b) {}
  void add(const AABBT<T>& b) { box_.extend(b); }
  AABBT<T> box() const { return box_; }

 private:
  AABBT<T> box_;
};

#if defined(__SSE2__)
// The same for float boxes (lo.x, lo.y, lo.z, hi.x, hi.y, hi.z) in two registers: the lows
// read from byte 0, the highs from byte 8 (both reads inside the box), and
// _mm_min_ps(x, lo) is x < lo ? x : lo, std::min(lo, x) (likewise max): the same bits in
// 8 instructions a box instead of 24.
template <>
class BoxUnion<float> {
 public:
  static_assert(sizeof(AABBT<float>) == 24 && offsetof(AABBT<float>, hi) == 12);
  explicit BoxUnion(const AABBT<float>& b) : lo_(_mm_loadu_ps(&b.lo.x)), hi_(_mm_loadu_ps(&b.lo.z)) {}
  void add(const AABBT<float>& b) {
    lo_ = _mm_min_ps(_mm_loadu_ps(&b.lo.x), lo_);
    hi_ = _mm_max_ps(_mm_loadu_ps(&b.lo.z), hi_);
  }
  AABBT<float> box() const {
    alignas(16) float l[4], h[4];
    _mm_store_ps(l, lo_);
    _mm_store_ps(h, hi_);
    AABBT<float> b;  // the members set: AABBT(a, b) would order each pair again
    b.lo = Vec3f(l[0], l[1], l[2]);
    b.hi = Vec3f(h[1], h[2], h[3]);
    return b;
  }

 private:
  __m128 lo_, hi_;
};
#endif

// The componentwise min and max of the centres c of keys [first, last) (not empty). Only
// max_axis(hi - lo) is read, so the values matter and not the sign of a zero bound: a
// difference with a zero operand is the other operand (or a zero), and max_axis compares
// -0 and +0 alike. The order of the min/max steps is thus free. With SSE2 the three
// coordinates (and the index's bits, unused) in one register, the keys read aligned
// (Key is 16-byte aligned), four per step into two pairs of bounds: about 3
// instructions a key instead of 9 (the pass is about a quarter of median_split).
template <class Key>
std::pair<Vec3f, Vec3f> centre_bounds(const Key* first, const Key* last) {
#if defined(__SSE2__)
  static_assert(sizeof(Key) == 16 && alignof(Key) == 16 && offsetof(Key, c) == 0);
  __m128 lo0 = _mm_load_ps(first->c), hi0 = lo0, lo1 = lo0, hi1 = lo0;
  const Key* k = first + 1;
  for (; last - k >= 4; k += 4) {
    const __m128 c0 = _mm_load_ps(k[0].c), c1 = _mm_load_ps(k[1].c), c2 = _mm_load_ps(k[2].c),
                 c3 = _mm_load_ps(k[3].c);
    lo0 = _mm_min_ps(_mm_min_ps(lo0, c0), c2);
    hi0 = _mm_max_ps(_mm_max_ps(hi0, c0), c2);
    lo1 = _mm_min_ps(_mm_min_ps(lo1, c1), c3);
    hi1 = _mm_max_ps(_mm_max_ps(hi1, c1), c3);
  }
  for (; k < last; ++k) {
    const __m128 c = _mm_load_ps(k->c);
    lo0 = _mm_min_ps(lo0, c);
    hi0 = _mm_max_ps(hi0, c);
  }
  alignas(16) float l[4], h[4];
  _mm_store_ps(l, _mm_min_ps(lo0, lo1));
  _mm_store_ps(h, _mm_max_ps(hi0, hi1));
  return {Vec3f(l[0], l[1], l[2]), Vec3f(h[0], h[1], h[2])};
#else
  Vec3f lo(first->c[0], first->c[1], first->c[2]), hi = lo;
  for (const Key* k = first + 1; k < last; ++k)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], k->c[a]);
      hi[a] = std::max(hi[a], k->c[a]);
    }
  return {lo, hi};
#endif
}

}  // namespace

// The split key: the box centre rounded to float, packed with the item so that the
// partitioning moves small records in place (16 bytes, aligned for centre_bounds).
template <class T>
struct alignas(16) Bvh<T>::Key {
  float c[3];
  uint32_t idx;
};

namespace {
// The median order on axis A: the centre coordinate, ties by item index. The same
// answers as the run-time-axis `c != c' ? c < c' : idx < idx'` (no NaN: !(y < x) after
// !(x < y) is equality, -0 == +0 alike), so nth_element makes the same moves; a constant
// axis and the common case (x < y) first cost about a fifth fewer instructions.
template <int A>
struct AxisLess {
  template <class Key>
  bool operator()(const Key& x, const Key& y) const {
    return x.c[A] < y.c[A] || (!(y.c[A] < x.c[A]) && x.idx < y.idx);
  }
};

// Keys [b, e) split at m: the axis of the centres' largest spread, ties by index, so the
// halves (and their order) depend on the keys only. Out of line: inlined, the three
// selections made the Morton rule's recursion (ISS) dearer.
template <class Key>
[[gnu::noinline]] void median_split(Key* b, Key* m, Key* e) {
  const auto [lo, hi] = centre_bounds(b, e);
  switch (max_axis(hi - lo)) {
    case 0: std::nth_element(b, m, e, AxisLess<0>()); break;
    case 1: std::nth_element(b, m, e, AxisLess<1>()); break;
    default: std::nth_element(b, m, e, AxisLess<2>()); break;
  }
}
}  // namespace

template <class T>
Bvh<T>::Bvh(const std::vector<Box>& boxes, const BuildRule& rule) : leaf_size_(rule.leaf_size) {
  VG_CHECK(rule.leaf_size >= 1);
  const uint32_t n = uint32_t(boxes.size());
  if (n == 0) return;
  std::vector<Key> keys(n);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kParallelGrain), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i < r.end(); ++i) {
      const Vec3<T> c = boxes[i].center();
      keys[i] = Key{{float(c.x), float(c.y), float(c.z)}, i};
    }
  });
  if (rule.split == Split::MortonHalves) {
    // Morton codes over the centres' box, ordered by a stable LSD radix sort from index
    // order, so equal codes stay in index order.
    AABB cb;
    for (const Key& k : keys) cb.extend(Vec3f(k.c[0], k.c[1], k.c[2]));
    const Vec3f ext = cb.extent();
    std::vector<uint32_t> code(n);
    for (uint32_t i = 0; i < n; ++i) {
      uint32_t q[3];
      for (int a = 0; a < 3; ++a) {
        const float f = ext[a] > 0 ? (keys[i].c[a] - cb.lo[a]) / ext[a] : 0.0f;
        q[a] = uint32_t(std::min(1023.0f, std::max(0.0f, f * 1024.0f)));
      }
      code[i] = (morton_spread10(q[0]) << 2) | (morton_spread10(q[1]) << 1) | morton_spread10(q[2]);
    }
    std::vector<Key> tmp(n);
    std::vector<uint32_t> count(1u << 10);
    for (int pass = 0; pass < 3; ++pass) {
      const int shift = 10 * pass;
      std::fill(count.begin(), count.end(), 0u);
      for (const Key& k : keys) ++count[(code[k.idx] >> shift) & 1023u];
      uint32_t sum = 0;
      for (uint32_t& c : count) {
        const uint32_t v = c;
        c = sum;
        sum += v;
      }
      for (const Key& k : keys) tmp[count[(code[k.idx] >> shift) & 1023u]++] = k;
      keys.swap(tmp);
    }
  }
  // Pre-order slots: the right child of a node over m items follows the left subtree's
  // nodes (floor(m / 2) items, one level down).
  const SubtreeNodes subtree(n, leaf_size_);
  nodes_.resize(subtree.of(0, n));
  struct Builder {
    Bvh& t;
    const std::vector<Box>& boxes;
    std::vector<Key>& keys;
    const SubtreeNodes& subtree;
    bool median;
    // The subtree over keys[begin, end) at depth d as node id and the following
    // subtree.of(d, end - begin) - 1 slots, left subtree first. Returns its box.
    Box operator()(uint32_t begin, uint32_t end, uint32_t id, size_t d) const {
      Node& nd = t.nodes_[id];
      nd.count = end - begin;
      if (end - begin <= t.leaf_size_) {
        BoxUnion<T> box(boxes[keys[begin].idx]);
        for (uint32_t i = begin + 1; i < end; ++i) box.add(boxes[keys[i].idx]);
        nd.box = box.box();
        nd.first = begin;
        return nd.box;
      }
      const uint32_t mid = begin + (end - begin) / 2;
      if (median) {
        median_split(keys.data() + begin, keys.data() + mid, keys.data() + end);
      }
      const uint32_t left = id + 1, right = left + subtree.of(d + 1, mid - begin);
      nd.first = right;
      Box bl, br;
      if (end - begin >= kParallelSubtree) {
        tbb::parallel_invoke([&] { bl = (*this)(begin, mid, left, d + 1); },
                             [&] { br = (*this)(mid, end, right, d + 1); });
      } else {
        bl = (*this)(begin, mid, left, d + 1);
        br = (*this)(mid, end, right, d + 1);
      }
      BoxUnion<T> box(bl);
      box.add(br);
      t.nodes_[id].box = box.box();
      return t.nodes_[id].box;
    }
  };
  Builder{*this, boxes, keys, subtree, rule.split == Split::MedianAxis}(0, n, 0, 0);
  order_.resize(n);
  if (rule.item_boxes) item_boxes_.resize(n);
  tbb::parallel_for(tbb::blocked_range<uint32_t>(0, n, kParallelGrain), [&](const tbb::blocked_range<uint32_t>& r) {
    for (uint32_t i = r.begin(); i < r.end(); ++i) {
      order_[i] = keys[i].idx;
      if (rule.item_boxes) item_boxes_[i] = boxes[keys[i].idx];  // leaf scans read memory in sequence
    }
  });
}

template <class T>
Bvh<T> Bvh<T>::restricted(const Bvh& src, std::span<const uint32_t> keep, const std::function<Box(uint32_t)>& box_of) {
  Bvh t;
  t.leaf_size_ = src.leaf_size_;
  if (src.empty()) return t;
  VG_CHECK(keep.size() >= src.order_.size());
  // Kept items per node, children before parents (pre-order: both children follow i).
  std::vector<uint32_t> kept(src.nodes_.size());
  for (size_t i = src.nodes_.size(); i-- > 0;) {
    const Node& nd = src.nodes_[i];
    if (src.is_leaf(nd)) {
      uint32_t k = 0;
      for (uint32_t p = nd.first; p < nd.first + nd.count; ++p) k += keep[src.order_[p]] != kDropped ? 1 : 0;
      kept[i] = k;
    } else {
      kept[i] = kept[i + 1] + kept[nd.first];
    }
  }
  if (kept[0] == 0) return t;
  t.nodes_.reserve(src.nodes_.size());
  t.order_.reserve(kept[0]);
  // Emits src node i (kept[i] > 0, its items at leaf-order positions [pos, pos +
  // count)) in pre-order; returns the new node's id.
  auto emit = [&](auto& self, uint32_t i, uint32_t pos) -> uint32_t {
    const Node& nd = src.nodes_[i];
    const uint32_t id = uint32_t(t.nodes_.size());
    if (kept[i] == nd.count) {
      // Nothing dropped below: src's subtree as it is (pre-order, so its nodes are i up to
      // its rightmost leaf), its leaves' positions and right children shifted.
      uint32_t last = i;
      while (!src.is_leaf(src.nodes_[last])) last = src.nodes_[last].first;
      const uint32_t first = uint32_t(t.order_.size());
      t.nodes_.insert(t.nodes_.end(), src.nodes_.begin() + i, src.nodes_.begin() + last + 1);
      for (size_t k = id; k < t.nodes_.size(); ++k) {
        Node& x = t.nodes_[k];
        x.first = t.is_leaf(x) ? x.first - pos + first : x.first - i + id;
      }
      t.order_.resize(first + nd.count);
      for (uint32_t p = 0; p < nd.count; ++p) t.order_[first + p] = keep[src.order_[pos + p]];
      return id;
    }
    if (!src.is_leaf(nd) && kept[i] > t.leaf_size_) {
      const uint32_t l = i + 1, r = nd.first;
      if (kept[r] == 0) return self(self, l, pos);
      if (kept[l] == 0) return self(self, r, pos + src.nodes_[l].count);
      t.nodes_.emplace_back();
      self(self, l, pos);
      const uint32_t right = self(self, r, pos + src.nodes_[l].count);
      Node& out = t.nodes_[id];
      out.first = right;
      out.count = kept[i];
      BoxUnion<T> box(t.nodes_[id + 1].box);
      box.add(t.nodes_[right].box);
      out.box = box.box();
      return id;
    }
    // A leaf that lost items, or a subtree left with at most leaf_size items.
    t.nodes_.emplace_back();
    const uint32_t first = uint32_t(t.order_.size());
    for (uint32_t p = pos; p < pos + nd.count; ++p)
      if (const uint32_t k = keep[src.order_[p]]; k != kDropped) t.order_.push_back(k);
    Node& out = t.nodes_[id];
    out.first = first;
    out.count = kept[i];
    BoxUnion<T> box(box_of(t.order_[first]));
    for (uint32_t p = first + 1; p < first + out.count; ++p) box.add(box_of(t.order_[p]));
    out.box = box.box();
    return id;
  };
  emit(emit, 0, 0);
  return t;
}

template class Bvh<float>;
template class Bvh<double>;

}  // namespace visgate::accel
