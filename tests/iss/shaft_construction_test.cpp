// lib/iss/shaft_construction.cpp: the blocker probe before the initial shaft (paper 000 section 4.8).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "lib/iss/shaft.h"
#include "lib/scene/exact_transform.h"
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

TEST(IssDenseRays, EarlyStopCastsTheLightsOfTheWholeEstimate) {
  // dense_ray_lights (iss_solver.cpp) stops a light's estimate at the first chunk after
  // which even every untested sample in its root shaft could not make it dense. The
  // lights it casts must be those of the whole estimate, computed here from its rule
  // alone: every n / 4096-th triangle of the unit copy, its box against the root shaft
  // (receivers' box to the light's jitter boxes, may_intersect_box), the count scaled to
  // the mesh, dense when at least max(8192, n / 8) and above relations / k. Thresholds k
  // on both sides of the lights' ratios (scan 20k: 63-100% of the samples in a light's
  // shaft, so at 1024 x 64 k = 4 stops some lights' estimates part way and casts others).
  // The stat counts the lights cast, so only scenes whose lights are all traversed.
  struct Case {
    Scene scene;
    std::vector<long> ks;
  };
  std::vector<Case> cases;
  cases.push_back({test_support::family("scan", 1, 20000, 64, 8), {1, 2, 3, 8}});
  cases.push_back({test_support::family("scan", 1, 20000, 1024, 64), {1, 2, 3, 4, 6, 8}});
  cases.push_back({test_support::family("scan", 1, 20000, 1024, 32), {1, 2, 3, 4}});
  size_t mixed = 0;
  for (const Case& c : cases) {
    const Scene u = scaled_scene(c.scene, unit_scale_exponent(c.scene));
    const size_t n = u.mesh.size();
    ASSERT_GE(n, 8192u) << u.name;
    AABB b = u.bounds(), rbox;
    double scale = 0;
    for (int k = 0; k < 3; ++k) scale = std::max({scale, std::abs(double(b.lo[k])), std::abs(double(b.hi[k]))});
    for (const Receiver& r : u.receivers) rbox.extend(r.p);
    const size_t step = std::max<size_t>(1, n / 4096);
    const double need = double(std::max<size_t>(8192, n / 8));
    for (long k : c.ks) {
      size_t expected = 0;
      for (const Light& light : u.lights) {
        AABB lbox;
        for (const AABB& jb : light.jitter_boxes) lbox.extend(jb);
        if (rbox.overlaps(lbox) || iss::choose_main_axis(rbox, lbox).axis < 0) continue;
        const iss::ShaftGeometry g(rbox, lbox, iss::MainAxis{}, scale);
        size_t hits = 0, tested = 0;
        for (size_t t = 0; t < n; t += step, ++tested) {
          AABB tb;
          for (int v = 0; v < 3; ++v) tb.extend(u.mesh.vertices[u.mesh.triangles[t][v]]);
          hits += g.may_intersect_box(iss::to_double(tb));
        }
        const double in_shaft = double(hits) * double(n) / double(tested);
        expected += in_shaft >= need && double(u.receivers.size()) * double(light.samples) < double(k) * in_shaft;
      }
      SolveResult r = run_iss(c.scene, {{"dense_ray_relations", std::to_string(k)}});
      EXPECT_EQ(r.stats.get("dense_ray_lights"), double(expected)) << u.name << " k=" << k;
      mixed += expected > 0 && expected < u.lights.size();
    }
  }
  EXPECT_GT(mixed, 0u);  // some threshold casts some lights and not others
}
