// lib/ssv/ssv_solver.h: the `ssv` method (paper 001) on hand-worked scenes, against direct
// counting on random scenes away from degeneracy, against the exact oracle, and on exact
// degeneracies of its reference rays.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <string>

#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "lib/ssv/integrate.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

// ---------------------------------------------------------------- hand-worked scenes

TEST(Ssv, TriangleBetweenPointAndLightQuad) {
  // The triangle at z = 1 with corners (0.05, 0.05), (1.05, 0.05), (0.05, 1.05). The
  // segment to sample (x, y, 2) crosses z = 1 at (x/2, y/2): blocked iff x, y >= 0.1 and
  // x + y <= 2.1, which among x, y in {+-0.25, +-0.75} holds for the four with x, y > 0.
  for (bool regions : {true, false}) {
    Scene s = quad_scene();
    add_quad_blocker(s);
    SolveResult r = run_ssv(s, regions);
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a)
        EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), !(a >= 2 && b >= 2)) << a << "," << b;
    EXPECT_FLOAT_EQ(r.receivers[0].visible_fraction[0], 12.0f / 16.0f);
  }
}

TEST(Ssv, ClosedBoxBlocksEverythingThroughIt) {
  // A closed box z in [0.5, 1.5] spanning [-3, 3]^2: the receiver below sees no sample
  // (every segment crosses the bottom and the top: depth 2), a receiver inside the box
  // sees none (depth 1: the top), one at x = 20 beside it sees all: its segment to
  // (x_s, y_s, 2), |x_s| <= 0.75, reaches the plane x = 3 at z = 34 / (20 - x_s) > 1.6,
  // above the box, and the plane z = 1.5 at x = 5 + 0.75 x_s > 4, beside it.
  Scene s = quad_scene();
  shapes::add_box(s.mesh, Vec3d(-3, -3, 0.5), Vec3d(3, 3, 1.5));
  s.receivers.push_back({Vec3f(0, 0, 1), Vec3f(0, 0, 1)});
  s.receivers.push_back({Vec3f(20, 0, 0), Vec3f(0, 0, 1)});
  for (bool regions : {true, false}) {
    SolveResult r = run_ssv(s, regions);
    for (size_t j = 0; j < 16; ++j) {
      EXPECT_FALSE(r.receivers[0].visible(j)) << j;
      EXPECT_FALSE(r.receivers[1].visible(j)) << j;
      EXPECT_TRUE(r.receivers[2].visible(j)) << j;
    }
  }
}

TEST(Ssv, ReceiverSeesPartOfTheLightThroughAHole) {
  // A wall at z = 1 over [-3, 3]^2 with a square hole [-0.2, 0.2]^2 (eight triangles
  // around it). Segment to (x, y, 2) meets z = 1 at (x/2, y/2): visible iff |x|, |y| < 0.4,
  // i.e. exactly the four samples with x, y in {-0.25, 0.25}. Also far from the origin.
  for (const Vec3d& shift : {Vec3d(0, 0, 0), Vec3d(4096, -2048, 1024)}) {
    Scene s = quad_scene(shift);
    auto q = [&](double x0, double y0, double x1, double y1) {
      shapes::add_quad(s.mesh, Vec3d(x0, y0, 1) + shift, Vec3d(x1, y0, 1) + shift, Vec3d(x1, y1, 1) + shift,
                       Vec3d(x0, y1, 1) + shift);
    };
    q(-3, -3, 3, -0.2);
    q(-3, 0.2, 3, 3);
    q(-3, -0.2, -0.2, 0.2);
    q(0.2, -0.2, 3, 0.2);
    for (bool regions : {true, false}) {
      SolveResult r = run_ssv(s, regions);
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a) {
          bool vis = (a == 1 || a == 2) && (b == 1 || b == 2);
          EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), vis) << a << "," << b << " shift " << shift.x;
        }
    }
  }
}

