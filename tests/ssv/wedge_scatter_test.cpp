// lib/ssv/wedge_scatter.h: wedges scattered through the receiver tree against a linear
// scan, and the solver with the scattered index against the lazy BSP.
#include <gtest/gtest.h>

#include <algorithm>

#include "lib/base/cpu_features.h"
#include "lib/solver.h"
#include "lib/ssv/occluders.h"
#include "lib/ssv/wedge.h"
#include "lib/ssv/wedge_scatter.h"
#include "tests/support/family_scene.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

namespace {

// The receivers' points (the receiver tree's input) and a skip flag on every k-th one.
std::vector<Vec3d> receiver_points(const Scene& s) {
  std::vector<Vec3d> pts;
  for (const Receiver& rc : s.receivers) pts.push_back(to_double(rc.p));
  return pts;
}
std::vector<uint8_t> every_kth(size_t n, size_t k) {
  std::vector<uint8_t> skip(n, 0);
  for (size_t i = 0; i < n; i += k) skip[i] = 1;
  return skip;
}

}  // namespace

TEST(SsvWedgeScatter, EveryWedgeContainingAReceiverIsACandidate) {
  // Like the BSP's test: every wedge that clearly contains the receiver (and, with
  // silhouette regions, whose edge is clearly a silhouette from it) is among its
  // candidates, once; skipped receivers get none; batches tile the tree's order.
  Scene s = random_scene(12, 16, 400);
  auto [pm, frame, fp, edges, counts, wedges] = make_wedges(s);
  const std::vector<Vec3d> pts = receiver_points(s);
  ReceiverTree tree(pts, 4);
  const std::vector<uint8_t> skip = every_kth(pts.size(), 7);
  const float eps = float(4e-6 * 4);
  for (uint32_t batch_size : {16u, 100000u}) {
    const auto batches = WedgeScatter::batches(tree, batch_size);
    uint32_t next = 0;
    for (int32_t b : batches) {
      EXPECT_EQ(tree.nodes()[size_t(b)].begin, next);
      next = tree.nodes()[size_t(b)].end;
    }
    EXPECT_EQ(next, uint32_t(pts.size()));
    for (bool regions : {true, false}) {
      size_t must = 0;
      WedgeScatter sc;
      for (int32_t b : batches) {
        sc.build(tree, b, wedges, eps, regions, skip);
        for (uint32_t p = tree.nodes()[size_t(b)].begin; p < tree.nodes()[size_t(b)].end; ++p) {
          const uint32_t i = tree.order()[p];
          std::vector<uint32_t> got;
          for (const WedgeState* c = sc.begin(p); c != sc.end(p); ++c) {
            got.push_back(c->wedge);
            // The planes cleared from the mask contain the receiver within eps.
            const uint32_t full = (1u << wedges[c->wedge].plane_count) - 1u;
            EXPECT_TRUE(point_in_wedge(wedges[c->wedge], full & ~uint32_t(c->mask), s.receivers[i].p, eps));
          }
          if (skip[i]) {
            EXPECT_TRUE(got.empty());
            continue;
          }
          EXPECT_TRUE(std::is_sorted(got.begin(), got.end()));
          EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << "a wedge handed out twice";
          for (size_t wi = 0; wi < wedges.size(); ++wi) {
            const Wedge& w = wedges[wi];
            if (!point_in_wedge(w, s.receivers[i].p, -eps)) continue;  // clearly inside only
            if (regions && w.has_region) {
              float f1 = w.tri[0].eval(s.receivers[i].p), f2 = w.tri[1].eval(s.receivers[i].p);
              if (!((f1 > eps && f2 < -eps) || (f1 < -eps && f2 > eps))) continue;
            }
            ++must;
            EXPECT_TRUE(std::binary_search(got.begin(), got.end(), uint32_t(wi))) << "wedge " << wi;
          }
        }
      }
      EXPECT_GT(must, 100u);
    }
  }
}

