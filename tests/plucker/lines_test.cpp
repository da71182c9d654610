// Tests of lib/plucker/lines.cpp: the side operator, stabbing by consistent orientation,
// Theorem 1 and the edge fans (paper 002 sections 3.1-3.3).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

TEST(PluckerGeometry, SideOperatorEqualsDeterminant) {
  Rng rng(3);
  for (int k = 0; k < 1000; ++k) {
    Vec3d p[4];
    for (auto& v : p) v = Vec3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
    double s = side(Pluckerd::through(p[0], p[1]), Pluckerd::through(p[2], p[3]));
    double d = orient3d(p[0], p[1], p[2], p[3]);  // det[q-p, a-p, b-p]
    EXPECT_NEAR(s, d, 1e-12 * (1 + std::abs(d)));
  }
}

TEST(PluckerGeometry, StabbingByConsistentOrientation) {
  Vec3f tri[3] = {Vec3f(0, 0, 1), Vec3f(1, 0, 1), Vec3f(0, 1, 1)};
  // Through the interior in both directions: stabs.
  EXPECT_TRUE(line_stabs_polygon(Plucker::through(Vec3f(0.2f, 0.2f, 0), Vec3f(0.2f, 0.2f, 2)), tri, 3));
  EXPECT_TRUE(line_stabs_polygon(Plucker::through(Vec3f(0.2f, 0.2f, 2), Vec3f(0.25f, 0.2f, 0)), tri, 3));
  // Outside the hypotenuse: misses.
  EXPECT_FALSE(line_stabs_polygon(Plucker::through(Vec3f(0.6f, 0.6f, 0), Vec3f(0.6f, 0.6f, 2)), tri, 3));
  // Lines from below stabbing a triangle whose normal points up are positive (lines.h).
  EXPECT_EQ(side_sign(Vec3f(0.2f, 0.2f, 0), Vec3f(0.2f, 0.2f, 2), tri[0], tri[1]), Sign::Positive);
  EXPECT_EQ(side_sign(Vec3f(0.2f, 0.2f, 0), Vec3f(0.2f, 0.2f, 2), tri[1], tri[2]), Sign::Positive);
  // Meeting the edge line: zero.
  EXPECT_EQ(side_sign(Vec3f(0.5f, 0, 0), Vec3f(0.5f, 0, 2), tri[0], tri[1]), Sign::Uncertain);
}

TEST(PluckerGeometry, Theorem1OrientationBoundsEveryStabbingLine) {
  // For random occluders, light quads and lines: a Positive (Negative) vvset orientation
  // implies every sampled stabbing line is positive (negative), evaluated in double.
  Rng rng(11);
  Vec3f light[4] = {Vec3f(-1, -1, 2), Vec3f(-1, 1, 2), Vec3f(1, 1, 2), Vec3f(1, -1, 2)};
  int decided = 0, mixed = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Vec3f o[3];
    for (auto& v : o) v = Vec3f(Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.5, 1.5)));
    Vec3f dir[12];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) dir[i * 4 + j] = light[j] - o[i];
    Vec3f a(Vec3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(0, 2)));
    Vec3f b(Vec3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(0, 2)));
    Orientation s = vvset_orientation(o, 3, dir, 4, a, b);
    if (s == Orientation::Mixed) {
      ++mixed;
      continue;
    }
    ++decided;
    for (int k = 0; k < 50; ++k) {
      double u = rng.uniform(), v = rng.uniform() * (1 - u);
      Vec3d x = to_double(o[0]) + (to_double(o[1]) - to_double(o[0])) * u + (to_double(o[2]) - to_double(o[0])) * v;
      Vec3d y(rng.uniform(-1, 1), rng.uniform(-1, 1), 2);
      double sd = orient3d(x, y, to_double(a), to_double(b));
      if (s == Orientation::Positive) EXPECT_GT(sd, 0.0);
      else EXPECT_LT(sd, 0.0);
    }
  }
  EXPECT_GT(decided, 50);
  EXPECT_GT(mixed, 50);
}