TEST(Ssv, ReceiverBehindTheLightAndSeveralLights) {
  // Two lights; a receiver above the first light (behind it) is answered by rays; a
  // blocker between the receiver at the origin and the second light only.
  Scene s = quad_scene();
  Light l2 = make_square_light_down(Vec3d(5, 0, 2), 0.5, 9, 3);
  s.lights.push_back(l2);
  s.receivers.push_back({Vec3f(0, 0, 3), Vec3f(0, 0, 1)});
  // A big quad at z = 1 over x in [1.5, 3.5]: the origin's segments to light 2 (x in
  // [4.5, 5.5] at z = 2) cross z = 1 at x in [2.25, 2.75]; segments to light 1 at
  // |x| <= 0.75/2. The receiver at z = 3 sees both lights from behind through nothing.
  shapes::add_quad(s.mesh, Vec3d(1.5, -2, 1), Vec3d(3.5, -2, 1), Vec3d(3.5, 2, 1), Vec3d(1.5, 2, 1));
  ASSERT_TRUE(finish_scene(s).ok());
  SolveResult r = run_ssv(s, true);
  for (size_t j = 0; j < 16; ++j) EXPECT_TRUE(r.receivers[0].visible(j));
  for (size_t j = 0; j < 9; ++j) EXPECT_FALSE(r.receivers[0].visible(16 + j));
  for (size_t j = 0; j < 25; ++j) EXPECT_TRUE(r.receivers[1].visible(j));
  EXPECT_EQ(r.stats.get("fallback_relations"), 25.0);
}

// ---------------------------------------------------------------- whole method

TEST(Ssv, FarFromOriginTerminatesAndMatchesOracle) {
  // Around 1e6 the float midpoint of a small BSP node equals one of its faces long before
  // the minimum node size: the lazy BSP must stop there (it used to split forever).
  const Scene scene = family("far-origin", 2, -1, 64, 32);
  ASSERT_FALSE(scene.receivers.empty());
  SolveResult r = run_ssv(scene, true);
  EXPECT_LT(r.stats.get("bsp_nodes"), 1e6);
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(scene, 0);
  EXPECT_GT(expect_matches_oracle(scene, ex, r, "far-origin"), 500u);
}

TEST(Ssv, RandomScenesMatchDirectCountingAwayFromDegeneracy) {
  size_t compared = 0;
  for (uint64_t seed = 21; seed <= 26; ++seed) {
    Scene s = random_scene(seed, 64, 40);
    SolveResult on = run_ssv(s, true, false), off = run_ssv(s, false, false);
    compared += expect_matches_direct(s, on, "regions on");
    expect_matches_direct(s, off, "regions off");
    for (size_t i = 0; i < s.receivers.size(); ++i)
      EXPECT_EQ(on.receivers[i].visible_bits, off.receivers[i].visible_bits) << "receiver " << i;
    EXPECT_LE(on.stats.get("wedges_reported"), off.stats.get("wedges_reported"));
    EXPECT_EQ(on.stats.get("wedges_validated"), off.stats.get("wedges_validated"));
  }
  EXPECT_GT(compared, 10000u);
}

TEST(Ssv, FamiliesMatchDirectCountingOnSafeRelations) {
  // Generated families against direct counting where it is safe.
  for (const char* fam : {"random-soup", "columns", "torus"}) {
    if (!is_family(fam)) continue;
    FamilyParams p;
    p.seed = 3;
    p.receivers = 100;
    p.samples = 64;
    auto scene = generate_family(fam, p);
    ASSERT_TRUE(scene.ok()) << fam;
    if (scene->mesh.size() > 3000) continue;  // keep direct counting fast
    SolveResult r = run_ssv(*scene, true);
    EXPECT_GT(expect_matches_direct(*scene, r, fam), 1000u) << fam;
  }
}

