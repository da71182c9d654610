// lib/raycast/embree_scene.h: Embree's input domain and the double-precision fallback, hit
// verification, certain crossings, ranged queries and packet fans.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "lib/raycast/embree_scene.h"
#include "lib/scene/families.h"
#include "lib/solver.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/scenes.h"

using namespace visgate;
using namespace visgate::test_support;

// quad_scene with the blocker of TriangleBetweenPointAndLightQuad, every coordinate
// (mesh, light, receiver) multiplied by `scale`, a power of two, so the scaled scene is
// exactly similar to the unscaled one and has the same answers.
static Scene scaled_triangle_scene(float scale) {
  Scene s;
  s.name = "scaled";
  Light l;
  l.polygon = {Vec3f(-1, -1, 2) * scale, Vec3f(1, -1, 2) * scale, Vec3f(1, 1, 2) * scale, Vec3f(-1, 1, 2) * scale};
  l.samples = 16;
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a) l.explicit_samples.push_back(Vec3f(-0.75f + 0.5f * a, -0.75f + 0.5f * b, 2.0f) * scale);
  s.lights.push_back(l);
  s.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
  s.mesh.vertices = {Vec3f(0.05f, 0.05f, 1) * scale, Vec3f(1.05f, 0.05f, 1) * scale, Vec3f(0.05f, 1.05f, 1) * scale};
  s.mesh.triangles = {{0, 1, 2}};
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

TEST(Raycast, EmbreeDomainBoundIsTheDerivedPowerOfTwo) {
  // 2^9 B^3 < 2^128 with B = 2^39 (embree_solver.h), and 2B below Embree's FLT_LARGE.
  EXPECT_EQ(raycast::kEmbreeCoordinateBound, std::ldexp(1.0f, 39));
  EXPECT_LT(2.0 * raycast::kEmbreeCoordinateBound, 1.844e18);
  EXPECT_TRUE(std::isfinite(512.0f * std::pow(raycast::kEmbreeCoordinateBound, 3.0f)));
  EXPECT_TRUE(raycast::within_embree_bound(Vec3f(raycast::kEmbreeCoordinateBound, 0, -raycast::kEmbreeCoordinateBound)));
  EXPECT_FALSE(raycast::within_embree_bound(Vec3f(0, std::nextafter(raycast::kEmbreeCoordinateBound, 1e30f), 0)));
  EXPECT_FALSE(raycast::within_embree_bound(Vec3f(0, 0, std::numeric_limits<float>::quiet_NaN())));
}

TEST(Raycast, CoordinatesBeyondEmbreesRangeAreDecidedWithoutEmbree) {
  // Open finding fa6417c2 (fuzz_embree): finite coordinates near 1e36 made libembree3
  // abort in `ray.valid()`. At scales 2^50, 2^61 and 2^120 (beyond 2^39, beyond FLT_LARGE,
  // 1.3e36) every relation goes to the fallback and must give the hand-worked answer of
  // TriangleBetweenPointAndLightQuad; at scale 1 none does.
  for (float scale : {1.0f, std::ldexp(1.0f, 50), std::ldexp(1.0f, 61), std::ldexp(1.0f, 120)}) {
    Scene s = scaled_triangle_scene(scale);
    for (const char* m : {"embree", "embree-robust"}) {
      SolveResult r = make_solver(m)->solve(s, SolveOptions{});
      for (int b = 0; b < 4; ++b)
        for (int a = 0; a < 4; ++a)
          EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), !(a >= 2 && b >= 2)) << m << " scale " << scale << " sample " << a << "," << b;
      EXPECT_EQ(r.stats.get("fallback_rays", -1), scale == 1.0f ? 0.0 : 16.0) << m << " scale " << scale;
    }
  }
}

