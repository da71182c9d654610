// lib/iss/patch_refinement.cpp: facings, merging and simplification of patches (paper 000 sections 4.7.3-4.7.5).
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "lib/iss/tree.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/families.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(IssBlockers, BoxPlaneClassificationEqualsTheEightCorners) {
  // classify_box_plane evaluates two corners; the reference evaluates all eight.
  std::mt19937 rng(5);
  size_t front = 0, back = 0;
  for (double offset : {0.0, 1e5, 1e-3}) {
    std::uniform_real_distribution<float> u(-5, 5);
    std::uniform_int_distribution<int> zero(0, 5);
    for (int it = 0; it < 3000; ++it) {
      Vec3f o(float(offset), float(-offset), float(offset));
      Vec3d a = to_double(o + Vec3f(u(rng), u(rng), u(rng)));
      Vec3d b = to_double(o + Vec3f(u(rng), u(rng), u(rng))), c = to_double(o + Vec3f(u(rng), u(rng), u(rng)));
      if (zero(rng) == 0) b.z = c.z = a.z;  // normal along z: n.x = n.y = 0
      iss::ConservativePlane pl = iss::plane_through(a, b, c, 2e5);
      AABB box = random_box(rng, o);
      if (zero(rng) == 0) box.hi = box.lo;  // a point
      AABBd bd = iss::to_double(box);
      double mn = 1e300, mx = -1e300;
      for (int i = 0; i < 8; ++i) {
        Vec3d q(i & 1 ? bd.hi.x : bd.lo.x, i & 2 ? bd.hi.y : bd.lo.y, i & 4 ? bd.hi.z : bd.lo.z);
        mn = std::min(mn, pl.eval(q));
        mx = std::max(mx, pl.eval(q));
      }
      int expect = mn > pl.tol ? 0 : (mx < -pl.tol ? 1 : 2);
      ASSERT_EQ(iss::classify_box_plane(bd, pl), expect) << "iteration " << it;
      front += expect == 0;
      back += expect == 1;
    }
  }
  EXPECT_GT(front, 500u);
  EXPECT_GT(back, 500u);
}

TEST(IssBlockers, ALoopThatCollapsesAwayStaysInTheHull) {
  // fuzz_iss 2f7607fd (corpus/iss/pouch/8f524c6c...), reduced by hand: one patch with
  // two boundary loops, a rim around the receivers at z in [-0.125, 0] and a triangle
  // far beside the shaft at z = 2 (the pouch's top rim, which the shafts pass through).
  // SIMPLIFY-PATCHES collapses the far loop away entirely (its ears lie outside the
  // extended shaft), and the box of what remains lies on the receivers' level while the
  // patch's triangles rise through the shaft. The hull keeps the far loop: then a
  // sub-shaft whose clip plane is that level keeps the surface and sends its relations
  // to the rays instead of dropping it as beyond the plane.
  iss::Surface s;
  auto loop = [&](std::initializer_list<Vec3d> pts) {
    std::vector<Vec3d> v(pts);
    for (size_t k = 0; k < v.size(); ++k) {
      iss::RawEdge re;
      re.v[0] = v[k];
      re.v[1] = v[(k + 1) % v.size()];
      re.nb[1] = 0;
      s.edges.push_back({uint32_t(s.raw.size()), 0});
      s.raw.push_back(re);
      s.hull.extend(re.v[0]);  // as construct_triangle_surface sets it
    }
  };
  loop({Vec3d(0.5, 0, 0), Vec3d(0, 0.5, 0), Vec3d(-0.5, 0, 0), Vec3d(0, -0.5, 0), Vec3d(0, -0.625, -0.125)});
  loop({Vec3d(10, 0, 2), Vec3d(11, 0, 2), Vec3d(10, 1, 2)});
  s.patches.push_back({0, uint32_t(s.edges.size()), iss::Facing::TowardsLight, -1});
  ASSERT_EQ(iss::validate(s, nullptr), "");
  AABB r(Vec3f(-0.2f, -0.25f, -2), Vec3f(0.2f, 0.2f, 0)), l(Vec3f(-2, -2, 2), Vec3f(2, 2, 2));
  iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 11.0);
  ASSERT_EQ(g.main_axis(), 2);
  iss::classify_edges(s, g);
  for (uint32_t k = 5; k < 8; ++k) ASSERT_FALSE(s.raw[k].inside) << "the far loop is outside the shaft";
  for (iss::RawEdge& re : s.raw) re.fresh = 1;
  iss::Workspace ws;
  iss::simplify_patches(s, g, ws);
  ASSERT_EQ(iss::validate(s, nullptr), "");
  ASSERT_EQ(s.patches.size(), 1u);
  EXPECT_EQ(s.edges.size(), 5u) << "the far loop collapsed away";
  EXPECT_EQ(s.hull.hi.z, 2.0) << "the hull still reaches the far loop";
  // A sub-shaft of the receivers on z = 0 only: the remaining boundary touches its clip
  // plane, the hull does not, so the surface stands beyond it and neither blocks nor is
  // dropped.
  AABB r1(Vec3f(-0.2f, -0.25f, 0), Vec3f(0.2f, 0.2f, 0));
  iss::ShaftGeometry g1(r1, l, iss::MainAxis{g.main_axis(), g.dir()}, 11.0);
  iss::compute_bounds(s, g1);
  EXPECT_TRUE(iss::beyond_clip_planes(s.box, g1));
  EXPECT_FALSE(iss::beyond_clip_planes(s.hull, g1));
  EXPECT_TRUE(iss::stands_beyond_clip_planes(s, g1));
  EXPECT_EQ(iss::blocking_test(s, g1), iss::BlockTest::Unknown);
  // Merging keeps the hull.
  iss::merge_patches(s, ws);
  EXPECT_EQ(s.hull.hi.z, 2.0);
}

