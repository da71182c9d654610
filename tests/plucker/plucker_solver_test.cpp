// Tests of lib/plucker/plucker_solver.cpp: the soft-shadow framework (paper 002 section
// 4.4) on hand-computed scenes, against ray casting in double and against the exact
// oracles.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/plucker/bsp.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/scene/families.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

namespace {

double fragments_area(const std::vector<Polygon3f>& frags) {
  double a = 0;
  for (const auto& f : frags) {
    // Independent of polygon_area: shoelace of the xy projection (the test lights are
    // horizontal).
    double twice = 0;
    for (size_t k = 0; k < f.size(); ++k) {
      const Vec3f& p = f[k];
      const Vec3f& q = f[(k + 1) % f.size()];
      twice += double(p.x) * double(q.y) - double(q.x) * double(p.y);
    }
    a += std::abs(0.5 * twice);
  }
  return a;
}

// Double precision relation classifier: +1 blocked, 0 visible, -1 within 1e-5
// (normalised) of a sign change of one of the predicates (skipped by the comparisons).
int classify_double(const TriangleSoup& soup, const Vec3f& rf, const Vec3f& lf) {
  Vec3d r = to_double(rf), l = to_double(lf);
  const double eps = 1e-5;
  auto sgn = [&](double v, double scale) { return scale == 0 ? 0 : (v > eps * scale ? 1 : (v < -eps * scale ? -1 : 0)); };
  bool ambiguous = false;
  for (size_t t = 0; t < soup.size(); ++t) {
    Vec3d a = to_double(soup.corner(t, 0)), b = to_double(soup.corner(t, 1)), c = to_double(soup.corner(t, 2));
    int s1 = sgn(orient3d(a, b, c, r), length(b - a) * length(c - a) * length(r - a));
    int s2 = sgn(orient3d(a, b, c, l), length(b - a) * length(c - a) * length(l - a));
    Vec3d v[3] = {a, b, c};
    int e[3];
    for (int k = 0; k < 3; ++k) {
      Vec3d p = v[k], q = v[(k + 1) % 3];
      e[k] = sgn(orient3d(r, l, p, q), length(l - r) * length(p - r) * length(q - r));
    }
    bool hit = s1 * s2 == -1 && ((e[0] == 1 && e[1] == 1 && e[2] == 1) || (e[0] == -1 && e[1] == -1 && e[2] == -1));
    if (hit) return 1;
    bool planes_can = (s1 >= 0 && s2 <= 0) || (s1 <= 0 && s2 >= 0);
    bool edges_can = (e[0] >= 0 && e[1] >= 0 && e[2] >= 0) || (e[0] <= 0 && e[1] <= 0 && e[2] <= 0);
    if (planes_can && edges_can) ambiguous = true;
  }
  return ambiguous ? -1 : 0;
}

struct BitCheck {
  size_t compared = 0, skipped = 0, mismatches = 0;
};

BitCheck compare_bits(const Scene& s, const SolveResult& res) {
  BitCheck c;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t li = 0; li < s.lights.size(); ++li)
      for (int j = 0; j < s.lights[li].samples; ++j) {
        int cls = classify_double(s.mesh, s.receivers[i].p, sample_position(s.lights[li], j, i));
        if (cls < 0) {
          ++c.skipped;
          continue;
        }
        ++c.compared;
        bool vis = res.receivers[i].visible(s.light_offset(li) + size_t(j));
        if (vis != (cls == 0)) ++c.mismatches;
      }
  return c;
}

// Bits against the relation oracle (non-degenerate relations with margin >= tau) and
// fractions against the region oracle (1e-4 of the light area): the criteria.
struct OracleCheck {
  size_t compared = 0, bit_mismatches = 0, fraction_mismatches = 0;
};

// Counts over every result in `rs` (solves of the same scene).
OracleCheck check_against_oracles(const Scene& s, const std::vector<SolveResult>& rs) {
  OracleCheck c;
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    for (size_t b = 0; b < ex.classes[i].size(); ++b) {
      char cls = ex.classes[i][b];
      if (cls == 'd' || ex.margins[i][b] < 1e-5) continue;
      ++c.compared;
      for (const SolveResult& r : rs) c.bit_mismatches += r.receivers[i].visible(b) != (cls == 'v');
    }
    for (size_t li = 0; li < s.lights.size(); ++li) {
      oracle::RegionAnswer reg = oracle::visible_region(s, i, li);
      if (reg.edge_on) continue;
      for (const SolveResult& r : rs)
        c.fraction_mismatches += !(std::abs(reg.visible_fraction - r.receivers[i].visible_fraction[li]) <= 1e-4);
    }
  }
  return c;
}

