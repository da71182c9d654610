// lib/ssv/wedge_bsp.h: the lazy wedge BSP against a linear scan.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "lib/ssv/wedge.h"
#include "lib/ssv/wedge_bsp.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

TEST(SsvWedge, BspQueryReportsEveryWedgeContainingThePoint) {
  // Lazy BSP against a linear scan: every wedge that contains the point (and, with
  // silhouette regions, whose edge is a silhouette from it) must be reported.
  Scene s = random_scene(12, 16, 400);
  auto [pm, frame, fp, edges, counts, wedges] = make_wedges(s);
  AABB root = s.bounds();
  const float eps = float(4e-6 * 4);
  for (bool regions : {true, false}) {
    WedgeBsp bsp(wedges, root, max_component(root.extent()) / 200.0f, eps, regions);
    std::mt19937_64 g(5);
    size_t must = 0;
    for (const Receiver& rc : s.receivers) {
      std::vector<uint32_t> got;
      bsp.query(rc.p, got);
      std::sort(got.begin(), got.end());
      EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << "a wedge reported twice";
      for (size_t wi = 0; wi < wedges.size(); ++wi) {
        const Wedge& w = wedges[wi];
        if (!point_in_wedge(w, rc.p, -eps)) continue;  // clearly inside only
        if (regions && w.has_region) {
          float f1 = w.tri[0].eval(rc.p), f2 = w.tri[1].eval(rc.p);
          if (!((f1 > eps && f2 < -eps) || (f1 < -eps && f2 > eps))) continue;
        }
        ++must;
        EXPECT_TRUE(std::binary_search(got.begin(), got.end(), uint32_t(wi))) << "wedge " << wi;
      }
    }
    EXPECT_GT(must, 100u);
    EXPECT_GT(bsp.node_count(), 1u);
  }
}
