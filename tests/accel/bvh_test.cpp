// lib/accel/bvh.h: the shared hierarchy, float and double, every build rule. Queries
// (boxes, segments) against brute force over random boxes; the shape and the rules'
// orders checked as properties.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "lib/accel/bvh.h"
#include "tests/support/bvh_walk.h"
#include "tests/support/random_boxes.h"

using namespace visgate;
using namespace visgate::accel;

namespace {

template <class T>
using Boxes = std::vector<AABBT<T>>;

template <class T>
Boxes<T> random_boxes(size_t n, uint32_t seed, double offset = 0.0, double extent = 100.0) {
  return test::random_boxes<T>(n, seed, offset, extent, extent / 20);
}

std::vector<BuildRule> every_rule() {
  std::vector<BuildRule> rules;
  for (Split s : {Split::MortonHalves, Split::MedianAxis})
    for (uint32_t leaf : {1u, 4u, 8u})
      for (bool keep : {false, true}) rules.push_back(BuildRule{s, leaf, keep});
  return rules;
}

std::string name(const BuildRule& r) {
  return std::string(r.split == Split::MortonHalves ? "morton" : "median") + "/leaf " + std::to_string(r.leaf_size) +
         (r.item_boxes ? "/item boxes" : "");
}

// Items reached by a conservative predicate, each leaf item tested by it too.
template <class T, class Pred>
std::vector<uint32_t> tree_query(const Bvh<T>& t, const Boxes<T>& boxes, Pred pred, bool use_item_boxes) {
  std::vector<uint32_t> out;
  if (use_item_boxes) {
    t.query_if(pred, [&](uint32_t i) { out.push_back(i); });
  } else {
    t.for_each_leaf(pred, [&](const typename Bvh<T>::Node& leaf) {
      for (uint32_t i : t.leaf_items(leaf))
        if (pred(boxes[i])) out.push_back(i);
    });
  }
  std::sort(out.begin(), out.end());
  return out;
}

template <class T, class Pred>
std::vector<uint32_t> brute_query(const Boxes<T>& boxes, Pred pred) {
  std::vector<uint32_t> out;
  for (uint32_t i = 0; i < boxes.size(); ++i)
    if (pred(boxes[i])) out.push_back(i);
  return out;
}

// Segment p + t (q - p), t in [0, 1], against a box by slabs, in double. Monotone under
// box containment (every rounding is), so conservative for node boxes.
template <class T>
bool segment_meets_box(const Vec3d& p, const Vec3d& q, const AABBT<T>& b) {
  double t0 = 0.0, t1 = 1.0;
  for (int a = 0; a < 3; ++a) {
    const double d = q[a] - p[a], lo = double(b.lo[a]) - p[a], hi = double(b.hi[a]) - p[a];
    if (d == 0.0) {
      if (lo > 0.0 || hi < 0.0) return false;
      continue;
    }
    double ta = lo / d, tb = hi / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// Every node: count of items below, halving shape, box = exact union of the items' boxes;
// the leaves cover every item once; kept item boxes are the items' boxes.
template <class T>
void expect_shape(const Bvh<T>& t, const Boxes<T>& boxes, const BuildRule& rule) {
  const uint32_t leaf_size = rule.leaf_size;
  std::vector<int> seen(boxes.size(), 0);
  // (node, first position, count) from the root down.
  struct Item {
    uint32_t node, first, count;
  };
  std::vector<Item> stack{{0, 0, uint32_t(boxes.size())}};
  size_t nodes = 0;
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    ++nodes;
    const auto& nd = t.node(it.node);
    ASSERT_EQ(nd.count, it.count);
    AABBT<T> u;
    for (uint32_t k = it.first; k < it.first + it.count; ++k) u.extend(boxes[t.item(k)]);
    EXPECT_EQ(nd.box.lo, u.lo);
    EXPECT_EQ(nd.box.hi, u.hi);
    if (it.count <= leaf_size) {
      ASSERT_TRUE(t.is_leaf(nd));
      EXPECT_EQ(nd.first, it.first);
      for (uint32_t k = it.first; k < it.first + it.count; ++k) {
        ++seen[t.item(k)];
        if (rule.item_boxes) {
          EXPECT_EQ(t.item_box(k).lo, boxes[t.item(k)].lo);
          EXPECT_EQ(t.item_box(k).hi, boxes[t.item(k)].hi);
        }
      }
      continue;
    }
    ASSERT_FALSE(t.is_leaf(nd));
    stack.push_back({t.left(it.node), it.first, it.count / 2});
    stack.push_back({t.right(it.node), it.first + it.count / 2, it.count - it.count / 2});
  }
  EXPECT_EQ(nodes, t.node_count());
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], 1) << "item " << i;
}