// The scene moved by `off` (every coordinate must stay exact in float: asserted).
Scene translated_exactly(const Scene& src, const Vec3d& off) {
  Scene s = src;
  auto move = [&](Vec3f& v) {
    Vec3f w(to_double(v) + off);
    EXPECT_EQ(to_double(w) - off, to_double(v)) << "offset not exact";
    v = w;
  };
  for (auto& v : s.mesh.vertices) move(v);
  for (auto& l : s.lights) {
    for (auto& v : l.polygon) move(v);
    for (auto& v : l.explicit_samples) move(v);
    for (auto& v : l.jitter_points) move(v);
    for (size_t j = 0; j < l.jitter_boxes.size(); ++j) {
      l.jitter_boxes[j] = AABB{};
      for (int k = 0; k < l.jitter; ++k) l.jitter_boxes[j].extend(l.jitter_point(int(j), k));
    }
  }
  for (auto& rc : s.receivers) move(rc.p);
  if (s.grid) move(s.grid->origin);
  return s;
}

}  // namespace

TEST(PluckerSolver, SquareOccluderHalfCoveringTheLight) {
  // Occluder x in [0, 0.5], y in [-0.5, 0.5] at z = 1 projects from the origin onto
  // x in [0, 1], y in [-1, 1] at z = 2: exactly half the light.
  Scene s = light_scene({Vec3f(0, 0, 0)});
  shapes::add_quad(s.mesh, Vec3d(0, -0.5, 1), Vec3d(0.5, -0.5, 1), Vec3d(0.5, 0.5, 1), Vec3d(0, 0.5, 1));
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], 0.5, 1e-6);
  EXPECT_NEAR(fragments_area(r.receivers[0].fragments[0]), 2.0, 1e-6);
  for (int j = 0; j < s.lights[0].samples; ++j) {
    Vec3f p = sample_position(s.lights[0], j, 0);
    if (std::abs(p.x) > 1e-4f) {
      EXPECT_EQ(r.receivers[0].visible(size_t(j)), p.x < 0) << j;
    }
  }
}

TEST(PluckerSolver, FarFromOrigin) {
  // The same configuration translated by (4096, -8192, 0): every coordinate is exact in
  // float and the fraction stays one half.
  Vec3d t(4096, -8192, 0);
  Scene s = light_scene({Vec3f(Vec3d(t))}, 64, Vec3d(4096, -8192, 2));
  shapes::add_quad(s.mesh, t + Vec3d(0, -0.5, 1), t + Vec3d(0.5, -0.5, 1), t + Vec3d(0.5, 0.5, 1), t + Vec3d(0, 0.5, 1));
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], 0.5, 1e-4);
}

TEST(PluckerSolver, TotalAndNoOcclusion) {
  Scene s = light_scene({Vec3f(0, 0, 0), Vec3f(5, 0, 0)});
  // A 2 x 2 square at z = 1 hides the light from the origin (its shadow spans [-2,2]^2);
  // from (5, 0, 0) the pyramid to the light passes x in [2, 3] at z = 1: no occlusion.
  shapes::add_quad(s.mesh, Vec3d(-1, -1, 1), Vec3d(1, -1, 1), Vec3d(1, 1, 1), Vec3d(-1, 1, 1));
  SolveResult r = run(s);
  EXPECT_EQ(r.receivers[0].visible_fraction[0], 0.0f);
  EXPECT_TRUE(r.receivers[0].fragments[0].empty());
  for (int j = 0; j < s.lights[0].samples; ++j) EXPECT_FALSE(r.receivers[0].visible(size_t(j)));
  EXPECT_NEAR(r.receivers[1].visible_fraction[0], 1.0, 1e-6);
  for (int j = 0; j < s.lights[0].samples; ++j) EXPECT_TRUE(r.receivers[1].visible(size_t(j)));
}

TEST(PluckerSolver, ReceiversOnBothSidesAndOnTheLightPlane) {
  // Above the light (z = 4): an occluder at z = 3 covering x in [0, 1] of the light as
  // seen from (0, 0, 4) (x in [0, 0.5] at mid-height) gives one half; a receiver on the
  // light plane outside the light falls back to segment tests.
  Scene s = light_scene({Vec3f(0, 0, 4), Vec3f(3, 0, 2)});
  shapes::add_quad(s.mesh, Vec3d(0, -0.5, 3), Vec3d(0.5, -0.5, 3), Vec3d(0.5, 0.5, 3), Vec3d(0, 0.5, 3));
  SolveResult r = run(s);
  EXPECT_NEAR(r.receivers[0].visible_fraction[0], 0.5, 1e-6);
  EXPECT_EQ(r.stats.get("fallback_receivers"), 1.0);
  EXPECT_NEAR(r.receivers[1].visible_fraction[0], 1.0, 1e-6);
}

