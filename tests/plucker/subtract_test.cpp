// Tests of lib/plucker/subtract.cpp: subtracting shadows from fragments, through whole
// solves.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "lib/plucker/lines.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/solver.h"
#include "oracle/region_oracle.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

// A shadow beside a fragment that still cuts it along the planes through its edges
// leaves the fragment whole: nothing of it is hidden. Splitting it anyway, the exact
// path's fragment list grew 1.8x per triangle to 145,369 fragments of one receiver, none
// hidden (fuzz_plucker 82d969b1..., corpus/fuzz/slow). Seen from receiver 0 at the
// origin (or far below), an occluder's shadow on the light plane z = 2 is its (x, y)
// scaled by 2 / z (or by 2 for one halfway to the far receiver).
TEST(PluckerSolver, ShadowBesideAFragmentLeavesItWhole) {
  // The fragments of receiver 0 must be `expect` (as vertex sets), the fractions exact.
  auto check = [](const Scene& s, const std::vector<std::vector<Vec3f>>& expect, const char* path) {
    const auto exact = oracle::visible_region(s, 0, 0);
    for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
      EXPECT_NEAR(r.receivers[0].visible_fraction[0], exact.visible_fraction, 1e-6) << path;
      const auto& frags = r.receivers[0].fragments[0];
      ASSERT_EQ(frags.size(), expect.size()) << path << " " << what;
      for (size_t k = 0; k < frags.size(); ++k) {
        ASSERT_EQ(frags[k].size(), expect[k].size()) << path;
        for (const Vec3f& v : frags[k]) {
          bool found = false;
          for (const Vec3f& e : expect[k]) found |= max_component(vabs(to_double(v) - to_double(e))) < 1e-6;
          EXPECT_TRUE(found) << path << " " << v.x << " " << v.y << " " << v.z;
        }
      }
    });
  };
  {
    // Exact path: receivers 2^24 below the light are more than 2^20 light widths away
    // (shade_group, extreme), and every candidate triangle is subtracted exactly. The
    // triangle halfway casts (1.2, 0.3), (2, -0.5), (2, 1.1) for receiver 0: right of the
    // light [-1, 1]^2, while its edges x + y = 1.5 and y = x - 0.9 both cross it (three
    // fragments, none hidden, before). Receiver 1 widens the shaft to take the triangle.
    const float rz = -0x1p24f, mid = 0.5f * (2.0f + rz);
    Scene s = light_scene({Vec3f(0, 0, rz), Vec3f(4, 0, rz)});
    s.mesh.vertices = {Vec3f(0.6f, 0.15f, mid), Vec3f(1, -0.25f, mid), Vec3f(1, 0.55f, mid)};
    s.mesh.triangles = {{0, 1, 2}};
    SolveResult r = run(s);
    EXPECT_EQ(r.stats.get("exact_receivers"), 2.0);
    EXPECT_GE(r.stats.get("exact_triangles"), 1.0);
    EXPECT_EQ(oracle::visible_region(s, 0, 0).visible_fraction, 1.0);
    check(s, {s.lights[0].polygon}, "exact");
  }
  {
    // Float path, near polygons: receivers at z = 0 and 1 form one group, and triangles
    // within the group's depth are subtracted per receiver, in order. Triangle A at
    // z = 0.75 hides the corner x + y > 1 of the light from receiver 0, leaving the
    // pentagon below. Triangle B at z = 0.5 casts its shadow near (0.8, 0.8), in that
    // corner, off the pentagon, and two of its edge planes cut the pentagon (two
    // fragments before).
    Scene s = light_scene({Vec3f(0, 0, 0), Vec3f(0.125f, 0, 1)});
    s.mesh.vertices = {Vec3f(1.125f, -0.75f, 0.75f), Vec3f(-0.75f, 1.125f, 0.75f), Vec3f(1.125f, 1.125f, 0.75f),
                       Vec3f(0.175f, 0.175f, 0.5f), Vec3f(0.2375f, 0.2f, 0.5f), Vec3f(0.2f, 0.2375f, 0.5f)};
    s.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    SolveResult r = run(s);
    EXPECT_GE(r.stats.get("near_polygons"), 2.0);
    check(s, {{Vec3f(-1, -1, 2), Vec3f(1, -1, 2), Vec3f(1, 0, 2), Vec3f(0, 1, 2), Vec3f(-1, 1, 2)}}, "near");
  }
}
