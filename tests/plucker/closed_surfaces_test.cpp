// Closed surfaces (lib/plucker/closed_surfaces.h) and what occluder selection does with
// them: the same answers as modelling every triangle (option closed=off, the previous code
// path) and as the region oracle, on the scan family and on closed meshes with concave
// parts; and the triangle tree's segment test against testing every triangle.
#include "lib/plucker/closed_surfaces.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>

#include "lib/base/union_find.h"
#include "lib/mesh/prepare.h"
#include "lib/plucker/local_light.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/rng.h"
#include "tests/support/plucker_scenes.h"

namespace visgate {
namespace {

using test_support::family_scene;
using test_support::light_scene;
using test_support::receiver_square;
using test_support::expect_region_oracle;
using test_support::expect_same_answers;
using test_support::run;

TEST(PluckerClosedSurfaces, FindsClosedConsistentComponentsOnly) {
  TriangleSoup m;
  shapes::add_box(m, Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  shapes::add_box(m, Vec3d(2, 0, 0), Vec3d(3, 1, 1));
  {
    plucker::ClosedSurfaces cs(m);
    ASSERT_EQ(cs.count(), 2u);
    for (uint32_t t = 0; t < 12; ++t) EXPECT_EQ(cs.surface(t), cs.surface(0));
    EXPECT_NE(cs.surface(12), cs.surface(0));
    EXPECT_EQ(cs.triangles(cs.surface(0)), 12u);
    EXPECT_EQ(cs.box(cs.surface(12)).lo.x, 2.0f);
  }
  // An open box (one triangle removed) and a box with one triangle flipped are not
  // closed; the other box still is.
  TriangleSoup open = m;
  open.triangles.erase(open.triangles.begin() + 3);
  EXPECT_EQ(plucker::ClosedSurfaces(open).count(), 1u);
  EXPECT_EQ(plucker::ClosedSurfaces(open).surface(0), -1);
  TriangleSoup flipped = m;
  std::swap(flipped.triangles[14][0], flipped.triangles[14][1]);
  EXPECT_EQ(plucker::ClosedSurfaces(flipped).count(), 1u);
  EXPECT_EQ(plucker::ClosedSurfaces(flipped).surface(14), -1);
  EXPECT_GE(plucker::ClosedSurfaces(flipped).surface(0), 0);
}

// The surfaces against an independent reference: union-find over the prepared
// neighbours, a component closed when no member has an edge without one, ids in the order
// of the components' smallest prepared triangles. Boxes, tori and an open and a flipped
// box, their triangles shuffled together so the components interleave in index order.
TEST(PluckerClosedSurfaces, SurfacesAreTheClosedComponentsInOrderOfTheirFirstTriangle) {
  TriangleSoup m;
  for (int i = 0; i < 4; ++i) shapes::add_box(m, Vec3d(2 * i, 0, 0), Vec3d(2 * i + 1, 1, 1));
  shapes::add_torus(m, Vec3d(0, 4, 0), 0.6, 0.2, 12, 8);
  shapes::add_torus(m, Vec3d(3, 4, 0), 0.6, 0.2, 10, 6);
  m.triangles.erase(m.triangles.begin() + 15);       // the second box: open
  std::swap(m.triangles[30][0], m.triangles[30][1]);  // the third box: one flipped
  Rng rng(5);
  for (size_t i = m.triangles.size(); i-- > 1;) std::swap(m.triangles[i], m.triangles[size_t(rng.below(i + 1))]);
  const mesh::PreparedMesh pm = mesh::prepare_mesh(m);
  UnionFind uf(pm.triangles.size());
  for (uint32_t t = 0; t < pm.triangles.size(); ++t)
    for (const int32_t nb : pm.triangles[t].neighbors)
      if (nb >= 0) uf.unite(t, uint32_t(nb));
  std::vector<uint8_t> open(pm.triangles.size(), 0);
  for (uint32_t t = 0; t < pm.triangles.size(); ++t)
    for (const int32_t nb : pm.triangles[t].neighbors)
      if (nb < 0) open[uf.find(t)] = 1;
  std::vector<int32_t> id(pm.triangles.size(), -1), want(m.size(), -1);
  int32_t count = 0;
  for (uint32_t t = 0; t < pm.triangles.size(); ++t) {
    const uint32_t root = uf.find(t);
    if (open[root]) continue;
    if (id[root] < 0) id[root] = count++;
    want[pm.triangles[t].source] = id[root];
  }
  ASSERT_EQ(count, 4);  // three boxes closed, the two tori
  const plucker::ClosedSurfaces cs(m, pm);
  ASSERT_EQ(cs.count(), size_t(count));
  std::vector<uint32_t> sizes(size_t(count), 0);
  for (uint32_t t = 0; t < m.size(); ++t) {
    EXPECT_EQ(cs.surface(t), want[t]) << t;
    if (want[t] >= 0) ++sizes[size_t(want[t])];
  }
  for (int32_t s = 0; s < count; ++s) EXPECT_EQ(cs.triangles(s), sizes[size_t(s)]) << s;
}

// Boxes and neighbours against the plain reference: per surface every corner of every
// triangle extended in triangle order, and per triangle its prepared neighbours' sources.
// Signed zeros on distinct vertices (extend keeps the first of -0 and +0, so the order
// decides the bits) and a dropped degenerate triangle (sources shifted) are in the soup.
TEST(PluckerClosedSurfaces, BoxesAndNeighboursAreEveryCornersAndThePreparedNeighbours) {
  TriangleSoup m;
  m.vertices = {Vec3f(5, 5, 5), Vec3f(6, 5, 5)};
  m.triangles.push_back({0, 1, 0});  // degenerate: dropped, every later source shifts
  shapes::add_box(m, Vec3d(-1, -1, -1), Vec3d(0, 0, 0));
  shapes::add_box(m, Vec3d(0, -2, 0), Vec3d(1, 0, 1));
  shapes::add_torus(m, Vec3d(0, 4, 0), 0.6, 0.2, 12, 8);
  // The boxes' zero corners: some vertices at -0 (the welding merges none of them).
  for (size_t v = 2; v < m.vertices.size(); v += 3)
    for (int k = 0; k < 3; ++k)
      if (m.vertices[v][k] == 0.0f) m.vertices[v][k] = -0.0f;
  Rng rng(11);
  for (size_t i = m.triangles.size(); i-- > 2;) std::swap(m.triangles[i], m.triangles[1 + size_t(rng.below(i))]);
  const mesh::PreparedMesh pm = mesh::prepare_mesh(m);
  ASSERT_EQ(pm.triangles.size() + 1, m.size());
  const plucker::ClosedSurfaces cs(m, pm);
  ASSERT_EQ(cs.count(), 3u);
  std::vector<AABB> want(cs.count());
  for (uint32_t t = 0; t < pm.triangles.size(); ++t) {
    const uint32_t src = pm.triangles[t].source;
    const int32_t s = cs.surface(src);
    ASSERT_GE(s, 0) << src;
    for (int k = 0; k < 3; ++k) {
      want[size_t(s)].extend(pm.corner(t, k));
      EXPECT_EQ(cs.neighbors(src)[size_t(k)], int32_t(pm.triangles[size_t(pm.triangles[t].neighbors[size_t(k)])].source))
          << src << " " << k;
    }
  }
  auto bits = [](float f) { return std::bit_cast<uint32_t>(f); };
  bool signed_zero = false;
  for (size_t s = 0; s < cs.count(); ++s)
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(bits(cs.box(int32_t(s)).lo[k]), bits(want[s].lo[k])) << s << " " << k;
      EXPECT_EQ(bits(cs.box(int32_t(s)).hi[k]), bits(want[s].hi[k])) << s << " " << k;
      signed_zero = signed_zero || bits(want[s].lo[k]) == bits(-0.0f) || bits(want[s].hi[k]) == bits(-0.0f);
    }
  EXPECT_TRUE(signed_zero);  // the soup does reach a -0 bound
}

TEST(PluckerClosedSurfaces, ScanAnswersMatchEveryTriangleAndTheOracle) {
  auto s = family_scene("scan", 3, 1500, 64, 16);
  ASSERT_TRUE(s.ok());
  // The triangle path (silhouette regions off: they leave the surface out whole).
  const SolveResult on = run(*s, {{"silhouette_regions", "off"}}), off = run(*s, {{"closed", "off"}});
  EXPECT_GT(on.stats.get("closed_dropped"), 0.0);
  EXPECT_EQ(off.stats.get("closed_dropped"), 0.0);
  EXPECT_LT(on.stats.get("occluders") + on.stats.get("near_polygons"),
            off.stats.get("occluders") + off.stats.get("near_polygons"));
  expect_same_answers(*s, on, off);
  expect_region_oracle(*s, on);
}

// Closed meshes with concave parts under the square light: a torus whose hole the light
// shines through, a tilted torus, and two interpenetrating boxes (each closed; their union
// is not convex). Receivers on a grid below, with the default groups.
TEST(PluckerClosedSurfaces, ConcaveClosedMeshesMatchEveryTriangleAndTheOracle) {
  std::vector<Vec3f> rec = receiver_square(8, -1.4f, 0.4f);
  for (int variant = 0; variant < 3; ++variant) {
    Scene s = light_scene(rec, 32, Vec3d(0.1, -0.05, 2.5));
    if (variant == 0) shapes::add_torus(s.mesh, Vec3d(0, 0, 1.2), 0.6, 0.2, 24, 12);
    if (variant == 1) {
      shapes::add_torus(s.mesh, Vec3d(0.2, 0, 1.2), 0.6, 0.25, 20, 10);
      shapes::rotate(s.mesh, 0, Vec3d(0.2, 0, 1.2), Vec3d(1, 0.3, 0), 0.7);
    }
    if (variant == 2) {
      shapes::add_box(s.mesh, Vec3d(-0.6, -0.2, 0.8), Vec3d(0.6, 0.2, 1.0));
      shapes::add_box(s.mesh, Vec3d(-0.2, -0.6, 0.7), Vec3d(0.2, 0.6, 1.3));
    }
    ASSERT_TRUE(finish_scene(s).ok());
    ASSERT_GT(plucker::ClosedSurfaces(s.mesh).count(), 0u) << variant;
    const SolveResult on = run(s, {{"silhouette_regions", "off"}}), off = run(s, {{"closed", "off"}});
    EXPECT_GT(on.stats.get("closed_dropped"), 0.0) << variant;
    expect_same_answers(s, on, off);
    expect_region_oracle(s, on);
  }
}

// A receiver inside a closed surface, or a light inside it, leaves the surface whole
// (its box is not apart from theirs): the receiver inside sees nothing.
TEST(PluckerClosedSurfaces, ReceiverInsideAClosedSurfaceSeesNothing) {
  Scene s = light_scene({Vec3f(0, 0, 1), Vec3f(0.5f, 0.5f, 0.0f), Vec3f(3, 3, 0)});
  shapes::add_box(s.mesh, Vec3d(-0.3, -0.3, 0.5), Vec3d(0.3, 0.3, 1.5));
  ASSERT_TRUE(finish_scene(s).ok());
  const SolveResult on = run(s), off = run(s, {{"closed", "off"}});
  EXPECT_EQ(on.receivers[0].visible_fraction[0], 0.0f);
  expect_same_answers(s, on, off);
  expect_region_oracle(s, on);
}

// TriangleTree::segment_blocked against the scan over every triangle on random segments,
// many of them through the soup.
TEST(PluckerClosedSurfaces, TreeSegmentTestEqualsEveryTriangle) {
  auto s = family_scene("random-soup", 5, 400, 16);
  ASSERT_TRUE(s.ok());
  const plucker::TriangleTree tree(s->mesh);
  AABB box;
  for (const Vec3f& v : s->mesh.vertices) box.extend(v);
  Rng rng(11);
  const Vec3f origin = s->mesh.vertices[0];
  int blocked = 0;
  for (int k = 0; k < 2000; ++k) {
    Vec3f p[2];
    for (Vec3f& q : p)
      for (int a = 0; a < 3; ++a) q[a] = float(rng.uniform(double(box.lo[a]) - 0.2, double(box.hi[a]) + 0.2));
    const Vec3f r = p[0] - origin, e = p[1] - origin;
    const bool want = plucker::segment_blocked_by_scene(*s, origin, r, e);
    EXPECT_EQ(tree.segment_blocked(s->mesh, origin, r, e), want) << k;
    blocked += want;
  }
  EXPECT_GT(blocked, 100);
  EXPECT_LT(blocked, 1900);
}

}  // namespace
}  // namespace visgate
