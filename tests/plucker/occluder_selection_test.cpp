// Tests of lib/plucker/occluder_selection.cpp (Figure 8 "SC"): occluders touching,
// crossing or beyond the slab planes, and the triangles rounding sends to the exact path,
// through whole solves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "lib/plucker/bsp.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/group_state.h"
#include "lib/plucker/lines.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/scene/scene_json.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "oracle/region_oracle.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

TEST(PluckerSelection, DistinctCornersOfAFlatBoxHoldEveryCornerOnce) {
  // The receivers' box of a grid is flat: its 8 corners are 4 points, each twice. Every
  // corner of the 8 must be among those returned, each returned one a corner, none twice,
  // in the order of first occurrence; -0 and +0 count as different (their bits differ).
  auto corner = [](const Vec3d& lo, const Vec3d& hi, int c) {
    return Vec3d((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
  };
  const struct {
    Vec3d lo, hi;
    int n;
  } cases[] = {{Vec3d(0, 0, 0), Vec3d(1, 2, 3), 8},   {Vec3d(0, 0, 1), Vec3d(1, 2, 1), 4},
               {Vec3d(5, 0, 1), Vec3d(5, 2, 1), 2},   {Vec3d(5, 2, 1), Vec3d(5, 2, 1), 1},
               {Vec3d(-0.0, 0, 1), Vec3d(0.0, 2, 1), 4}};
  for (const auto& cs : cases) {
    Vec3d out[8];
    const int n = distinct_corners(cs.lo, cs.hi, out);
    ASSERT_EQ(n, cs.n);
    int last = -1;
    for (int k = 0; k < n; ++k) {
      int first = -1;  // the first corner c equal to out[k], bit for bit
      for (int c = 0; c < 8 && first < 0; ++c) {
        const Vec3d x = corner(cs.lo, cs.hi, c);
        if (std::memcmp(&x, &out[k], sizeof x) == 0) first = c;
      }
      EXPECT_GT(first, last);  // a corner, new, in increasing order
      last = first;
    }
    for (int c = 0; c < 8; ++c) {
      const Vec3d x = corner(cs.lo, cs.hi, c);
      bool found = false;
      for (int k = 0; k < n; ++k) found = found || std::memcmp(&x, &out[k], sizeof x) == 0;
      EXPECT_TRUE(found) << c;
    }
    for (int k = n; k < 8; ++k) EXPECT_EQ(out[k], out[0]);
  }
}

TEST(PluckerSolver, OccluderTouchingTheLightPlane) {
  // Triangle in the plane x = 0 with its edge y in [-3, 3] on the light plane z = 2 and
  // apex (0, 0, 1); receiver (0.5, 0, 0). A point (0, y, z) projects to
  // x = 0.5 - 1/z, y' = 2y/z: the apex to (-0.5, 0), the edge to itself. The shadow is
  // the triangle apex (-0.5, 0), base x = 0, |y| <= 3, half-width 6t at t = x + 0.5;
  // inside |y| <= 1: 12 t^2/2 on [0, 1/6] plus 2 (1/2 - 1/6): 1/6 + 2/3 = 5/6.
  Scene s = light_scene({Vec3f(0.5f, 0, 0)});
  s.mesh.vertices = {Vec3f(0, -3, 2), Vec3f(0, 3, 2), Vec3f(0, 0, 1)};
  s.mesh.triangles = {{0, 1, 2}};
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], (4.0 - 5.0 / 6.0) / 4.0, 1e-5);
}

TEST(PluckerSolver, OccluderCrossingTheLightPlane) {
  // Vertices (0, +-3, 3) above the light and apex (0, 0, 1): clipped at z = 2 to the base
  // y in [-1.5, 1.5]; half-width 3t: 6 t^2/2 on [0, 1/3] plus 2 (1/2 - 1/3): 2/3.
  Scene s = light_scene({Vec3f(0.5f, 0, 0)});
  s.mesh.vertices = {Vec3f(0, -3, 3), Vec3f(0, 3, 3), Vec3f(0, 0, 1)};
  s.mesh.triangles = {{0, 1, 2}};
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], (4.0 - 2.0 / 3.0) / 4.0, 1e-5);
}