TEST(Raycast, FarReceiverWithAnInRangeMeshUsesTheFallbackForItsRaysOnly) {
  // Receiver at z = -2^41 below the scene of TriangleBetweenPointAndLightQuad: its
  // segment to sample (x, y, 2) crosses z = 1 at (x, y) scaled by (2^41 + 1)/(2^41 + 2),
  // within 2^-41 of (x, y); blocked iff x, y >= 0.05 and x + y <= 1.05, i.e. samples
  // (0.25,0.25), (0.25,0.75), (0.75,0.25) (0.75 + 0.75 > 1.05). The near receiver at the
  // origin keeps Embree's answer (4 blocked).
  Scene s = scaled_triangle_scene(1.0f);
  s.receivers.push_back({Vec3f(0, 0, -std::ldexp(1.0f, 41)), Vec3f(0, 0, 1)});
  for (const char* m : {"embree", "embree-robust"}) {
    SolveResult r = make_solver(m)->solve(s, SolveOptions{});
    for (int b = 0; b < 4; ++b)
      for (int a = 0; a < 4; ++a) {
        const bool far_blocked = a >= 2 && b >= 2 && !(a == 3 && b == 3);
        EXPECT_EQ(r.receivers[1].visible(size_t(b * 4 + a)), !far_blocked) << m << " sample " << a << "," << b;
        EXPECT_EQ(r.receivers[0].visible(size_t(b * 4 + a)), !(a >= 2 && b >= 2)) << m << " sample " << a << "," << b;
      }
    EXPECT_EQ(r.stats.get("fallback_rays", -1), 16.0) << m;
  }
}

TEST(Raycast, FarReceiverDoesNotBlurASmallTriangle) {
  // fuzz_embree finding d439daea (the first fallback, orientation tests through the far
  // receiver, lost the triangle's coordinates): receiver at (0.25, 7.1e22, 0), light
  // point (-0.5, -0.5, 2), unit triangle in z = 0.5 around the origin. The segment meets
  // z = 0.5 at y ~ 5.4e22, far from the triangle: visible. A segment from a far receiver
  // straight down the y axis through a triangle in y = 0 is blocked.
  TriangleSoup soup;
  soup.vertices = {Vec3f(0.5f, -1, 0.5f), Vec3f(-0.25f, -0.25f, 0.5f), Vec3f(-0.25f, -1.5f, 0.5f),
                   Vec3f(-1, 0, -1), Vec3f(1, 0, -1), Vec3f(0, 0, 1)};
  soup.triangles = {{0, 1, 2}};
  const Vec3f far(0.25f, 7.145125640569654e+22f, 0.0f);
  EXPECT_FALSE(raycast::fallback_occluded(soup, far, Vec3f(-0.5f, -0.5f, 2)));
  soup.triangles = {{3, 4, 5}};
  EXPECT_TRUE(raycast::fallback_occluded(soup, Vec3f(0.25f, 7.1e22f, 0.0f), Vec3f(0.25f, -1, 0)));
  EXPECT_TRUE(raycast::fallback_occluded(soup, Vec3f(0.25f, -1, 0), Vec3f(0.25f, 7.1e22f, 0.0f)));
  EXPECT_FALSE(raycast::fallback_occluded(soup, Vec3f(2.0f, 7.1e22f, 0.0f), Vec3f(2.0f, -1, 0)));
}

TEST(Raycast, FallbackAgreesWithEmbreeRobustAwayFromDegeneracy) {
  // The fallback (double orientation tests) against Embree on in-range random soups in
  // general position; same bound as the brute-force comparison above.
  const Scene scene = family("random-soup", 12, -1, 128, 32);
  ASSERT_FALSE(scene.receivers.empty());
  SolveResult b = make_solver("embree-robust")->solve(scene, SolveOptions{});
  size_t differ = 0, total = scene.relation_count(), blocked = 0;
  for (size_t i = 0; i < scene.receivers.size(); ++i) {
    size_t bit = 0;
    for (const Light& light : scene.lights)
      for (int j = 0; j < light.samples; ++j, ++bit) {
        const bool occ = raycast::fallback_occluded(scene.mesh, scene.receivers[i].p, sample_position(light, j, i));
        differ += occ == b.receivers[i].visible(bit);
        blocked += occ;
      }
  }
  EXPECT_GT(blocked, total / 20) << "the soup should block a fair share";
  EXPECT_LT(blocked, total);
  EXPECT_LT(differ * 10000, total) << differ << " of " << total;
}

