// Tests of oracle/relation_oracle.cpp: constructed cases, an independent reference with
// CGAL's exact constructions, and whole scenes under exact transforms.
#include <gtest/gtest.h>

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/intersections.h>

#include <algorithm>
#include <cmath>
#include <cfenv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <tuple>

#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "oracle/comparator.h"
#include "oracle/oracle_json.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tests/support/oracle_scenes.h"

namespace visgate::oracle {
namespace {

using namespace test_support;

// Class of the open segment (p, q) against one closed triangle from CGAL's exact
// intersection constructions (a different path from the oracle's predicates): the
// closed intersection is computed; the open segment meets the triangle iff that set has
// a point other than p and q; it crosses properly iff the intersection is one point,
// not p or q, the segment is not coplanar, and the point lies on no edge line.
RC reference_class(const Vec3f& pf, const Vec3f& qf, const Vec3f& af, const Vec3f& bf, const Vec3f& cf) {
  using EK = CGAL::Epeck;
  auto P = [](const Vec3f& v) { return EK::Point_3(double(v.x), double(v.y), double(v.z)); };
  EK::Point_3 p = P(pf), q = P(qf), a = P(af), b = P(bf), c = P(cf);
  if (p == q) return RC::Visible;
  EK::Segment_3 s(p, q);
  auto meets_other_than_ends = [&](const auto& res) {
    if (!res) return false;
    if (const EK::Point_3* x = boost::get<EK::Point_3>(&*res)) return *x != p && *x != q;
    return true;  // a segment of positive length: has points other than p and q
  };
  if (CGAL::collinear(a, b, c)) {
    // Zero area: the union of its (possibly degenerate) edges.
    for (auto [u, v] : {std::pair{a, b}, std::pair{b, c}, std::pair{c, a}}) {
      if (u == v) {
        if (s.has_on(u) && u != p && u != q) return RC::Degenerate;
        continue;
      }
      if (meets_other_than_ends(CGAL::intersection(s, EK::Segment_3(u, v)))) return RC::Degenerate;
    }
    return RC::Visible;
  }
  EK::Triangle_3 t(a, b, c);
  auto res = CGAL::intersection(s, t);
  if (!meets_other_than_ends(res)) return RC::Visible;
  const EK::Point_3* x = boost::get<EK::Point_3>(&*res);
  if (!x) return RC::Degenerate;
  EK::Plane_3 pl(a, b, c);
  if (pl.has_on(p) && pl.has_on(q)) return RC::Degenerate;
  if (CGAL::collinear(a, b, *x) || CGAL::collinear(b, c, *x) || CGAL::collinear(c, a, *x)) return RC::Degenerate;
  return RC::Blocked;
}

RC reference_scene_class(const Scene& s, const Vec3f& p, const Vec3f& q) {
  bool touched = false;
  for (size_t t = 0; t < s.mesh.size(); ++t) {
    RC c = reference_class(p, q, s.mesh.corner(t, 0), s.mesh.corner(t, 1), s.mesh.corner(t, 2));
    if (c == RC::Blocked) return RC::Blocked;
    touched |= c == RC::Degenerate;
  }
  return touched ? RC::Degenerate : RC::Visible;
}

class RelationCases : public ::testing::Test {
 protected:
  // Triangle a = (0,0,0), b = (4,0,0), c = (0,4,0) in the plane z = 0.
  Scene s = soup_scene({{Vec3f(0, 0, 0), Vec3f(4, 0, 0), Vec3f(0, 4, 0)}});
};

// Applies an exact transform to every point of a scene.
template <class F>
Scene transformed(const Scene& s, F f) {
  Scene t = s;
  for (Vec3f& v : t.mesh.vertices) v = f(v);
  for (Light& l : t.lights) {
    for (Vec3f& v : l.polygon) v = f(v);
    for (Vec3f& v : l.explicit_samples) v = f(v);
    EXPECT_TRUE(prepare_light(l, "t").ok());
  }
  for (Receiver& r : t.receivers) r.p = f(r.p);
  return t;
}

TEST_F(RelationCases, ProperCrossingIsBlockedWithHandMargin) {
  RelationAnswer a = classify_segment(s, {1, 1, -1}, {1, 1, 1});
  EXPECT_EQ(a.cls, RC::Blocked);
  // Distances: both endpoints 1 from the plane; the vertical line x = y = 1 is 1 from the
  // edge lines y = 0 and x = 0 and sqrt(2) from x + y = 4: minimum 1. The scene is the
  // triangle alone: diagonal |(4,4,0)| = 4 sqrt(2).
  EXPECT_NEAR(a.margin, 1.0 / (4.0 * std::sqrt(2.0)), 1e-15);
}

TEST_F(RelationCases, ThroughVertexIsDegenerate) { EXPECT_EQ(cls(s, {0, 0, -1}, {0, 0, 1}), RC::Degenerate); }

TEST_F(RelationCases, ThroughEdgeInteriorIsDegenerate) {
  EXPECT_EQ(cls(s, {2, 0, -1}, {2, 0, 1}), RC::Degenerate);
  EXPECT_EQ(cls(s, {2, 2, -1}, {2, 2, 1}), RC::Degenerate);  // hypotenuse
}

TEST_F(RelationCases, AlongAnEdge) {
  EXPECT_EQ(cls(s, {1, 0, 0}, {3, 0, 0}), RC::Degenerate);   // inside the edge
  EXPECT_EQ(cls(s, {-1, 0, 0}, {5, 0, 0}), RC::Degenerate);  // covering the edge
  EXPECT_EQ(cls(s, {5, 0, 0}, {6, 0, 0}), RC::Visible);      // collinear, disjoint
  EXPECT_EQ(cls(s, {4, 0, 0}, {6, 0, 0}), RC::Visible);      // only the excluded endpoint touches
  EXPECT_EQ(cls(s, {6, 0, 0}, {4, 0, 0}), RC::Visible);
  EXPECT_EQ(cls(s, {3, 0, 0}, {6, 0, 0}), RC::Degenerate);   // overlaps the edge
}

TEST_F(RelationCases, InsideTheTrianglePlane) {
  EXPECT_EQ(cls(s, {1, 1, 0}, {2, 1, 0}), RC::Degenerate);    // inside the face
  EXPECT_EQ(cls(s, {-1, 1, 0}, {5, 1, 0}), RC::Degenerate);   // across the face
  EXPECT_EQ(cls(s, {5, 5, 0}, {6, 5, 0}), RC::Visible);       // in the plane, outside
  EXPECT_EQ(cls(s, {0, 0, 0}, {-1, -1, 0}), RC::Visible);     // from a vertex outwards
  EXPECT_EQ(cls(s, {0, 0, 0}, {1, 1, 0}), RC::Degenerate);    // from a vertex inwards
  EXPECT_EQ(cls(s, {-1, 5, 0}, {5, -1, 0}), RC::Degenerate);  // along the hypotenuse line, beyond both ends
  EXPECT_EQ(cls(s, {-2, 1, 0}, {-1, 5, 0}), RC::Visible);
}

TEST_F(RelationCases, EndpointOnTheFaceIsVisibleWithZeroMargin) {
  RelationAnswer a = classify_segment(s, {1, 1, 0}, {1, 1, 1});
  EXPECT_EQ(a.cls, RC::Visible);
  EXPECT_EQ(a.margin, 0.0);  // moving the endpoint through the face would block it
  EXPECT_EQ(cls(s, {1, 1, 1}, {1, 1, 0}), RC::Visible);
  EXPECT_EQ(cls(s, {0, 0, 0}, {3, 3, 1}), RC::Visible);  // endpoint on a vertex
  EXPECT_EQ(cls(s, {2, 0, 0}, {2, -3, 1}), RC::Visible); // endpoint on an edge
  // Both endpoints on the faces of two triangles facing each other: still visible.
  Scene two = soup_scene({{Vec3f(0, 0, 0), Vec3f(4, 0, 0), Vec3f(0, 4, 0)}, {Vec3f(0, 0, 2), Vec3f(0, 4, 2), Vec3f(4, 0, 2)}});
  EXPECT_EQ(cls(two, {1, 1, 0}, {1, 1, 2}), RC::Visible);
}

TEST(RelationOracle, TriangleVertexOnTheSegment) {
  // Vertex (1,1,0.5) lies on the segment x = y = 1; the rest of the triangle is off it.
  Scene s = soup_scene({{Vec3f(1, 1, 0.5f), Vec3f(3, 3, 3), Vec3f(5, 0, 3)}});
  EXPECT_EQ(cls(s, {1, 1, 0}, {1, 1, 1}), RC::Degenerate);
  EXPECT_EQ(cls(s, {1, 1, 0}, {1, 1, 0.5f}), RC::Visible);  // vertex at the excluded endpoint
  EXPECT_EQ(cls(s, {1, 1, -1}, {1, 1, 0.25f}), RC::Visible);
}

TEST(RelationOracle, SharedDiagonalOfAQuadIsDegenerate) {
  // The segment from (0.5, 0.5, 0) to (0.1f, 0.1f, 2) meets z = 1 at x = y, on the
  // diagonal both triangles of the quad share: touching, no proper crossing.
  Scene s;
  add_quad(s, {0.25f, 0.25f, 1}, {0.5f, 0.25f, 1}, {0.5f, 0.5f, 1}, {0.25f, 0.5f, 1});
  EXPECT_EQ(cls(s, {0.5f, 0.5f, 0}, {0.1f, 0.1f, 2}), RC::Degenerate);
  EXPECT_EQ(cls(s, {0.5f, 0.5f, 0}, {0.1f, 0.2f, 2}), RC::Blocked);
}

TEST(RelationOracle, ZeroAreaTrianglesTouchButNeverBlock) {
  Scene line = soup_scene({{Vec3f(0, 0, 0), Vec3f(2, 2, 0), Vec3f(4, 4, 0)}});
  EXPECT_EQ(cls(line, {1, 1, -1}, {1, 1, 1}), RC::Degenerate);
  EXPECT_EQ(cls(line, {1, 0, -1}, {1, 0, 1}), RC::Visible);
  EXPECT_EQ(cls(line, {5, 5, 0}, {6, 6, 0}), RC::Visible);
  EXPECT_EQ(cls(line, {3, 3, 0}, {6, 6, 0}), RC::Degenerate);
  Scene point = soup_scene({{Vec3f(1, 1, 0), Vec3f(1, 1, 0), Vec3f(1, 1, 0)}});
  EXPECT_EQ(cls(point, {1, 1, -1}, {1, 1, 1}), RC::Degenerate);
  EXPECT_EQ(cls(point, {1, 1, 0}, {1, 1, 1}), RC::Visible);
  EXPECT_EQ(cls(point, {1, 2, -1}, {1, 2, 1}), RC::Visible);
}

TEST(RelationOracle, EmptySegmentIsVisible) {
  Scene s = soup_scene({{Vec3f(0, 0, 0), Vec3f(4, 0, 0), Vec3f(0, 4, 0)}});
  RelationAnswer a = classify_segment(s, {1, 1, 0}, {1, 1, 0});
  EXPECT_EQ(a.cls, RC::Visible);
  EXPECT_EQ(a.margin, 0.0);
}

TEST(RelationOracle, BlockedDominatesDegenerate) {
  Scene s = soup_scene({{Vec3f(0, 0, 0), Vec3f(4, 0, 0), Vec3f(0, 4, 0)},      // touched at a vertex
                        {Vec3f(-1, -1, 1), Vec3f(3, -1, 1), Vec3f(-1, 3, 1)}});  // crossed properly
  EXPECT_EQ(cls(s, {0, 0, -1}, {0, 0, 2}), RC::Blocked);
  EXPECT_EQ(cls(s, {0, 0, -1}, {0, 0, 0.5f}), RC::Degenerate);
}

TEST(RelationOracle, SliversAreExact) {
  // Needle of height 2^-20 over a base of length 4.
  const float h = std::ldexp(1.0f, -20);
  Scene s = soup_scene({{Vec3f(0, 0, 0), Vec3f(4, 0, 0), Vec3f(2, h, 0)}});
  EXPECT_EQ(cls(s, {2, h / 4, -1}, {2, h / 4, 1}), RC::Blocked);
  EXPECT_EQ(cls(s, {2, h, -1}, {2, h, 1}), RC::Degenerate);      // through the apex
  EXPECT_EQ(cls(s, {2, 2 * h, -1}, {2, 2 * h, 1}), RC::Visible);
  EXPECT_EQ(cls(s, {1, h / 2, -1}, {1, h / 2, 1}), RC::Degenerate);  // on the edge (0,0)-(2,h)
  EXPECT_EQ(cls(s, {1, h / 2 + std::ldexp(1.0f, -40), -1}, {1, h / 2 + std::ldexp(1.0f, -40), 1}), RC::Visible);
  EXPECT_EQ(cls(s, {1, h / 2 - std::ldexp(1.0f, -40), -1}, {1, h / 2 - std::ldexp(1.0f, -40), 1}), RC::Blocked);
}

TEST(RelationOracle, FarFromOrigin) {
  // The blocked/degenerate/visible triple of the slivers test, translated by 2^24
  // (float spacing there is 2, so use coordinates that are even).
  const float o = std::ldexp(1.0f, 24);
  Scene s = soup_scene({{Vec3f(o, o, o), Vec3f(o + 8, o, o), Vec3f(o, o + 8, o)}});
  EXPECT_EQ(cls(s, {o + 2, o + 2, o - 2}, {o + 2, o + 2, o + 2}), RC::Blocked);
  EXPECT_EQ(cls(s, {o + 4, o + 4, o - 2}, {o + 4, o + 4, o + 2}), RC::Degenerate);
  EXPECT_EQ(cls(s, {o + 6, o + 6, o - 2}, {o + 6, o + 6, o + 2}), RC::Visible);
  EXPECT_EQ(cls(s, {o + 2, o + 2, o}, {o + 2, o + 2, o + 2}), RC::Visible);  // endpoint on the face
}

TEST(RelationOracle, CoordinatesNearFloatMaxBuildTheBvh) {
  // fuzz_embree 34d3cdc4 / fuzz_iss 7884d4d6: with boxes spanning -FLT_MAX..FLT_MAX the
  // BVH's centroid extent overflowed to infinity and (centre - c0) / inf binned a NaN
  // (UBSan: NaN to int; a segfault in the g++ build). Eight small triangles far apart
  // force inner nodes, a ninth spans the whole float range. Classes worked out by hand:
  // each triangle lies in a plane z = const and the vertical segments cross it inside
  // (blocked) or pass beside it (visible).
  const float big = std::numeric_limits<float>::max(), m = big * 0.9f;  // centres span 1.35 FLT_MAX
  std::vector<std::array<Vec3f, 3>> tris;
  for (int k = 0; k < 8; ++k) {
    const float x = (k % 2 ? 1.0f : -1.0f) * m / float(1 << k);
    const float leg = std::abs(x) * 0x1p-18f;  // 4 d, d = |x| 2^-20
    tris.push_back({Vec3f(x, 0, 0), Vec3f(x + leg, 0, 0), Vec3f(x, leg, 0)});
  }
  tris.push_back({Vec3f(-big, -big, 1), Vec3f(big, -big, 1), Vec3f(-big, big, 1)});
  Scene s = soup_scene(tris);
  const float x3 = m / 8, d = x3 * 0x1p-20f;  // triangle k = 3, legs 4 d
  const std::vector<Vec3f> from = {{x3 + d, d, -1}, {x3 + d, 3.5f * d, -1}, {-1, -1, 0.5f}};
  const std::vector<Vec3f> to = {{x3 + d, d, 0.5f}, {x3 + d, 3.5f * d, 0.5f}, {-1, -1, 2}};
  const RC expected[3] = {RC::Blocked, RC::Visible, RC::Blocked};
  s.lights.push_back(explicit_light({{-1, -1, 4}, {-1, 1, 4}, {1, 1, 4}, {1, -1, 4}}, to));
  for (const Vec3f& p : from) s.receivers.push_back({p, {0, 0, 1}});
  RelationOracleResult r = run_relation_oracle(s, 1);
  for (size_t i = 0; i < from.size(); ++i) {
    EXPECT_EQ(r.classes[i][i], char(expected[i])) << i;
    for (size_t j = 0; j < to.size(); ++j)  // the BVH run agrees with the brute-force scan
      EXPECT_EQ(r.classes[i][j], char(classify_segment(s, from[i], to[j]).cls)) << i << " " << j;
  }
}

TEST(RelationOracle, DenormalInputsAreReadAsGivenUnderFlushToZero) {
  // Embree leaves flush-to-zero and denormals-are-zero on in TBB workers
  // (lib/geom/float_mode.h). A segment at x = 2^-140 (a float32 denormal) crosses the
  // triangle's plane strictly inside it, 2^-140 from its edge x = 0: blocked. Read with
  // DAZ, x would be 0 and the crossing on the edge: degenerate. The oracle runs in an
  // IeeeFloatMode scope, so DAZ on the calling thread changes nothing.
#if defined(__SSE2__)
  const float x = std::ldexp(1.0f, -140);
  ASSERT_GT(x, 0.0f);
  ASSERT_LT(x, std::numeric_limits<float>::min());
  Scene s = soup_scene({{Vec3f(0, 0, 1), Vec3f(2, 0, 1), Vec3f(0, 2, 1)}});
  s.lights.push_back(explicit_light({{-1, -1, 4}, {-1, 1, 4}, {1, 1, 4}, {1, -1, 4}}, {{x, 0.5f, 2}}));
  s.receivers.push_back({{x, 0.5f, 0}, {0, 0, 1}});
  const unsigned saved = _mm_getcsr();
  _mm_setcsr(saved | 0x8040u);  // FTZ | DAZ, as in an Embree-touched TBB worker
  const RC single = cls(s, {x, 0.5f, 0}, {x, 0.5f, 2});
  const RelationOracleResult all = run_relation_oracle(s, 1);
  const unsigned after = _mm_getcsr();
  _mm_setcsr(saved);
  EXPECT_EQ(single, RC::Blocked);
  EXPECT_EQ(all.classes[0], "b");
  // The mode bits (rounding, masks, FTZ, DAZ); the six sticky exception flags (bits 0-5)
  // carry whatever earlier tests of the same process raised.
  EXPECT_EQ(after & ~0x3Fu, (saved | 0x8040u) & ~0x3Fu) << "the scope restores the caller's mode";
#else
  GTEST_SKIP() << "no SSE MXCSR on this target";
#endif
}

TEST(RelationOracle, NonFiniteInputIsRejectedUpstreamByTheSceneReader) {
  // The oracle never sees NaN or Inf: read_scene_json rejects them (DESIGN section 2),
  // naming the element.
  const char* text = R"({"format": "visgate-scene", "version": 1,
    "meshes": [{"vertices": [[0,0,0],[1,0,0],["nan",1,0]], "triangles": [[0,1,2]]}],
    "lights": [{"polygon": [[0,0,2],[0,1,2],[1,1,2],[1,0,2]], "samples": 1, "jitter": 1,
                "explicit_samples": [[0.5,0.5,2]]}],
    "receivers": [{"p": [0.5,0.5,-1], "n": [0,0,1]}]})";
  auto r = read_scene_json(text, "nan.json", ".");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("nan.json"), std::string::npos) << r.error().message;
}