TEST(PluckerSolver, OccluderCrossingTheReceiverPlane) {
  // A wall x = 0, |y| <= 100, z in [-5, 1]; receiver (0.5, 0, 0). Only z in (0, 1]
  // counts; it projects to x = 0.5 - 1/z <= -0.5 with |y'| >= 200: the strip
  // x in [-1, -0.5] is hidden, fraction 3/4. The part below z = 0 must not block.
  Scene s = light_scene({Vec3f(0.5f, 0, 0)});
  shapes::add_quad(s.mesh, Vec3d(0, -100, -5), Vec3d(0, 100, -5), Vec3d(0, 100, 1), Vec3d(0, -100, 1));
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], 0.75, 1e-5);
}

TEST(PluckerSolver, OccludersBehindBeyondAndInThePlanes) {
  Scene s = light_scene({Vec3f(0, 0, 0)});
  shapes::add_quad(s.mesh, Vec3d(-3, -3, -1), Vec3d(3, -3, -1), Vec3d(3, 3, -1), Vec3d(-3, 3, -1));  // behind
  shapes::add_quad(s.mesh, Vec3d(-3, -3, 3), Vec3d(3, -3, 3), Vec3d(3, 3, 3), Vec3d(-3, 3, 3));      // beyond
  shapes::add_quad(s.mesh, Vec3d(-3, -3, 2), Vec3d(3, -3, 2), Vec3d(3, 3, 2), Vec3d(-3, 3, 2));      // in the light plane
  shapes::add_quad(s.mesh, Vec3d(-3, -3, 0), Vec3d(3, -3, 0), Vec3d(3, 3, 0), Vec3d(-3, 3, 0));      // through the receiver
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], 1.0, 1e-6);
  for (int j = 0; j < s.lights[0].samples; ++j) EXPECT_TRUE(r.receivers[0].visible(size_t(j)));
}

TEST(PluckerSolver, OccluderWithAVertexFarAway) {
  // fuzz_plucker dfb33fdd... and de071e79... (far-origin scenes with one coordinate
  // replaced): sliver triangles reaching from the light to a vertex 6e5 away. Clipped
  // and split in float they moved by u |edge| = 0.04 at a light of size 2, and judged
  // through the far vertex their planes did too (fragment.h clip_by_values, lines.h
  // nearest_base). Fractions against the region oracle, for receivers around the light.
  Scene s = light_scene({Vec3f(0, 0, 0), Vec3f(0.3f, -0.2f, 0), Vec3f(-0.6f, 0.5f, 0.5f), Vec3f(0.9f, 0.1f, 0)});
  s.mesh.vertices = {Vec3f(600000.0f, 0.1f, 1.5f), Vec3f(-0.8f, 0.05f, 1.2f), Vec3f(-0.7f, 0.3f, 1.4f),
                     Vec3f(-600000.0f, -0.3f, 1.0f), Vec3f(0.5f, -0.6f, 1.3f), Vec3f(0.4f, -0.2f, 1.6f)};
  s.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  ASSERT_TRUE(finish_scene(s).ok());
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      double exact = oracle::visible_region(s, i, 0).visible_fraction;
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact, 1e-4) << i << " " << what;
    }
  });
}