template <class T>
class BvhTest : public ::testing::Test {};
using Scalars = ::testing::Types<float, double>;
TYPED_TEST_SUITE(BvhTest, Scalars);

}  // namespace

TYPED_TEST(BvhTest, EmptyAndSingle) {
  using T = TypeParam;
  for (const BuildRule& r : every_rule()) {
    Bvh<T> none(Boxes<T>{}, r);
    EXPECT_TRUE(none.empty());
    EXPECT_EQ(none.node_count(), 0u);
    int calls = 0;
    none.for_each_leaf([](const AABBT<T>&) { return true; }, [&](const auto&) { ++calls; });
    EXPECT_EQ(calls, 0);
    Boxes<T> one{AABBT<T>(Vec3<T>(1, 2, 3), Vec3<T>(4, 5, 6))};
    Bvh<T> single(one, r);
    EXPECT_EQ(single.node_count(), 1u);
    EXPECT_EQ(tree_query(single, one, [](const AABBT<T>&) { return true; }, r.item_boxes),
              std::vector<uint32_t>{0});
  }
}

TYPED_TEST(BvhTest, ShapeIsHalvingWithExactUnionBoxes) {
  using T = TypeParam;
  for (size_t n : {2u, 5u, 9u, 40u, 333u, 1000u})
    for (const BuildRule& r : every_rule()) {
      SCOPED_TRACE(name(r) + " n=" + std::to_string(n));
      const Boxes<T> boxes = random_boxes<T>(n, uint32_t(n) * 7 + 1);
      Bvh<T> t(boxes, r);
      expect_shape(t, boxes, r);
    }
}

TYPED_TEST(BvhTest, BoxQueriesMatchBruteForce) {
  using T = TypeParam;
  for (const BuildRule& r : every_rule())
    for (double offset : {0.0, -1e6, 3e7}) {
      SCOPED_TRACE(name(r) + " offset " + std::to_string(offset));
      const Boxes<T> boxes = random_boxes<T>(700, 11, offset);
      Bvh<T> t(boxes, r);
      const Boxes<T> queries = random_boxes<T>(60, 12, offset - 10, 120);
      for (const AABBT<T>& q : queries) {
        auto pred = [&](const AABBT<T>& b) { return b.overlaps(q); };
        EXPECT_EQ(tree_query(t, boxes, pred, r.item_boxes), brute_query(boxes, pred));
      }
      // Every item, and the item itself, when the query is an item's own box.
      for (uint32_t i = 0; i < boxes.size(); i += 37) {
        auto pred = [&](const AABBT<T>& b) { return b.overlaps(boxes[i]); };
        const auto got = tree_query(t, boxes, pred, r.item_boxes);
        EXPECT_TRUE(std::binary_search(got.begin(), got.end(), i));
        EXPECT_EQ(got, brute_query(boxes, pred));
      }
    }
}

TYPED_TEST(BvhTest, SegmentQueriesMatchBruteForce) {
  using T = TypeParam;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-20.0, 120.0);
  for (const BuildRule& r : every_rule()) {
    SCOPED_TRACE(name(r));
    const Boxes<T> boxes = random_boxes<T>(500, 21);
    Bvh<T> t(boxes, r);
    for (int k = 0; k < 80; ++k) {
      Vec3d p(u(rng), u(rng), u(rng)), q(u(rng), u(rng), u(rng));
      if (k % 8 == 0) q = Vec3d(p.x, p.y, q.z);  // axis-parallel: zero direction components
      auto pred = [&](const AABBT<T>& b) { return segment_meets_box(p, q, b); };
      EXPECT_EQ(tree_query(t, boxes, pred, r.item_boxes), brute_query(boxes, pred));
    }
  }
}