TEST(Ssv, EdgeOnSliverDoesNotPoisonTheReceiver) {
  // Found by `visgate check --family sliver-soup --seed 1 --count 2 --receivers 256
  // --samples 64`: in sliver-soup seed 2, receiver 7 sees triangle 188 edge-on; sample 7
  // lies within rounding of its projection and got a spurious depth of -1, so the
  // reference ray to it (unblocked) declared the 63 visible samples blocked. That sample
  // lies within rounding of a projected piece (3.8e-9 away), so it is never the
  // reference (clearance), nor the check sample; since projection and clipping run in
  // double it also gets the depth of its neighbours, and the receiver needs no rays.
  const Scene scene = family("sliver-soup", 2, -1, 256, 64);
  ASSERT_FALSE(scene.receivers.empty());
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(scene, 0);
  SolveResult r = run_ssv(scene, true);
  EXPECT_GT(expect_matches_oracle(scene, ex, r, "sliver-soup seed 2"), 10000u);
  EXPECT_EQ(r.stats.get("inconsistent_receivers"), 0.0);
}

TEST(Ssv, OracleAgreesOnRandomSoupAndColumns) {
  // No mismatch against the exact relation oracle, silhouette regions on and off.
  for (const char* fam : {"random-soup", "columns"}) {
    for (uint64_t seed : {1, 2}) {
      FamilyParams p;
      p.seed = seed;
      p.receivers = 64;
      p.samples = 64;
      auto scene = generate_family(fam, p);
      ASSERT_TRUE(scene.ok()) << fam;
      oracle::RelationOracleResult ex = oracle::run_relation_oracle(*scene, 0);
      for (bool regions : {true, false}) {
        SolveResult r = run_ssv(*scene, regions);
        std::string what = std::string(fam) + " seed " + std::to_string(seed) + (regions ? " regions on" : " regions off");
        EXPECT_GT(expect_matches_oracle(*scene, ex, r, what), 1000u) << what;
      }
    }
  }
}

TEST(Ssv, EmbreeQuadsOnAndOffGiveTheSameAnswers) {
  // embree_quads changes only the primitives of the reference rays' Embree scene: the
  // same bits and fractions on families that pair every triangle (scan, columns' boxes),
  // some (rooms, shared-edge-fan) or none (random-soup; sliver-soup, whose slivers SSV
  // drops first), and, on one thread, the same count of reference rays. edge_rays is off:
  // its rays to every sample keep Embree's semantics on degenerate relations (a segment
  // through a shared edge of shared-edge-fan), which may differ between quads and
  // triangles; EdgeRaysOnAndOffGiveTheSameRelationsAboveTau holds them to the oracle.
  for (const char* fam : {"scan", "columns", "rooms", "shared-edge-fan", "random-soup", "sliver-soup", "far-origin"}) {
    const Scene s = family(fam, 2, fam[0] == 'r' && fam[1] == 'o' ? 7000 : -1, 100, 16);
    SolveOptions on, off;
    on.opts["embree_quads"] = "on";
    off.opts["embree_quads"] = "off";
    on.opts["edge_rays"] = off.opts["edge_rays"] = "off";
    on.threads = off.threads = 1;  // reference_rays depends on the threads' order (ThreadState)
    const SolveResult a = make_solver("ssv")->solve(s, on), b = make_solver("ssv")->solve(s, off);
    ASSERT_EQ(a.receivers.size(), b.receivers.size()) << fam;
    for (size_t i = 0; i < a.receivers.size(); ++i) {
      EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << fam << " receiver " << i;
      EXPECT_EQ(a.receivers[i].visible_fraction, b.receivers[i].visible_fraction) << fam << " receiver " << i;
    }
    EXPECT_EQ(a.stats.get("reference_rays"), b.stats.get("reference_rays")) << fam;
    EXPECT_GT(a.stats.get("reference_rays"), 0.0) << fam;
  }
}

