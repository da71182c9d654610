// Orientation predicates and the textbook float32 segment/triangle test.
//
// orient3d(a, b, c, d) = det[b - a, c - a, d - a]: positive when d lies on the side of
// the plane (a, b, c) that the normal (b - a) x (c - a) points to. Written once as a
// template; `orient3d_f32` is the plain float evaluation (no error bound: it can return
// the wrong sign near zero, which is exactly the failure the oracle measures), the
// oracle instantiates the same formula with CGAL's exact number type.
#pragma once

#include <algorithm>
#include <cmath>

#include "lib/geom/expansion.h"
#include "lib/geom/vec.h"

namespace visgate {

template <class T>
T orient3d(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c, const Vec3<T>& d) {
  return dot(cross(b - a, c - a), d - a);
}

inline float orient3d_f32(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  return orient3d<float>(a, b, c, d);
}

// The exact sign of the 2D orientation (b - a) x (c - a) of float points given by their
// two coordinates (ax, ay), ...: positive for a counter-clockwise turn. Shewchuk's
// expansion arithmetic in double: each difference of two floats is an exact Two-Sum
// (hi + lo), each product of two such sums four exact Two-Products (by fused multiply-
// add), the sixteen terms summed exactly (Grow-Expansion) and the sign read from the
// largest component. Float inputs keep everything inside double's range (products below
// 2^260, roundoff terms above 2^-360). For light validation (lib/scene prepare_light),
// which must agree with the region oracle's exact frame polygon.
inline int orient2d_exact_sign(float ax, float ay, float bx, float by, float cx, float cy) {
  // Shewchuk's filter (orient2d's ccwerrboundA = (3 + 16 u) u, u = 2^-53, for double
  // inputs, which the floats are): the double evaluation's sign when its magnitude
  // exceeds the bound, else the exact sum below.
  {
    const double l = (double(bx) - double(ax)) * (double(cy) - double(ay));
    const double r = (double(by) - double(ay)) * (double(cx) - double(ax));
    const double det = l - r, bound = (3.0 + 16.0 * 0x1p-53) * 0x1p-53 * (std::abs(l) + std::abs(r));
    if (det > bound) return 1;
    if (-det > bound) return -1;
  }
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
  if (n == 0) return 0;
  return e[n - 1] > 0.0 ? 1 : -1;
}

// Closed point-in-triangle test of a point x in the triangle's plane (n its normal).
// The point must lie in the triangle's box (grown by 2^-40 of the largest magnitude,
// far above the rounding of x): without this a sliver fails the sign test below, for a
// triangle of area 4e-25 the edge products of a point on the extension of its long
// edges all round to zero or agree, and a point 0.7 beyond the sliver passed as inside
// (fuzz_embree campaign, corpus/embree-robust/sliver/6cbacd9b: a robust-mode false hit
// that this test then confirmed; fuzz_iss 79223f0b, corpus/iss/sliver/c979ba88: the same
// for ISS's custom caster). Then, in the projection that drops n's dominant axis, the
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
