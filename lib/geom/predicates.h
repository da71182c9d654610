// Orientation predicates in one family of names (lib/geom/sign.h, geogram-style):
//   orient2d, orient3d                    the plain value in the inputs' number type (no
//                                         error bound: near zero its sign can be wrong,
//                                         which is exactly the failure the oracle measures);
//   orient2d_filtered, orient3d_filtered  the sign of a double evaluation when it exceeds
//                                         a forward error bound, else Sign::Uncertain;
//   orient2d_exact, orient3d_exact        the exact sign (Shewchuk's expansion
//                                         arithmetic, lib/geom/expansion.h), never
//                                         Uncertain.
// orient3d(a, b, c, d) = det[b - a, c - a, d - a]: positive when d lies on the side of the
// plane (a, b, c) that the normal (b - a) x (c - a) points to; orient2d(a, b, c) =
// (b - a) x (c - a): positive for a counter-clockwise turn. The plain forms are templates
// over the number type; the oracle instantiates the same formula with CGAL's exact type.
// Also: the closed point-in-triangle test of the ray verification and the textbook
// float32 segment/triangle test.
#pragma once

#include <algorithm>
#include <cmath>

#include "lib/geom/error_bounds.h"
#include "lib/geom/expansion.h"
#include "lib/geom/sign.h"
#include "lib/geom/vec.h"

namespace visgate {

template <class T>
T orient3d(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c, const Vec3<T>& d) {
  return dot(cross(b - a, c - a), d - a);
}

inline float orient3d_f32(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  return orient3d<float>(a, b, c, d);
}

template <class T>
T orient2d(T ax, T ay, T bx, T by, T cx, T cy) {
  return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
}

// orient2d of float points (ax, ay), ... in double against Shewchuk's bound
// ccwerrboundA = (3 + 16 u) u of |l| + |r| (u = 2^-53; the floats are exact doubles).
inline Sign orient2d_filtered(float ax, float ay, float bx, float by, float cx, float cy) {
  const double l = (double(bx) - double(ax)) * (double(cy) - double(ay));
  const double r = (double(by) - double(ay)) * (double(cx) - double(ax));
  const double det = l - r, bound = (3.0 + 16.0 * kUnitRoundoffD) * kUnitRoundoffD * (std::abs(l) + std::abs(r));
  return sign_with_bound(det, bound);
}

// The exact sign: orient2d_filtered's when certain, else each difference of two floats
// as an exact Two-Sum (hi + lo), each product of two such sums four exact Two-Products
// (by fused multiply-add), the sixteen terms summed exactly (Grow-Expansion) and the sign
// read from the largest component. Float inputs keep everything inside double's range
// (products below 2^260, roundoff terms above 2^-360). Light validation (lib/scene
// prepare_light) uses it to agree with the region oracle's exact frame polygon.
inline Sign orient2d_exact(float ax, float ay, float bx, float by, float cx, float cy) {
  if (const Sign s = orient2d_filtered(ax, ay, bx, by, cx, cy); is_certain(s)) return s;
  using expansion::grow;
  using expansion::two_product;
  using expansion::two_sum;
  double d[4][2];  // bx - ax, cy - ay, by - ay, cx - ax as exact hi + lo
  two_sum(double(bx), -double(ax), d[0][0], d[0][1]);
  two_sum(double(cy), -double(ay), d[1][0], d[1][1]);
  two_sum(double(by), -double(ay), d[2][0], d[2][1]);
  two_sum(double(cx), -double(ax), d[3][0], d[3][1]);
  double e[17];  // sixteen terms: at most sixteen components
  int n = 0;
  for (int t = 0; t < 2; ++t) {
    const double sg = t == 0 ? 1.0 : -1.0;
    const double* u = d[2 * t];
    const double* v = d[2 * t + 1];
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) {
        double x, y;
        two_product(u[i], v[j], x, y);
        grow(e, n, sg * x);
        grow(e, n, sg * y);
      }
  }
  if (n == 0) return Sign::Zero;
  return e[n - 1] > 0.0 ? Sign::Positive : Sign::Negative;
}

// A point as the exact sum of a float vector and a double vector (an input point: lo =
// 0; plucker-bsp's fragment vertex: a light's local origin plus its local coordinates).
struct SumPoint {
  Vec3f hi{};
  Vec3d lo{};
  SumPoint() = default;
  SumPoint(const Vec3f& h) : hi(h) {}  // NOLINT: an input point is its own sum
  SumPoint(const Vec3f& h, const Vec3d& l) : hi(h), lo(l) {}
};

