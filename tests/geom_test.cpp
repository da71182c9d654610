// lib/geom: vectors, AABB, triangle/box overlap, Plücker side operator, predicates.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lib/geom/aabb.h"
#include "lib/geom/plucker.h"
#include "lib/geom/predicates.h"
#include "lib/scene/rng.h"

using namespace visgate;

TEST(Vec, CrossAndDotByHand) {
  Vec3f a(1, 2, 3), b(4, 5, 6);
  EXPECT_EQ(cross(a, b), Vec3f(-3, 6, -3));
  EXPECT_EQ(dot(a, b), 32.0f);
  EXPECT_EQ(max_axis(Vec3f(1, 5, 2)), 1);
}

TEST(Vec, CanonicalBitsMergesSignedZero) {
  EXPECT_EQ(canonical_bits(0.0f), canonical_bits(-0.0f));
  EXPECT_NE(canonical_bits(1.0f), canonical_bits(-1.0f));
}

TEST(Plucker, SideEqualsOrientationDeterminant) {
  // Property from the derivation in plucker.h, checked in double on random points.
  Rng rng(7);
  for (int i = 0; i < 1000; ++i) {
    Vec3d p(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    Vec3d q(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    Vec3d a(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    Vec3d b(rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(-5, 5));
    double s = side(Pluckerd::through(p, q), Pluckerd::through(a, b));
    double d = dot(q - p, cross(a - p, b - p));
    EXPECT_NEAR(s, d, 1e-9 * (1 + std::abs(d)));
  }
}

TEST(Plucker, IncidentLinesHaveZeroSide) {
  // Two lines through a common point (exact small integers: no rounding).
  Pluckerd l = Pluckerd::through(Vec3d(0, 0, 0), Vec3d(1, 2, 3));
  Pluckerd r = Pluckerd::through(Vec3d(1, 2, 3), Vec3d(-4, 1, 7));
  EXPECT_EQ(side(l, r), 0.0);
  // Parallel lines.
  Pluckerd s = Pluckerd::through(Vec3d(1, 0, 0), Vec3d(2, 2, 3));
  EXPECT_EQ(side(l, s), 0.0);
  // Reversing one line flips the sign.
  Pluckerd t = Pluckerd::through(Vec3d(0, 1, 0), Vec3d(1, 1, 1));
  EXPECT_EQ(side(l, t), -side(l, t.reversed()));
}

TEST(Predicates, Orient3dSignsByHand) {
  Vec3f a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_GT(orient3d_f32(a, b, c, Vec3f(0, 0, 1)), 0.0f);
  EXPECT_LT(orient3d_f32(a, b, c, Vec3f(0, 0, -1)), 0.0f);
  EXPECT_EQ(orient3d_f32(a, b, c, Vec3f(0.25f, 0.25f, 0)), 0.0f);
}

TEST(Predicates, MollerTrumboreOpenSegment) {
  Vec3f v0(-1, -1, 1), v1(1, -1, 1), v2(0, 1, 1);
  // Crossing in the middle.
  EXPECT_TRUE(segment_hits_triangle_mt(Vec3f(0, 0, 0), Vec3f(0, 0, 2), v0, v1, v2));
  // The triangle at the far endpoint (t = 1) is excluded, and at the near one (t = 0).
  EXPECT_FALSE(segment_hits_triangle_mt(Vec3f(0, 0, 0), Vec3f(0, 0, 1), v0, v1, v2));
  EXPECT_FALSE(segment_hits_triangle_mt(Vec3f(0, 0, 1), Vec3f(0, 0, 1), v0, v1, v2));
  // Missing the triangle.
  EXPECT_FALSE(segment_hits_triangle_mt(Vec3f(5, 0, 0), Vec3f(0, 0, 2), v0, v1, v2));
  // Parallel segment in the plane: zero determinant is a miss (no epsilon).
  EXPECT_FALSE(segment_hits_triangle_mt(Vec3f(-2, 0, 1), Vec3f(4, 0, 0), v0, v1, v2));
}

TEST(Predicates, FarFromOriginKeepsTheAnswerForLargeMargins) {
  float off = 1e5f;
  Vec3f v0(off - 1, off - 1, off + 1), v1(off + 1, off - 1, off + 1), v2(off, off + 1, off + 1);
  EXPECT_TRUE(segment_hits_triangle_mt(Vec3f(off, off, off), Vec3f(0, 0, 2), v0, v1, v2));
}

TEST(Aabb, TriangleOverlapByHand) {
  AABB box(Vec3f(0, 0, 0), Vec3f(1, 1, 1));
  EXPECT_TRUE(triangle_overlaps_aabb(Vec3f(0.5f, 0.5f, 0.5f), Vec3f(2, 0.5f, 0.5f), Vec3f(0.5f, 2, 0.5f), box));
  // Box bounds overlap but the triangle's plane passes beside the box corner.
  EXPECT_FALSE(triangle_overlaps_aabb(Vec3f(2, 0, 0), Vec3f(0, 2, 0), Vec3f(0, 0, 2.9f), AABB(Vec3f(0, 0, 0), Vec3f(0.5f, 0.5f, 0.5f))));
  // Touching a face exactly counts (conservative).
  EXPECT_TRUE(triangle_overlaps_aabb(Vec3f(1, 0, 0), Vec3f(1, 1, 0), Vec3f(1, 0, 1), box));
  EXPECT_FALSE(triangle_overlaps_aabb(Vec3f(1.5f, 0, 0), Vec3f(1.5f, 1, 0), Vec3f(1.5f, 0, 1), box));
}

TEST(Aabb, OverlapIsConservativeAgainstSampledPoints) {
  // Property: if a point of the triangle lies in the box, the test must say "overlaps".
  Rng rng(3);
  for (int i = 0; i < 2000; ++i) {
    AABB box(Vec3f(float(rng.uniform(-1, 0)), float(rng.uniform(-1, 0)), float(rng.uniform(-1, 0))),
             Vec3f(float(rng.uniform(0, 1)), float(rng.uniform(0, 1)), float(rng.uniform(0, 1))));
    Vec3f a(float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)));
    Vec3f b(float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)));
    Vec3f c(float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)));
    bool inside = false;
    for (int k = 0; k < 200 && !inside; ++k) {
      double s = rng.uniform(), t = rng.uniform();
      if (s + t > 1) {
        s = 1 - s;
        t = 1 - t;
      }
      Vec3f p(to_double(a) + (to_double(b) - to_double(a)) * s + (to_double(c) - to_double(a)) * t);
      inside = box.contains(p);
    }
    if (inside) {
      EXPECT_TRUE(triangle_overlaps_aabb(a, b, c, box));
    }
  }
}

TEST(Aabb, DegenerateSliverTriangle) {
  AABB box(Vec3f(0, 0, 0), Vec3f(1, 1, 1));
  // Zero-area triangle (collinear) through the box.
  EXPECT_TRUE(triangle_overlaps_aabb(Vec3f(-1, 0.5f, 0.5f), Vec3f(0, 0.5f, 0.5f), Vec3f(2, 0.5f, 0.5f), box));
  EXPECT_FALSE(triangle_overlaps_aabb(Vec3f(-1, 2, 0.5f), Vec3f(0, 2, 0.5f), Vec3f(2, 2, 0.5f), box));
}