TEST(PluckerSolver, BitsMatchDoublePrecisionRayCastingOnRandomSoup) {
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    auto scene = family_scene("random-soup", seed, 60, 100, 32);
    ASSERT_TRUE(scene.ok());
    SolveResult r = run(*scene, {}, seed);
    BitCheck c = compare_bits(*scene, r);
    EXPECT_EQ(c.mismatches, 0u) << "seed " << seed << " compared " << c.compared;
    EXPECT_GT(c.compared, 20 * c.skipped);
  }
}

TEST(PluckerSolver, BitsMatchDoublePrecisionRayCastingOnColumns) {
  // Columns stand on the floor: their lower parts are behind or beside the receivers,
  // exercising the per-receiver near polygons and the slab clipping.
  auto scene = family_scene("columns", 2, 600, 144, 32);
  ASSERT_TRUE(scene.ok());
  SolveResult r = run(*scene, {{"tile", "4"}});
  BitCheck c = compare_bits(*scene, r);
  EXPECT_EQ(c.mismatches, 0u) << "compared " << c.compared;
  EXPECT_GT(c.compared, 20 * c.skipped);
}

TEST(PluckerSolver, FragmentsAreDisjointInsideTheLightAndSumToTheFraction) {
  auto scene = family_scene("random-soup", 5, 80, 64);
  ASSERT_TRUE(scene.ok());
  const Scene& s = *scene;
  SolveResult r = run(s);
  const Light& light = s.lights[0];
  UVAxes frame = UVAxes::from_normal(light.normal);
  Rng rng(9);
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    const auto& frags = r.receivers[i].fragments[0];
    EXPECT_NEAR(fragments_area(frags) / light.area, r.receivers[i].visible_fraction[0], 1e-6);
    for (const auto& f : frags) {
      ASSERT_GE(f.size(), 3u);
      for (const Vec3f& v : f) {
        EXPECT_NEAR(v.z, 2.0f, 1e-5f);
        EXPECT_LE(std::abs(v.x), 0.5f + 1e-5f);
        EXPECT_LE(std::abs(v.y), 0.5f + 1e-5f);
      }
    }
    // Disjoint interiors: no point lies strictly inside two fragments (shrunk by 1e-5).
    for (int k = 0; k < 200; ++k) {
      Vec3f x(Vec3d(rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 2.0));
      int inside = 0;
      for (const auto& f : frags) {
        bool in = true;
        for (size_t e = 0; e < f.size() && in; ++e) {
          Vec3d a = to_double(f[e]), b = to_double(f[(e + 1) % f.size()]), q = to_double(x);
          double len = std::hypot(b.x - a.x, b.y - a.y);
          double o = (b.x - a.x) * (q.y - a.y) - (b.y - a.y) * (q.x - a.x);
          if (frame.flip) o = -o;
          in = o > 1e-5 * len;
        }
        inside += in;
      }
      EXPECT_LE(inside, 1) << "receiver " << i;
    }
  }
}

TEST(PluckerSolver, SeedsReproduceAndCoherenceDoesNotChangeTheAnswer) {
  auto scene = family_scene("random-soup", 4, 120, 64);
  ASSERT_TRUE(scene.ok());
  SolveResult a = run(*scene, {}, 7), b = run(*scene, {}, 7), c = run(*scene, {}, 8);
  SolveResult d = run(*scene, {{"coherence", "off"}}, 7);
  EXPECT_EQ(a.stats.get("bsp_nodes"), b.stats.get("bsp_nodes"));
  EXPECT_GT(d.stats.get("bsp_nodes"), a.stats.get("bsp_nodes"));
  for (size_t i = 0; i < scene->receivers.size(); ++i) {
    EXPECT_EQ(a.receivers[i].fragments[0], b.receivers[i].fragments[0]);
    EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits);
    EXPECT_NEAR(a.receivers[i].visible_fraction[0], c.receivers[i].visible_fraction[0], 1e-5);
    EXPECT_NEAR(a.receivers[i].visible_fraction[0], d.receivers[i].visible_fraction[0], 1e-5);
  }
}

