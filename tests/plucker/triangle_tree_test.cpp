// Tests of lib/plucker/triangle_tree.cpp: occluder candidates against the shaft and
// coplanar convex patches.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "lib/plucker/lines.h"
#include "lib/plucker/shaft.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/families.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

namespace {

// Patch pid (triangle_tree.h), checked in double independently of the exact predicates:
// its triangles name it, its corners are exactly the corners of its triangles, and the
// polygon is planar (every corner within 1e-12 of the plane of the first three),
// strictly convex (every turn of one sign about that plane's normal) and of the area of
// its triangles together (they tile it, no overlap).
void expect_convex_patch(const TriangleSoup& m, const TriangleTree& tree, int32_t pid) {
  const auto tris = tree.patch_triangles(pid);
  const auto poly = tree.patch_polygon(pid);
  ASSERT_GE(tris.size(), 2u);
  ASSERT_LE(poly.size(), size_t(TriangleTree::kMaxPatchVertices));
  EXPECT_TRUE(std::is_sorted(tris.begin(), tris.end()));
  double tri_area = 0.0;
  const Vec3d pn = cross(to_double(poly[1]) - to_double(poly[0]), to_double(poly[2]) - to_double(poly[0]));
  for (uint32_t t : tris) {
    EXPECT_EQ(tree.patch(t), pid);
    // Each triangle has the polygon's orientation (shade_patch's near polygons take the
    // plane of the first one).
    const Vec3d tn = cross(to_double(m.corner(t, 1)) - to_double(m.corner(t, 0)),
                           to_double(m.corner(t, 2)) - to_double(m.corner(t, 0)));
    EXPECT_GT(dot(tn, pn), 0.0) << t;
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::find(poly.begin(), poly.end(), m.corner(t, k)) != poly.end());
    tri_area += 0.5 * length(cross(to_double(m.corner(t, 1)) - to_double(m.corner(t, 0)),
                                   to_double(m.corner(t, 2)) - to_double(m.corner(t, 0))));
  }
  for (const Vec3f& c : poly) {
    bool found = false;
    for (uint32_t t : tris)
      for (int k = 0; k < 3; ++k) found |= m.corner(t, k) == c;
    EXPECT_TRUE(found);
  }
  const size_t n = poly.size();
  std::vector<Vec3d> d(n);
  for (size_t k = 0; k < n; ++k) d[k] = to_double(poly[k]);
  const Vec3d nrm = cross(d[1] - d[0], d[2] - d[0]);
  Vec3d area2(0, 0, 0);
  for (size_t k = 0; k < n; ++k) {
    EXPECT_NEAR(dot(nrm, d[k] - d[0]) / length(nrm), 0.0, 1e-12);
    EXPECT_GT(dot(cross(d[(k + 1) % n] - d[k], d[(k + 2) % n] - d[(k + 1) % n]), nrm), 0.0) << k;
    area2 += cross(d[k], d[(k + 1) % n]);
  }
  EXPECT_NEAR(0.5 * length(area2), tri_area, 1e-12 * tri_area);
}

// A box about a random point of `sb`, half-extents in [emin, emax) per axis, in the
// local frame at `origin` (rounded to float there, as the shafts' boxes are).
AABB random_local_box(Rng& rng, const AABB& sb, const Vec3f& origin, double emin, double emax) {
  const Vec3d lo = to_double(sb.lo), hi = to_double(sb.hi);
  const Vec3d c(rng.uniform(lo.x, hi.x), rng.uniform(lo.y, hi.y), rng.uniform(lo.z, hi.z));
  const Vec3d e(rng.uniform(emin, emax), rng.uniform(emin, emax), rng.uniform(emin, emax));
  return AABB(Vec3f(c - e) - origin, Vec3f(c + e) - origin);
}

// A random-soup scene of n triangles moved far from the world origin (the shafts' local
// frames then matter).
Scene far_soup(uint64_t seed, int n) {
  auto scene = family_scene("random-soup", seed, n, -1);
  EXPECT_TRUE(scene.ok());
  Scene s = scene.ok() ? *scene : Scene{};
  for (Vec3f& v : s.mesh.vertices) v = Vec3f(to_double(v) + Vec3d(1e5, -3e5, 2e5));
  return s;
}

}  // namespace

