// lib/iss/empty_shaft.cpp: the empty-shaft rule and its sloped-floor extension (paper 000 section 4.12).
#include <gtest/gtest.h>

#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(Iss, SlopedFloorReceiversUseTheEmptyShaftOnlyOnTheirSide) {
  // The sloped floor of section 4.12: receivers 0.01 above the plane z = 0.1 x, so
  // every receiver node's box meets the floor triangles. Hand-worked: with the light
  // above the floor every relation is visible, and the extended empty-shaft rule
  // decides them without rays; with the light below the floor every segment crosses
  // it, so every relation is blocked, and the rule must not fire.
  for (double lz : {4.0, -4.0}) {
    Scene s;
    s.lights.push_back(make_square_light_down(Vec3d(0, 0, lz), 0.5, 16, 3));
    for (int b = 0; b < 16; ++b)
      for (int a = 0; a < 16; ++a) {
        float x = float(-1.0 + 2.0 * (a + 0.5) / 16), y = float(-1.0 + 2.0 * (b + 0.5) / 16);
        s.receivers.push_back({Vec3f(x, y, 0.1f * x + 0.01f), Vec3f(0, 0, 1)});
      }
    ASSERT_TRUE(finish_scene(s).ok());
    shapes::add_quad(s.mesh, Vec3d(-3, -3, -0.3), Vec3d(3, -3, 0.3), Vec3d(3, 3, 0.3), Vec3d(-3, 3, -0.3));
    for (const auto& o : kOptionSets) {
      SolveResult r = run_iss(s, o);
      double rel = double(s.relation_count());
      if (lz > 0) {
        EXPECT_EQ(count_visible(s, r), rel) << describe(o);
        EXPECT_GT(r.stats.get("relations_visible_by_empty_shaft"), 0.5 * rel) << describe(o);
      } else {
        EXPECT_EQ(count_visible(s, r), 0.0) << describe(o);
        EXPECT_EQ(r.stats.get("relations_visible_by_empty_shaft"), 0.0) << describe(o);
      }
    }
  }
}

TEST(Iss, EmptySceneIsAllVisibleWithoutRays) {
  Scene s = light_over_grid(0, 0, 4, 0.5, -1, 1, -1, 1, 8);
  SolveResult r = run_iss(s, {});
  EXPECT_EQ(count_visible(s, r), double(s.relation_count()));
  EXPECT_EQ(r.stats.get("relations_ray_cast"), 0.0);
}