TYPED_TEST(BvhTest, InfiniteBoxesAreFound) {
  using T = TypeParam;
  const T inf = std::numeric_limits<T>::infinity();
  Boxes<T> boxes = random_boxes<T>(100, 3);
  boxes[17].hi.x = inf;
  boxes[42].lo = Vec3<T>(-inf, -inf, -inf);
  for (const BuildRule& r : every_rule()) {
    SCOPED_TRACE(name(r));
    Bvh<T> t(boxes, r);
    // Far along +x beside item 17, far along -x beside item 42.
    for (auto [i, x] : {std::pair<uint32_t, T>{17, T(1e4)}, std::pair<uint32_t, T>{42, T(-1e4)}}) {
      const AABBT<T> q(Vec3<T>(x, boxes[i].hi.y, boxes[i].hi.z), Vec3<T>(x + 1, boxes[i].hi.y + 1, boxes[i].hi.z + 1));
      auto pred = [&](const AABBT<T>& b) { return b.overlaps(q); };
      const auto got = tree_query(t, boxes, pred, r.item_boxes);
      EXPECT_EQ(got, brute_query(boxes, pred));
      EXPECT_TRUE(std::binary_search(got.begin(), got.end(), i));
    }
  }
}

TYPED_TEST(BvhTest, MedianRuleSplitsAtTheMedianOfTheWidestAxis) {
  // Each inner node's left half holds the floor(n / 2) smallest (centre, index) keys on
  // the axis of the largest centre spread of its items.
  using T = TypeParam;
  const Boxes<T> boxes = random_boxes<T>(300, 9);
  auto key = [&](uint32_t i, int a) { return float(boxes[i].center()[a]); };
  Bvh<T> t(boxes, BuildRule{Split::MedianAxis, 4, false});
  struct Item {
    uint32_t node, first, count;
  };
  std::vector<Item> stack{{0, 0, uint32_t(boxes.size())}};
  while (!stack.empty()) {
    const Item it = stack.back();
    stack.pop_back();
    if (it.count <= 4) continue;
    const float inf = std::numeric_limits<float>::infinity();
    Vec3f lo(inf, inf, inf), hi(-inf, -inf, -inf);
    for (uint32_t k = it.first; k < it.first + it.count; ++k)
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], key(t.item(k), a));
        hi[a] = std::max(hi[a], key(t.item(k), a));
      }
    const Vec3f ext = hi - lo;
    const int axis = ext.x >= ext.y && ext.x >= ext.z ? 0 : (ext.y >= ext.z ? 1 : 2);
    const uint32_t mid = it.first + it.count / 2;
    auto less = [&](uint32_t x, uint32_t y) { return key(x, axis) != key(y, axis) ? key(x, axis) < key(y, axis) : x < y; };
    for (uint32_t a = it.first; a < mid; ++a)
      for (uint32_t b = mid; b < it.first + it.count; ++b) ASSERT_TRUE(less(t.item(a), t.item(b)));
    stack.push_back({t.left(it.node), it.first, it.count / 2});
    stack.push_back({t.right(it.node), mid, it.count - it.count / 2});
  }
}

TYPED_TEST(BvhTest, MortonRuleOrdersByCodeThenIndex) {
  // Leaf order is the stable sort by Morton code: codes never decrease, and equal codes
  // keep index order. Codes computed here from the definition (bit interleaving).
  using T = TypeParam;
  const Boxes<T> boxes = random_boxes<T>(400, 13);
  AABB cb;
  for (const auto& b : boxes) {
    const Vec3<T> c = b.center();
    cb.extend(Vec3f(float(c.x), float(c.y), float(c.z)));
  }
  auto code = [&](uint32_t i) {
    const Vec3<T> c = boxes[i].center();
    const float cf[3] = {float(c.x), float(c.y), float(c.z)};
    uint32_t q[3];
    for (int a = 0; a < 3; ++a) {
      const float ext = cb.hi[a] - cb.lo[a];
      const float f = ext > 0 ? (cf[a] - cb.lo[a]) / ext : 0.0f;
      q[a] = uint32_t(std::min(1023.0f, std::max(0.0f, f * 1024.0f)));
    }
    uint64_t m = 0;
    for (int bit = 9; bit >= 0; --bit)
      for (int a = 0; a < 3; ++a) m = (m << 1) | ((q[a] >> bit) & 1u);
    return m;
  };
  Bvh<T> t(boxes, BuildRule{Split::MortonHalves, 8, false});
  for (uint32_t k = 1; k < boxes.size(); ++k) {
    const uint32_t a = t.item(k - 1), b = t.item(k);
    ASSERT_TRUE(code(a) < code(b) || (code(a) == code(b) && a < b)) << k;
  }
}