TEST(RelationOracle, AgreesWithExactConstructionReferenceOnGridSoups) {
  std::mt19937 g(7);
  size_t counts[3] = {0, 0, 0};
  for (int iter = 0; iter < 4000; ++iter) {
    int range = iter % 2 ? 2 : 4;
    Vec3f a = grid_point(g, range), b = grid_point(g, range), c = grid_point(g, range);
    if (iter % 7 == 0) c = a + (b - a) * 2.0f;  // zero-area
    if (iter % 11 == 0) c[2] = a[2] = b[2];     // axis-parallel plane
    Vec3f p = grid_point(g, range), q = grid_point(g, range);
    if (iter % 5 == 0) q[2] = p[2] = a[2] == b[2] ? a[2] : p[2];  // often coplanar segments
    if (iter % 13 == 0) p = (a + b) * 0.5f;                       // endpoint on an edge
    RC want = reference_class(p, q, a, b, c);
    RC got = classify_segment_triangle(p, q, a, b, c);
    ASSERT_EQ(char(got), char(want)) << "iter " << iter << " p=(" << p.x << "," << p.y << "," << p.z << ") q=(" << q.x
                                     << "," << q.y << "," << q.z << ") a=(" << a.x << "," << a.y << "," << a.z
                                     << ") b=(" << b.x << "," << b.y << "," << b.z << ") c=(" << c.x << "," << c.y
                                     << "," << c.z << ")";
    ++counts[want == RC::Visible ? 0 : (want == RC::Blocked ? 1 : 2)];
  }
  // The generator must actually exercise all three classes.
  EXPECT_GT(counts[0], 100u);
  EXPECT_GT(counts[1], 100u);
  EXPECT_GT(counts[2], 100u);
}