TEST(PluckerSelection, TriangleTreeKeepsEveryTriangleTheShaftKeeps) {
  // TriangleTree::candidates (triangle_tree.h) returns, in increasing order, a superset of
  // the triangles Shaft::culls keeps, for shafts in local frames far from the world origin.
  const Scene s = far_soup(4, 600);
  ASSERT_GT(s.mesh.size(), 0u);
  TriangleTree tree(s.mesh);
  Rng rng(6);
  std::vector<uint32_t> cand;
  for (int trial = 0; trial < 50; ++trial) {
    Vec3f origin = s.mesh.vertices[size_t(rng.below(s.mesh.vertices.size()))];
    const AABB sb = s.mesh.bounds();
    Shaft shaft(random_local_box(rng, sb, origin, 0, 1), random_local_box(rng, sb, origin, 0, 1));
    tree.candidates(shaft, origin, cand);
    EXPECT_TRUE(std::is_sorted(cand.begin(), cand.end()));
    size_t kept = 0;
    for (size_t t = 0; t < s.mesh.size(); ++t) {
      if (shaft.culls(s.mesh.corner(t, 0) - origin, s.mesh.corner(t, 1) - origin, s.mesh.corner(t, 2) - origin)) continue;
      ++kept;
      EXPECT_TRUE(std::binary_search(cand.begin(), cand.end(), uint32_t(t))) << t;
    }
    EXPECT_LE(kept, cand.size());
  }
}

TEST(PluckerSelection, TriangleTreeSkippedSubtreesHoldTheirTrianglesAndMissNone) {
  // The candidates variant that leaves out whole subtrees (triangle_tree.h): its kept
  // triangles are plain candidates, they and those of the skipped ranges hold every plain
  // candidate, each once (a skipped subtree may hold triangles the shaft culls deeper
  // down), and every skipped triangle's vertices lie in the local box the predicate
  // accepted for it, compared exactly (long double holds v - origin here: 64-bit
  // mantissas and exponents a few apart).
  const Scene s = far_soup(5, 800);
  ASSERT_GT(s.mesh.size(), 0u);
  TriangleTree tree(s.mesh);
  Rng rng(8);
  std::vector<uint32_t> plain, cand, back;
  std::vector<TriangleTree::Range> skipped;
  size_t total_skipped = 0;
  for (int trial = 0; trial < 40; ++trial) {
    const Vec3f origin = s.mesh.vertices[size_t(rng.below(s.mesh.vertices.size()))];
    const AABB sb = s.mesh.bounds();
    const Shaft shaft(random_local_box(rng, sb, origin, 0.5, 2), random_local_box(rng, sb, origin, 0.5, 2));
    tree.candidates(shaft, origin, plain);
    // Accept the boxes lying on one side of a random plane x = cut (local).
    const double cut = rng.uniform(-2.0, 2.0);
    std::vector<std::pair<Vec3d, Vec3d>> boxes;
    tree.candidates(shaft, origin, cand, skipped, [&](const Vec3d& lo, const Vec3d& hi) {
      if (!(lo.x > cut)) return false;
      boxes.emplace_back(lo, hi);
      return true;
    });
    ASSERT_EQ(boxes.size(), skipped.size());
    EXPECT_TRUE(std::is_sorted(cand.begin(), cand.end()));
    back = cand;
    for (size_t i = 0; i < skipped.size(); ++i) {
      const size_t before = back.size();
      tree.append_items(skipped[i], back);
      EXPECT_EQ(back.size() - before, skipped[i].count);
      for (size_t j = before; j < back.size(); ++j)
        for (int k = 0; k < 3; ++k)
          for (int a = 0; a < 3; ++a) {
            const long double x = (long double)s.mesh.corner(back[j], k)[a] - (long double)origin[a];
            EXPECT_LE((long double)boxes[i].first[a], x);
            EXPECT_GE((long double)boxes[i].second[a], x);
          }
      total_skipped += skipped[i].count;
    }
    std::sort(back.begin(), back.end());
    EXPECT_TRUE(std::adjacent_find(back.begin(), back.end()) == back.end());  // each once
    for (uint32_t t : plain) EXPECT_TRUE(std::binary_search(back.begin(), back.end(), t)) << t;
    for (uint32_t t : cand) EXPECT_TRUE(std::binary_search(plain.begin(), plain.end(), t)) << t;
  }
  EXPECT_GT(total_skipped, 0u);
}