TEST(Raycast, VerifiedScenesRejectRobustModesCoplanarFalseHit) {
  // corpus/embree-robust/sliver/2df110a9...: the triangle lies in the plane z - y = 2,
  // the segment runs within 6e-8 of that plane but 0.375 beside the triangle (at x =
  // -0.5, where the triangle's x range begins, it is at y = -0.125, z = 1.875; the
  // triangle spans y <= -0.5). RTC_SCENE_FLAG_ROBUST (libembree3 3.13.5) reports a hit
  // at t = 1; EmbreeScene's verification (the default, used by ISS and SSV) rejects it.
  TriangleSoup soup;
  soup.vertices = {Vec3f(-0.0f, -0.5f, 1.5f), Vec3f(-0.5f, -1, 1), Vec3f(0, -1, 1)};
  soup.triangles = {{0, 1, 2}};
  const Vec3f from(-2, -0.50000006f, 1.5f), to(-0.0f, 0, 2);
  EXPECT_FALSE(raycast::segment_hits_triangle(soup.vertices[0], soup.vertices[1], soup.vertices[2], from, to));
  raycast::EmbreeScene verified(soup, true);
  EXPECT_FALSE(verified.occluded(from, to));
  // A segment through the triangle's interior (its centroid, off the plane on both
  // sides) is still blocked in every mode.
  const Vec3f centroid(-1.0f / 6, -2.5f / 3, 3.5f / 3), n(0, -1, 1);
  for (bool robust : {false, true})
    for (bool verify : {false, true}) {
      raycast::EmbreeScene es(soup, robust, verify);
      EXPECT_TRUE(es.occluded(centroid - n, centroid + n)) << robust << verify;
    }
  EXPECT_EQ(verified.rejected_hits(), 1u);
  // The packet path is verified as well: a fan whose lane 3 is that segment.
  Vec3f fan[5] = {centroid + n, centroid + n, centroid + n, to, centroid + n};
  bool out[5];
  verified.occluded_fan(from, fan, 5, out);
  EXPECT_FALSE(out[3]);
  EXPECT_EQ(verified.rejected_hits(), 2u);
  for (int k : {0, 1, 2, 4}) EXPECT_EQ(out[k], verified.occluded(from, fan[k])) << k;
}

TEST(Raycast, MissesWithARejectedHitAreReportedAsDisputed) {
  // The coplanar false hit above: the ranged query misses and says its verification
  // rejected a hit; a clean miss and a hit say nothing.
  {
    TriangleSoup soup;
    soup.vertices = {Vec3f(-0.0f, -0.5f, 1.5f), Vec3f(-0.5f, -1, 1), Vec3f(0, -1, 1)};
    soup.triangles = {{0, 1, 2}};
    raycast::EmbreeScene verified(soup, true);
    bool disputed = false;
    EXPECT_FALSE(verified.occluded(Vec3f(-2, -0.50000006f, 1.5f), Vec3f(-0.0f, 0, 2), 0.0f, 1.0f, disputed));
    EXPECT_TRUE(disputed);
    EXPECT_FALSE(verified.occluded(Vec3f(5, 5, 0), Vec3f(5, 5, 2), 0.0f, 1.0f, disputed));
    EXPECT_FALSE(disputed);
    const Vec3f centroid(-1.0f / 6, -2.5f / 3, 3.5f / 3), n(0, -1, 1);
    EXPECT_TRUE(verified.occluded(centroid - n, centroid + n, 0.0f, 1.0f, disputed));
    EXPECT_FALSE(disputed);
  }
  // fuzz_ssv cfbec7f8 (tests/ssv/ssv_solver_test.cpp, ReferenceRayAlongAnInteriorEdgeIsNotConclusive):
  // a segment 2e-8 from the interior edge 0-1 of a disk, crossing triangle 1 just inside
  // that edge by the double-precision test. Embree's watertight test gave the crossing
  // to triangle 0 and the verification rejected it: the verified query missed. Whichever
  // triangle Embree reports, the query never ends as a miss without a dispute.
  TriangleSoup disk;
  disk.vertices = {Vec3f(-0.737304688f, -0.0493164062f, 1.12841797f), Vec3f(-0.647599995f, 0.0830169916f, 1.1089114f),
                   Vec3f(-1, 0, 1), Vec3f(-0.5f, 0, 1), Vec3f(-0.5f, 0.25f, 1)};
  disk.triangles = {{0, 1, 2}, {0, 3, 1}, {2, 1, 4}, {1, 3, 4}};
  const Vec3f r(-1.36551249f, 0.0683776736f, 0.21782279f), q(0.0703040287f, 0.0976455733f, 2);
  EXPECT_TRUE(raycast::segment_hits_triangle(disk.vertices[0], disk.vertices[3], disk.vertices[1], r, q));
  raycast::EmbreeScene es(disk, true);
  bool disputed = false;
  const bool hit = es.occluded(r, q, 0.0f, 1.0f + 0x1p-18f, disputed);
  EXPECT_TRUE(hit || disputed);
}