TEST(PluckerSolver, WallReachingThroughATiltedLightFromAFarVertex) {
  // The scene form of the case above: a wall x = 0.5 from z = 1 up to a vertex 2^73
  // above, through a tilted light (z = 2 + 0.1 x). Its clipped top edge lay below the
  // light plane and a wedge of its shadow was reported visible.
  Scene s;
  s.name = "wall-to-far-vertex";
  Light l;
  l.polygon = {Vec3f(-1, -1, 1.9f), Vec3f(1, -1, 2.1f), Vec3f(1, 1, 2.1f), Vec3f(-1, 1, 1.9f)};
  l.samples = 16;
  l.seed = 3;
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(0.5f, -1, 1), Vec3f(0.5f, 1, 1), Vec3f(0.5f, 0, 0x1p73f)};
  s.mesh.triangles = {{0, 1, 2}};
  s.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
  s.receivers.push_back({Vec3f(0.2f, 0.3f, 0.5f), Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(s).ok());
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      double exact = oracle::visible_region(s, i, 0).visible_fraction;
      EXPECT_GT(exact, 0.01);
      EXPECT_LT(exact, 0.99);
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact, 1e-5) << i << " " << what;
    }
  });
}

TEST(PluckerSolver, OccluderVertexWithinRoundingOfATiltedLightsPlane) {
  // fuzz_plucker 09bd12dc... minimised (one triangle of 16): a light quad at z = 2 with
  // one vertex lifted by 5.8e-6, so its Newell plane passes a few 1e-6 above the float
  // plane z = 2, and a triangle whose first vertex lies on z = 2 inside the footprint,
  // just beyond the lifted plane. Clipped to the light side, that vertex became two clip
  // points 1e-21 apart; the plane through a receiver and their edge (a direction of pure
  // rounding) cut the shadow at the vertex in half: fractions 0.75 for 0.62 and fragment
  // points blocked at margin 0.013. Clip points within rounding of a neighbour are merged
  // (plucker_solver.cpp merge_plane_points).
  Scene s;
  s.name = "tilted-light-vertex-on-plane";
  Light l;
  l.polygon = {Vec3f(-0.5f, -0.5f, 2.0f), Vec3f(-0.5f, 0.5f, 2.0f), Vec3f(0.5f, 0x1.fffffep-2f, 0x1.000188p+1f),
               Vec3f(0.5f, -0.5f, 2.0f)};
  l.samples = 16;
  l.seed = 41662;
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(-0.25f, -0.25f, 2.0f), Vec3f(-0.75f, 0.25f, 1.25f), Vec3f(0.25f, 0.5f, 0.5f)};
  s.mesh.triangles = {{0, 1, 2}};
  for (Vec3f p : {Vec3f(-0.75f, 1.5f, 0), Vec3f(-0.5f, -1.25f, 0), Vec3f(-0.75f, 1.0f, 0), Vec3f(-0.25f, -1.5f, 0),
                  Vec3f(1.5f, 1.5f, 0), Vec3f(0.25f, -1.25f, 0)})
    s.receivers.push_back({p, Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(s).ok());
  int partial = 0;
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {{"tile", "5"}},
      [&](const SolveResult& r, const std::string& what) {
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      const double exact = oracle::visible_region(s, i, 0).visible_fraction;
      partial += exact > 0.001 && exact < 0.999;
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact, 1e-4) << i << " " << what;
    }
  });
  EXPECT_GT(partial, 0);
}

TEST(PluckerSolver, TriangleReachingFarBeyondTheSceneIsSubtractedExactly) {
  // fuzz_plucker 1cb7edfb...: a wall of the on-surface family reaching (-1.5, 1.5, 8.2e22),
  // entirely beyond a tilted unit light inside the slab between the receivers and the
  // light. Its light-plane crossing on an edge from z = -4.3e18 came out 480 off in
  // double and the clipped sliver hid 40% of the light (fraction 0.60 for 1). Triangles
  // reaching beyond 2^20 times the group's working scale are subtracted exactly.
  Scene s;
  s.name = "far-reaching-wall";
  Light l;
  l.polygon = {Vec3f(-0.5f, -0.5f, -0x1.a0acdep-59f), Vec3f(-0.5f, 0.5f, 2.0f), Vec3f(0.5f, 0.5f, 2.0f),
               Vec3f(0.5f, -0.5f, -0x1p-27f)};
  l.samples = 16;
  l.seed = 10480;
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(-1.5f, -1.5f, 0), Vec3f(1.5f, -1.5f, 0), Vec3f(0, -1.5f, -0x1.e090f2p+61f),
                     Vec3f(-1.5f, 1.5f, 0x1.14e586p+76f)};
  s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  for (Vec3f p : {Vec3f(-1.5f, 0x1p-48f, 0), Vec3f(0x1.9f937ap-4f, 0x1.4239eap-1f, 0), Vec3f(1.5f, 0x1.7e2deep+0f, 0),
                  Vec3f(-0x1.562034p+0f, -0x1.aec6p-3f, 0), Vec3f(-1.5f, 0x1.6eb27ap-2f, 0)})
    s.receivers.push_back({p, Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(s).ok());
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {{"tile", "7"}},
      [&](const SolveResult& r, const std::string& what) {
    EXPECT_GE(r.stats.get("far_triangles"), 1.0) << what;
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      const double exact = oracle::visible_region(s, i, 0).visible_fraction;
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact, 1e-4) << i << " " << what;
    }
  });
}

