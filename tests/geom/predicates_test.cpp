// Tests of lib/geom/predicates.h: orientation predicates and the segment/triangle test.
#include <gtest/gtest.h>

#include <gmp.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/scene/rng.h"

using namespace visgate;

namespace {
// det[b - a, c - a, d - a] of float points in exact rationals (GMP), the reference for
// orient3d_exact.
int orient3d_gmp_sign(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d, double* value = nullptr) {
  mpq_t m[3][3], t, u, det;
  mpq_inits(t, u, det, nullptr);
  const Vec3f* q[3] = {&b, &c, &d};
  for (int r = 0; r < 3; ++r)
    for (int k = 0; k < 3; ++k) {
      mpq_init(m[r][k]);
      mpq_set_d(m[r][k], double((*q[r])[k]));
      mpq_set_d(t, double(a[k]));
      mpq_sub(m[r][k], m[r][k], t);
    }
  static const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  for (int p = 0; p < 6; ++p) {
    mpq_mul(t, m[0][perm[p][0]], m[1][perm[p][1]]);
    mpq_mul(u, t, m[2][perm[p][2]]);
    if (p < 3) mpq_add(det, det, u);
    else mpq_sub(det, det, u);
  }
  int sign = mpq_sgn(det);
  if (value) *value = mpq_get_d(det);
  for (auto& row : m)
    for (auto& e : row) mpq_clear(e);
  mpq_clears(t, u, det, nullptr);
  return sign;
}
}  // namespace

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
    ASSERT_EQ(to_int(orient2d_exact(ax, ay, bx, by, cx, cy)), expect) << it;
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
    ASSERT_EQ(to_int(orient2d_exact(ax, ay, bx, by, cx, cy)), det > 0 ? 1 : det < 0 ? -1 : 0) << it;
  }
  // Hand cases: a counter-clockwise, a clockwise and a collinear triple.
  EXPECT_EQ(to_int(orient2d_exact(0, 0, 1, 0, 0, 1)), 1);
  EXPECT_EQ(to_int(orient2d_exact(0, 0, 0, 1, 1, 0)), -1);
  EXPECT_EQ(to_int(orient2d_exact(1, 1, 2, 2, 3, 3)), 0);
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

TEST(Predicates, Orient3dExactAgreesWithRationalArithmetic) {
  // orient3d_exact against the determinant in GMP rationals (and orient3d_filtered, where
  // certain, with the same sign), on
  // near-degenerate float quadruples: a point moved by a few ulps off the plane of three
  // others, at scales from 2^-100 to 2^100, and exactly coplanar grid points.
  Rng rng(31);
  int nonzero = 0, zero = 0, certain = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    double scale = std::ldexp(1.0, int(rng.below(201)) - 100);
    Vec3f p[4];
    for (int k = 0; k < 3; ++k) p[k] = Vec3f(Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * scale);
    double u = rng.uniform(), w = rng.uniform();
    Vec3d on = to_double(p[0]) + (to_double(p[1]) - to_double(p[0])) * u + (to_double(p[2]) - to_double(p[0])) * w;
    p[3] = Vec3f(on);
    int steps = int(rng.below(5));
    for (int s = 0; s < steps; ++s) p[3].z = std::nextafter(p[3].z, rng.below(2) ? 1e38f : -1e38f);
    if (trial % 10 == 0) {  // exactly coplanar: small integers in the plane z = 3
      for (auto& v : p) v = Vec3f(float(rng.below(17)) - 8, float(rng.below(17)) - 8, 3);
    }
    int want = orient3d_gmp_sign(p[0], p[1], p[2], p[3]);
    EXPECT_EQ(orient3d_exact(p[0], p[1], p[2], p[3]), sign_of_int(want)) << trial;
    const Sign filtered = orient3d_filtered(p[0], p[1], p[2], SumPoint(p[3]));
    if (is_certain(filtered)) {
      EXPECT_EQ(filtered, sign_of_int(want)) << trial;
    }
    certain += is_certain(filtered);
    ++(want == 0 ? zero : nonzero);
  }
  EXPECT_GT(zero, 200);
  EXPECT_GT(nonzero, 1000);
  EXPECT_GT(certain, 0);
}