TEST(Ssv, EdgeRaysOnAndOffGiveTheSameRelationsAboveTau) {
  // edge_rays (ssv_solver.cpp): a receiver and light with more candidate edges than
  // edge_ray_limit per sample is answered by its rays, and wedge_index=auto takes the
  // edges when its probe finds most receivers so (foliage). On and off, with every index
  // and with limits that send some receivers each way, every relation of margin at least
  // tau outside the oracle's degenerate class gets the oracle's answer, so on and off agree there.
  struct Case {
    const char* fam;
    long tris;
  };
  for (const Case c : {Case{"foliage", 1200}, Case{"columns", -1}, Case{"torus", -1}, Case{"random-soup", -1},
                       Case{"rooms", 7000}}) {
    const Scene s = family(c.fam, 2, c.tris, 48, 16);
    const oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
    SolveOptions off;
    off.opts["edge_rays"] = "off";
    const SolveResult r_off = make_solver("ssv")->solve(s, off);
    EXPECT_EQ(r_off.stats.get("edge_ray_receivers"), 0.0) << c.fam;
    expect_matches_oracle(s, ex, r_off, std::string(c.fam) + " off");
    for (const char* index : {"auto", "edges", "receivers", "bsp"}) {
      for (const char* limit : {"1", "0"}) {
        SolveOptions on;
        on.opts["wedge_index"] = index;
        on.opts["edge_ray_limit"] = limit;
        const SolveResult r = make_solver("ssv")->solve(s, on);
        const std::string what = std::string(c.fam) + " " + index + " limit " + limit;
        EXPECT_GT(expect_matches_oracle(s, ex, r, what), 200u) << what;
        // Foliage's receivers see far more than 64 edges (the least limit).
        if (std::string(c.fam) == "foliage") {
          EXPECT_GT(r.stats.get("edge_ray_receivers"), 24.0) << what;
        }
        EXPECT_GE(r.stats.get("fallback_relations"), 16.0 * r.stats.get("edge_ray_receivers")) << what;
      }
    }
  }
  // Foliage below 16 edges per receiver: auto takes the edges for the rays (here every
  // receiver's rays without them: ray_solve), off keeps the scattered wedges.
  const Scene f = family("foliage", 2, 1200, 256, 16);
  SolveOptions by_receiver;
  by_receiver.opts["ray_solve"] = "off";
  EXPECT_EQ(make_solver("ssv")->solve(f, by_receiver).stats.get("edge_index"), 1.0);
  const SolveResult r_on = make_solver("ssv")->solve(f, SolveOptions{});
  EXPECT_EQ(r_on.stats.get("ray_solve"), 1.0);
  EXPECT_GT(r_on.stats.get("edge_ray_receivers"), 128.0);
  SolveOptions off;
  off.opts["edge_rays"] = "off";
  EXPECT_EQ(make_solver("ssv")->solve(f, off).stats.get("edge_index"), 0.0);
}