TEST(PluckerSolver, MultipleLightsAreIndependent) {
  auto scene = family_scene("random-soup", 6, 60, 36);
  ASSERT_TRUE(scene.ok());
  Scene one = *scene;
  Scene two = *scene;
  Light second = make_square_light_down(Vec3d(0.4, -0.3, 2.2), 0.3, 16, 3);
  ASSERT_TRUE(prepare_light(second, "second").ok());
  two.lights.push_back(second);
  Scene only_second = *scene;
  only_second.lights = {second};
  SolveResult r1 = run(one), r2 = run(two), r3 = run(only_second);
  for (size_t i = 0; i < one.receivers.size(); ++i) {
    EXPECT_NEAR(r2.receivers[i].visible_fraction[0], r1.receivers[i].visible_fraction[0], 1e-5);
    EXPECT_NEAR(r2.receivers[i].visible_fraction[1], r3.receivers[i].visible_fraction[0], 1e-5);
  }
}

TEST(PluckerSolver, GroupsCoverEveryReceiverOnce) {
  auto scene = family_scene("random-soup", 1, -1, 100);
  ASSERT_TRUE(scene.ok());
  Scene scattered = *scene;
  scattered.grid.reset();
  for (const Scene* s : {&*scene, &scattered}) {
    std::vector<int> seen(s->receivers.size(), 0);
    for (const auto& g : receiver_groups(*s, 3))
      for (uint32_t i : g) ++seen[i];
    for (int v : seen) EXPECT_EQ(v, 1);
  }
}

TEST(PluckerSolver, RegisteredWithOptions) {
  auto solver = make_solver("plucker-bsp");
  ASSERT_TRUE(solver);
  EXPECT_TRUE(solver->reports_fragments());
  SolveOptions o;
  o.opts["coherence"] = "maybe";
  EXPECT_FALSE(solver->check_options(o).ok());
  o.opts["coherence"] = "off";
  EXPECT_TRUE(solver->check_options(o).ok());
}

TEST(PluckerOracle, FractionsMatchTheRegionOracle) {
  for (const char* fam : {"random-soup", "columns"}) {
    FamilyParams p;
    p.seed = 3;
    p.receivers = 64;
    p.samples = 16;
    if (std::string(fam) == "columns") p.triangles = 400;
    auto scene = generate_family(fam, p);
    ASSERT_TRUE(scene.ok());
    SolveResult r = run(*scene);
    int bad = 0;
    for (size_t i = 0; i < scene->receivers.size(); ++i) {
      oracle::RegionAnswer ex = oracle::visible_region(*scene, i, 0);
      if (std::abs(ex.visible_fraction - r.receivers[i].visible_fraction[0]) > 1e-4) ++bad;
    }
    EXPECT_EQ(bad, 0) << fam;
  }
}

TEST(PluckerOracle, FarOriginMatchesTheRelationAndRegionOracles) {
  // far-origin: base scenes moved by offsets of 1e5..1e6 per axis, where the float
  // spacing (1/128..1/16) is a sizeable part of the unit light. In absolute coordinates
  // the fragments were off by that spacing (187 mismatches on seeds 1-2).
  size_t compared = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    auto scene = family_scene("far-origin", seed, 150, 25, 16);
    ASSERT_TRUE(scene.ok());
    // With and without coherence (the tree is developed by different query sequences).
    OracleCheck c = check_against_oracles(*scene, {run(*scene, {}, seed), run(*scene, {{"coherence", "off"}}, seed)});
    EXPECT_EQ(c.bit_mismatches, 0u) << scene->name;
    EXPECT_EQ(c.fraction_mismatches, 0u) << scene->name;
    compared += c.compared;
  }
  EXPECT_GT(compared, 1000u);
}

TEST(PluckerSolver, FarOriginEqualsTheSceneMovedBackToTheOrigin) {
  // Coordinates are taken relative to a light vertex, so moving the whole scene by an
  // offset that keeps every input exact changes no bit and no fraction.
  for (uint64_t seed = 1; seed <= 3; ++seed) {
    auto scene = family_scene("far-origin", seed, 150, 25, 16);
    ASSERT_TRUE(scene.ok());
    // Back near the origin: minus the light's first vertex rounded to a multiple of 64
    // (the far scene's coordinates are multiples of their float spacing, at most 1/16,
    // and the moved ones are below 2^16 in magnitude, so the difference is exact).
    Vec3d off;
    for (int k = 0; k < 3; ++k) off[k] = -64.0 * std::round(double(scene->lights[0].polygon[0][k]) / 64.0);
    Scene near = translated_exactly(*scene, off);
    SolveResult a = run(*scene, {}, seed), b = run(near, {}, seed);
    for (size_t i = 0; i < scene->receivers.size(); ++i) {
      EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << scene->name << " receiver " << i;
      EXPECT_EQ(a.receivers[i].visible_fraction, b.receivers[i].visible_fraction) << scene->name << " receiver " << i;
    }
  }
}

