// Tests of lib/plucker/bsp.cpp: the lazy BSP of Algorithm 1 (paper 002 sections 4.1-4.3).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/plucker/bsp.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

namespace {

// Total area of a tree's output fragments (polygon_area of each).
double region_area(const FragmentList& out) {
  double a = 0;
  for (size_t k = 0; k < out.size(); ++k) a += polygon_area(out.data(k), out.count(k));
  return a;
}

// `count` small triangles at heights 0.5 to 1.5 over x, y in [-1.3, 1.3], oriented so
// that receivers below (z = -10 and the query plane z = 0) are on their negative side
// (bsp.h Occluder).
std::vector<Occluder> random_occluders(Rng& rng, int count) {
  std::vector<Occluder> occ;
  for (int k = 0; k < count; ++k) {
    Occluder o;
    o.n = 3;
    Vec3d c(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.5, 1.5));
    for (int i = 0; i < 3; ++i) o.v[i] = c + Vec3d(rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), 0);
    if (orient3d(o.v[0], o.v[1], o.v[2], Vec3d(0, 0, -10)) > 0)
      std::swap(o.v[0], o.v[1]);  // receivers below on the negative side (bsp.h)
    occ.push_back(o);
  }
  return occ;
}
// `queries` random query points (z = 0, |x|, |y| <= 0.5) on trees x and y: the same
// fragments vertex for vertex, then the same nodes, developments, insertion tests and
// splits.
void expect_same_answers(LazyBsp& x, LazyBsp& y, Rng& rng, int queries) {
  FragmentList a, b;
  for (int q = 0; q < queries; ++q) {
    const Vec3d r(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0);
    x.query(r, a);
    y.query(r, b);
    ASSERT_EQ(a.size(), b.size());
    ASSERT_EQ(a.verts.size(), b.verts.size());
    for (size_t k = 0; k < a.verts.size(); ++k) {
      EXPECT_EQ(a.verts[k].x, b.verts[k].x);
      EXPECT_EQ(a.verts[k].y, b.verts[k].y);
      EXPECT_EQ(a.verts[k].z, b.verts[k].z);
    }
  }
  EXPECT_EQ(x.node_count(), y.node_count());
  EXPECT_EQ(x.counters().nodes_created, y.counters().nodes_created);
  EXPECT_EQ(x.counters().developments, y.counters().developments);
  EXPECT_EQ(x.counters().insert_tests, y.counters().insert_tests);
  EXPECT_EQ(x.counters().splits, y.counters().splits);
}

// The plane z = height in the tests' frame, as the solver gives it to a tree
// (fragment.h LightPlane: nd . x = h0, positive towards the receivers below).
LightPlane plane_at(double height, float extent) {
  LightPlane lp;
  lp.n = Vec3f(0, 0, -1);
  lp.extent = extent;
  lp.axes = UVAxes::from_normal(lp.n);
  lp.nd = Vec3d(0, 0, -1);
  lp.h0 = -height;
  return lp;
}

}  // namespace

TEST(PluckerBsp, EmptyTreeReturnsTheLight) {
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  LazyBsp bsp(light, 4, {}, 1);
  FragmentList out;
  bsp.query(Vec3d(0, 0, 0), out);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(polygon_area(out.data(0), out.count(0)), 4.0);
}

TEST(PluckerBsp, SingleOccluderHasFourLeaves) {
  // bsp(o) (Figure 4): three inner nodes, three visible leaves, one invisible leaf.
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  Occluder o;
  o.n = 3;
  o.v[0] = Vec3d(-0.25f, -0.25f, 1);
  o.v[1] = Vec3d(0.25f, -0.25f, 1);
  o.v[2] = Vec3d(0, 0.25f, 1);  // normal +z: receivers below are on its negative side
  LazyBsp bsp(light, 4, {o}, 1);
  FragmentList out;
  bsp.query(Vec3d(0, 0, 0), out);
  EXPECT_EQ(bsp.node_count(), 7u);
  // The shadow is the occluder scaled by 2 from the origin: area 0.125 * 4 = 0.5.
  EXPECT_NEAR(region_area(out), 4.0 - 0.5, 1e-6);
  // A second query reuses the developed tree.
  bsp.query(Vec3d(0.1f, 0, 0), out);
  EXPECT_EQ(bsp.node_count(), 7u);
  bsp.reset();
  EXPECT_EQ(bsp.node_count(), 1u);
}