TEST(Raycast, DoubleTestRejectsPointsBeyondASliver) {
  // corpus/embree-robust/sliver/: a sliver of area 4e-25 in the plane z = 1 (its long
  // edges on the line y = -x) and a segment crossing that plane at (-0.5, 0.5, 1), on
  // the extension of the long edges, 0.7 beyond the sliver. The edge sign products round
  // to zero there; the box check rejects the point. A segment through the sliver's box
  // on the far side of the line misses too; one through a vertex (closed test) hits.
  const Vec3f a(0, 8.27180613e-25f, 1), b(1, -1, 1), c(0, -0.0f, 1);
  EXPECT_FALSE(raycast::segment_hits_triangle(a, b, c, Vec3f(0, -0.0f, -0.0f), Vec3f(-1, 1, 2)));
  EXPECT_FALSE(raycast::segment_hits_triangle(a, b, c, Vec3f(0.5f, 0, 0), Vec3f(0.5f, 0, 2)));
  EXPECT_TRUE(raycast::segment_hits_triangle(a, b, c, Vec3f(1, -1, 0), Vec3f(1, -1, 2)));
  // A regular triangle: the box check keeps interior hits.
  EXPECT_TRUE(raycast::segment_hits_triangle(Vec3f(0, 0, 1), Vec3f(2, 0, 1), Vec3f(0, 2, 1), Vec3f(0.5f, 0.5f, 0),
                                             Vec3f(0.5f, 0.5f, 2)));
}

TEST(Raycast, VerifiedHitsAreConfirmedByTheDoubleTest) {
  // Property: a verified scene reports a hit only where segment_hits_triangle confirms
  // one, and on general-position soups it agrees with the unverified robust scene.
  const Scene scene = family("sliver-soup", 5, -1, 64, 16);
  ASSERT_FALSE(scene.receivers.empty());
  raycast::EmbreeScene verified(scene.mesh, true), plain(scene.mesh, true, false);
  size_t differ = 0, total = 0;
  for (size_t i = 0; i < scene.receivers.size(); ++i)
    for (int j = 0; j < scene.lights[0].samples; ++j, ++total) {
      const Vec3f r = scene.receivers[i].p, l = sample_position(scene.lights[0], j, i);
      const bool v = verified.occluded(r, l);
      if (v) {
        EXPECT_TRUE(raycast::fallback_occluded(scene.mesh, r, l)) << i << " " << j;
      }
      differ += v != plain.occluded(r, l);
    }
  EXPECT_LE(differ, verified.rejected_hits());  // a rejected candidate may hide behind a true hit
  EXPECT_LT(differ * 100, total) << differ << " of " << total;
}

