// Exact transforms of scenes (lib/scene/exact_transform.h) and the production methods at
// every scale (DESIGN section 2, "Scale"): an exact 2^k copy of a scene must get the same
// bits and fractions as the scene, and both must agree with the exact oracle on the copy.
// The exponents include the extents where, before Solver::solve handed the methods the
// unit copy, embree-robust's leaf rays (iss, ssv: extent 2^-37 and below), plucker-bsp
// (receivers in the light's plane: 2^43 and above, 2^-44 and below) and ssv (2^66 and
// above) answered blocked relations visible.
#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <set>

#include "lib/scene/exact_transform.h"
#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "tests/support/family_scene.h"
#include "lib/solver.h"
#include "oracle/comparator.h"
#include "oracle/relation_oracle.h"

namespace visgate {
namespace {

using visgate::test_support::family;

bool same_bits(const Vec3f& a, const Vec3f& b) {
  for (int k = 0; k < 3; ++k)
    if (std::bit_cast<uint32_t>(a[k]) != std::bit_cast<uint32_t>(b[k])) return false;
  return true;
}

// Every point of two scenes is the same float, bit for bit.
void expect_same_points(const Scene& a, const Scene& b) {
  ASSERT_EQ(a.mesh.vertices.size(), b.mesh.vertices.size());
  for (size_t i = 0; i < a.mesh.vertices.size(); ++i) EXPECT_TRUE(same_bits(a.mesh.vertices[i], b.mesh.vertices[i])) << i;
  ASSERT_EQ(a.receivers.size(), b.receivers.size());
  for (size_t i = 0; i < a.receivers.size(); ++i) EXPECT_TRUE(same_bits(a.receivers[i].p, b.receivers[i].p)) << i;
  ASSERT_EQ(a.lights.size(), b.lights.size());
  for (size_t l = 0; l < a.lights.size(); ++l) {
    ASSERT_EQ(a.lights[l].jitter_points.size(), b.lights[l].jitter_points.size());
    for (size_t i = 0; i < a.lights[l].jitter_points.size(); ++i)
      EXPECT_TRUE(same_bits(a.lights[l].jitter_points[i], b.lights[l].jitter_points[i])) << l << " " << i;
    for (size_t i = 0; i < a.lights[l].polygon.size(); ++i)
      EXPECT_TRUE(same_bits(a.lights[l].polygon[i], b.lights[l].polygon[i])) << l << " " << i;
    EXPECT_EQ(a.lights[l].area, b.lights[l].area);
  }
}

TEST(ExactScale, PreparingAScaledLightEqualsScalingThePreparedLight) {
  // A tilted pentagon, so that every sampling step (fan areas, square roots, the map)
  // has non-trivial rounding.
  Light base;
  // In the plane z = 2 + 0.1 x + 0.2 y (within float rounding).
  base.polygon = {Vec3f(0.1f, 0.2f, 2.05f), Vec3f(0.9f, 0.1f, 2.11f), Vec3f(1.3f, 0.7f, 2.27f), Vec3f(0.8f, 1.4f, 2.36f),
                  Vec3f(0.0f, 1.1f, 2.22f)};
  base.samples = 64;
  base.seed = 7;
  Light prepared = base;
  ASSERT_TRUE(prepare_light(prepared, "pentagon").ok());
  Scene s;
  s.lights = {prepared};
  for (int k : {-120, -100, -44, -37, 43, 66, 100, 124}) {
    Light scaled_input = base;
    for (auto& p : scaled_input.polygon)
      p = Vec3f(std::ldexp(p.x, k), std::ldexp(p.y, k), std::ldexp(p.z, k));
    ASSERT_TRUE(prepare_light(scaled_input, "scaled").ok()) << k;
    Scene t;
    t.lights = {scaled_input};
    expect_same_points(scaled_scene(s, k), t);
    EXPECT_TRUE(same_bits(scaled_input.normal, prepared.normal)) << k;
  }
}

TEST(ExactScale, TheRangeIsExactToItsEndsAndNotOneBeyond) {
  Scene s = family("random-soup", 3, 60, 16, 8);
  const ScaleRange r = exact_scale_range(s);
  ASSERT_LT(r.lo, -100);
  ASSERT_GT(r.hi, 100);
  // At both ends the copy scales back to the scene bit for bit.
  expect_same_points(scaled_scene(scaled_scene(s, r.lo), -r.lo), s);
  expect_same_points(scaled_scene(scaled_scene(s, r.hi), -r.hi), s);
  // One beyond: a coordinate overflows, or one loses its lowest bit.
  Scene over = scaled_scene(s, r.hi + 1);
  bool infinite = false;
  for (const auto& v : over.mesh.vertices)
    for (int k = 0; k < 3; ++k) infinite |= !std::isfinite(v[k]);
  for (const auto& rc : over.receivers)
    for (int k = 0; k < 3; ++k) infinite |= !std::isfinite(rc.p[k]);
  for (const auto& l : over.lights)
    for (const auto& p : l.jitter_points)
      for (int k = 0; k < 3; ++k) infinite |= !std::isfinite(p[k]);
  EXPECT_TRUE(infinite);
  Scene back = scaled_scene(scaled_scene(s, r.lo - 1), 1 - r.lo);
  bool changed = false;
  for (size_t i = 0; i < s.mesh.vertices.size(); ++i) changed |= !same_bits(s.mesh.vertices[i], back.mesh.vertices[i]);
  for (size_t i = 0; i < s.receivers.size(); ++i) changed |= !same_bits(s.receivers[i].p, back.receivers[i].p);
  for (size_t i = 0; i < s.lights[0].jitter_points.size(); ++i)
    changed |= !same_bits(s.lights[0].jitter_points[i], back.lights[0].jitter_points[i]);
  EXPECT_TRUE(changed);
}

TEST(ExactScale, EveryExactCopyHasTheSameUnitCopy) {
  for (const char* f : {"random-soup", "far-origin", "columns", "sliver-soup"}) {
    Scene s = family(f, 2, 80, 16, 8);
    const int u = unit_scale_exponent(s);
    const Scene unit = scaled_scene(s, u);
    const double e = unit_length(unit);
    EXPECT_GE(e, 2.0) << f;
    EXPECT_LT(e, 4.0) << f;
    const ScaleRange r = exact_scale_range(s);
    for (int k : {-120, -96, -64, -40, -16, 16, 48, 96, 124}) {
      if (!r.contains(k)) continue;
      const Scene copy = scaled_scene(s, k);
      EXPECT_EQ(unit_scale_exponent(copy), u - k) << f << " " << k;
      expect_same_points(scaled_scene(copy, unit_scale_exponent(copy)), unit);
    }
  }
}

// One explicit sample 2^64 away from a light of size 1 (fuzz_iss seed sliver-soup-29285):
// the unit copy keeps the rest of the scene at lengths near 2, where a bounding-box
// normalisation would have shrunk it to 2^-63.
TEST(ExactScale, AnOutlyingPointDoesNotShrinkTheUnitCopy) {
  Scene s = family("random-soup", 8, 30, 6, 8);
  Light l = s.lights[0];
  l.explicit_samples = std::vector<Vec3f>(l.jitter_points.begin(), l.jitter_points.begin() + 8);
  l.explicit_samples[3].x = 0x1.e154p+64f;
  l.jitter = 1;
  ASSERT_TRUE(prepare_light(l, "outlier").ok());
  s.lights[0] = l;
  EXPECT_EQ(unit_scale_exponent(s), 0);
  EXPECT_EQ(unit_scale_exponent(scaled_scene(s, -50)), 50);
  // The clamp: a scene whose typical length is 2^-100 but which holds a coordinate near
  // FLT_MAX is scaled up only as far as that coordinate allows.
  Scene t = scaled_scene(family("random-soup", 8, 30, 6, 8), -100);
  t.mesh.vertices[0].x = 0x1p+120f;
  EXPECT_EQ(unit_scale_exponent(t), exact_scale_range(t).hi);
}

TEST(AxisMap, FortyEightDistinctMapsAndTheirHandedness) {
  std::set<std::pair<std::array<int, 3>, std::array<int, 3>>> seen;
  int reversing = 0;
  for (unsigned i = 0; i < 48; ++i) {
    const AxisMap m = axis_map(i);
    seen.insert({m.axis, m.sign});
    // Handedness from the determinant of the signed permutation matrix.
    double M[3][3] = {};
    for (int r = 0; r < 3; ++r) M[r][m.axis[r]] = m.sign[r];
    const double det = M[0][0] * (M[1][1] * M[2][2] - M[1][2] * M[2][1]) -
                       M[0][1] * (M[1][0] * M[2][2] - M[1][2] * M[2][0]) +
                       M[0][2] * (M[1][0] * M[2][1] - M[1][1] * M[2][0]);
    EXPECT_EQ(m.reverses_handedness(), det < 0) << i;
    reversing += det < 0;
  }
  EXPECT_EQ(seen.size(), 48u);
  EXPECT_EQ(reversing, 24);
  EXPECT_TRUE(axis_map(0).identity());
}

TEST(AxisMap, TheMappedLightStillEmitsTowardsTheMappedSide) {
  Scene s = family("random-soup", 5, 40, 8, 8);
  for (unsigned i = 0; i < 48; ++i) {
    const Scene t = axis_mapped_scene(s, axis_map(i));
    // prepare_light on the mapped polygon derives the mapped normal from its order.
    Light again = t.lights[0];
    again.explicit_samples.clear();
    ASSERT_TRUE(prepare_light(again, "mapped").ok()) << i;
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(again.normal[k], t.lights[0].normal[k], 1e-6) << i;
  }
}

TEST(AxisMap, TheOraclesClassesDoNotChange) {
  for (const char* f : {"shared-edge-fan", "grid-snapped", "on-surface"}) {
    Scene s = family(f, 3, 60, 16, 8);
    const auto a = oracle::run_relation_oracle(s, 1);
    for (unsigned i : {1u, 13u, 30u, 47u}) {
      const auto b = oracle::run_relation_oracle(axis_mapped_scene(s, axis_map(i)), 1);
      EXPECT_EQ(a.classes, b.classes) << f << " map " << i;
    }
  }
}

struct Method {
  const char* name;
  std::map<std::string, std::string> opts;
};

const std::vector<Method>& production_methods() {
  static const std::vector<Method> m = {
      {"iss", {}},
      {"iss", {{"leaf_receivers", "1"}, {"leaf_samples", "1"}, {"auto_rays", "off"}}},
      {"iss", {{"ray_caster", "custom"}}},
      {"ssv", {}},
      {"ssv", {{"silhouette_regions", "off"}}},
      {"plucker-bsp", {}},
      {"plucker-bsp", {{"coherence", "off"}}},
  };
  return m;
}

std::string label(const Method& m) {
  std::string s = m.name;
  for (const auto& [k, v] : m.opts) s += " " + k + "=" + v;
  return s;
}

// Every production method on the scene and on its exact 2^k copies: identical bits and
// fractions, and no mismatch against the oracle on the copy.
void expect_scale_free(const Scene& s, const std::vector<int>& exponents) {
  const ScaleRange r = exact_scale_range(s);
  size_t copies = 0;
  for (int k : exponents) copies += r.contains(k);
  EXPECT_GE(copies, exponents.size() / 2) << s.name << ": most exponents must give exact copies";
  ASSERT_GT(s.relation_count(), 0u);
  for (const Method& m : production_methods()) {
    auto solver = make_solver(m.name);
    ASSERT_TRUE(solver);
    SolveOptions o;
    o.opts = m.opts;
    o.threads = 1;
    const SolveResult base = solver->solve(s, o);
    for (int k : exponents) {
      if (!r.contains(k)) continue;
      const Scene copy = scaled_scene(s, k);
      const SolveResult res = solver->solve(copy, o);
      ASSERT_EQ(res.receivers.size(), base.receivers.size());
      for (size_t i = 0; i < res.receivers.size(); ++i) {
        EXPECT_EQ(res.receivers[i].visible_bits, base.receivers[i].visible_bits)
            << s.name << " " << label(m) << " 2^" << k << " receiver " << i;
        EXPECT_EQ(res.receivers[i].visible_fraction, base.receivers[i].visible_fraction)
            << s.name << " " << label(m) << " 2^" << k << " receiver " << i;
      }
      const auto exact = oracle::run_relation_oracle(copy, 1);
      const auto cmp = oracle::compare_relations(copy, res, exact, 1e-5);
      EXPECT_EQ(cmp.mismatch_count(), 0u) << s.name << " " << label(m) << " 2^" << k;
    }
  }
}

TEST(MethodsAtScale, AdversarialFamiliesGetTheSameAnswersAtEveryExactScale) {
  const std::vector<int> ks = {-120, -96, -64, -44, -37, 43, 66, 96, 124};
  for (const char* f : {"random-soup", "shared-edge-fan", "sliver-soup", "pouch", "grid-snapped"})
    expect_scale_free(family(f, 11, 40, 9, 8), ks);
}

// Receivers exactly in the light's plane beside the light, a wall between some of them
// and the light: every relation's segment lies in the light's plane.
TEST(MethodsAtScale, ReceiversInTheLightsPlaneAtExtentsFrom2pMinus100To2p100) {
  Scene s;
  s.name = "in-light-plane";
  Light l = make_square_light_down(Vec3d(0, 0, 2), 0.25, 8, 3);
  s.lights.push_back(l);
  // A wall crossing the plane z = 2 at x = 0.6, spanning y in [-0.2, 0.3].
  s.mesh.vertices = {Vec3f(0.6f, -0.2f, 1.5f), Vec3f(0.6f, 0.3f, 1.5f), Vec3f(0.6f, 0.3f, 2.5f), Vec3f(0.6f, -0.2f, 2.5f)};
  s.mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  for (int i = 0; i < 6; ++i) {
    s.receivers.push_back({Vec3f(0.9f + 0.05f * float(i), -0.35f + 0.13f * float(i), 2.0f), Vec3f(-1, 0, 0)});
    s.receivers.push_back({Vec3f(-0.9f, -0.3f + 0.1f * float(i), 2.0f), Vec3f(1, 0, 0)});
  }
  ASSERT_TRUE(finish_scene(s).ok());
  const auto exact = oracle::run_relation_oracle(s, 1);
  size_t blocked = 0;
  for (const auto& c : exact.classes) blocked += size_t(std::count(c.begin(), c.end(), 'b'));
  ASSERT_GT(blocked, 0u);
  expect_scale_free(s, {-100, -64, -44, -37, 43, 64, 66, 100});
}

// fuzz_plucker 3318459b (torus at 2^94, a steep light through the origin, the receiver
// 2^-54 beside the light's centroid): with the relation length alone as the unit, the
// copy was scaled up to the edge of overflow and plucker-bsp answered a blocked relation
// visible. The light's size keeps the unit copy near 1.
TEST(MethodsAtScale, AReceiverOnTheLightDoesNotBlowTheSceneUp) {
  const char* text = R"JSON({"format":"visgate-scene","version":1,"name":"torus-4864",
"meshes":[{"vertices":[["0x1p+94","0x0p+0","-0x1.4p+95"],["-0x1p+94","0x1p+94","-0x1p+95"],["-0x1p+93","0x1p+94","-0x1.4p+95"],["0x1p+93","0x0p+0","-0x1.4000cp+95"],["-0x1p+93","0x1p+94","-0x1p+95"],["0x1p+93","0x0p+0","-0x1.4p+95"],["-0x1p+94","-0x1p+94","0x1p+95"],["-0x1p+93","0x1p+93","-0x1p+95"],["-0x1p+93","-0x1p+93","-0x1p+95"]],
"triangles":[[0,2,1],[0,3,2],[3,4,2],[3,5,4],[5,1,4],[5,0,1],[1,7,6],[1,2,7],[2,8,7],[2,4,8],[4,6,8],[4,1,6],[6,3,0],[6,7,3],[7,5,3],[7,8,5],[8,0,5],[8,6,0]]}],
"lights":[{"polygon":[["0x1p+94","-0x1p+94","0x1p+96"],["0x1p+94","0x1p+94","0x1p-20"],["-0x1p+94","0x1p+94","-0x1p+96"],["-0x1p+94","-0x1p+94","-0x0p+0"]],"samples":1,"pattern":"stratified","jitter":4,"seed":4864}],
"receivers":[{"p":["0x1p-54","0x0p+0","-0x0p+0"],"n":["0x0p+0","0x0p+0","-0x1p+0"]}]})JSON";
  auto s = read_scene_json(text, "fuzz_plucker 3318459b", ".");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_LT(typical_relation_length(*s), 0x1p-50);
  EXPECT_LT(unit_scale_exponent(*s), -90);
  const auto exact = oracle::run_relation_oracle(*s, 1);
  for (const Method& m : production_methods()) {
    SolveOptions o;
    o.opts = m.opts;
    o.threads = 1;
    const SolveResult r = make_solver(m.name)->solve(*s, o);
    EXPECT_EQ(oracle::compare_relations(*s, r, exact, 1e-5).mismatch_count(), 0u) << label(m);
  }
  // The fuzz target's own options.
  SolveOptions o;
  o.opts = {{"choice", "random"}, {"coherence", "off"}, {"tile", "7"}};
  o.threads = 1;
  const SolveResult r = make_solver("plucker-bsp")->solve(*s, o);
  EXPECT_EQ(oracle::compare_relations(*s, r, exact, 1e-5).mismatch_count(), 0u);
}