// An exact sign with the value it belongs to, rounded to double (within a few ulps).
struct ExactOrient {
  int sign = 0;
  double value = 0.0;
};

// orient3d of three float points and a sum point in double (d rounded to double from
// hi + lo) against a forward error bound: twice Shewchuk's orient3d errboundA
// (7 + 56 u) u of the permanent, plus the rounding of d moved through |(b - a) x (c - a)|_1.
// Uncertain within the bound.
Sign orient3d_filtered(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& d);

// The exact orientation of sum points: each coordinate difference an exact expansion
// (Two-Sum), each product of three components an exact expansion (Two-Product by fused
// multiply-add), the terms of det[b - a, c - a, d - a] summed exactly (Grow-Expansion).
// Exact for every finite float input (and double parts of local coordinates): products
// of three differences stay below 2^390, nonzero products and their roundoff terms above
// 2^-500. Microseconds: callers use it where a float bound leaves a decision open.
ExactOrient orient3d_exact_value(const SumPoint& a, const SumPoint& b, const SumPoint& c, const SumPoint& d);

// Its sign for float points.
inline Sign orient3d_exact(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  return sign_of_int(orient3d_exact_value(SumPoint(a), SumPoint(b), SumPoint(c), SumPoint(d)).sign);
}

// Closed point-in-triangle test of a point x in the triangle's plane (n its normal).
// The point must lie in the triangle's box (grown by 2^-40 of the largest magnitude,
// far above the rounding of x): for a sliver the edge products of a point on the
// extension of its long edges all round to zero or agree, so the sign test alone accepts
// points far beyond it (corpus cases embree-robust/sliver/6cbacd9b and
// iss/sliver/c979ba88). Then, in the projection that drops n's dominant axis, the
// three edge cross products agree in sign (zeros allowed). Used by the ray verification
// (lib/raycast) and ISS's segment_hits_triangle_d.
inline bool point_in_triangle_closed(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& n,
                                     const Vec3d& x) {
  const Vec3d lo = vmin(a, vmin(b, c)), hi = vmax(a, vmax(b, c));
  const Vec3d mag = vmax(vabs(lo), vmax(vabs(hi), vabs(x)));
  const double slack = 0x1p-40 * std::max(mag.x, std::max(mag.y, mag.z));
  for (int k = 0; k < 3; ++k)
    if (x[k] < lo[k] - slack || x[k] > hi[k] + slack) return false;
  const Vec3d an = vabs(n);
  const int drop = an.x >= an.y && an.x >= an.z ? 0 : (an.y >= an.z ? 1 : 2);
  const int u = (drop + 1) % 3, v = (drop + 2) % 3;
  auto edge = [&](const Vec3d& e0, const Vec3d& e1) {
    const double w = (e1[u] - e0[u]) * (x[v] - e0[v]) - (e1[v] - e0[v]) * (x[u] - e0[u]);
    return (w > 0.0) - (w < 0.0);
  };
  const int e0 = edge(a, b), e1 = edge(b, c), e2 = edge(c, a);
  return (e0 >= 0 && e1 >= 0 && e2 >= 0) || (e0 <= 0 && e1 <= 0 && e2 <= 0);
}

// Textbook Möller-Trumbore ("Fast, Minimum Storage Ray/Triangle Intersection", 1997) in
// float32 for the open segment org + t*dir, 0 < t < 1. No epsilon tricks: a zero
// determinant (segment parallel to the plane) is a miss, the barycentric tests are the
// paper's inclusive ones (u < 0 or u > 1 miss, v < 0 or u + v > 1 miss), and the t test
// excludes both endpoints. Float32 throughout: it can crack between triangles sharing an
// edge and misjudge near-degenerate cases; it is the fragile reference.
inline bool segment_hits_triangle_mt(const Vec3f& org, const Vec3f& dir, const Vec3f& v0,
                                     const Vec3f& v1, const Vec3f& v2) {
  Vec3f e1 = v1 - v0, e2 = v2 - v0;
  Vec3f p = cross(dir, e2);
  float det = dot(e1, p);
  if (det == 0.0f) return false;
  float inv = 1.0f / det;
  Vec3f s = org - v0;
  float u = dot(s, p) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  Vec3f q = cross(s, e1);
  float v = dot(dir, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  float t = dot(e2, q) * inv;
  return t > 0.0f && t < 1.0f;
}

}  // namespace visgate
