// lib/geom: vectors, AABB, triangle/box overlap, Plücker side operator, predicates.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "lib/geom/aabb.h"
#include "lib/geom/expansion.h"
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

TEST(Predicates, Orient2dExactSignAgainstInt128OnNearCollinearFloats) {
  // Floats in [8, 2^40) are integer multiples of 2^-20, so the orientation in units of
  // 2^-40 is an integer below 2^122: __int128 gives the exact sign independently. The
  // third point is on the line through the first two up to float rounding, then moved
  // by -1..1 ulps; a quarter of the cases are exactly collinear (integers), a quarter
  // mix magnitudes 2^3 and 2^40 (coordinate differences inexact in double).
  Rng rng(7);
  auto pick = [&]() {
    int k = 3 + int(rng.below(37));
    return std::ldexp(float(1.0 + rng.uniform()), k);
  };
  __extension__ typedef __int128 i128;
  auto fix = [](float v) { return i128(std::llround(std::ldexp(double(v), 20))); };
  int zero = 0;
  for (int it = 0; it < 20000; ++it) {
    float ax = pick(), ay = pick(), bx = pick(), by = pick(), cx, cy;
    if (it % 4 == 0) {  // exactly collinear integers: a + 2^10 d, a + m d
      ax = float(8 + rng.below(100)), ay = float(8 + rng.below(100));
      float dx = float(1 + rng.below(50)), dy = float(1 + rng.below(50));
      float m = float(rng.below(4096));
      bx = ax + 1024 * dx, by = ay + 1024 * dy, cx = ax + m * dx, cy = ay + m * dy;
    } else {
      if (it % 4 == 1) ax = std::ldexp(ax, -int(rng.below(30))), ay = std::ldexp(ay, -int(rng.below(30)));
      if (ax < 8) ax = 8 + ax;  // keep the multiples-of-2^-20 range
      if (ay < 8) ay = 8 + ay;
      double t = rng.uniform(-2, 3);
      cx = float(double(ax) + t * (double(bx) - double(ax)));
      cy = float(double(ay) + t * (double(by) - double(ay)));
    }
    if (!(cx >= 8 && cy >= 8 && cx < 0x1p40f && cy < 0x1p40f)) continue;
    int step = int(rng.below(3)) - 1;
    if (step) cy = std::nextafter(cy, step > 0 ? 0x1p41f : 0.0f);
    i128 det = (fix(bx) - fix(ax)) * (fix(cy) - fix(ay)) - (fix(by) - fix(ay)) * (fix(cx) - fix(ax));
    int expect = det > 0 ? 1 : det < 0 ? -1 : 0;
    ASSERT_EQ(orient2d_exact_sign(ax, ay, bx, by, cx, cy), expect) << it;
    zero += expect == 0;
  }
  EXPECT_GT(zero, 1000);  // the exactly collinear triples came out zero
  // General triples of the same range, and triples moved 1-64 ulps off a line, for the
  // floating-point filter in front of the exact sum (predicates.h): int128's sign.
  for (int it = 0; it < 20000; ++it) {
    float ax = pick(), ay = pick(), bx = pick(), by = pick(), cx = pick(), cy = pick();
    if (it % 2 == 1) {
      double t = rng.uniform(-2, 3);
      cx = float(double(ax) + t * (double(bx) - double(ax)));
      cy = float(double(ay) + t * (double(by) - double(ay)));
      for (int k = int(1 + rng.below(64)); k > 0; --k) cy = std::nextafter(cy, 0x1p41f);
      if (!(cx >= 8 && cy >= 8 && cx < 0x1p40f && cy < 0x1p40f)) continue;
    }
    i128 det = (fix(bx) - fix(ax)) * (fix(cy) - fix(ay)) - (fix(by) - fix(ay)) * (fix(cx) - fix(ax));
    ASSERT_EQ(orient2d_exact_sign(ax, ay, bx, by, cx, cy), det > 0 ? 1 : det < 0 ? -1 : 0) << it;
  }
  // Hand cases: a counter-clockwise, a clockwise and a collinear triple.
  EXPECT_EQ(orient2d_exact_sign(0, 0, 1, 0, 0, 1), 1);
  EXPECT_EQ(orient2d_exact_sign(0, 0, 0, 1, 1, 0), -1);
  EXPECT_EQ(orient2d_exact_sign(1, 1, 2, 2, 3, 3), 0);
}