TYPED_TEST(BvhTest, AllCentresEqual) {
  // No spread on any axis: the median rule falls back to index order, the Morton rule to
  // one code; both still find every item.
  using T = TypeParam;
  Boxes<T> boxes;
  for (int i = 0; i < 50; ++i) boxes.push_back(AABBT<T>(Vec3<T>(T(-i), 0, 0), Vec3<T>(T(i), 0, 0)));
  for (const BuildRule& r : every_rule()) {
    SCOPED_TRACE(name(r));
    Bvh<T> t(boxes, r);
    expect_shape(t, boxes, r);
    // Index order down to the leaves (inside a median leaf, nth_element's order).
    t.for_each_leaf([](const AABBT<T>&) { return true; }, [&](const typename Bvh<T>::Node& leaf) {
      std::vector<uint32_t> items(t.leaf_items(leaf).begin(), t.leaf_items(leaf).end());
      std::sort(items.begin(), items.end());
      for (uint32_t k = 0; k < leaf.count; ++k) EXPECT_EQ(items[k], leaf.first + k);
    });
    const AABBT<T> q(Vec3<T>(T(30.5), 0, 0), Vec3<T>(T(40), 0, 0));
    auto pred = [&](const AABBT<T>& b) { return b.overlaps(q); };
    EXPECT_EQ(tree_query(t, boxes, pred, r.item_boxes), brute_query(boxes, pred));
  }
}

namespace {

// The median build of lib/accel/bvh.cpp at 09bde24, kept as the reference: float
// centres, at each node nth_element on the widest centre axis with the comparison
// (coordinate, then index) written with a run-time axis, pre-order nodes.
template <class T>
struct ReferenceMedianTree {
  struct Key {
    float c[3];
    uint32_t idx;
  };
  std::vector<typename Bvh<T>::Node> nodes;
  std::vector<Key> keys;
  const Boxes<T>& boxes;
  uint32_t leaf;