TEST(PluckerSelection, CoplanarConvexPatches) {
  // triangle_tree.h patches: a cylinder of 16 segments makes each of its 16 side
  // rectangles (two triangles) a patch, and each cap's fan of 14 triangles a few convex
  // patches of at most kMaxPatchVertices corners (a 16-gon needs at least three).
  TriangleSoup cyl;
  shapes::add_cylinder(cyl, Vec3d(0.3, -0.2, 0.0), 0.7, 2.5, 16);
  ASSERT_EQ(cyl.size(), 60u);
  TriangleTree tree(cyl);
  std::vector<int32_t> seen;
  for (uint32_t t = 0; t < cyl.size(); ++t) {
    const int32_t p = tree.patch(t);
    ASSERT_GE(p, 0) << t;
    if (std::find(seen.begin(), seen.end(), p) == seen.end()) {
      seen.push_back(p);
      expect_convex_patch(cyl, tree, p);
    }
  }
  for (uint32_t t = 0; t < 32; t += 2) EXPECT_EQ(tree.patch(t), tree.patch(t + 1)) << t;  // the rectangles
  EXPECT_EQ(tree.patch_triangles(tree.patch(0)).size(), 2u);
  EXPECT_GE(seen.size(), 16u + 2u * 3u);
  EXPECT_LE(seen.size(), 16u + 2u * 4u);

  // Pairs: a fold (the fourth corner 2^-20 off the plane), darts (a reflex corner), a
  // straight corner (exactly on the line of its neighbours: not strictly convex), a
  // fourth corner on the shared edge, opposite windings, an edge of three triangles are
  // not patches; corners stored twice, at -0 and +0 (one position), are.
  auto patched = [](Vec3f a, Vec3f b, Vec3f c, Vec3f d) {
    TriangleSoup m;
    m.vertices = {a, b, c, d};
    m.triangles = {{0, 1, 2}, {1, 0, 3}};
    TriangleTree tr(m);
    if (tr.patch(0) >= 0) expect_convex_patch(m, tr, tr.patch(0));
    return tr.patch(0) >= 0 && tr.patch(0) == tr.patch(1);
  };
  const Vec3f a(0, 0, 0), b(1, 1, 0), c(0, 1, 0), d(1, 0, 0);
  EXPECT_TRUE(patched(a, b, c, d));
  EXPECT_FALSE(patched(a, b, c, Vec3f(1, 0, 0x1p-20f)));
  EXPECT_TRUE(patched(a, b, c, Vec3f(0.3f, 0.2f, 0)));    // convex
  EXPECT_FALSE(patched(a, b, c, Vec3f(-0.5f, -1, 0)));    // reflex at a
  EXPECT_FALSE(patched(a, b, c, Vec3f(2, 1.5f, 0)));      // reflex at b
  EXPECT_FALSE(patched(a, b, c, Vec3f(0.5f, 0.5f, 0)));   // d on the shared edge: not across it
  EXPECT_FALSE(patched(a, b, c, Vec3f(2, 1, 0)));         // c, b, d collinear: a straight corner at b
  {
    TriangleSoup m;  // the convex pair again, the second triangle wound the other way
    m.vertices = {a, b, c, d};
    m.triangles = {{0, 1, 2}, {0, 1, 3}};
    EXPECT_EQ(TriangleTree(m).patch(0), -1);
  }
  {
    TriangleSoup m;
    m.vertices = {a, b, c, d, Vec3f(0.5f, 0.5f, 1)};
    m.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
    TriangleTree tree3(m);
    for (uint32_t t = 0; t < 3; ++t) EXPECT_EQ(tree3.patch(t), -1);
  }
  {
    TriangleSoup m;  // two triangles with their own copies of the shared corners, one at -0
    m.vertices = {Vec3f(-0.0f, 0, 0), b, c, Vec3f(0, 0, 0), Vec3f(1, 1, -0.0f), d};
    m.triangles = {{0, 1, 2}, {4, 3, 5}};
    TriangleTree tree2(m);
    ASSERT_GE(tree2.patch(0), 0);
    EXPECT_EQ(tree2.patch(0), tree2.patch(1));
  }
  {
    // A grid of 3 x 3 unit squares in one plane (18 triangles): its strictly convex
    // patches are the squares (any larger union has a straight corner on a grid line;
    // merging across the longest edge, the diagonal, first finds them), each checked as
    // above.
    TriangleSoup m;
    for (int y = 0; y < 3; ++y)
      for (int x = 0; x < 3; ++x)
        shapes::add_quad(m, Vec3d(x, y, 0.5), Vec3d(x + 1, y, 0.5), Vec3d(x + 1, y + 1, 0.5), Vec3d(x, y + 1, 0.5));
    TriangleTree tg(m);
    std::vector<int32_t> ids;
    size_t alone = 0;
    for (uint32_t t = 0; t < m.size(); ++t) {
      const int32_t p = tg.patch(t);
      if (p < 0) {
        ++alone;
      } else if (std::find(ids.begin(), ids.end(), p) == ids.end()) {
        ids.push_back(p);
        expect_convex_patch(m, tg, p);
      }
    }
    EXPECT_EQ(ids.size(), 9u);
    EXPECT_EQ(alone, 0u);
  }
}

