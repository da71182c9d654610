// lib/repair/weld.cpp: welding by exact distance, against all pairs decided one by one;
// chained clusters in chain and strict mode.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "tests/support/repair_fixtures.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

// The weld decides |p - q| <= T exactly: a pair at exactly T merges, the next double
// above does not.
TEST(RepairWeld, ToleranceBoundaryIsExact) {
  std::vector<Vec3d> p = {{0, 0, 0}, {0.375, 0, 0}};
  std::vector<uint8_t> used(2, 1);
  EXPECT_EQ(weld_vertices_exact(p, used, 0.375, WeldMode::Chain, kEx).merged, 1u);
  EXPECT_EQ(weld_vertices_exact(p, used, std::nextafter(0.375, 0.0), WeldMode::Chain, kEx).merged, 0u);
  // 3-4-5 triangle far from the origin: distance exactly 5e-3 * 2^-? is not a double, so
  // use a dyadic one: (3, 4) * 2^-10 has length 5 * 2^-10 exactly.
  std::vector<Vec3d> q = {{1e6, -1e6, 7}, {1e6 + 3 * 0x1p-10, -1e6 + 4 * 0x1p-10, 7}};
  EXPECT_EQ(weld_vertices_exact(q, used, 5 * 0x1p-10, WeldMode::Chain, kEx).merged, 1u);
  EXPECT_EQ(weld_vertices_exact(q, used, std::nextafter(5 * 0x1p-10, 0.0), WeldMode::Chain, kEx).merged, 0u);
  // Exact mode: -0 equals +0.
  std::vector<Vec3d> z = {{0.0, 1, 2}, {-0.0, 1, 2}};
  EXPECT_EQ(weld_vertices_exact(z, used, 0.0, WeldMode::Chain, kEx).merged, 1u);
}

// The spatial hash misses no pair: clusters equal those of union-find over all pairs
// decided exactly, on points where many pairs sit exactly at distance T (a dyadic grid
// of step T on two axes, so neighbours are T apart when T is dyadic), others a few ulps
// beyond it, far from the origin and across cell boundaries.
TEST(RepairWeld, MatchesAllPairsBruteForce) {
  Rng rng(21);
  for (double T : {0.25, 0x1p-20, 3e-7}) {
    std::vector<Vec3d> p;
    const Vec3d o(1e5, -2e5, 7);
    for (int i = 0; i < 700; ++i) {
      Vec3d q = o + Vec3d(double(rng.below(12)) * T, double(rng.below(12)) * T, double(rng.below(3)) * 3 * T);
      if (rng.below(3) == 0) q.x = ulps(q.x, int(rng.below(5)) - 2);
      p.push_back(q);
    }
    std::vector<uint8_t> used(p.size(), 1);
    WeldResult w = weld_vertices_exact(p, used, T, WeldMode::Chain, kEx);
    // Brute force: union-find with the lowest index as root.
    std::vector<uint32_t> root(p.size());
    std::iota(root.begin(), root.end(), 0u);
    std::function<uint32_t(uint32_t)> find = [&](uint32_t x) { return root[x] == x ? x : root[x] = find(root[x]); };
    size_t exact_t = 0;
    for (uint32_t i = 0; i < p.size(); ++i)
      for (uint32_t j = i + 1; j < p.size(); ++j) {
        const int c = kEx.compare_distance(p[i], p[j], T);
        exact_t += c == 0;
        if (c <= 0) {
          uint32_t a = find(i), b = find(j);
          if (a != b) root[std::max(a, b)] = std::min(a, b);
        }
      }
    std::vector<uint32_t> want(p.size());
    for (uint32_t i = 0; i < p.size(); ++i) want[i] = find(i);
    if (T != 3e-7) {
      EXPECT_GT(exact_t, 100u) << "T " << T;  // dyadic T: the boundary case is exercised
    }
    EXPECT_EQ(w.rep, want) << "T " << T;
  }
}

// Chaining: v0, v1, v2 on a line 0.6 T apart. Chain mode merges all three (diameter
// 1.2 T, reported); strict mode refuses, merging {v0, v1} and keeping v2.
TEST(RepairWeld, ChainingIsReportedAndStrictModeRefusesIt) {
  const double T = 1.0;
  std::vector<Vec3d> p = {{0, 0, 0}, {0.625, 0, 0}, {1.25, 0, 0}, {10, 0, 0}};
  std::vector<uint8_t> used(4, 1);
  WeldResult c = weld_vertices_exact(p, used, T, WeldMode::Chain, kEx);
  EXPECT_EQ(c.merged, 2u);
  EXPECT_EQ(c.clusters, 1u);
  ASSERT_EQ(c.chained.size(), 1u);
  EXPECT_EQ(c.chained[0].vertices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_DOUBLE_EQ(c.chained[0].diameter, 1.25);
  EXPECT_EQ(c.rep, (std::vector<uint32_t>{0, 0, 0, 3}));
  WeldResult s = weld_vertices_exact(p, used, T, WeldMode::Strict, kEx);
  EXPECT_EQ(s.merged, 1u);
  EXPECT_EQ(s.strict_splits, 1u);
  EXPECT_EQ(s.rep, (std::vector<uint32_t>{0, 0, 2, 3}));

  // Through repair_mesh: three triangles hanging off w0 = 0, w1 = 0.9, w2 = -0.5 (on x).
  // Chain: w2-w0-w1 is one cluster of diameter 1.4 > T. Strict: w2 is 1.4 from w1, so
  // it keeps its own vertex, still 0.5 (<= T) from the merged w0: one near-duplicate
  // vertex remains and is reported.
  PolygonSoup soup = make_soup({{0, 0, 0}, {0.9, 0, 0}, {-0.5, 0, 0}, {0, 5, 0}, {0, 0, 5}, {0, -5, 0}, {0, 0, -5}, {5, 5, 5}, {5, -5, 5}},
                               {{0, 3, 4}, {1, 5, 6}, {2, 7, 8}});
  RepairOptions o;
  o.weld_tolerance = T;
  o.weld_mode = WeldMode::Strict;
  RepairResult r = run(soup, o);
  EXPECT_EQ(r.before.defects.near_duplicate_vertices, 2u);
  EXPECT_EQ(r.after.defects.near_duplicate_vertices, 1u);
}