namespace {

// The value of the lowest set bit of a nonzero finite double.
double lowest_bit(double x) {
  int exp = 0;
  const double m = std::frexp(std::abs(x), &exp);  // m in [0.5, 1)
  auto mant = static_cast<uint64_t>(std::ldexp(m, 53));
  int tz = 0;
  while ((mant & 1u) == 0) {
    mant >>= 1;
    ++tz;
  }
  return std::ldexp(1.0, exp - 53 + tz);
}

// Nonoverlapping, increasing magnitude, no zeros: each component below the lowest set
// bit of the next.
template <class V>
bool well_formed(const V& e) {
  for (size_t i = 0; i < e.size(); ++i) {
    if (e[i] == 0.0 || !std::isfinite(e[i])) return false;
    if (i + 1 < e.size() && !(std::abs(e[i]) < lowest_bit(e[i + 1]))) return false;
  }
  return true;
}

// An expansion of n random doubles over a wide exponent range, with cancellation.
expansion::Small random_expansion(Rng& rng, int n) {
  expansion::Small e;
  for (int i = 0; i < n; ++i) {
    const double x = std::ldexp(rng.uniform(-1, 1), int(rng.below(120)) - 60);
    expansion::grow_vector(e, x);
    if (rng.below(4) == 0) expansion::grow_vector(e, -x * 0.5);  // partial cancellation
  }
  return e;
}

}  // namespace

TEST(Expansion, LinearScaleAndSumAreExactAgainstGrowExpansion) {
  // scale_expansion and sum_expansions (Shewchuk's Scale-Expansion and
  // Fast-Expansion-Sum) against the independent Grow-Expansion: (e + f) - h and e b - h,
  // grown term by term (each product as its exact Two-Product pair), must be exactly
  // zero, and h well formed.
  Rng rng(2026);
  int nonzero = 0, zero = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const expansion::Small e = random_expansion(rng, 1 + int(rng.below(12)));
    expansion::Small f = random_expansion(rng, int(rng.below(12)));
    if (trial % 5 == 0) {  // f = -e: the sum is exactly zero (an empty expansion)
      f = e;
      for (double& x : f) x = -x;
    }
    expansion::Small h(e.size() + f.size());
    h.resize(size_t(expansion::sum_expansions(e.data(), int(e.size()), f.data(), int(f.size()), h.data())));
    ASSERT_TRUE(well_formed(h)) << trial;
    expansion::Small check;
    for (double x : e) expansion::grow_vector(check, x);
    for (double x : f) expansion::grow_vector(check, x);
    for (double x : h) expansion::grow_vector(check, -x);
    EXPECT_TRUE(check.empty()) << trial;
    (h.empty() ? zero : nonzero) += 1;

    const double b = trial % 7 == 0 ? 0.0 : std::ldexp(rng.uniform(-1, 1), int(rng.below(80)) - 40);
    h.resize(2 * e.size());
    h.resize(size_t(expansion::scale_expansion(e.data(), int(e.size()), b, h.data())));
    ASSERT_TRUE(well_formed(h)) << trial;
    check.clear();
    for (double x : e) {
      double hi, lo;
      expansion::two_product(x, b, hi, lo);
      expansion::grow_vector(check, hi);
      expansion::grow_vector(check, lo);
    }
    for (double x : h) expansion::grow_vector(check, -x);
    EXPECT_TRUE(check.empty()) << trial;
    EXPECT_EQ(h.empty(), b == 0.0) << trial;
  }
  EXPECT_GT(zero, 300);
  EXPECT_GT(nonzero, 1000);
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
