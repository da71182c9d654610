// Tests of lib/geom/aabb.h: boxes and the conservative triangle/box overlap.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/scene/rng.h"

using namespace visgate;

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