  ReferenceMedianTree(const Boxes<T>& b, uint32_t leaf_size) : boxes(b), leaf(leaf_size) {
    for (uint32_t i = 0; i < b.size(); ++i) {
      const Vec3<T> c = b[i].center();
      keys.push_back(Key{{float(c.x), float(c.y), float(c.z)}, i});
    }
    if (!b.empty()) build(0, uint32_t(b.size()));
  }
  AABBT<T> build(uint32_t begin, uint32_t end) {
    const size_t id = nodes.size();
    nodes.emplace_back();
    nodes[id].count = end - begin;
    AABBT<T> box;
    if (end - begin <= leaf) {
      for (uint32_t i = begin; i < end; ++i) box.extend(boxes[keys[i].idx]);
      nodes[id].first = begin;
    } else {
      Vec3f lo(keys[begin].c[0], keys[begin].c[1], keys[begin].c[2]), hi = lo;
      for (uint32_t i = begin + 1; i < end; ++i)
        for (int a = 0; a < 3; ++a) {
          lo[a] = std::min(lo[a], keys[i].c[a]);
          hi[a] = std::max(hi[a], keys[i].c[a]);
        }
      const int axis = max_axis(hi - lo);
      const uint32_t mid = begin + (end - begin) / 2;
      std::nth_element(keys.begin() + begin, keys.begin() + mid, keys.begin() + end, [axis](const Key& x, const Key& y) {
        return x.c[axis] != y.c[axis] ? x.c[axis] < y.c[axis] : x.idx < y.idx;
      });
      box = build(begin, mid);
      nodes[id].first = uint32_t(nodes.size());
      box.extend(build(mid, end));
    }
    nodes[id].box = box;
    return box;
  }
};

// Soups whose centres tie often: coordinates on a coarse grid (many equal on one axis,
// some items with all three equal), a quarter points, some at -0 and +0 (equal keys of
// different bits), and plain random boxes.
template <class T>
Boxes<T> tie_soup(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  Boxes<T> out = test::random_boxes<T>(n / 2, seed, -50.0, 100.0, 5.0);
  auto grid = [&](int cells) { return T(int(rng() % uint32_t(cells)) - cells / 2); };
  while (out.size() < n) {
    switch (rng() % 4) {
      case 0: {  // a point at the grid, with signed zeros
        Vec3<T> p(grid(9), grid(9), grid(9));
        for (int a = 0; a < 3; ++a)
          if (p[a] == 0 && rng() % 2) p[a] = -T(0);
        out.push_back(AABBT<T>(p, p));
        break;
      }
      case 1: {  // symmetric about a grid point: the same centre, other boxes
        const Vec3<T> c(grid(5), grid(5), grid(5));
        const Vec3<T> h(T(rng() % 7), T(rng() % 7), T(rng() % 7));
        out.push_back(AABBT<T>(c - h, c + h));
        break;
      }
      case 2:  // a duplicate
        out.push_back(out[rng() % out.size()]);
        break;
      default: {  // flat on one axis
        AABBT<T> b = test::random_boxes<T>(1, uint32_t(rng()), -20.0, 40.0, 8.0)[0];
        const int a = int(rng() % 3);
        b.lo[a] = b.hi[a] = grid(3);
        out.push_back(b);
      }
    }
  }
  std::shuffle(out.begin(), out.end(), rng);
  return out;
}

}  // namespace

TYPED_TEST(BvhTest, MedianTreeIsTheReferenceBuildNodeByNode) {
  // Against the kept reference: every node's box (bit for bit), count and right child, and the leaf
  // order (so the item order within leaves and nodes, which nth_element's moves decide).
  // Sizes across the parallel grain and subtree (1 << 14, 1 << 15).
  using T = TypeParam;
  for (uint32_t leaf : {1u, 4u, 8u})
    for (size_t n : {size_t(1), size_t(9), size_t(2047), size_t(2048), size_t(2049), size_t(5000), size_t(40000)}) {
      if (n == 40000 && leaf != 4) continue;
      for (uint32_t seed : {1u, 2u}) {
        const Boxes<T> boxes = seed == 1 ? tie_soup<T>(n, seed) : random_boxes<T>(n, seed, -30.0);
        SCOPED_TRACE("leaf " + std::to_string(leaf) + ", n " + std::to_string(n) + ", seed " + std::to_string(seed));
        const Bvh<T> t(boxes, BuildRule{Split::MedianAxis, leaf, true});
        const ReferenceMedianTree<T> ref(boxes, leaf);
        ASSERT_EQ(t.node_count(), ref.nodes.size());
        for (uint32_t i = 0; i < ref.nodes.size(); ++i) {
          const auto &a = t.node(i), &b = ref.nodes[i];
          ASSERT_EQ(a.count, b.count) << i;
          ASSERT_EQ(a.first, b.first) << i;
          // Bit for bit: equal values and equal signs (no NaN), so -0 against +0 fails.
          for (int k = 0; k < 3; ++k) {
            ASSERT_TRUE(a.box.lo[k] == b.box.lo[k] && std::signbit(a.box.lo[k]) == std::signbit(b.box.lo[k])) << i;
            ASSERT_TRUE(a.box.hi[k] == b.box.hi[k] && std::signbit(a.box.hi[k]) == std::signbit(b.box.hi[k])) << i;
          }
        }
        for (uint32_t k = 0; k < n; ++k) {
          ASSERT_EQ(t.item(k), ref.keys[k].idx) << k;
          const AABBT<T>& b = t.item_box(k);
          ASSERT_TRUE(b.lo == boxes[ref.keys[k].idx].lo && b.hi == boxes[ref.keys[k].idx].hi) << k;
        }
      }
    }
}