TEST(SsvWedgeScatter, PassedBatchesGiveTheSameCandidates) {
  // build from pass_batches' lists (with AVX2: the leaves eight per step, no walks)
  // against build's walks over every wedge: the same candidates (wedge, mask and region
  // bits, in order) for every receiver, batches of one leaf, of 16 receivers and one
  // batch for the whole tree (spare lanes), silhouette regions on and off; the lists
  // leave wedges out (with AVX2), so the test sees the eight-box test decide.
  Scene s = random_scene(31, 16, 400);
  auto [pm, frame, fp, edges, counts, wedges] = make_wedges(s);
  ReceiverTree tree(receiver_points(s), 4);
  const std::vector<uint8_t> skip = every_kth(s.receivers.size(), 5);
  const float eps = float(4e-6 * 4);
  size_t dropped = 0;
  for (uint32_t batch_size : {1u, 16u, 100000u})
    for (bool regions : {true, false}) {
      const auto batches = WedgeScatter::batches(tree, batch_size);
      WedgeScatter all, passed;
      std::vector<std::vector<uint32_t>> lists;
      for (size_t b = 0; b < batches.size(); ++b) {
        const size_t group = b % WedgeScatter::kPassGroup;
        if (group == 0) {
          passed.pass_batches(tree, batches, b, wedges, eps, regions, lists);
          ASSERT_EQ(lists.size(), std::min(WedgeScatter::kPassGroup, batches.size() - b));
        }
        const std::vector<uint32_t>& list = lists[group];
        EXPECT_TRUE(std::is_sorted(list.begin(), list.end()));
        dropped += wedges.size() - list.size();
        all.build(tree, batches[b], wedges, eps, regions, skip);
        passed.build(tree, batches[b], wedges, eps, regions, skip, &list);
        ASSERT_EQ(all.entries(), passed.entries()) << "batch " << b;
        for (uint32_t p = tree.nodes()[size_t(batches[b])].begin; p < tree.nodes()[size_t(batches[b])].end; ++p) {
          ASSERT_EQ(all.end(p) - all.begin(p), passed.end(p) - passed.begin(p)) << "position " << p;
          for (const WedgeState *x = all.begin(p), *y = passed.begin(p); x != all.end(p); ++x, ++y) {
            EXPECT_EQ(x->wedge, y->wedge);
            EXPECT_EQ(x->mask, y->mask);
            EXPECT_EQ(x->region, y->region);
          }
        }
      }
    }
  if (avx2_enabled("VISGATE_SSV_NO_AVX2")) {
    EXPECT_GT(dropped, 1000u);
  }
}

TEST(SsvWedgeScatter, SolverAnswersEqualTheBsp) {
  for (const char* fam : {"columns", "torus", "random-soup", "foliage", "sliver-soup", "grid-snapped", "scan"}) {
    Scene s = family(fam, 4, -1, 144, 16);
    SolveOptions a, b;
    a.opts["wedge_index"] = "receivers";
    b.opts["wedge_index"] = "bsp";
    const SolveResult ra = make_solver("ssv")->solve(s, a), rb = make_solver("ssv")->solve(s, b);
    ASSERT_EQ(ra.receivers.size(), rb.receivers.size());
    for (size_t i = 0; i < ra.receivers.size(); ++i)
      EXPECT_EQ(ra.receivers[i].visible_bits, rb.receivers[i].visible_bits) << fam << " receiver " << i;
    EXPECT_GT(ra.stats.get("scattered_candidates"), 0.0) << fam;
  }
}

TEST(SsvWedgeScatter, RegionPrefilterDropsOnlyWedgesEveryBoxExcludes) {
  // build_wedges with receiver boxes against without: every wedge dropped is a double
  // edge whose silhouette region classify_box calls Outside for every box; the others
  // are built identically.
  Scene s = random_scene(21, 16, 400);
  auto [pm, frame, fp, edges, counts, wedges] = make_wedges(s);
  ReceiverTree tree(receiver_points(s), 4);
  RegionBoxes regions;
  regions.eps = float(4e-6 * 4);
  for (int32_t id : WedgeScatter::batches(tree, 32)) {
    AABB b;
    for (uint32_t p = tree.nodes()[size_t(id)].begin; p < tree.nodes()[size_t(id)].end; ++p)
      b.extend(s.receivers[tree.order()[p]].p);
    regions.parts.push_back(b);
    regions.all.extend(b);
  }
  WedgeBuildCounts c2;
  std::vector<Wedge> kept;
  const double M = 4.0;
  build_wedges(pm, edges, fp, frame, 1e-9 * M, c2, nullptr, kept, nullptr, &regions);
  EXPECT_GT(c2.region_culled, 0u);
  EXPECT_EQ(kept.size() + c2.region_culled, wedges.size());
  size_t k = 0;
  for (const Wedge& w : wedges) {
    if (k < kept.size() && kept[k].edge == w.edge) {
      EXPECT_EQ(kept[k].plane_count, w.plane_count);
      ++k;
      continue;
    }
    ASSERT_TRUE(w.has_region) << "edge " << w.edge;
    for (const AABB& b : regions.parts) {
      WedgeState st;
      st.mask = uint16_t((1u << w.plane_count) - 1u);
      EXPECT_EQ(classify_box(w, st, b, regions.eps, true), BoxClass::Outside) << "edge " << w.edge;
    }
  }
  EXPECT_EQ(k, kept.size());
}
