// lib/raycast: the embree, embree-robust and brute solvers on hand-worked scenes.
#include <gtest/gtest.h>

#include "lib/raycast/brute.h"
#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"

using namespace visgate;

namespace {

const char* kMethods[] = {"embree", "embree-robust", "brute"};

// A light quad [-1,1]^2 at z = 2 with explicit samples on a 4 x 4 grid (x, y in
// {-0.75, -0.25, 0.25, 0.75}), one receiver at the origin.
Scene quad_scene() {
  Scene s;
  s.name = "hand";
  Light l = make_square_light_down(Vec3d(0, 0, 2), 1.0, 16, 1);
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a) l.explicit_samples.push_back(Vec3f(-0.75f + 0.5f * a, -0.75f + 0.5f * b, 2.0f));
  s.lights.push_back(l);
  s.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

}  // namespace

TEST(Raycast, TriangleBetweenPointAndLightQuad) {
  // Triangle at z = 1 covering x >= 0.05, y >= 0.05 in the region x + y <= 1.05 (a right
  // triangle with legs of length 1). Segment from the origin to sample (x, y, 2) crosses
  // z = 1 at (x/2, y/2): blocked iff x/2 >= 0.05, y/2 >= 0.05 and (x + y)/2 <= 1.05.
  // Samples with x, y in {0.25, 0.75}: (0.25,0.25), (0.25,0.75), (0.75,0.25), (0.75,0.75):
  // all satisfy (x + y)/2 <= 0.75 < 1.05, so exactly those four are blocked.
  Scene s = quad_scene();
  s.mesh.vertices = {Vec3f(0.05f, 0.05f, 1), Vec3f(1.05f, 0.05f, 1), Vec3f(0.05f, 1.05f, 1)};
  s.mesh.triangles = {{0, 1, 2}};
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
  FamilyParams p;
  p.seed = 4;
  p.receivers = 64;
  p.samples = 16;
  auto scene = generate_family("random-soup", p);
  ASSERT_TRUE(scene.ok());
  for (const char* m : kMethods) {
    SolveOptions one, all;
    one.threads = 1;
    all.threads = 0;
    SolveResult a = make_solver(m)->solve(*scene, one);
    SolveResult b = make_solver(m)->solve(*scene, all);
    for (size_t i = 0; i < a.receivers.size(); ++i) EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << m;
  }
}

TEST(Raycast, BruteAgreesWithEmbreeRobustAwayFromDegeneracy) {
  // Random soups in general position: no shared edges, so float cracks cannot occur;
  // the two casters must agree on all but a vanishing fraction of relations (those
  // within float rounding of an edge). Bound: fewer than 1 in 10^4.
  FamilyParams p;
  p.seed = 11;
  p.receivers = 256;
  p.samples = 64;
  auto scene = generate_family("random-soup", p);
  ASSERT_TRUE(scene.ok());
  SolveResult a = make_solver("brute")->solve(*scene, SolveOptions{});
  SolveResult b = make_solver("embree-robust")->solve(*scene, SolveOptions{});
  size_t differ = 0, total = scene->relation_count();
  for (size_t i = 0; i < a.receivers.size(); ++i)
    for (size_t j = 0; j < scene->samples_per_receiver(); ++j) differ += a.receivers[i].visible(j) != b.receivers[i].visible(j);
  EXPECT_LT(differ * 10000, total) << differ << " of " << total;
}

TEST(Solver, OptionsAreChecked) {
  auto s = make_solver("embree");
  SolveOptions o;
  o.opts["nope"] = "1";
  Status st = s->check_options(o);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("nope"), std::string::npos);
  EXPECT_EQ(make_solver("no-such-method"), nullptr);
}