TEST(PluckerBsp, SplitsWhosePiecesAllStayVisibleAreUndone) {
  // Occluder A at z = 1 (normal +z) casts its shape scaled by 2 about the query point
  // onto the light at z = 2. From r0 = the origin: the triangle (-0.6, 0.1), (0.2, -0.7),
  // (0.2, 0.9) inside the light (area 0.64), which develops bsp(A). From r1 = (-1.8, 0, 0)
  // the same triangle moved by 1.8: (1.2, 0.1), (2, -0.7), (2, 0.9), right of the light,
  // but the planes through r1 and A's edges from (1.2, 0.1) (lines x + y = 1.3 and
  // y = x - 1.1 on the light) cut the light, and the walk splits it along them. Every
  // piece comes out visible, so the query returns the light itself, one fragment. The
  // same after a reset: no edge of A has the whole light on its outer side, so the
  // undefined root develops A for r1 too.
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  Occluder a;
  a.n = 3;
  a.v[0] = Vec3d(-0.3, 0.05, 1);
  a.v[1] = Vec3d(0.1, -0.35, 1);
  a.v[2] = Vec3d(0.1, 0.45, 1);
  for (int coherent = 0; coherent < 2; ++coherent) {
    LazyBsp bsp(light, 4, {a}, 1);
    FragmentList out;
    bsp.query(Vec3d(0, 0, 0), out);
    EXPECT_NEAR(region_area(out), 4.0 - 0.64, 1e-12);
    EXPECT_EQ(bsp.node_count(), 7u);
    EXPECT_EQ(bsp.counters().merged, 0u);  // every split of r0's walk cut the shadow off
    if (!coherent) bsp.reset();
    const uint64_t splits = bsp.counters().splits;
    bsp.query(Vec3d(-1.8, 0, 0), out);
    ASSERT_EQ(out.size(), 1u) << coherent;
    ASSERT_EQ(out.count(0), 4) << coherent;
    for (int k = 0; k < 4; ++k) EXPECT_EQ(out.data(0)[k], light[k]) << coherent << " " << k;
    EXPECT_GE(bsp.counters().splits - splits, 1u) << coherent;
    EXPECT_EQ(bsp.counters().merged, bsp.counters().splits - splits) << coherent;
  }
}

TEST(PluckerBsp, TwoSidedOccluderHidesFromBothSides) {
  // A two-sided occluder (bsp.h) answers queries from either side of its plane like the
  // one-sided occluder oriented for that side.
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  Occluder o;
  o.n = 3;
  o.v[0] = Vec3d(0, -0.5, 0.5);  // vertical triangle in the plane x = 0
  o.v[1] = Vec3d(0, 0.5, 0.5);
  o.v[2] = Vec3d(0, 0, 1.5);
  o.two_sided = true;
  Occluder flipped = o;
  flipped.two_sided = false;
  std::swap(flipped.v[0], flipped.v[1]);
  for (float x : {-0.5f, 0.5f}) {
    // o's normal (v1 - v0) x (v2 - v0) is +x: a receiver at x < 0 is on its negative side.
    Occluder one = x < 0 ? o : flipped;
    one.two_sided = false;
    LazyBsp two(light, 4, {o}, 3), single(light, 4, {one}, 3);
    FragmentList a, b;
    two.query(Vec3d(x, 0.1, 0), a);
    single.query(Vec3d(x, 0.1, 0), b);
    double area_a = 0, area_b = 0;
    for (size_t k = 0; k < a.size(); ++k) area_a += polygon_area(a.data(k), a.count(k));
    for (size_t k = 0; k < b.size(); ++k) area_b += polygon_area(b.data(k), b.count(k));
    EXPECT_LT(area_b, 4.0 - 0.1);
    EXPECT_NEAR(area_a, area_b, 1e-5) << x;
  }
}