TEST(Raycast, CertainCrossingsAreExactHits) {
  // Property against the exact oracle: whenever certainly_crosses_interior proves a
  // crossing, the exact class of the open segment against the closed triangle is
  // Blocked and the double-precision test confirms it. Inputs: general position,
  // grid-snapped (exact coplanarity and segments through edges and vertices), slivers,
  // segments nearly in the triangle's plane, coordinates far from the origin and tiny.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::uniform_int_distribution<int> grid(-2, 2);
  size_t certain = 0, general = 0, general_certain = 0;
  for (int it = 0; it < 200000; ++it) {
    const int kind = it % 5;
    auto pt = [&] {
      if (kind == 1) return Vec3f(float(grid(rng)), float(grid(rng)), float(grid(rng)));
      return Vec3f(u(rng), u(rng), u(rng));
    };
    Vec3f a = pt(), b = pt(), c = pt(), p = pt(), q = pt();
    if (kind == 2) c = a + (b - a) * 0.5f + Vec3f(0, 0, 1e-7f * u(rng));  // a sliver
    if (kind == 3) {  // end points within 1e-6 of the plane z = 0 of a flat triangle
      a.z = b.z = c.z = 0.0f;
      p.z = 1e-6f * u(rng);
      q.z = 1e-6f * u(rng);
    }
    if (kind == 4) {  // far from the origin, or tiny
      const float s = it % 2 ? 1e6f : 1e-30f;
      for (Vec3f* v : {&a, &b, &c, &p, &q}) *v = *v * s + (it % 2 ? Vec3f(3e6f, 0, 0) : Vec3f());
    }
    const bool cert = raycast::certainly_crosses_interior(to_double(p), to_double(q), a, b, c);
    // The AVX2 build (where the CPU has it) and the default build: the same answer.
    ASSERT_EQ(cert, raycast::certainly_crosses_interior_default(to_double(p), to_double(q), a, b, c)) << it;
    if (kind == 0) {
      ++general;
      general_certain += cert;
    }
    if (!cert) continue;
    ++certain;
    EXPECT_EQ(oracle::classify_segment_triangle(p, q, a, b, c), oracle::RelationClass::Blocked) << it;
    EXPECT_TRUE(raycast::segment_hits_triangle(a, b, c, p, q)) << it;
  }
  // It is a fast path, not a refusal: in general position almost every true crossing
  // is proved (random segments cross a random triangle about 5% of the time).
  EXPECT_GT(general_certain * 40, general) << general_certain << " of " << general;
  EXPECT_GT(certain, general_certain);
  // Hand-worked: the segment through the centroid of a unit triangle is proved, the
  // ones through a vertex, along an edge, ending on the triangle or in its plane not.
  const Vec3f a(0, 0, 1), b(3, 0, 1), c(0, 3, 1);
  auto cert = [&](Vec3f p, Vec3f q) { return raycast::certainly_crosses_interior(to_double(p), to_double(q), a, b, c); };
  EXPECT_TRUE(cert(Vec3f(1, 1, 0), Vec3f(1, 1, 2)));
  EXPECT_TRUE(cert(Vec3f(1, 1, 2), Vec3f(1, 1, 0)));
  EXPECT_FALSE(cert(Vec3f(0, 0, 0), Vec3f(0, 0, 2)));
  EXPECT_FALSE(cert(Vec3f(1, 0, 0), Vec3f(1, 0, 2)));
  EXPECT_FALSE(cert(Vec3f(1, 1, 0), Vec3f(1, 1, 1)));
  EXPECT_FALSE(cert(Vec3f(1, 1, 1), Vec3f(1, 1, 2)));
  EXPECT_FALSE(cert(Vec3f(-1, 1, 1), Vec3f(2, 1, 1)));
  EXPECT_FALSE(cert(Vec3f(5, 5, 0), Vec3f(5, 5, 2)));
}

TEST(Raycast, RangedQueriesTellEndpointHitsFromInteriorHits) {
  // Segment (0,0,0) -> (0,0,2) and unit triangles in z = 1 (t = 0.5) and z = 2 (through
  // the far endpoint, t = 1). The ranged query sees a hit iff its t lies in the range,
  // for Embree and for the double-precision fallback alike; the endpoint hit counts for
  // [0, 1] (Embree's inclusive tfar), not for [0, 1 - 2^-18], and for [0, 1 + 2^-18].
  TriangleSoup mid, end;
  mid.vertices = {Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)};
  mid.triangles = {{0, 1, 2}};
  end.vertices = {Vec3f(-1, -1, 2), Vec3f(1, -1, 2), Vec3f(0, 1, 2)};
  end.triangles = {{0, 1, 2}};
  const Vec3f a(0, 0, 0), b(0, 0, 2);
  const float lo = 1.0f - 0x1p-18f, hi = 1.0f + 0x1p-18f;
  raycast::EmbreeScene em(mid, true), ee(end, true);
  EXPECT_TRUE(em.occluded(a, b, 0.0f, 0.6f));
  EXPECT_FALSE(em.occluded(a, b, 0.0f, 0.4f));
  EXPECT_FALSE(em.occluded(a, b, 0.6f, 2.0f));
  EXPECT_TRUE(ee.occluded(a, b, 0.0f, 1.0f));
  EXPECT_FALSE(ee.occluded(a, b, 0.0f, lo));
  EXPECT_TRUE(ee.occluded(a, b, 0.0f, hi));
  EXPECT_TRUE(ee.occluded(a, b, lo, hi));
  EXPECT_TRUE(raycast::fallback_occluded(mid, a, b, 0.0, 0.6));
  EXPECT_FALSE(raycast::fallback_occluded(mid, a, b, 0.0, 0.4));
  EXPECT_FALSE(raycast::fallback_occluded(mid, a, b, 0.6, 2.0));
  EXPECT_TRUE(raycast::fallback_occluded(end, a, b, 0.0, 1.0));
  EXPECT_FALSE(raycast::fallback_occluded(end, a, b, 0.0, lo));
  EXPECT_TRUE(raycast::fallback_occluded(end, a, b, 0.0, hi));
  // Reversed: the triangle at the origin end is at t = 1 seen from the far end.
  // Embree's robust intersector includes tnear too (a hit at the origin counts), and so
  // does the ranged fallback; only a positive tnear excludes the origin end.
  EXPECT_TRUE(ee.occluded(b, a, 0.0f, 1.0f));
  EXPECT_FALSE(ee.occluded(b, a, 0x1p-18f, 1.0f));
  EXPECT_TRUE(raycast::fallback_occluded(end, b, a, 0.0, 0.5));
  EXPECT_FALSE(raycast::fallback_occluded(end, b, a, 0x1p-18, 0.5));
}