TEST(PluckerSolver, TriangleWithinRoundingBeforeTheLightPlane) {
  // fuzz_plucker a77807ad (a sanitizer-free 30 s run), minimised by hand from a pouch:
  // a triangle with an edge in the light plane z = 2 and its third vertex 6e-7 before
  // it, under the plane's rounding bound (7e-7 for this light), hides the light points
  // above it (1/8 of the light) from every receiver; it was culled as lying in the
  // light's plane (fraction 1 for 0.875). The exact side of its vertices now decides.
  Scene s = light_scene({Vec3f(-1, -1, 0), Vec3f(1, -1, 0), Vec3f(-1, 1, 0), Vec3f(1, 1, 0)}, 16);
  s.mesh.vertices = {Vec3f(0, 0, 2), Vec3f(0, 1, 0x1.fffffap+0f), Vec3f(1, 0, 2)};
  s.mesh.triangles = {{0, 1, 2}};
  ASSERT_TRUE(finish_scene(s).ok());
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
    EXPECT_GE(r.stats.get("band_triangles"), 1.0) << what;
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      const double exact = oracle::visible_region(s, i, 0).visible_fraction;
      EXPECT_NEAR(exact, 0.875, 1e-6) << i;
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], exact, 1e-4) << i << " " << what;
    }
  });
}