TEST(PluckerBsp, RelevantAndRandomChoicesGiveTheSameRegion) {
  // Both ways of developing a leaf (bsp.h Choice), the relevant one with and without the
  // light's plane (largest_overlap or a random candidate), answer every query with the same
  // visible area, with and without coherence, on random occluder soups; the relevant
  // choice returns fragments from undefined leaves that no occluder of theirs meets.
  Rng rng(8);
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  uint64_t lazy = 0;
  for (int scene = 0; scene < 20; ++scene) {
    std::vector<Occluder> occ = random_occluders(rng, 12);
    LazyBsp relevant(light, 4, occ, 9), random(light, 4, occ, 9), overlap(light, 4, occ, 9);
    random.set_choice(LazyBsp::Choice::Random);
    overlap.set_light_plane(plane_at(2.0, 2.0f));  // relevant, merging by largest_overlap
    FragmentList a, b, c;
    for (int q = 0; q < 10; ++q) {
      Vec3d r(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0);
      relevant.query(r, a);
      random.query(r, b);
      overlap.query(r, c);
      EXPECT_NEAR(region_area(a), region_area(b), 1e-5);
      EXPECT_NEAR(region_area(c), region_area(b), 1e-5);
      if (q % 3 == 0) {
        relevant.reset();
        random.reset();
        overlap.reset();
      }
    }
    lazy += relevant.counters().lazy_visible;
  }
  EXPECT_GT(lazy, 0u);
}

TEST(PluckerBsp, RelevantChoiceMergesTheOccluderWhoseShadowOverlapsMostFirst) {
  // Hand-worked: seen from r = 0 the big triangle at z = 1 casts the shadow (-0.8, -0.8),
  // (0.8, -0.8), (0, 0.8) on the light square [-1, 1]^2 at z = 2 (area 1.28), the small one
  // at z = 1.5 the same triangle scaled by 1/4 (edges parallel, strictly inside). Both
  // hide part of the light, neither all of it. Listed small first, the relevant choice
  // with the light's plane known merges the big one (bsp.h largest_overlap): every piece
  // outside its shadow lies beyond one of its edge lines, so beyond the small one's
  // parallel edge line too, a miss, and one development answers the query. The visible
  // area is 4 - 1.28 either way.
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  auto tri = [](double s, double z) {
    Occluder o;
    o.n = 3;
    o.v[0] = Vec3d(-s, -s, z), o.v[1] = Vec3d(s, -s, z), o.v[2] = Vec3d(0, s, z);  // normal +z: r below is negative
    return o;
  };
  const std::vector<Occluder> occ = {tri(0.15, 1.5), tri(0.4, 1.0)};
  LazyBsp tree(light, 4, occ, 3);
  tree.set_light_plane(plane_at(2.0, 2.0f));
  FragmentList out;
  tree.query(Vec3d(0, 0, 0), out);
  EXPECT_NEAR(region_area(out), 4.0 - 1.28, 1e-9);
  EXPECT_EQ(tree.counters().developments, 1u);
  // The same tree and query with the paper's random choice end with the same area.
  LazyBsp random(light, 4, occ, 3);
  random.set_choice(LazyBsp::Choice::Random);
  random.query(Vec3d(0, 0, 0), out);
  EXPECT_NEAR(region_area(out), 4.0 - 1.28, 1e-9);
}