TEST(Raycast, PacketFanAgreesWithSingleRays) {
  // occluded_fan traces one 16-wide packet; every lane must give occluded()'s answer.
  // Random soups in general position (ties have probability zero), fans of 1..20 rays
  // (20: two packets), near and far from the origin, and a fan whose origin is beyond
  // Embree's domain (every lane through the fallback), checked against the hand-worked
  // answers of TriangleBetweenPointAndLightQuad.
  for (float off : {0.0f, 4096.0f}) {
    const Scene scene = family("random-soup", 5, -1, 64, 20);
    ASSERT_FALSE(scene.receivers.empty());
    Scene s = scene;
    for (auto& v : s.mesh.vertices) v.x += off;
    for (auto& r : s.receivers) r.p.x += off;
    raycast::EmbreeScene es(s.mesh, true);
    const Light& l = s.lights[0];
    size_t blocked = 0, lanes = 0;
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      int n = 1 + int(i % 20);
      Vec3f to[20];
      bool out[20];
      for (int k = 0; k < n; ++k) to[k] = sample_position(l, k, i) + Vec3f(off, 0, 0);
      es.occluded_fan(s.receivers[i].p, to, n, out);
      for (int k = 0; k < n; ++k) {
        EXPECT_EQ(out[k], es.occluded(s.receivers[i].p, to[k])) << "receiver " << i << " lane " << k;
        // And the double-precision test over every triangle, computed without Embree.
        EXPECT_EQ(out[k], raycast::fallback_occluded(s.mesh, s.receivers[i].p, to[k])) << "receiver " << i;
        blocked += out[k];
        ++lanes;
      }
    }
    EXPECT_GT(blocked, 0u);
    EXPECT_LT(blocked, lanes);
    // Every blocked answer came with a hit the filter accepted for that very lane (ray
    // id bookkeeping of the packets): nothing had to be answered again.
    EXPECT_EQ(es.unverified_hits(), 0u);
    EXPECT_EQ(es.fallback_rays(), 0u);
  }
  Scene far = scaled_triangle_scene(std::ldexp(1.0f, 50));
  raycast::EmbreeScene es(far.mesh, true);
  const Vec3f* to = far.lights[0].explicit_samples.data();
  bool out[16];
  es.occluded_fan(far.receivers[0].p, to, 16, out);
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a) EXPECT_EQ(out[b * 4 + a], a >= 2 && b >= 2) << a << "," << b;
  EXPECT_EQ(es.fallback_rays(), 16u);
}

TEST(Raycast, CachedCrossingTermsNeverCrossScenesOrOrigins) {
  // The verification keeps crossing terms per thread, keyed by scene, origin and
  // primitive id. Two scenes whose triangle 0 differs (one blocks the fans, the other is
  // moved aside) are queried alternately from the same origin, in many fans per origin
  // (cache hits) and from several origins: every lane must equal the double-precision
  // test over the lane's own scene, computed without Embree.
  TriangleSoup near_soup, aside_soup;
  near_soup.vertices = {Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)};
  near_soup.triangles = {{0u, 1u, 2u}};
  aside_soup.vertices = {Vec3f(1.5f, -1, 1), Vec3f(3.5f, -1, 1), Vec3f(2.5f, 1, 1)};
  aside_soup.triangles = {{0u, 1u, 2u}};
  raycast::EmbreeScene near_es(near_soup, true), aside_es(aside_soup, true);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-3.0f, 7.0f);
  size_t blocked_near = 0, blocked_aside = 0;
  for (int o = 0; o < 6; ++o) {
    const Vec3f from(u(rng) * 0.1f, u(rng) * 0.1f, 0.0f);
    for (int fan = 0; fan < 8; ++fan) {
      Vec3f to[16];
      bool out[16];
      for (auto& t : to) t = Vec3f(u(rng), u(rng) * 0.5f, 2.0f);
      for (const raycast::EmbreeScene* es : {&near_es, &aside_es}) {
        const TriangleSoup& soup = es == &near_es ? near_soup : aside_soup;
        es->occluded_fan(from, to, 16, out);
        for (int k = 0; k < 16; ++k) {
          EXPECT_EQ(out[k], raycast::fallback_occluded(soup, from, to[k])) << o << " " << fan << " " << k;
          EXPECT_EQ(out[k], es->occluded(from, to[k]));
          (es == &near_es ? blocked_near : blocked_aside) += out[k];
        }
      }
    }
  }
  EXPECT_GT(blocked_near, 0u);
  EXPECT_GT(blocked_aside, 0u);
  EXPECT_EQ(near_es.unverified_hits() + aside_es.unverified_hits(), 0u);
}

