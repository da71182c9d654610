// lib/ssv/light_frame.h: the light frame and the expanded light L'.
#include <gtest/gtest.h>

#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "lib/ssv/light_frame.h"
#include "oracle/relation_oracle.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

TEST(SsvLightFrame, NearlyCoincidentVerticesAreDropped) {
  // fuzz_ssv 0741b915 / 51dac59d: a light vertex within 1e-17..1e-44 of the next. The
  // frame keeps a triangle (the short edge is gone), stays usable, and every side plane
  // through a receiver has a non-zero normal: the solve matches the oracle.
  Scene s;
  s.name = "near-duplicate-vertex";
  Light l;
  l.polygon = {Vec3f(-0.5f, -0.5f, 2), Vec3f(-0.5f, 0.5f, 2), Vec3f(0.5f, 1e-30f, 2), Vec3f(0.5f, 0, 2)};
  l.samples = 16;
  l.jitter = 4;
  l.seed = 3;
  s.lights.push_back(l);
  for (int k = 0; k < 16; ++k) s.receivers.push_back({Vec3f(-0.9f + 0.12f * float(k), 0.3f - 0.05f * float(k), 0), Vec3f(0, 0, 1)});
  shapes::add_sphere(s.mesh, Vec3d(0.1, 0.05, 1.0), 0.3, 10, 6);
  ASSERT_TRUE(finish_scene(s).ok());
  const LightFrame f = make_light_frame(s.lights[0]);
  EXPECT_EQ(f.poly.size(), 3u);
  EXPECT_TRUE(f.usable);
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
  for (bool regions : {true, false}) {
    SolveResult r = run_ssv(s, regions);
    EXPECT_GT(expect_matches_oracle(s, ex, r, "near-duplicate vertex"), 150u);
    EXPECT_EQ(r.stats.get("fallback_relations"), 0.0);
  }
}

TEST(SsvLightFrame, SampleFarOutsideTheLightSendsTheLightToRays) {
  // fuzz_ssv 9ede82eb and others: an explicit sample 1e36 outside the light polygon. L'
  // may grow to 4 times the polygon at most; beyond, the light is answered by one ray
  // per relation (counted), and the answers still match the oracle.
  Scene s = quad_scene();
  s.lights[0].explicit_samples[5] = Vec3f(0.25f, 4.69e36f, 2);
  s.mesh.vertices = {Vec3f(-0.3f, -0.4f, 1), Vec3f(0.6f, -0.2f, 1), Vec3f(0.1f, 0.7f, 1.2f)};
  s.mesh.triangles = {{0, 1, 2}};
  ASSERT_TRUE(finish_scene(s).ok());
  EXPECT_FALSE(make_light_frame(s.lights[0]).usable);
  SolveResult r = run_ssv(s, true);
  EXPECT_EQ(r.stats.get("fallback_relations"), double(s.relation_count()));
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
  EXPECT_GT(expect_matches_oracle(s, ex, r, "far sample"), 10u);
}