TEST(PluckerBsp, ARebuiltTreeAnswersAsAFreshOne) {
  // LazyBsp::rebuild (the solver's per-thread tree, reused group after group) keeps
  // storage, nothing else: after queries on a larger tree with another light, a random
  // choice, a light plane and another seed, the rebuilt tree returns the same fragments,
  // vertex for vertex, and the same counters as a tree constructed from scratch. Round 0
  // sets no light plane on either tree (rebuild drops the old one); rounds 1 and 2 set
  // one on both, with as many occluders as the round before, so shadow-box caches left
  // from the previous tree would be read if rebuild kept them.
  Rng rng(21);
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  Vec3d big_light[3] = {Vec3d(-3, -3, 2.5), Vec3d(3, -3, 2.5), Vec3d(0, 3, 2.5)};
  std::vector<Occluder> first = random_occluders(rng, 40);
  LazyBsp reused(big_light, 3, first, 5);
  reused.set_choice(LazyBsp::Choice::Random);
  reused.set_light_plane(plane_at(2.5, 6.0f));
  FragmentList out;
  for (int q = 0; q < 12; ++q) reused.query(Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0), out);
  ASSERT_GT(reused.node_count(), 1u);
  for (int round = 0; round < 3; ++round) {
    const std::vector<Occluder> occ = random_occluders(rng, 12);
    std::vector<Occluder> handed = occ;
    reused.rebuild(light, 4, handed, 9 + uint64_t(round));
    EXPECT_TRUE(handed.empty());  // swapped in; the previous storage comes back cleared
    LazyBsp fresh(light, 4, occ, 9 + uint64_t(round));
    if (round > 0) {
      reused.set_light_plane(plane_at(2.0, 2.0f));
      fresh.set_light_plane(plane_at(2.0, 2.0f));
    }
    EXPECT_EQ(reused.node_count(), 1u);
    EXPECT_EQ(reused.occluder_count(), occ.size());
    expect_same_answers(reused, fresh, rng, 10);
  }
}

TEST(PluckerBsp, KeptInsertionOrientationsGiveTheSameTree) {
  // develop() keeps each insertion test's orientation for later merges of the same
  // occluder at other leaves (bsp.h orient_): a tree keeping them and one keeping none
  // (set_orient_cache_bytes(0)) make the same tests' answers, so the same developments,
  // nodes and fragments, vertex for vertex; with a receiver region (the second fan) and
  // with random and relevant choices; and the kept answers are read.
  Rng rng(41);
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  const Vec3d region[4] = {Vec3d(-0.5, -0.5, 0), Vec3d(0.5, -0.5, 0), Vec3d(0.5, 0.5, 0), Vec3d(-0.5, 0.5, 0)};
  for (int round = 0; round < 2; ++round) {
    const std::vector<Occluder> occ = random_occluders(rng, 40);
    LazyBsp kept(light, 4, occ, 3, region, 4), none(light, 4, occ, 3, region, 4);
    none.set_orient_cache_bytes(0);
    if (round == 0) {
      kept.set_choice(LazyBsp::Choice::Random);
      none.set_choice(LazyBsp::Choice::Random);
    } else {
      kept.set_light_plane(plane_at(2.0, 2.0f));
      none.set_light_plane(plane_at(2.0, 2.0f));
    }
    expect_same_answers(kept, none, rng, 60);
    EXPECT_GT(kept.counters().insert_reused, 0u);
    EXPECT_EQ(none.counters().insert_reused, 0u);
  }
}