TEST(Ssv, RaySolveAnswersEveryReceiverByRaysAsTheOracle) {
  // ray_solve=auto (ssv_solver.cpp): when edge_rays' probe finds at least half of its
  // receivers past the limit (foliage: every leaf above every receiver), no index
  // is built and every receiver is answered by its verified rays. Held to the oracle,
  // with ray_solve=off (the receivers below the limit integrated) as a second answer,
  // on foliage in a dense and a sparse crown, and the decision on scenes it must not take.
  // The last case has 94 edges per receiver: the edges by density, the tree's probe.
  struct Case {
    uint64_t seed;
    long tris, receivers;
  };
  for (const Case c : {Case{2, 1200, 256}, Case{3, 600, 256}, Case{2, 4000, 64}}) {
    const Scene s = family("foliage", c.seed, c.tris, c.receivers, 16);
    const oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
    SolveOptions off;
    off.opts["ray_solve"] = "off";
    const SolveResult r_auto = make_solver("ssv")->solve(s, SolveOptions{}), r_off = make_solver("ssv")->solve(s, off);
    const std::string what = "foliage " + std::to_string(c.seed) + " " + std::to_string(c.tris);
    EXPECT_EQ(r_auto.stats.get("ray_solve"), 1.0) << what;
    EXPECT_EQ(r_off.stats.get("ray_solve"), 0.0) << what;
    EXPECT_EQ(r_auto.stats.get("edge_index"), 0.0) << what;
    EXPECT_EQ(r_auto.stats.get("queries"), 0.0) << what;
    // Every receiver by its rays (none grazing or hidden here).
    EXPECT_EQ(r_auto.stats.get("edge_ray_receivers"), double(s.receivers.size())) << what;
    EXPECT_EQ(r_auto.stats.get("fallback_relations"), double(s.relation_count())) << what;
    EXPECT_LT(r_off.stats.get("edge_ray_receivers"), double(s.receivers.size())) << what;
    EXPECT_EQ(r_off.stats.get("edge_index"), 1.0) << what;
    EXPECT_GT(expect_matches_oracle(s, ex, r_auto, what + " auto"), s.relation_count() * 3 / 4) << what;
    expect_matches_oracle(s, ex, r_off, what + " off");
  }
  // A crown under a small light, where the probe finds fewer than half past: receiver
  // by receiver (the scattered wedges), some of them cast.
  const Scene f = family("foliage", 2, 1200, 256, 16, 0.25);
  const SolveResult rf = make_solver("ssv")->solve(f, SolveOptions{});
  EXPECT_EQ(rf.stats.get("ray_solve"), 0.0);
  EXPECT_GT(rf.stats.get("edge_ray_receivers"), 64.0);
  EXPECT_LT(rf.stats.get("edge_ray_receivers"), 256.0);
  expect_matches_oracle(f, oracle::run_relation_oracle(f, 0), rf, "foliage 2 1200 light 0.25");
  for (const char* fam : {"columns", "rooms", "torus"}) {
    const Scene s = family(fam, 2, fam[0] == 'r' ? 7000 : -1, 48, 16);
    EXPECT_EQ(make_solver("ssv")->solve(s, SolveOptions{}).stats.get("ray_solve"), 0.0) << fam;
  }
}

// ---------------------------------------------------------------- exact degeneracies