namespace {

// Checks `r`, src restricted by `keep`, against brute force: r's leaf order is src's with
// the dropped items left out (renumbered by keep), every item in one leaf; per node its
// count is the items below it and its box the componentwise min/max of their boxes
// (boxes[item], by value); inner nodes have more than leaf_size items and two children
// (left at i + 1), leaves at most leaf_size.
template <class T>
void expect_restriction(const Bvh<T>& src, const Boxes<T>& src_boxes, const std::vector<uint32_t>& keep,
                        const Bvh<T>& r, const std::string& what) {
  std::vector<uint32_t> want;
  for (uint32_t item : src.order())
    if (keep[item] != Bvh<T>::kDropped) want.push_back(keep[item]);
  ASSERT_TRUE(std::equal(want.begin(), want.end(), r.order().begin(), r.order().end())) << what;
  ASSERT_EQ(r.empty(), want.empty()) << what;
  if (r.empty()) return;
  std::vector<AABBT<T>> boxes(want.size());
  for (uint32_t item = 0; item < keep.size(); ++item)
    if (keep[item] != Bvh<T>::kDropped) boxes[keep[item]] = src_boxes[item];
  // Per node the union of its items' boxes, by value.
  test::expect_bvh_shape(r, [&](uint32_t i, uint32_t pos) {
    const auto& nd = r.node(i);
    AABBT<T> u;
    for (uint32_t p = pos; p < pos + nd.count; ++p) {
      const AABBT<T>& b = boxes[r.item(p)];
      for (int a = 0; a < 3; ++a) {
        u.lo[a] = std::min(u.lo[a], b.lo[a]);
        u.hi[a] = std::max(u.hi[a], b.hi[a]);
      }
    }
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(nd.box.lo[a], u.lo[a]) << what << " node " << i << " axis " << a;
      ASSERT_EQ(nd.box.hi[a], u.hi[a]) << what << " node " << i << " axis " << a;
    }
  });
}

template <class T>
void check_restrictions() {
  std::mt19937 rng(7);
  for (uint32_t leaf : {1u, 4u, 8u})
    for (size_t n : {1u, 5u, 40u, 1000u, 20000u}) {
      const Boxes<T> boxes = random_boxes<T>(n, uint32_t(n * 31 + leaf));
      const Bvh<T> src(boxes, BuildRule{Split::MedianAxis, leaf, false});
      // Kept shares from nothing to everything, random and in runs (whole subtrees
      // dropped), and the one item kept.
      for (double share : {0.0, 0.02, 0.5, 0.9, 0.999, 1.0})
        for (int runs = 0; runs < 2; ++runs) {
          std::vector<uint32_t> keep(n, Bvh<T>::kDropped);
          std::uniform_real_distribution<double> u(0.0, 1.0);
          uint32_t next = 0;
          for (size_t i = 0; i < n; ++i) {
            const bool in = runs ? (double((i * 7919) % n) / double(n) < share) : u(rng) < share;
            if (in) keep[i] = next++;
          }
          std::vector<uint32_t> item_of(next);
          for (uint32_t i = 0; i < n; ++i)
            if (keep[i] != Bvh<T>::kDropped) item_of[keep[i]] = i;
          const Bvh<T> r = Bvh<T>::restricted(src, keep, [&](uint32_t k) { return boxes[item_of.at(k)]; });
          expect_restriction(src, boxes, keep, r,
                             "leaf " + std::to_string(leaf) + " n " + std::to_string(n) + " share " +
                                 std::to_string(share) + " runs " + std::to_string(runs));
          if (share == 1.0) {
            ASSERT_EQ(r.node_count(), src.node_count());
          }
        }
      std::vector<uint32_t> one(n, Bvh<T>::kDropped);
      one[n / 2] = 0;
      const Bvh<T> r = Bvh<T>::restricted(src, one, [&](uint32_t) { return boxes[n / 2]; });
      expect_restriction(src, boxes, one, r, "one item");
      ASSERT_EQ(r.node_count(), 1u);
    }
}

}  // namespace

// Bvh::restricted against brute force: the leaf order filtered, every kept item in one
// leaf, counts and boxes those of the items below each node (exact unions).
TEST(BvhTest, RestrictedTreeIsTheFilteredLeafOrderWithExactBoxes) {
  check_restrictions<float>();
  check_restrictions<double>();
}