TEST(PluckerGeometry, EdgeFanOrientationIsTheRuleOverEveryEntry) {
  // EdgeFan::orientation (two entries at a time with SSE2, an odd fan padded by its last
  // entry) equals the rule it states, evaluated here entry by entry from w and scale:
  // Mixed when some value sign * (x_i - a) . W_k is within scale_k |x_i - a|_1 or both
  // signs occur, else the one sign. Fans of 1 to 9 points, 0 to 6 points x, both
  // directions; a third of the cases with a point in the plane of the line and one fan
  // point.
  Rng rng(23);
  int counts[3] = {0, 0, 0};
  for (int trial = 0; trial < 3000; ++trial) {
    const int m = 1 + trial % 9, n = trial % 7;
    std::vector<Vec3d> p(static_cast<size_t>(m)), x(static_cast<size_t>(n));
    for (auto& v : p) v = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(1.5, 2.5));
    for (auto& v : x) v = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 0));
    const Vec3d a(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.5, 1));
    const Vec3d b(rng.uniform(-1, 1), rng.uniform(-1, 1), 1);
    // A point in the plane of a, b and one fan point: that entry's value is undecided,
    // the others mostly not (so one lane of a pair decides and the other does not).
    if (trial % 3 == 0 && n > 0) x[0] = a + (p[size_t(trial % m)] - a) * -0.5 + (b - a) * 0.3;
    EdgeFan fan;
    fan.set(a, b, p.data(), m);
    for (const bool toward : {true, false}) {
      bool pos = false, neg = false, mixed = false;
      for (int i = 0; i < n && !mixed; ++i) {
        const Vec3d d = x[size_t(i)] - a;
        const double nd = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
        for (int k = 0; k < m; ++k) {
          const double s = (toward ? 1.0 : -1.0) * dot(d, fan.w[size_t(k)]);
          const double bound = fan.scale[size_t(k)] * nd;
          if (s > bound) pos = true;
          else if (s < -bound) neg = true;
          else mixed = true;
        }
      }
      const Orientation want =
          mixed || (pos && neg) ? Orientation::Mixed : (pos ? Orientation::Positive : Orientation::Negative);
      const Orientation got = fan.orientation(x.data(), n, toward);
      EXPECT_EQ(got, want) << "trial " << trial;
      ++counts[int(want)];
    }
  }
  EXPECT_GT(counts[int(Orientation::Positive)], 500);
  EXPECT_GT(counts[int(Orientation::Negative)], 500);
  EXPECT_GT(counts[int(Orientation::Mixed)], 500);
}

TEST(PluckerGeometry, EdgeFanAgreesWithTheVvsetOrientation) {
  // EdgeFan (lines.h) evaluates side(x -> p_k, a -> b) as (x - a) . ((p_k - a) x (b - a)):
  // checked against the determinant in double, and its decided orientations against
  // vvset_orientation's (both conservative, so a decided pair never disagrees).
  Rng rng(21);
  Vec3f light[4] = {Vec3f(-1, -1, 2), Vec3f(-1, 1, 2), Vec3f(1, 1, 2), Vec3f(1, -1, 2)};
  int both = 0;
  for (int trial = 0; trial < 500; ++trial) {
    Vec3f o[3];
    for (auto& v : o) v = Vec3f(Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.5, 1.5)));
    Vec3f a(Vec3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(0, 2)));
    Vec3f b(Vec3d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(0, 2)));
    // Every point converted once (GCC 12 -O3 may forward a float's unrounded double
    // value to some uses and not others; see the report of this commit series).
    const Vec3d ad = to_double(a), bd = to_double(b);
    EdgeFan fan;
    fan.set(ad, bd, light, 4);
    Vec3d od[3] = {to_double(o[0]), to_double(o[1]), to_double(o[2])};
    for (int i = 0; i < 3; ++i)
      for (int k = 0; k < 4; ++k) {
        double want = orient3d(od[i], to_double(light[k]), ad, bd);
        double got = dot(od[i] - ad, fan.w[size_t(k)]);
        EXPECT_NEAR(got, want, 1e-12 * (1 + std::abs(want)));
      }
    Vec3f dir[12];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 4; ++j) dir[i * 4 + j] = light[j] - o[i];
    Orientation f = fan.orientation(od, 3, true), v = vvset_orientation(o, 3, dir, 4, a, b);
    if (f != Orientation::Mixed && v != Orientation::Mixed) {
      ++both;
      EXPECT_EQ(f, v);
    }
    // Reversed lines (p_k -> x): the opposite orientation.
    Orientation r = fan.orientation(od, 3, false);
    if (f == Orientation::Positive) {
      EXPECT_EQ(r, Orientation::Negative);
    }
    if (f == Orientation::Negative) {
      EXPECT_EQ(r, Orientation::Positive);
    }
  }
  EXPECT_GT(both, 50);
}
