// lib/iss/blocking.cpp: clamping and the blocking test (paper 000 sections 4.5, 4.6).
#include <gtest/gtest.h>

#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "lib/scene/families.h"
#include "lib/solver.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(IssBlockers, CanBlockShaftUsesTheClampedBoxAndFaceToFaceSegments) {
  // Receiver box 1 x 1 x 0.5 at z in [1, 1.5] (outer face z = 1, the lower clip
  // plane), light face at z = 4. Hand-worked: the winding test clamps a boundary lying
  // below z = 1 onto that plane, so a surface whose boundary box [-2, 2]^2 x [0, 0.5]
  // covers the receiver face from below may block (its surface can reach up through the
  // shaft); the unclamped box meets no box-to-box segment. A boundary below the plane
  // but beside the face ([5, 6] in x) cannot wind around the test segment.
  AABB r(Vec3f(0, 0, 1), Vec3f(1, 1, 1.5f)), l(Vec3f(0.25f, 0.25f, 4), Vec3f(0.75f, 0.75f, 4));
  iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 6.0);
  ASSERT_EQ(g.main_axis(), 2);
  AABBd below{Vec3d(-2, -2, 0), Vec3d(2, 2, 0.5)}, beside{Vec3d(5, -2, 0), Vec3d(6, 2, 0.5)};
  EXPECT_TRUE(iss::can_block_shaft(below, g));
  EXPECT_FALSE(iss::can_block_shaft(beside, g));
  AABBd c = iss::clamped_box(below, g);
  EXPECT_EQ(c.lo.z, 1.0);
  EXPECT_EQ(c.hi.z, 1.0);
  // A box across the whole slab is unchanged by the clamp and may block.
  AABBd across{Vec3d(-2, -2, 2), Vec3d(2, 2, 3)};
  EXPECT_TRUE(iss::can_block_shaft(across, g));
  EXPECT_EQ(iss::clamped_box(across, g).lo.z, 2.0);
}

TEST(IssBlockers, ClampingKeepsSplitPointsOnTheirClipPlanes) {
  // Hand-worked (fuzz_iss crash-cfabe77d, corpus/iss/other): triangle A = (0.25, 0.5, 0),
  // B = (1, 0, 1), C = (0.5, 0, 2); receiver R = (1, 1.5, z_r), light sample L = (-0.25,
  // -0.25, e) with e = 0x1.d2e914p-109 (about 2.8e-33). The segment RL runs in the plane
  // z ~ 0, where the triangle has only its vertex A; RL passes A at distance ~0.03 (at
  // y = 0.5 it is at x = 0.286), so nothing is blocked. The shaft keeps the main axis z
  // of its ancestors (the receivers lie in z = 0 below the light), so its slab is
  // [z_r, e]. Edge C -> A crosses z = e at parameter 1 - e/2, which rounds to 1: the
  // split point used to be A itself, clamped to z_r instead of e, and the clamped
  // boundary then ran diagonally through the slab under the test line (winding 2,
  // false-blocked). With z_r = 2^-133 both clip planes are within an ulp of A and the
  // two split points came out lower plane first (a zig-zag, also winding 2).
  const float e = 0x1.d2e914p-109f;
  for (float zr : {0.0f, 0x1p-133f}) {
    Vec3d a(0.25, 0.5, 0), b(1, 0, 1), c(0.5, 0, 2);
    iss::Surface s = one_triangle_surface(a, b, c, iss::Facing::TowardsLight);
    AABB r(Vec3f(1, 1.5f, zr), Vec3f(1, 1.5f, zr)), l(Vec3f(-0.25f, -0.25f, e), Vec3f(-0.25f, -0.25f, e));
    iss::ShaftGeometry g(r, l, iss::MainAxis{2, 1}, 2.0);
    EXPECT_EQ(iss::classify_edges(s, g), 3u) << "every edge is 0.03 or more from the shaft";
    iss::compute_bounds(s, g);
    EXPECT_EQ(iss::validate(s, nullptr), "");
    EXPECT_TRUE(iss::can_block_shaft(s.box, g)) << "the clamped box covers the segment";
    EXPECT_FALSE(iss::blocks_shaft(s, g)) << "z_r = " << zr;
    // The same through the solver, with one-point leaves so that this very shaft is built.
    Scene sc;
    Light li = square_light(0, 0, 2, 0.25, 2);
    li.jitter = 1;
    li.pattern = SamplePattern::Explicit;
    li.explicit_samples = {Vec3f(0.25f, 0.25f, 2), Vec3f(-0.25f, -0.25f, e)};
    sc.lights.push_back(li);
    sc.receivers.push_back({Vec3f(1, 1.5f, zr), Vec3f(0, 0, 1)});
    sc.receivers.push_back({Vec3f(-1.5f, -0.25f, 0), Vec3f(0, 0, 1)});
    ASSERT_TRUE(finish_scene(sc).ok());
    sc.mesh.vertices = {Vec3f(0.25f, 0.5f, 0), Vec3f(1, 0, 1), Vec3f(0.5f, 0, 2)};
    sc.mesh.triangles = {{0, 1, 2}};
    for (const auto& o : kOptionSets) {
      SolveResult res = run_iss(sc, o);
      EXPECT_TRUE(res.receivers[0].visible(1)) << describe(o) << " z_r = " << zr;
    }
    for (const char* rc : {"embree", "custom"}) {
      SolveResult res = run_iss(sc, {{"leaf_receivers", "1"}, {"leaf_samples", "1"}, {"ray_caster", rc}});
      EXPECT_TRUE(res.receivers[0].visible(1)) << rc << " z_r = " << zr;
    }
  }
}
