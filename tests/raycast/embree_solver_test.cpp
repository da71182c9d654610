// lib/raycast/embree_solver.h: the embree, embree-robust and brute solvers on hand-worked scenes.
#include <gtest/gtest.h>

#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "tests/support/family_scene.h"
#include "tests/support/scenes.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

const char* kMethods[] = {"embree", "embree-robust", "brute"};

}  // namespace

TEST(Raycast, TriangleBetweenPointAndLightQuad) {
  // Triangle at z = 1 covering x >= 0.05, y >= 0.05 in the region x + y <= 1.05 (a right
  // triangle with legs of length 1). Segment from the origin to sample (x, y, 2) crosses
  // z = 1 at (x/2, y/2): blocked iff x/2 >= 0.05, y/2 >= 0.05 and (x + y)/2 <= 1.05.
  // Samples with x, y in {0.25, 0.75}: (0.25,0.25), (0.25,0.75), (0.75,0.25), (0.75,0.75):
  // all satisfy (x + y)/2 <= 0.75 < 1.05, so exactly those four are blocked.
  Scene s = quad_scene();
  add_quad_blocker(s);
  for (const char* m : kMethods) {
    SolveResult r = make_solver(m)->solve(s, SolveOptions{});
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a) {
        bool blocked = a >= 2 && b >= 2;
        EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), !blocked) << m << " sample " << a << "," << b;
      }
    EXPECT_FLOAT_EQ(r.receivers[0].visible_fraction[0], 12.0f / 16.0f) << m;
  }
}

TEST(Raycast, PointInsideAndBehindAClosedBox) {
  Scene s = quad_scene();
  shapes::add_box(s.mesh, Vec3d(-3, -3, 0.5), Vec3d(3, 3, 1.5));  // a slab box between receiver and light
  s.receivers.push_back({Vec3f(0, 0, 1), Vec3f(0, 0, 1)});          // inside the box
  s.receivers.push_back({Vec3f(10, 0, 0), Vec3f(0, 0, 1)});         // beside it: segments pass outside
  for (const char* m : kMethods) {
    SolveResult r = make_solver(m)->solve(s, SolveOptions{});
    for (size_t j = 0; j < 16; ++j) {
      EXPECT_FALSE(r.receivers[0].visible(j)) << m;
      EXPECT_FALSE(r.receivers[1].visible(j)) << m;
      // From (10,0,0) to (sx, sy, 2): the segment leaves the slab's side x = 3 at
      // t = 7 / (10 - sx), height z = 2t; it passes into the box iff z <= 1.5, i.e.
      // sx <= 2/3. Samples with sx = 0.75 (column a = 3) pass over the top edge
      // (z = 1.514), all others are blocked.
      EXPECT_EQ(r.receivers[2].visible(j), j % 4 == 3) << m << " sample " << j;
    }
  }
}

TEST(Raycast, UnblockedReceiverAndEmptyMesh) {
  Scene s = quad_scene();
  for (const char* m : kMethods) {
    SolveResult r = make_solver(m)->solve(s, SolveOptions{});
    EXPECT_FLOAT_EQ(r.receivers[0].visible_fraction[0], 1.0f) << m;
  }
}

TEST(Raycast, ResultsIndependentOfThreadCount) {
  const Scene scene = family("random-soup", 4, -1, 64, 16);
  ASSERT_FALSE(scene.receivers.empty());
  for (const char* m : kMethods) {
    SolveOptions one, all;
    one.threads = 1;
    all.threads = 0;
    SolveResult a = make_solver(m)->solve(scene, one);
    SolveResult b = make_solver(m)->solve(scene, all);
    for (size_t i = 0; i < a.receivers.size(); ++i) EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << m;
  }
}

TEST(Solver, OptionsAreChecked) {
  auto s = make_solver("embree");
  SolveOptions o;
  o.opts.emplace("nope", "1");  // (operator[] = "1" trips GCC 12's false -Wrestrict, PR 105329)
  Status st = s->check_options(o);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("nope"), std::string::npos);
  EXPECT_EQ(make_solver("no-such-method"), nullptr);
}