TEST(RelationOracle, AgreesWithReferenceOnRandomFloatSoups) {
  std::mt19937 g(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int iter = 0; iter < 1000; ++iter) {
    Vec3f a(u(g), u(g), u(g)), b(u(g), u(g), u(g)), c(u(g), u(g), u(g)), p(u(g), u(g), u(g)), q(u(g), u(g), u(g));
    ASSERT_EQ(char(classify_segment_triangle(p, q, a, b, c)), char(reference_class(p, q, a, b, c))) << iter;
  }
}

TEST(RelationOracle, BvhRunMatchesBruteForceAndReference) {
  Scene s = grid_scene(3, 60, 12, 20);
  RelationOracleResult r = run_relation_oracle(s, 2);
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (int j = 0; j < s.lights[0].samples; ++j) {
      Vec3f p = s.receivers[i].p, q = sample_position(s.lights[0], j, i);
      RelationAnswer a = classify_segment(s, p, q);
      EXPECT_EQ(r.classes[i][size_t(j)], char(a.cls));
      EXPECT_EQ(r.margins[i][size_t(j)], a.margin);
      EXPECT_EQ(r.classes[i][size_t(j)], char(reference_scene_class(s, p, q)));
    }
}

TEST(RelationOracle, ThreadCountDoesNotChangeAnswers) {
  Scene s = grid_scene(5, 200, 40, 16);
  RelationOracleResult one = run_relation_oracle(s, 1), two = run_relation_oracle(s, 2);
  EXPECT_EQ(one.classes, two.classes);
  EXPECT_EQ(one.margins, two.margins);
}