TEST(PluckerBsp, CompactedListArenaAnswersAsTheOccluders) {
  // The leaves' occluder lists share one arena that grow_lists compacts when half of it is
  // dead (bsp.h). After many developments and compactions every query still answers as
  // the occluders do: a light point lies in a returned fragment iff the segment from r to
  // it misses every occluder (double orientations; points within 1e-9 of deciding, i.e.
  // near a shadow edge, skipped).
  Rng rng(33);
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  const std::vector<Occluder> occ = random_occluders(rng, 60);
  LazyBsp tree(light, 4, occ, 7);
  tree.set_choice(LazyBsp::Choice::Random);  // develops far more leaves than needed
  auto det = [](const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
    const Vec3d u = b - a, v = c - a, w = d - a;
    return u.x * (v.y * w.z - v.z * w.y) - u.y * (v.x * w.z - v.z * w.x) + u.z * (v.x * w.y - v.y * w.x);
  };
  const UVAxes axes = UVAxes::from_normal(Vec3f(0, 0, -1));  // the light square runs clockwise about +z
  FragmentList out;
  // Queries until the arena has been compacted twice, then 40 checked ones.
  for (int q = 0; q < 500 && tree.counters().list_compactions < 2; ++q)
    tree.query(Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0), out);
  ASSERT_GE(tree.counters().list_compactions, 2u);
  int checked = 0;
  for (int q = 0; q < 40; ++q) {
    const Vec3d r(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0);
    tree.query(r, out);
    for (int k = 0; k < 64; ++k) {
      const Vec3d p(rng.uniform(-1, 1), rng.uniform(-1, 1), 2);
      bool blocked = false, near = false;
      for (const Occluder& o : occ) {
        const double s[5] = {det(o.v[0], o.v[1], o.v[2], r), det(o.v[0], o.v[1], o.v[2], p), det(r, p, o.v[0], o.v[1]),
                             det(r, p, o.v[1], o.v[2]), det(r, p, o.v[2], o.v[0])};
        for (double x : s) near |= std::abs(x) < 1e-9;
        blocked |= (s[0] > 0) != (s[1] > 0) && (s[2] > 0) == (s[3] > 0) && (s[3] > 0) == (s[4] > 0);
      }
      if (near) continue;
      bool inside = false;
      for (size_t f = 0; f < out.size() && !inside; ++f) inside = point_in_fragment(axes, out.data(f), out.count(f), p);
      EXPECT_EQ(inside, !blocked) << "query " << q << " point " << k;
      ++checked;
    }
  }
  EXPECT_GT(checked, 2000);
}

TEST(PluckerBsp, ListArenaStopsAtTheBudgetBeforeGrowingPastIt) {
  // A tree bound to a 4 MB budget and developed until it throws holds at most the budget
  // afterwards: the arena's growth is charged before it is allocated (grow_lists), so the
  // throw comes instead of the doubling, not after it.
  Rng rng(34);
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  const std::vector<Occluder> occ = random_occluders(rng, 300);
  MemoryBudget budget("plucker-bsp", 4);
  LazyBsp tree(light, 4, occ, 7);
  tree.set_choice(LazyBsp::Choice::Random);
  tree.set_memory_budget(&budget);
  FragmentList out;
  bool stopped = false;
  for (int q = 0; q < 2000 && !stopped; ++q) {
    try {
      tree.query(Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 0), out);
    } catch (const MemoryBudgetExceeded&) {
      stopped = true;
    }
  }
  ASSERT_TRUE(stopped);
  EXPECT_LE(tree.memory_bytes(), size_t(4) << 20);
}

TEST(PluckerBsp, HidesAllWhenOneOccluderCoversTheLight) {
  Vec3d light[4] = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  Occluder big, small;
  big.n = small.n = 4;
  // A 3 x 3 square at z = 1 (normal +z): from (0, 0, 0) its shadow covers [-3, 3]^2.
  big.v[0] = Vec3d(-1.5, -1.5, 1), big.v[1] = Vec3d(1.5, -1.5, 1), big.v[2] = Vec3d(1.5, 1.5, 1),
  big.v[3] = Vec3d(-1.5, 1.5, 1);
  small.v[0] = Vec3d(-0.1, -0.1, 1.5), small.v[1] = Vec3d(0.1, -0.1, 1.5), small.v[2] = Vec3d(0.1, 0.1, 1.5),
  small.v[3] = Vec3d(-0.1, 0.1, 1.5);
  LazyBsp bsp(light, 4, {small, big}, 2);
  EXPECT_TRUE(bsp.hides_all(Vec3d(0, 0, 0)));
  FragmentList out;
  bsp.query(Vec3d(0, 0, 0), out);
  EXPECT_EQ(out.size(), 0u);
  // From (5, 0, 0) the big square hides only part of the light: not all.
  EXPECT_FALSE(bsp.hides_all(Vec3d(5, 0, 0)));
  LazyBsp only_small(light, 4, {small}, 2);
  EXPECT_FALSE(only_small.hides_all(Vec3d(0, 0, 0)));
}
