// lib/iss/shaft_construction.cpp: the blocker probe before the initial shaft (paper 000 section 4.8).
#include <gtest/gtest.h>

#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

TEST(Iss, SlabAboveClutterIsDecidedByTheProbe) {
  // Receivers on a floor, a closed slab above them, the light above the slab, and many
  // small boxes under the slab: the probe of section 4.8 (shaft_construction.cpp) finds the slab
  // among the wide triangles and decides the initial shaft without building the rest.
  // Hand-worked: the slab covers the whole shaft, every relation is blocked.
  Scene s;
  s.lights.push_back(square_light(0, 0, 4, 0.3, 16));
  add_receiver_grid(s, -2, 2, -2, 2, 0.01, 16);
  ASSERT_TRUE(finish_scene(s).ok());
  shapes::add_box(s.mesh, Vec3d(-3, -3, 2.8), Vec3d(3, 3, 3.0));
  for (int k = 0; k < 64; ++k) {
    double x = -1.8 + 0.45 * (k % 8), y = -1.8 + 0.45 * (k / 8);
    shapes::add_box(s.mesh, Vec3d(x, y, 1.0), Vec3d(x + 0.1, y + 0.1, 1.1));
  }
  for (const auto& o : kOptionSets) {
    SolveResult r = run_iss(s, o);
    EXPECT_EQ(count_visible(s, r), 0.0) << describe(o);
    EXPECT_EQ(r.stats.get("relations_ray_cast"), 0.0) << describe(o);
    EXPECT_GE(r.stats.get("initial_shafts_blocked_by_probe"), 1.0) << describe(o);
  }
}