TEST(RelationOracle, InvariantUnderPowerOfTwoScalingAndTranslation) {
  Scene s = grid_scene(9, 80, 16, 16);
  RelationOracleResult base = run_relation_oracle(s);
  for (float k : {0.125f, 1024.0f}) {
    RelationOracleResult r = run_relation_oracle(transformed(s, [k](Vec3f v) { return v * k; }));
    EXPECT_EQ(r.classes, base.classes);
    EXPECT_EQ(r.margins, base.margins);  // doubles scale exactly by powers of two
  }
  Vec3f off(4096.0f, -1536.0f, 65536.0f);  // integers: every translated coordinate is exact
  RelationOracleResult r = run_relation_oracle(transformed(s, [off](Vec3f v) { return v + off; }));
  EXPECT_EQ(r.classes, base.classes);
  for (size_t i = 0; i < base.margins.size(); ++i)
    for (size_t j = 0; j < base.margins[i].size(); ++j) EXPECT_NEAR(r.margins[i][j], base.margins[i][j], 1e-9);
}

TEST(RelationOracle, InvariantUnderSwapsAndPermutations) {
  Scene s = grid_scene(13, 80, 1, 1);
  std::mt19937 g(17);
  for (int iter = 0; iter < 300; ++iter) {
    Vec3f p = grid_point(g, 3), q = grid_point(g, 3);
    RelationAnswer base = classify_segment(s, p, q);
    RelationAnswer swapped = classify_segment(s, q, p);
    EXPECT_EQ(swapped.cls, base.cls);
    EXPECT_NEAR(swapped.margin, base.margin, 1e-12);
    // Rotate and mirror every triangle's vertex order, and shuffle the triangles.
    Scene t = s;
    for (auto& tri : t.mesh.triangles) {
      if (iter % 2) std::rotate(tri.begin(), tri.begin() + 1, tri.end());
      else std::swap(tri[0], tri[2]);
    }
    std::shuffle(t.mesh.triangles.begin(), t.mesh.triangles.end(), g);
    RelationAnswer perm = classify_segment(t, p, q);
    EXPECT_EQ(perm.cls, base.cls);
    EXPECT_NEAR(perm.margin, base.margin, 1e-12);
  }
}