// quad_scene (samples x, y in {-0.75, -0.25, 0.25, 0.75} at z = 2, receiver at the
// origin) plus a triangle at z = 1 with an edge on the line x = xe (from y = -3 to 3)
// and its third vertex at x = xe + 3 * side. The segment to (x, y, 2) meets z = 1 at
// (x / 2, y / 2): with xe = -0.375 the four samples with x = -0.75 lie exactly on the
// projected edge (their segments touch it: Degenerate), sample 0 first among them. With
// side = -1 the triangle covers x < -0.375 and every other sample is visible; with
// side = +1 it covers the three other columns (blocked) and the edge samples are the
// only ones outside. `flip` reverses the winding.
static Scene edge_through_samples(const Vec3d& shift, double side, bool flip) {
  Scene s = quad_scene(shift);
  const double xe = -0.375;
  s.mesh.vertices = {Vec3f(Vec3d(xe, -3, 1) + shift), Vec3f(Vec3d(xe, 3, 1) + shift),
                     Vec3f(Vec3d(xe + 3 * side, 0, 1) + shift)};
  s.mesh.triangles = {flip ? std::array<uint32_t, 3>{0, 2, 1} : std::array<uint32_t, 3>{0, 1, 2}};
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

TEST(SsvDegenerate, SampleOnAProjectedSilhouetteEdgeIsNotTheReference) {
  // Found by `visgate check --family all --count 4 --seed 100 --methods ssv`
  // (far-origin-102, corpus/ssv/far-origin): the first sample of the minimum class lay
  // exactly on a projected boundary edge; its reference ray touched the edge (Embree:
  // blocked) and the whole visible class was declared blocked. Here both sides, both
  // windings, at the origin and around 2^18 (float spacing 2^-5 there: every coordinate
  // below is a multiple of 1/8, so the scene is exactly the same one translated).
  for (const Vec3d& shift : {Vec3d(0, 0, 0), Vec3d(262144, -262144, 393216)})
    for (double side : {-1.0, 1.0})
      for (bool flip : {false, true}) {
        Scene s = edge_through_samples(shift, side, flip);
        oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
        // The geometry is as described: the x = -0.75 column degenerate, the rest decided.
        for (int b = 0; b < 4; ++b)
          for (int a = 0; a < 4; ++a) {
            const char want = a == 0 ? 'd' : (side < 0 ? 'v' : 'b');
            ASSERT_EQ(ex.classes[0][size_t(b * 4 + a)], want) << a << "," << b;
          }
        for (bool regions : {true, false}) {
          SolveResult r = run_ssv(s, regions);
          const std::string what = "shift " + std::to_string(shift.x) + " side " + std::to_string(side) +
                                   (flip ? " flipped" : "") + (regions ? " regions on" : " regions off");
          EXPECT_EQ(expect_matches_oracle(s, ex, r, what), 12u) << what;
        }
      }
}

// ---------------------------------------------------------------- reference rays and the light frame

TEST(SsvDegenerate, LightPointOnATriangleInTheLightPlaneIsNotTheReference) {
  // Hand-worked (fuzz_ssv 1653e5da): light [-1,1]^2 at z = 2 emitting down, explicit
  // samples (-0.5, -0.5, 2) and (0.5, 0.5, 2), receiver at the origin, and one triangle
  // lying in the light plane under sample 0: (-0.75,-0.75,2), (0,-0.75,2), (-0.75,0,2).
  // No vertex lies below the plane (h > 0), so the triangle meets no open segment: both
  // relations are visible (sample 0 with margin 0: its endpoint is on the face), both
  // samples have the same depth, and sample 0 comes first. Embree's inclusive tfar
  // reports the endpoint hit, so a plain reference ray to sample 0 would call the class
  // blocked; the ranged rays see a hit only at the end and move to sample 1.
  for (bool regions : {true, false}) {
    Scene s;
    s.name = "in-plane";
    Light l = make_square_light_down(Vec3d(0, 0, 2), 1.0, 2, 1);
    l.jitter = 1;
    l.pattern = SamplePattern::Explicit;
    l.explicit_samples = {Vec3f(-0.5f, -0.5f, 2), Vec3f(0.5f, 0.5f, 2)};
    s.lights.push_back(l);
    s.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
    s.mesh.vertices = {Vec3f(-0.75f, -0.75f, 2), Vec3f(0, -0.75f, 2), Vec3f(-0.75f, 0, 2)};
    s.mesh.triangles = {{0, 1, 2}};
    ASSERT_TRUE(finish_scene(s).ok());
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
    ASSERT_EQ(ex.classes[0], "vv");
    SolveResult r = run_ssv(s, regions);
    EXPECT_TRUE(r.receivers[0].visible(0));
    EXPECT_TRUE(r.receivers[0].visible(1));
    EXPECT_EQ(r.stats.get("fallback_relations"), 0.0) << "decided by a second reference, not by rays";
  }
}

// The minimised fuzz_ssv finding cfbec7f8 (corpus/ssv/other/59df1244...): a four-triangle
// disk (boundary loop 2 -> 0 -> 3 -> 4, interior vertex 1) between a receiver and a
// quad light, 8 explicit samples.
static Scene interior_edge_scene() {
  Scene s;
  s.name = "interior-edge-reference";
  Light l;
  l.polygon = {Vec3f(-0.125f, -0.125f, 2), Vec3f(-0.125f, 0.125f, 2), Vec3f(0.125f, 0.125f, 2), Vec3f(0.09765625f, -0.125f, 2)};
  l.samples = 8;
  l.jitter = 1;
  l.seed = 154;
  l.pattern = SamplePattern::Explicit;
  l.explicit_samples = {Vec3f(0.0703125f, 0.09765625f, 2),  Vec3f(-0.1015625f, 0.1171875f, 2),
                        Vec3f(0.046875f, -0.046875f, 2),    Vec3f(0.0390625f, -0.0625f, 2),
                        Vec3f(-0.05078125f, 0.046875f, 2),  Vec3f(0.0234375f, 0.08984375f, 2),
                        Vec3f(0.109375f, 0.05078125f, 2),   Vec3f(0.12109375f, 0.046875f, 2)};
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(-0.737304688f, -0.0493164062f, 1.12841797f), Vec3f(-0.647599995f, 0.0830169916f, 1.1089114f),
                     Vec3f(-1, 0, 1), Vec3f(-0.5f, 0, 1), Vec3f(-0.5f, 0.25f, 1)};
  s.mesh.triangles = {{0, 1, 2}, {0, 3, 1}, {2, 1, 4}, {1, 3, 4}};
  s.receivers.push_back({Vec3f(-1.36551249f, 0.0683776736f, 0.21782279f), Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

TEST(SsvDegenerate, ReferenceRayAlongAnInteriorEdgeIsNotConclusive) {
  // fuzz_ssv cfbec7f8 (shared-edge-fan). Every segment from the receiver r to a sample
  // is blocked: the disk lies at heights 1 .. 1.13, strictly between r (0.22) and the
  // light (2), so its central projection from r onto z = 2 is defined, and the
  // projection of a disk covers every point inside the projection of its boundary loop
  // when that is a simple polygon (here the convex quadrilateral P2 P0 P3 P4). All 8
  // samples lie inside it by at least 1e-3, checked below in double. The integration
  // gives all samples one class (depth 1). Sample 0 projects onto the interior vertex 1
  // (6e-8 away), and its reference point, offset by a quarter of the clearance in a
  // direction hashed from (receiver, sample), lies along the projection of the interior
  // edge 0-1 (2e-8 from it): Embree's watertight test gave the crossing to triangle 0,
  // the double-precision verification rejected it and confirmed only triangle 1, which
  // Embree never reported. The verified ray missed, and the whole class was answered
  // visible (margins 1e-3 .. 1e-2). A miss with a rejected hit is now not conclusive:
  // the next sample decides.
  const Scene s = interior_edge_scene();
  const Vec3d r = to_double(s.receivers[0].p);
  auto project = [&](const Vec3f& p) {
    const Vec3d x = to_double(p);
    const double t = (2.0 - r.z) / (x.z - r.z);
    return std::array<double, 2>{r.x + (x.x - r.x) * t, r.y + (x.y - r.y) * t};
  };
  std::vector<std::array<double, 2>> loop;
  for (uint32_t v : {2u, 0u, 3u, 4u}) loop.push_back(project(s.mesh.vertices[v]));
  double area2 = 0.0;
  for (size_t k = 0; k < 4; ++k)
    area2 += loop[k][0] * loop[(k + 1) % 4][1] - loop[(k + 1) % 4][0] * loop[k][1];
  for (int j = 0; j < 8; ++j) {
    const Vec3f q = sample_position(s.lights[0], j, 0);
    const std::array<double, 2> x{double(q.x), double(q.y)};
    for (size_t k = 0; k < 4; ++k) {
      const auto &a = loop[k], &b = loop[(k + 1) % 4];
      const double eu = b[0] - a[0], ev = b[1] - a[1];
      const double inside = (area2 > 0 ? 1.0 : -1.0) * (eu * (x[1] - a[1]) - ev * (x[0] - a[0])) / std::hypot(eu, ev);
      ASSERT_GT(inside, 1e-3) << "sample " << j << " loop edge " << k;
    }
  }
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
  ASSERT_EQ(ex.classes[0], "bbbbbbbb");
  for (bool regions : {true, false}) {
    SolveResult res = run_ssv(s, regions);
    for (int j = 0; j < 8; ++j) EXPECT_FALSE(res.receivers[0].visible(size_t(j))) << "sample " << j << (regions ? " regions on" : " regions off");
    EXPECT_EQ(res.stats.get("fallback_relations"), 0.0) << "decided by the next reference, not by rays";
  }
}

TEST(SsvDegenerate, ReceiverGrazingTheLightPlaneIsAnsweredByRays) {
  // fuzz_ssv b190d0b6 (double-surface, minimised): the light's plane is z = (10/3) y
  // (a quad tilted from z = -2 to z = 2), the receiver (-0.5, 2^-98, 0) lies in it up to
  // a height of 3e-30, so its segments to the samples lie in the light's plane. Each of
  // the two triangles crosses that plane along a cut segment, and a segment is blocked
  // iff it crosses a cut segment. The counters, built on a pyramid of height 3e-30 whose
  // frame heights are rounding noise, put visible and blocked samples in one class
  // (false-blocked, margins 6e-4 .. 1e-3). Against the exact oracle, both settings.
  Scene s;
  s.name = "grazing-receiver";
  Light l;
  l.polygon = {Vec3f(-0.6f, -0.6f, -2), Vec3f(-0.6f, 0.6f, 2), Vec3f(0.6f, 0.6f, 2), Vec3f(0.6f, -0.6f, -2)};
  l.samples = 16;
  l.jitter = 4;
  l.seed = 65535;
  l.pattern = SamplePattern::Stratified;
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(0, 0, 0), Vec3f(0, 0.5f, 0), Vec3f(-0.5f, 0, 1), Vec3f(0, 0, 1)};
  s.mesh.triangles = {{0, 1, 2}, {3, 1, 2}};
  s.receivers.push_back({Vec3f(-0.5f, 0x1p-98f, 0), Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(s).ok());
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
  ASSERT_NE(ex.classes[0].find('v'), std::string::npos);
  ASSERT_NE(ex.classes[0].find('b'), std::string::npos);
  for (bool regions : {true, false}) {
    SolveResult r = run_ssv(s, regions);
    EXPECT_EQ(expect_matches_oracle(s, ex, r, regions ? "regions on" : "regions off"), 16u);
    EXPECT_EQ(r.stats.get("fallback_relations"), 16.0);
  }
  // The threshold: a receiver under the light [-1,1]^2 at z = 2 (extent E = 2 sqrt 2)
  // at (0.25, -0.25) and height h = k 2^-20 E below it: its scale S = E + 0.5 + h lies
  // between E and 2 E, so it is counted at k = 2 (h > 2^-20 S) and answered by rays at
  // k = 1/2 (the rounding of z, 1.2e-7, is far from the threshold 3e-6 either way);
  // visible either way.
  for (double k : {2.0, 0.5}) {
    Scene q;
    q.name = "near-light-plane";
    q.lights.push_back(make_square_light_down(Vec3d(0, 0, 2), 1.0, 16, 3));
    const float z = float(2.0 - k * 0x1p-20 * 2.0 * std::sqrt(2.0));
    q.receivers.push_back({Vec3f(0.25f, -0.25f, z), Vec3f(0, 0, 1)});
    ASSERT_TRUE(finish_scene(q).ok());
    SolveResult r = run_ssv(q, true);
    for (int j = 0; j < 16; ++j) EXPECT_TRUE(r.receivers[0].visible(size_t(j))) << "k " << k << " sample " << j;
    EXPECT_EQ(r.stats.get("fallback_relations"), k > 1.0 ? 0.0 : 16.0) << "k " << k;
  }
}

TEST(SsvDegenerate, NearlyEdgeOnTriangleBoundary) {
  // The nearly-edge-on rule of ReceiverIntegrator::facing: a triangle whose plane passes
  // within 2^-20 (relative to the receiver's distance from its farthest corner, here
  // sqrt(0.5^2 + 1.5^2) = 1.58) of the receiver makes the receiver doubtful (rays). The
  // vertical triangle in the plane x = d, seen by a receiver at the origin: d = 2^-22 is
  // inside the band (2^-22 < 1.5e-6), d = 2^-18 outside it; both must match the oracle.
  for (float d : {0x1p-22f, 0x1p-18f}) {
    Scene s = quad_scene();
    s.mesh.vertices = {Vec3f(d, -0.5f, 0.5f), Vec3f(d, 0.5f, 0.5f), Vec3f(d, 0, 1.5f)};
    s.mesh.triangles = {{0, 1, 2}};
    ASSERT_TRUE(finish_scene(s).ok());
    SolveResult r = run_ssv(s, true);
    EXPECT_EQ(r.stats.get("doubtful_receivers"), d < 0x1p-20f ? 1.0 : 0.0) << d;
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
    expect_matches_oracle(s, ex, r, "edge-on d = " + std::to_string(d));
  }
}