TEST(Raycast, CachedCrossingTermsOfAnotherSceneCannotConfirmAFalseHit) {
  // The coplanar false hit of VerifiedScenesRejectRobustModesCoplanarFalseHit, queried
  // right after a scene whose triangle 0 the same segment certainly crosses: terms
  // cached for that scene's triangle 0 from the same origin would prove the sliver's
  // false candidate; the per-scene key must keep them apart.
  TriangleSoup sliver;
  sliver.vertices = {Vec3f(-0.0f, -0.5f, 1.5f), Vec3f(-0.5f, -1, 1), Vec3f(0, -1, 1)};
  sliver.triangles = {{0, 1, 2}};
  const Vec3f from(-2, -0.50000006f, 1.5f), to(-0.0f, 0, 2);
  const Vec3f mid = (from + to) * 0.5f;
  TriangleSoup wall;  // the plane x = mid.x, around the segment's midpoint
  wall.vertices = {mid + Vec3f(0, -4, -4), mid + Vec3f(0, 4, -4), mid + Vec3f(0, 0, 4)};
  wall.triangles = {{0, 1, 2}};
  raycast::EmbreeScene wall_es(wall, true), sliver_es(sliver, true);
  for (int round = 0; round < 3; ++round) {
    bool out = false;
    wall_es.occluded_fan(from, &to, 1, &out);
    EXPECT_TRUE(out);
    sliver_es.occluded_fan(from, &to, 1, &out);
    EXPECT_FALSE(out);
  }
  EXPECT_EQ(sliver_es.rejected_hits(), 3u);
}

TEST(Raycast, FanLanesBeyondEmbreesDomainUseTheFallbackOneByOne) {
  // A fan whose odd lanes end beyond Embree's domain (a light point pushed 2^41 along its
  // direction from the origin): those lanes go to the fallback, the even ones to the
  // packet; every lane equals the double-precision test without Embree, in 8- and
  // 16-lane fans and one of 13 (a partial packet).
  TriangleSoup soup;
  soup.vertices = {Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)};
  soup.triangles = {{0u, 1u, 2u}};
  raycast::EmbreeScene es(soup, true);
  const Vec3f from(0.1f, 0.0f, 0.0f);
  size_t far_lanes = 0, blocked = 0;
  for (int n : {8, 13, 16}) {
    Vec3f to[16];
    bool out[16];
    for (int k = 0; k < n; ++k) {
      const Vec3f near(-2.0f + 0.3f * float(k), 0.5f - 0.1f * float(k), 2.0f);
      to[k] = k % 2 ? from + (near - from) * std::ldexp(1.0f, 41) : near;
      far_lanes += k % 2;
    }
    es.occluded_fan(from, to, n, out);
    for (int k = 0; k < n; ++k) {
      EXPECT_EQ(out[k], raycast::fallback_occluded(soup, from, to[k])) << n << " lane " << k;
      blocked += out[k];
    }
  }
  EXPECT_EQ(es.fallback_rays(), far_lanes);
  EXPECT_GT(blocked, 0u);
  EXPECT_EQ(es.unverified_hits(), 0u);
}