TEST(RelationOracle, ClassesOnlyRunAndFilledMarginsCompareAsTheFullRun) {
  // run_relation_oracle_classes (relation_oracle.h) gives run_relation_oracle's classes;
  // with fill_disagreement_margins (comparator.h), compare_relations finds the same
  // counts, histogram and mismatch records for a method result that disagrees with the
  // exact classes at pseudo-random relations (the fuzz targets' path), and the filled
  // margins are the full run's, bit for bit. Scenes: the region-test families and the
  // fuzz seeds (degenerate and far-away inputs among them).
  std::vector<Scene> scenes = bound_scenes();
  std::mt19937 rng(7);
  size_t relations = 0, disagreements = 0;
  for (size_t k = 0; k < scenes.size(); k += 3) {
    const Scene& sc = scenes[k];
    RelationOracleResult full = run_relation_oracle(sc, 1), cl = run_relation_oracle_classes(sc, 1);
    ASSERT_EQ(cl.classes, full.classes) << "scene " << k;
    SolveResult m = make_empty_result(sc);
    for (size_t i = 0; i < sc.receivers.size(); ++i)
      for (size_t b = 0; b < full.classes[i].size(); ++b) {
        bool v = full.classes[i][b] == 'v';
        if (full.classes[i][b] == 'd' || rng() % 3 == 0) v = rng() % 2 == 0;
        m.receivers[i].set_visible(b, v);
      }
    fill_disagreement_margins(sc, m, cl);
    Comparison a = compare_relations(sc, m, full, 1e-5), c = compare_relations(sc, m, cl, 1e-5);
    EXPECT_EQ(a.relations, c.relations);
    EXPECT_EQ(a.degenerate, c.degenerate);
    EXPECT_EQ(a.agree, c.agree);
    EXPECT_EQ(a.disagree, c.disagree);
    EXPECT_EQ(a.false_visible, c.false_visible);
    EXPECT_EQ(a.false_blocked, c.false_blocked);
    EXPECT_EQ(a.disagreement_margins.buckets, c.disagreement_margins.buckets);
    EXPECT_EQ(a.disagreement_margins.below, c.disagreement_margins.below);
    ASSERT_EQ(a.mismatches.size(), c.mismatches.size());
    for (size_t q = 0; q < a.mismatches.size(); ++q) {
      EXPECT_EQ(a.mismatches[q].receiver, c.mismatches[q].receiver);
      EXPECT_EQ(a.mismatches[q].sample, c.mismatches[q].sample);
      EXPECT_EQ(a.mismatches[q].margin, c.mismatches[q].margin);
    }
    for (size_t i = 0; i < sc.receivers.size(); ++i)
      for (size_t b = 0; b < full.classes[i].size(); ++b) {
        const char e = full.classes[i][b];
        if (e == 'd' || m.receivers[i].visible(b) == (e == 'v')) continue;
        EXPECT_EQ(cl.margins[i][b], full.margins[i][b]) << "scene " << k << " receiver " << i << " relation " << b;
        ++disagreements;
      }
    relations += a.relations;
  }
  EXPECT_GT(disagreements, 1000u);
  EXPECT_GT(relations, 5000u);
}

