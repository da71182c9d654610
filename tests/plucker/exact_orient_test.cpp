// Tests of lib/plucker/exact_orient.cpp: the Newell side and the
// lifted light plane, against GMP rationals.
#include <gtest/gtest.h>

#include <gmp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

namespace {

// m |N_w| c . (X(u, v) - p) in GMP rationals, X the exact lifted light point
// (exact_orient.h LiftedLight), for the test below.
double lifted_gmp(const std::vector<Vec3f>& poly, int u, int v, const Vec3f& p, const Vec3f& q1, const Vec3f& q2,
                  double uu, double vv, int* sign) {
  const int w = 3 - u - v, m = int(poly.size());
  mpq_t N[3], S[3], c[3], d1[3], d2[3], t, t2, X[3], f;
  for (int k = 0; k < 3; ++k) mpq_inits(N[k], S[k], c[k], d1[k], d2[k], X[k], nullptr);
  mpq_inits(t, t2, f, nullptr);
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    for (int i = 0; i < m; ++i) {
      const Vec3f &a = poly[size_t(i)], &b = poly[size_t((i + 1) % m)];
      mpq_set_d(t, double(a[k1]));
      mpq_set_d(t2, double(b[k2]));
      mpq_mul(t, t, t2);
      mpq_add(N[k], N[k], t);
      mpq_set_d(t, double(a[k2]));
      mpq_set_d(t2, double(b[k1]));
      mpq_mul(t, t, t2);
      mpq_sub(N[k], N[k], t);
      mpq_set_d(t, double(a[k]));
      mpq_add(S[k], S[k], t);
    }
    mpq_set_d(d1[k], double(q1[k]));
    mpq_set_d(t, double(p[k]));
    mpq_sub(d1[k], d1[k], t);
    mpq_set_d(d2[k], double(q2[k]));
    mpq_sub(d2[k], d2[k], t);
  }
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    mpq_mul(t, d1[k1], d2[k2]);
    mpq_mul(t2, d1[k2], d2[k1]);
    mpq_sub(c[k], t, t2);
  }
  // X = (u, v, w): m N_w w = N . S - m N_u u - m N_v v.
  mpq_set_d(X[u], uu);
  mpq_set_d(X[v], vv);
  mpq_set_ui(f, 0, 1);
  for (int k = 0; k < 3; ++k) {
    mpq_mul(t, N[k], S[k]);
    mpq_add(f, f, t);
  }
  mpq_set_si(t2, m, 1);
  mpq_mul(t, N[u], X[u]);
  mpq_mul(t, t, t2);
  mpq_sub(f, f, t);
  mpq_mul(t, N[v], X[v]);
  mpq_mul(t, t, t2);
  mpq_sub(f, f, t);
  mpq_mul(t, N[w], t2);
  mpq_div(X[w], f, t);
  // m |N_w| c . (X - p)
  mpq_set_ui(f, 0, 1);
  for (int k = 0; k < 3; ++k) {
    mpq_set_d(t, double(p[k]));
    mpq_sub(t, X[k], t);
    mpq_mul(t, t, c[k]);
    mpq_add(f, f, t);
  }
  mpq_abs(t, N[w]);
  mpq_mul(f, f, t);
  mpq_set_si(t2, m, 1);
  mpq_mul(f, f, t2);
  *sign = mpq_sgn(f);
  const double value = mpq_get_d(f);
  for (int k = 0; k < 3; ++k) mpq_clears(N[k], S[k], c[k], d1[k], d2[k], X[k], nullptr);
  mpq_clears(t, t2, f, nullptr);
  return value;
}

}  // namespace


