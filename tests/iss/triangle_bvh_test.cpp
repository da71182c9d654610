// lib/iss/triangle_bvh.h: box and shaft queries of the triangle BVH.
#include <gtest/gtest.h>

#include <random>

#include "lib/iss/shaft.h"
#include "lib/iss/triangle_bvh.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(IssBvh, QueriesReturnEverySelectedTriangleSorted) {
  // Property against brute force: query_box returns exactly the boxes that overlap,
  // query_shaft a superset of those ShaftGeometry::may_intersect_box accepts; both in
  // index order. Near and far from the origin, with flat (axis-plane) boxes and
  // identical boxes (degenerate splits).
  std::mt19937 rng(11);
  for (double off : {0.0, 3e5}) {
    std::uniform_real_distribution<float> u(-10, 10), e(0, 1.5f);
    std::vector<AABB> boxes;
    for (int i = 0; i < 3000; ++i) {
      Vec3f lo(float(off) + u(rng), u(rng), u(rng));
      Vec3f hi = lo + Vec3f(e(rng), i % 7 == 0 ? 0.0f : e(rng), e(rng));
      boxes.emplace_back(lo, hi);
      if (i % 50 == 0) boxes.push_back(boxes.back());
    }
    iss::TriangleBvh bvh(boxes);
    std::vector<uint32_t> got;
    for (int q = 0; q < 40; ++q) {
      Vec3f a(float(off) + u(rng), u(rng), u(rng));
      AABB qb(a, a + Vec3f(3 * e(rng), 3 * e(rng), q % 5 == 0 ? 0.0f : 3 * e(rng)));
      bvh.query_box(qb, got);
      std::vector<uint32_t> want;
      for (uint32_t i = 0; i < boxes.size(); ++i)
        if (boxes[i].overlaps(qb)) want.push_back(i);
      EXPECT_EQ(got, want);
      Vec3f b(float(off) + u(rng), u(rng), u(rng) + 25);
      AABB lb(b, b + Vec3f(e(rng), e(rng), 0));
      iss::ShaftGeometry g(qb, lb, iss::choose_main_axis(qb, lb), off + 40);
      bvh.query_shaft(g, got);
      EXPECT_TRUE(std::is_sorted(got.begin(), got.end()));
      for (uint32_t i = 0; i < boxes.size(); ++i) {
        if (g.may_intersect_box(iss::to_double(boxes[i]))) {
          EXPECT_TRUE(std::binary_search(got.begin(), got.end(), i)) << "box " << i << " missing";
        }
      }
    }
  }
  const std::vector<AABB> none;
  iss::TriangleBvh empty(none);
  std::vector<uint32_t> got{7};
  empty.query_box(AABB(Vec3f(0, 0, 0), Vec3f(1, 1, 1)), got);
  EXPECT_TRUE(got.empty());
}

TEST(IssBvh, SeveralShaftsQueryIsTheUnionOfTheBoxTests) {
  // Property against brute force: query_shafts returns, in index order, exactly the
  // triangles whose box some shaft's may_intersect_box accepts (each triangle is tested;
  // a node containing an accepted box is accepted too, the test being monotone in the
  // box). Shafts from one receiver box to lights around it, with and without a main
  // axis (overlapping boxes).
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-10, 10), e(0, 1.5f);
  std::vector<AABB> boxes;
  for (int i = 0; i < 4000; ++i) {
    Vec3f lo(u(rng), u(rng), u(rng));
    boxes.emplace_back(lo, lo + Vec3f(e(rng), e(rng), i % 9 == 0 ? 0.0f : e(rng)));
  }
  iss::TriangleBvh bvh(boxes);
  const AABB rb(Vec3f(-3, -3, -10), Vec3f(3, 3, -9));
  for (int n = 1; n <= 4; ++n) {
    std::vector<iss::ShaftGeometry> gs;
    for (int k = 0; k < n; ++k) {
      Vec3f c(u(rng), u(rng), k == 3 ? -9.5f : 8.0f + float(k));
      AABB lb(c, c + Vec3f(0.5f, 0.5f, 0));
      const iss::MainAxis ax = k == 3 ? iss::MainAxis{} : iss::choose_main_axis(rb, lb);
      gs.emplace_back(rb, lb, ax, 20.0);
    }
    std::vector<uint32_t> got, want;
    bvh.query_shafts(gs, got);
    for (uint32_t i = 0; i < boxes.size(); ++i)
      for (const iss::ShaftGeometry& g : gs)
        if (g.may_intersect_box(iss::to_double(boxes[i]))) {
          want.push_back(i);
          break;
        }
    EXPECT_EQ(got, want) << n << " shafts";
    EXPECT_LT(want.size(), boxes.size()) << "the shafts leave some out";
  }
}
