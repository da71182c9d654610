// Tests of lib/geom/plucker.h: the side operator and its determinant form.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lib/geom/plucker.h"
#include "lib/geom/predicates.h"
#include "lib/scene/rng.h"

using namespace visgate;

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