TEST(IssBlockers, AMergedPatchKeepsItsTrianglesInTheHull) {
  // MERGE-PATCHES forgets the edges inside a merged patch: the three faces of the open
  // tetrahedron, consistent towards the light, merge into one patch whose boundary is the
  // base triangle, flat on z = 0, while the faces rise to z = 0.5. The boundary's box is
  // flat; the hull keeps the apex, so a shaft from a receiver on the base plane does
  // not drop the surface as beyond its clip plane.
  Scene sc;
  add_open_tetrahedron(sc);
  sc.lights.push_back(square_light(0, 0, 2, 2, 4));
  sc.receivers.push_back({Vec3f(-0.5f, 1, 0), Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(sc).ok());
  mesh::PreparedMesh pm = mesh::prepare_mesh(sc.mesh);
  iss::BlockerContext ctx{&pm, 4.0};
  AABB r(Vec3f(-0.5f, 0.8f, -1.5f), Vec3f(-0.3f, 1, 0)), l(Vec3f(-2, -2, 2), Vec3f(2, 2, 2));
  iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 4.0);
  ASSERT_EQ(g.main_axis(), 2);
  iss::TreeNode rn, ln;  // no inside triangles
  iss::Workspace ws;
  iss::Surface s = iss::construct_triangle_surface(ctx, {0, 1, 2}, g, rn, ln, ws);
  ASSERT_EQ(s.patches.size(), 3u);
  iss::classify_edges(s, g);
  iss::update_patch_facings(ctx, s, g);
  iss::merge_patches(s, ws);
  ASSERT_EQ(iss::validate(s, &pm), "");
  ASSERT_EQ(s.patches.size(), 1u) << "the faces merge";
  iss::compute_bounds(s, g);
  EXPECT_EQ(s.box.hi.z, 0.0) << "the boundary is the base";
  EXPECT_EQ(s.hull.hi.z, 0.5) << "the hull keeps the apex";
  // The sub-shaft of the receiver on the base: its clip plane is z = 0.
  AABB r1(Vec3f(-0.5f, 1, 0), Vec3f(-0.5f, 1, 0));
  iss::ShaftGeometry g1(r1, l, iss::MainAxis{g.main_axis(), g.dir()}, 4.0);
  EXPECT_TRUE(iss::beyond_clip_planes(s.box, g1));
  EXPECT_FALSE(iss::beyond_clip_planes(s.hull, g1)) << "not to be dropped";
  EXPECT_NE(iss::blocking_test(s, g1), iss::BlockTest::Clear) << "not to be removed";
}