TEST(PluckerSelection, TriangleBoxesAreTheCornerExtendsBitForBit) {
  // Against AABB() extended by the three corners (the scalar std::min/std::max order):
  // every coordinate's value and sign, so a tie of -0 and +0 kept the other way fails.
  // Corners on a small grid with signed zeros (ties on every axis), repeated vertices and
  // degenerate triangles, plus random floats; the last vertex of the array is used, so a
  // read past a corner's 12 bytes would show under the sanitizers.
  std::mt19937 rng(7);
  TriangleSoup m;
  auto grid = [&]() {
    const float f = float(int(rng() % 5u) - 2);
    return f == 0.0f && rng() % 2 ? -0.0f : f;
  };
  for (int i = 0; i < 300; ++i) m.vertices.push_back(Vec3f(grid(), grid(), grid()));
  std::uniform_real_distribution<float> u(-1e3f, 1e3f);
  for (int i = 0; i < 100; ++i) m.vertices.push_back(Vec3f(u(rng), u(rng), u(rng)));
  const uint32_t nv = uint32_t(m.vertices.size());
  auto vertex = [&]() { return uint32_t(rng() % nv); };
  for (int i = 0; i < 2000; ++i) m.triangles.push_back({vertex(), i % 7 == 0 ? nv - 1 : vertex(), vertex()});
  auto same = [](float a, float b) { return a == b && std::signbit(a) == std::signbit(b); };
  auto expect_box = [&](const AABB& got, uint32_t t) {
    AABB want;
    for (int k = 0; k < 3; ++k) want.extend(m.corner(t, k));
    for (int a = 0; a < 3; ++a) {
      ASSERT_TRUE(same(got.lo[a], want.lo[a])) << t << " axis " << a;
      ASSERT_TRUE(same(got.hi[a], want.hi[a])) << t << " axis " << a;
    }
  };
  const std::vector<AABB> all = triangle_boxes(m);
  ASSERT_EQ(all.size(), m.size());
  for (uint32_t t = 0; t < m.size(); ++t) expect_box(all[t], t);
  std::vector<uint32_t> some;
  for (uint32_t t = 0; t < m.size(); t += 3) some.push_back(t);
  std::shuffle(some.begin(), some.end(), rng);
  const std::vector<AABB> part = triangle_boxes(m, &some);
  ASSERT_EQ(part.size(), some.size());
  for (size_t i = 0; i < some.size(); ++i) expect_box(part[i], some[i]);
}