TEST(PluckerGeometry, NewellSideAgreesWithRationalArithmetic) {
  // newell_side_exact: the sign of N . (m x - sum v_i), N the Newell normal, against GMP
  // rationals, for non-planar quads (one vertex off by a few ulps or by 2^-72) and
  // points at, near and far from their plane.
  Rng rng(11);
  auto rational_side = [](const std::vector<Vec3f>& P, const Vec3f& x) {
    mpq_t n[3], d[3], t, acc;
    for (int k = 0; k < 3; ++k) mpq_init(n[k]), mpq_init(d[k]);
    mpq_init(t);
    mpq_init(acc);
    auto q = [&](mpq_t out, float f) { mpq_set_d(out, double(f)); };
    const size_t m = P.size();
    mpq_t a, b;
    mpq_init(a);
    mpq_init(b);
    for (int k = 0; k < 3; ++k) {
      const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
      for (size_t i = 0; i < m; ++i) {
        q(a, P[i][k1]), q(b, P[(i + 1) % m][k2]), mpq_mul(t, a, b), mpq_add(n[k], n[k], t);
        q(a, P[i][k2]), q(b, P[(i + 1) % m][k1]), mpq_mul(t, a, b), mpq_sub(n[k], n[k], t);
        q(a, P[i][k]), mpq_sub(d[k], d[k], a);
      }
      q(a, x[k]);
      mpq_set_ui(b, unsigned(m), 1);
      mpq_mul(t, a, b);
      mpq_add(d[k], d[k], t);
      mpq_mul(t, n[k], d[k]);
      mpq_add(acc, acc, t);
    }
    int s = mpq_sgn(acc);
    for (int k = 0; k < 3; ++k) mpq_clear(n[k]), mpq_clear(d[k]);
    mpq_clear(t), mpq_clear(acc), mpq_clear(a), mpq_clear(b);
    return s;
  };
  int zero = 0, nonzero = 0;
  for (int it = 0; it < 400; ++it) {
    std::vector<Vec3f> P = {Vec3f(-0.5f, -0.5f, 2), Vec3f(-0.5f, 0.5f, 2), Vec3f(5.5e6f, 0.5f, 2), Vec3f(0.5f, -0.5f, 2)};
    if (it % 2) P[1].z = std::nextafter(2.0f, 0.0f);
    if (it % 3 == 0) P[3].z = 0x1p-72f;
    if (it % 5 == 0) P = {Vec3f(0, 0, 1), Vec3f(1, 0, 1), Vec3f(1, 1, 1), Vec3f(0, 1, 1)};
    Vec3f x(float(rng.uniform() * 4 - 2), float(rng.uniform() * 4 - 2), float(rng.uniform() * 4 - 1));
    if (it % 4 == 0) x.z = P[0].z;
    if (it % 7 == 0) x.z = std::nextafter(x.z, 10.0f);
    int want = rational_side(P, x);
    EXPECT_EQ(newell_side_exact(P.data(), int(P.size()), x), want) << it;
    (want == 0 ? zero : nonzero)++;
  }
  EXPECT_GT(zero, 0);
  EXPECT_GT(nonzero, 0);
}

TEST(PluckerGeometry, LiftedLightPlaneValuesAgreeWithRationalArithmetic) {
  // LiftedLight::value against GMP rationals: tilted quads (planar, and with one vertex a
  // few ulps off), planes through points near the light's plane and through its edges,
  // at (u, v) points of the light given as float + double sums: the same sign and the
  // value within 2^-29, by the double filter or the exact expansions (both are used).
  Rng rng(77);
  int near_zero = 0, compared = 0, exact_used = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const double scale = std::ldexp(1.0, int(rng.below(41)) - 20);
    const double sx = rng.uniform(-2, 2), sy = rng.uniform(-2, 2);
    auto on_plane = [&](double x, double y) { return Vec3f(Vec3d(x, y, 1.0 + sx * x + sy * y) * scale); };
    std::vector<Vec3f> poly = {on_plane(-1, -1), on_plane(1, -1), on_plane(1, 1), on_plane(-1, 1)};
    if (trial % 2) poly[2].z = std::nextafter(std::nextafter(poly[2].z, 1e38f), 1e38f);
    const Vec3d nn = cross(to_double(poly[1]) - to_double(poly[0]), to_double(poly[2]) - to_double(poly[0]));
    const int w = max_axis(vabs(nn)), u = (w + 1) % 3, v = (w + 2) % 3;
    LiftedLight lift(poly.data(), 4, u, v);
    // A receiver-like point within rounding of the plane (or on it), and a triangle edge
    // in the plane or crossing it.
    const Vec3f r = on_plane(rng.uniform(-3, 3), rng.uniform(-3, 3));
    const Vec3f a = trial % 3 ? on_plane(rng.uniform(-1, 1), rng.uniform(-1, 1)) : Vec3f(Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0, 2)) * scale);
    const Vec3f b = on_plane(rng.uniform(-1, 1), rng.uniform(-1, 1));
    LiftedPlane pl = lift.plane(r, a, b);
    for (int k = 0; k < 8; ++k) {
      const Vec3f o = poly[0];
      const double lu = rng.uniform(-2, 2) * scale, lv = rng.uniform(-2, 2) * scale;
      int want = 0;
      const double exact = lifted_gmp(poly, u, v, r, a, b, double(o[u]) + lu, double(o[v]) + lv, &want);
      // The rational's (u, v) is the double sum, the evaluator's the exact one: compare
      // at points whose sum is exact in double.
      if (double(o[u]) + lu - double(o[u]) != lu || double(o[v]) + lv - double(o[v]) != lv) continue;
      const ExactOrient got = lift.value(pl, o[u], lu, o[v], lv);
      EXPECT_EQ(got.sign, want) << trial << " " << k;
      EXPECT_LE(std::abs(got.value - exact), 0x1p-29 * std::abs(exact)) << trial << " " << k;
      near_zero += std::abs(exact) < 1e-6 * scale * scale * scale * scale * scale;
      exact_used += pl.exact_ready;
      ++compared;
    }
  }
  EXPECT_GT(compared, 2000);
  EXPECT_GT(near_zero, 0);
  EXPECT_GT(exact_used, 0);
  EXPECT_LT(exact_used, compared);
}
