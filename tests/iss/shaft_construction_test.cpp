// lib/iss/shaft_construction.cpp: the blocker probe before the initial shaft (paper 000 section 4.8).
#include <gtest/gtest.h>

#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
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

TEST(IssInitialCost, InitialShaftsCastByCostEqualBuiltOnesAndOracle) {
  // The cost rule across initial shafts (cost_initial): with a factor of 0 every light
  // after the first casts its relations instead of building its initial shaft (every
  // 8th still builds); the answers must be the bits of cost_initial=off on every
  // relation the oracle does not class as touching, and the oracle's away from
  // degeneracy. Dense closed meshes with several lights (the rule needs the clusters
  // and the lazy band) and a torus.
  const double tau = 1e-5;
  for (const Scene& s : {test_support::family("scan", 1, 6000, 96, 16), test_support::family("scan", 2, 6000, 96, 16),
                         test_support::family("torus", 3, -1, 96, 16)}) {
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
    SolveResult off = test_support::run_iss(s, {{"clusters", "on"}, {"cost_initial", "off"}});
    SolveResult on =
        test_support::run_iss(s, {{"clusters", "on"}, {"cost_initial", "on"}, {"cost_initial_factor", "0"}});
    const test_support::OracleTally t = test_support::tally_against_oracle(s, ex, tau, {&on, &off});
    EXPECT_EQ(t.differ_any, 0u) << s.name;
    EXPECT_EQ(t.wrong, 0u) << s.name;
    EXPECT_EQ(off.stats.get("cost_ray_initial_shafts"), 0.0) << s.name;
    if (s.lights.size() > 1) {
      EXPECT_GT(on.stats.get("cost_ray_initial_shafts"), 0.0) << s.name;
      EXPECT_LT(on.stats.get("cost_ray_initial_shafts"), double(s.lights.size())) << s.name;  // the first is built
    }
  }
}

TEST(IssDenseRays, DenseLightsCastEqualShaftsAndOracle) {
  // dense_rays (iss_solver.cpp): a light of a dense mesh with fewer than
  // dense_ray_relations relations per triangle of its root shaft casts every relation
  // and builds no shaft. Scan 20k at 64 receivers x 8 samples: every light is so (512
  // relations against about 20k triangles), and the solve builds no mesh preparation,
  // hierarchy or tree. With a copy of light 0 at 1024 samples (65k relations, about 3
  // per triangle) that light keeps its shafts and the others are cast. The answers must be
  // dense_rays=off's bits on every relation the oracle does not class as touching, and
  // the oracle's away from degeneracy.
  const double tau = 1e-5;
  const Scene all = test_support::family("scan", 1, 20000, 64, 8);
  Scene mixed = all;
  Light extra = all.lights[0];
  extra.samples = 1024;
  mixed.lights.push_back(extra);
  ASSERT_TRUE(finish_scene(mixed).ok());
  ASSERT_GT(all.mesh.size(), 8192u);
  const Scene* const scenes[] = {&all, &mixed};
  for (const Scene* s : scenes) {
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(*s, 2);
    SolveResult off = run_iss(*s, {{"dense_rays", "off"}});
    SolveResult on = run_iss(*s, {});
    const OracleTally t = tally_against_oracle(*s, ex, tau, {&on, &off});
    EXPECT_EQ(t.differ_any, 0u) << s->lights.size();
    EXPECT_EQ(t.wrong, 0u) << s->lights.size();
    EXPECT_GT(t.checked, 0u);
    EXPECT_EQ(off.stats.get("dense_ray_lights"), 0.0);
    EXPECT_GT(off.stats.get("shafts_built"), 0.0);
    EXPECT_EQ(on.stats.get("dense_ray_lights"), double(all.lights.size())) << s->lights.size();
    if (s == &all) {
      EXPECT_EQ(on.stats.get("shafts_built"), 0.0);
      EXPECT_EQ(on.stats.get("percent_ray_cast"), 100.0);
      EXPECT_EQ(on.stats.get("receiver_tree_nodes"), 0.0);  // rays only: no tree
    } else {
      EXPECT_GT(on.stats.get("shafts_built"), 0.0);
    }
  }
}
