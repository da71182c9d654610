// Tests of lib/geom/vec.h: vector arithmetic and canonical bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lib/geom/vec.h"

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