TEST(Raycast, EveryBuildQualityGivesTheDoublePrecisionAnswers) {
  // The build quality changes only Embree's BVH, never which triangles a segment meets:
  // single rays and packets of every quality against fallback_occluded computed without
  // Embree, on a soup in general position and a dense closed surface (scan).
  for (const char* fam : {"random-soup", "scan"}) {
    const Scene s = family(fam, 3, fam[0] == 's' ? 4000 : -1, 48, 8);
    ASSERT_FALSE(s.receivers.empty());
    for (auto q : {raycast::BuildQuality::low, raycast::BuildQuality::medium, raycast::BuildQuality::high}) {
      raycast::EmbreeScene es(s.mesh, true, true, q);
      size_t blocked = 0, lanes = 0;
      for (size_t i = 0; i < s.receivers.size(); ++i) {
        const Light& l = s.lights[i % s.lights.size()];
        Vec3f to[8];
        bool out[8];
        for (int k = 0; k < 8; ++k) to[k] = sample_position(l, k, i);
        es.occluded_fan(s.receivers[i].p, to, 8, out);
        for (int k = 0; k < 8; ++k) {
          const bool ref = raycast::fallback_occluded(s.mesh, s.receivers[i].p, to[k]);
          EXPECT_EQ(out[k], ref) << fam << " quality " << int(q) << " receiver " << i << " lane " << k;
          EXPECT_EQ(es.occluded(s.receivers[i].p, to[k]), ref) << fam << " receiver " << i << " lane " << k;
          blocked += ref;
          ++lanes;
        }
      }
      EXPECT_GT(blocked, 0u) << fam;
      EXPECT_LT(blocked, lanes) << fam;
    }
  }
}

TEST(Raycast, PairedQuadsGiveTheTrianglesAnswers) {
  // Primitives::paired_quads changes Embree's primitives, not the triangles a segment
  // meets: single rays (plain, ranged with their disputes) and packets against the
  // triangle scene and fallback_occluded, on scan (every triangle paired), scan without
  // its first triangle (pairs across the cells, unpaired ones between) and a soup in
  // general position (no pairs: triangles only).
  for (int variant = 0; variant < 3; ++variant) {
    Scene s = family(variant == 2 ? "random-soup" : "scan", 3, variant == 2 ? -1 : 4000, 48, 8);
    ASSERT_FALSE(s.receivers.empty());
    if (variant == 1) s.mesh.triangles.erase(s.mesh.triangles.begin());
    raycast::EmbreeScene tri(s.mesh, true, true, raycast::BuildQuality::low);
    raycast::EmbreeScene quad(s.mesh, true, true, raycast::BuildQuality::low, raycast::Primitives::paired_quads);
    EXPECT_EQ(tri.quad_count(), 0u);
    const size_t paired = 2 * quad.quad_count();
    EXPECT_EQ(paired == s.mesh.size(), variant == 0) << variant;
    EXPECT_EQ(paired > 0, variant != 2) << variant;
    size_t blocked = 0, lanes = 0;
    for (size_t i = 0; i < s.receivers.size(); ++i) {
      const Light& l = s.lights[i % s.lights.size()];
      const Vec3f& r = s.receivers[i].p;
      Vec3f to[8];
      bool out[8];
      for (int k = 0; k < 8; ++k) to[k] = sample_position(l, k, i);
      quad.occluded_fan(r, to, 8, out);
      for (int k = 0; k < 8; ++k) {
        const bool ref = raycast::fallback_occluded(s.mesh, r, to[k]);
        EXPECT_EQ(out[k], ref) << variant << " receiver " << i << " lane " << k;
        EXPECT_EQ(quad.occluded(r, to[k]), ref) << variant << " receiver " << i << " lane " << k;
        EXPECT_EQ(tri.occluded(r, to[k]), ref) << variant << " receiver " << i << " lane " << k;
        for (auto [t0, t1] : {std::pair(0.0f, 1.0f + 0x1p-18f), std::pair(0x1p-18f, 1.0f - 0x1p-18f)}) {
          bool dq = false, dt = false;
          EXPECT_EQ(quad.occluded(r, to[k], t0, t1, dq), tri.occluded(r, to[k], t0, t1, dt)) << variant << " " << i;
          EXPECT_EQ(dq, dt) << variant << " receiver " << i << " lane " << k;
        }
        blocked += ref;
        ++lanes;
      }
    }
    EXPECT_GT(blocked, 0u) << variant;
    EXPECT_LT(blocked, lanes) << variant;
    EXPECT_EQ(quad.unverified_hits(), 0u);
    EXPECT_EQ(quad.fallback_rays(), 0u);
  }
}