TEST(MethodsAtScale, TheUnitCopyIsReportedAndBaselinesAnswerTheSceneAsGiven) {
  Scene s = family("random-soup", 4, 30, 4, 4);
  const Scene big = scaled_scene(s, 40);
  auto iss = make_solver("iss");
  SolveOptions o;
  o.threads = 1;
  EXPECT_EQ(iss->solve(s, o).stats.get("scale_exponent", 99), 0.0);
  EXPECT_EQ(iss->solve(big, o).stats.get("scale_exponent", 99), -40.0);
  for (const char* b : {"embree", "embree-robust", "brute"}) {
    EXPECT_FALSE(make_solver(b)->normalises_scale()) << b;
    EXPECT_EQ(make_solver(b)->solve(big, o).stats.find("scale_exponent"), nullptr) << b;
  }
}

TEST(MethodsAtScale, PluckerFragmentsComeBackAtTheScenesScale) {
  Scene s = family("random-soup", 6, 30, 4, 4);
  auto p = make_solver("plucker-bsp");
  SolveOptions o;
  o.threads = 1;
  const SolveResult a = p->solve(s, o);
  for (int k : {-60, 50}) {
    const SolveResult b = p->solve(scaled_scene(s, k), o);
    for (size_t i = 0; i < a.receivers.size(); ++i) {
      ASSERT_EQ(a.receivers[i].fragments.size(), b.receivers[i].fragments.size());
      for (size_t l = 0; l < a.receivers[i].fragments.size(); ++l) {
        ASSERT_EQ(a.receivers[i].fragments[l].size(), b.receivers[i].fragments[l].size());
        for (size_t f = 0; f < a.receivers[i].fragments[l].size(); ++f) {
          const auto& pa = a.receivers[i].fragments[l][f];
          const auto& pb = b.receivers[i].fragments[l][f];
          ASSERT_EQ(pa.size(), pb.size());
          for (size_t v = 0; v < pa.size(); ++v)
            for (int c = 0; c < 3; ++c) EXPECT_EQ(double(pb[v][c]), std::ldexp(double(pa[v][c]), k));
        }
      }
    }
  }
}

}  // namespace
}  // namespace visgate