TEST(RelationOracle, BlockedSegmentTestEqualsClassifySegment) {
  // The comparator's fragment test: BlockedSegmentTest::blocked must be exactly
  // "classify_segment is Blocked with margin >= tau", also at tau equal to the margin
  // and just above it, on segments from receivers to light points and random points.
  size_t segments = 0, blocked = 0;
  std::mt19937 rng(7);
  for (const char* fam : {"random-soup", "grid-snapped", "shared-edge-fan", "on-surface", "pouch", "columns"}) {
    auto scene = small_family_scene(fam, 3, 80);
    ASSERT_TRUE(scene.ok()) << fam;
    BlockedSegmentTest test(*scene);
    AABB b = scene->bounds();
    std::uniform_real_distribution<float> ux(b.lo.x, b.hi.x), uy(b.lo.y, b.hi.y), uz(b.lo.z, b.hi.z);
    for (size_t i = 0; i < scene->receivers.size(); ++i)
      for (int k = 0; k < 40; ++k) {
        Vec3f from = scene->receivers[i].p;
        Vec3f to = k % 2 ? Vec3f(ux(rng), uy(rng), uz(rng))
                         : sample_position(scene->lights[size_t(k) % scene->lights.size()], k / 2 % 4, i);
        RelationAnswer a = classify_segment(*scene, from, to);
        for (double tau : {1e-5, 1e-3, a.margin, std::nextafter(a.margin, 1.0)}) {
          bool expect = a.cls == RelationClass::Blocked && a.margin >= tau;
          EXPECT_EQ(test.blocked(from, to, tau), expect) << fam << " " << i << " " << k << " " << tau;
        }
        ++segments;
        blocked += a.cls == RelationClass::Blocked;
      }
  }
  EXPECT_GT(blocked, segments / 10);
}

}  // namespace
}  // namespace visgate::oracle