TEST(PluckerSolver, SliverLostInTheLocalFrameIsSubtractedExactly) {
  // fuzz_plucker eb250d24 (ASan run, 2026-12-03): a collapsed torus whose triangle
  // (-0, 0, 2), (-0, -1.5 2^-148, -2), (2^-147, 0, 2) is a sliver along the z axis, and
  // receivers at the origin 2^-149 from its plane: seen from there it hides the wedge
  // 0 <= x <= 4|y|/3, y < 0 of the light at z = 2, 5/32 of it (fraction 0.84375). In the
  // local frame of the light's first vertex (-2, -2, 2) the sliver's x = 2^-147 rounded
  // away, the triangle became a segment and was dropped: fraction 1. A triangle whose
  // translation is rounded and that is that thin is now subtracted exactly
  // (plucker_solver.cpp, "rounded_triangles").
  const char* text = R"JSON({"format":"visgate-scene","version":1,"name":"torus-28747",
"meshes":[{"vertices":[["0x0p+0","0x0p+0","-0x0p+0"],["-0x0p+0","0x0p+0","0x1p+1"],["-0x0p+0","0x0p+0","0x1p+1"],["0x0p+0","0x0p+0","0x1p+1"],["-0x0p+0","0x0p+0","0x1p+1"],["0x0p+0","0x0p+0","0x0p+0"],["0x1p-147","-0x0p+0","0x1p+1"],["-0x0p+0","-0x0p+0","0x1p+1"],["-0x0p+0","-0x1.8p-148","-0x1p+1"]],
"triangles":[[0,1,2],[0,2,3],[3,2,4],[3,4,5],[5,4,1],[5,1,0],[1,6,7],[1,7,2],[2,7,8],[2,8,4],[4,8,6],[4,6,1],[6,0,3],[6,3,7],[7,3,5],[7,5,8],[8,5,0],[8,0,6]]}],
"lights":[{"polygon":[["-0x1p+1","-0x1p+1","0x1p+1"],["-0x1p+1","0x1.fffffep+0","0x1p+1"],["0x1p+1","0x1p+1","0x1p+1"],["0x1p+1","-0x1p+1","0x1p+1"]],"samples":6,"pattern":"stratified","jitter":4,"seed":28747}],
"receivers":[{"p":["-0x0p+0","-0x0p+0","0x0p+0"],"n":["0x1p-77","0x0p+0","-0x1p-74"]},
{"p":["0x0p+0","-0x0p+0","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]},
{"p":["0x1.e4acdp-68","0x0p+0","0x0p+0"],"n":["0x1p+1","0x0p+0","0x1p+0"]},
{"p":["0x0p+0","0x0p+0","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]}]})JSON";
  auto s = read_scene_json(text, "fuzz", ".");
  ASSERT_TRUE(s.ok()) << s.error().message;
  for_each_solve(*s, {{"coherence", {"on", "off"}}}, {{"tile", "7"}},
      [&](const SolveResult& r, const std::string& what) {
    EXPECT_GT(r.stats.get("rounded_triangles"), 0.0);
    expect_fractions_match_region_oracle(*s, r, what);
  });
  EXPECT_NEAR(oracle::visible_region(*s, 1, 0).visible_fraction, 27.0 / 32.0, 1e-8);  // the hand-worked wedge
}

TEST(PluckerSolver, ExtremeReceiverDoesNotSetTheGroupsWorkingScale) {
  // fuzz_plucker 96d10f7c (a sanitizer-free 30 s run, 2026-12-03): a fan whose wall
  // reaches 2^104 away crosses the slab 0.78 below a unit light; receiver 0, at 2^99,
  // is shaded exactly (more than 2^20 light widths away) but it set the group's working
  // scale, so the wall was not "far" for receivers 1-3 and was clipped in double, where
  // merge_plane_points (tolerance 2^-36 of the points' magnitudes, 2^68 there) merged
  // the clip points at the light plane with the vertices below them and dropped it:
  // fractions 0.885, 0.817, 0.555 for 0.767, 0.789, 0.527. The scale now counts only the
  // receivers the float path shades, and the wall is subtracted exactly.
  const char* text = R"JSON({"format":"visgate-scene","version":1,"name":"double-surface-13285",
"meshes":[{"vertices":[["0x0p+0","0x1p+0","0x1.c8ead8p+75"],["0x1.54f1ecp-2","-0x1.cf0d12p-2","0x1.1da482p+0"],["0x1.cacae4p+103","0x1.54f1ecp-2","0x1.37ef58p+0"],["-0x1.e1e1ep+98","0x1.cf0d12p-2","0x1.37ef58p+0"],["-0x1.cf0cfp-2","-0x1.54f1ecp-2","0x1.1da482p+0"],["0x1.54f1ecp-2","-0x1.cf0d12p-2","0x1.f0eb58p-1"],["-0x1.54f1ecp-2","0x1.54f1ecp-2","0x1.bc55acp-1"],["-0x1.54f1ecp-2","0x1.cf0d12p-2","0x1.d0ea92p+124"],["-0x1.cf0d12p-2","-0x1.54f1ecp-2","0x1.f0eb58p-1"]],
"triangles":[[0,1,2],[0,2,3],[0,3,4],[0,4,5],[0,5,6],[0,6,7],[0,7,8],[0,8,1]]}],
"lights":[{"polygon":[["-0x1.333334p-1","-0x1.333288p-1","0x1p+1"],["-0x1.333334p-1","0x1.333334p-1","0x1p+1"],["0x1.333334p-1","0x1.333334p-1","0x1p+1"],["0x1.333334p-1","-0x1.333334p-1","0x1p+1"]],"samples":11,"pattern":"stratified","jitter":4,"seed":13285}],
"receivers":[{"p":["-0x1.e1e1ep+98","-0x1p-1","0x1p-149"],"n":["0x0p+0","0x0p+0","0x1p+0"]},
{"p":["0x1p-1","-0x1p-1","0x0p+0"],"n":["0x0p+0","0x0p+0","-0x1p-144"]},
{"p":["-0x1p-1","0x1p-1","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]},
{"p":["0x1p-1","0x1p-1","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]}]})JSON";
  auto s = read_scene_json(text, "fuzz", ".");
  ASSERT_TRUE(s.ok()) << s.error().message;
  for_each_solve(*s, {{"coherence", {"on", "off"}}}, {{"tile", "7"}},
      [&](const SolveResult& r, const std::string& what) {
    EXPECT_GT(r.stats.get("far_triangles"), 0.0);
    expect_fractions_match_region_oracle(*s, r, what);
  });
}

TEST(PluckerSolver, SliverSeenEdgeOnIsNotMergedAwayAtTheLightPlane) {
  // fuzz_plucker 2d069e89 (a sanitizer-free 60 s run, 2026-12-04), reduced to its one
  // triangle: a sliver in the plane y = 0 with vertices (0, 0, 2), (2^-37, 0, 2) on the
  // light's plane z = 2 and (0, 0, -2); light [-2, 2]^2 at z = 2; receiver r = (0, e, 0),
  // e = 1.6e-34. By hand: a segment from r to a light point (lx, ly) with ly < 0 crosses
  // y = 0 at t = e / (e - ly), at (t lx, 0, 2t); the sliver there spans x in [0, about
  // 2^-38], so the segment is blocked exactly when lx > 0 (for all but |ly| below about
  // e 2^39 = 1e-22): a quarter of the light is hidden, fraction 0.75. A receiver at the
  // origin lies on the sliver's edge line and in its plane: nothing hides (fraction 1).
  // The two light-plane vertices, 2^-37 apart, were within the merge tolerance of clip
  // points (2^-36 of the coordinates), so they were merged and the sliver dropped
  // (fraction 1 for 0.75); such triangles now go to the exact path.
  const char* text = R"JSON({"format":"visgate-scene","version":1,"name":"torus-28747",
"meshes":[{"vertices":[["-0x0p+0","0x0p+0","0x1p+1"],["0x1p-37","-0x0p+0","0x1p+1"],["-0x0p+0","0x0p+0","-0x1p+1"]],
"triangles":[[0,1,2]]}],
"lights":[{"polygon":[["-0x1p+1","-0x1p+1","0x1p+1"],["-0x1p+1","0x1p+1","0x1p+1"],["0x1p+1","0x1p+1","0x1p+1"],["0x1p+1","-0x1p+1","0x1p+1"]],"samples":6,"pattern":"stratified","jitter":4,"seed":28747}],
"receivers":[{"p":["0x0p+0","0x1.a045cap-114","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]},
{"p":["0x0p+0","0x0p+0","0x0p+0"],"n":["0x0p+0","0x0p+0","0x1p+0"]}]})JSON";
  auto s = read_scene_json(text, "fuzz", ".");
  ASSERT_TRUE(s.ok()) << s.error().message;
  for_each_solve(*s, {{"coherence", {"on", "off"}}, {"choice", {"random", "relevant"}}}, {{"tile", "7"}},
      [&](const SolveResult& r, const std::string& what) {
    EXPECT_NEAR(r.receivers[0].visible_fraction[0], 0.75, 1e-6) << what;
    EXPECT_EQ(r.receivers[1].visible_fraction[0], 1.0f) << what;
    EXPECT_GE(r.stats.get("plane_point_triangles"), 1.0);
    expect_fractions_match_region_oracle(*s, r, what);
  });
  EXPECT_NEAR(oracle::visible_region(*s, 0, 0).visible_fraction, 0.75, 1e-9);  // the hand computation
}