TEST(PluckerOracle, QuadrilateralOccludersMatchTheRegionOracle) {
  // Coplanar convex pairs shaded as quadrilaterals (plucker_solver.cpp shade_patch), each
  // against the region oracle (fractions) and the relation oracle (bits):
  //  - a tilted square between a receiver grid and the light, its shared diagonal's
  //    shadow crossing the light for most receivers: one occluder in the tree;
  //  - a wall standing in the grid, from below the receivers' level to above it, whose
  //    plane separates the receivers (and holds one of them): its part above the band is
  //    a two-sided near polygon, its part in the band another, both of the pair, and the
  //    receiver in its plane takes the exact path for both triangles.
  std::vector<Vec3f> rs;
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x) rs.push_back(Vec3f(-0.7f + 0.2f * float(x), -0.7f + 0.2f * float(y), 0.0f));
  rs.push_back(Vec3f(0.05f, 0.1f, 0.0f));
  for (int which = 0; which < 2; ++which) {
    Scene s = light_scene(rs, 16);
    if (which == 0) {
      shapes::add_quad(s.mesh, Vec3d(-0.35, -0.3, 0.9), Vec3d(0.3, -0.35, 1.0), Vec3d(0.35, 0.3, 1.1),
                       Vec3d(-0.3, 0.35, 1.0));
    } else {
      shapes::add_quad(s.mesh, Vec3d(0.05, -0.4, -0.2), Vec3d(0.05, 0.4, -0.2), Vec3d(0.05, 0.4, 1.2),
                       Vec3d(0.05, -0.4, 1.2));
    }
    SolveResult r = run(s);
    EXPECT_GT(r.stats.get("patches"), 0.0) << which;
    OracleCheck c = check_against_oracles(s, {r});
    EXPECT_GT(c.compared, 0u);
    EXPECT_EQ(c.bit_mismatches, 0u) << which;
    EXPECT_EQ(c.fraction_mismatches, 0u) << which;
    double lo = 1.0, hi = 0.0;
    for (const auto& rr : r.receivers)
      lo = std::min(lo, double(rr.visible_fraction[0])), hi = std::max(hi, double(rr.visible_fraction[0]));
    EXPECT_LT(lo, 0.6) << which;  // the quadrilateral hides a good part of the light from some receivers
    EXPECT_GT(hi, 0.75) << which;
  }
}

TEST(PluckerSolver, ReceiverBelowALongLightUndecidedInFloat) {
  // fuzz_plucker crash-61c69374...: a light 5.5e6 long (one vertex replaced) has a float
  // plane bound above 2 near its base, so receivers 2 below it were "on the light
  // plane" and shaded by the fallback's sample counts: fraction 1 for a receiver 2^-149
  // under a horizontal face (exact 0). Their side is now decided exactly against the
  // oracle's plane of the light.
  Scene s;
  s.name = "long-light-receiver-under-a-face";
  Light l;
  l.polygon = {Vec3f(-0.5f, -0.5f, 2), Vec3f(-0.5f, 0.5f, 0x1.fffffep+0f), Vec3f(0x1.4fd17ep+22f, 0.5f, 2),
               Vec3f(0.5f, -0.5f, 2)};
  l.samples = 16;
  l.seed = 5;
  s.lights.push_back(l);
  s.mesh.vertices = {Vec3f(0, 0, 0), Vec3f(1.5f, 1.5f, 0), Vec3f(0, 1.5f, 0), Vec3f(0.9f, -0.3f, 1), Vec3f(1.2f, -0.2f, 1),
                     Vec3f(1.0f, 0.2f, 1.2f)};
  s.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
  s.receivers.push_back({Vec3f(0x1.58cbb2p-2f, 0x1.596cc2p+0f, -0x1p-149f), Vec3f(0, 0, 1)});
  s.receivers.push_back({Vec3f(0.8f, -0.4f, 0.0f), Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(s).ok());
  EXPECT_EQ(oracle::visible_region(s, 0, 0).visible_fraction, 0.0);
  for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
    EXPECT_EQ(r.stats.get("fallback_receivers"), 0.0) << what;
    for (size_t i = 0; i < s.receivers.size(); ++i)
      EXPECT_NEAR(r.receivers[i].visible_fraction[0], oracle::visible_region(s, i, 0).visible_fraction, 1e-4)
          << i << " " << what;
  });
}
