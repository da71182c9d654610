// Exact predicates for mesh repair with a double-precision static filter in front of the
// exact ones (lib/repair/repair.h ExactPredicates, implemented with CGAL by
// cgal_predicates.h).
//
// Guarantee: exact. Each filter (`*_filtered`, geogram naming as lib/geom/sign.h)
// evaluates the predicate's polynomial in double and compares it with a proven bound on
// its rounding error (derived at each constant below, in the gamma notation of
// lib/geom/error_bounds.h); it answers only when the sign is certain and returns
// Sign::Uncertain otherwise, in which case the exact predicate decides. An exactly zero
// value is certified only where it is zero by structure (the points share a coordinate
// exactly: coplanar in an axis-aligned plane, as the faces of boxes standing on a floor
// are); every other degenerate case (coplanar, collinear, touching) goes to the exact
// predicate. The bounds hold for round-to-nearest and for directed rounding (unit
// roundoff u' = 2u, u = kUnitRoundoffD = 2^-53, so gamma'(n) = gamma_d(2n)), and for any
// finite double input: where a product could overflow or underflow the filter returns
// Uncertain.
//
// The triangle/triangle and segment/triangle tests below are CGAL's own algorithms
// (Guigue and Devillers, CGAL 5.5 Triangle_3_Triangle_3_do_intersect.h and
// Segment_3_Triangle_3_do_intersect.h) written over the filtered orientation, their
// coplanar sub-cases over a filtered 2D orientation in a coordinate projection of the
// common plane.
#pragma once

#include <algorithm>
#include <cmath>

#include "lib/geom/error_bounds.h"
#include "lib/geom/sign.h"
#include "lib/repair/repair.h"

namespace visgate::mesh {

// Sign of u1 * v1 - u2 * v2 where each factor is a double difference fl(s - t) of two
// doubles. Error bound: the exact value is e = x - y with x = (s1 - t1)(s3 - t3) etc.;
// X = fl(u1 v1) = x (1 + theta_3), |theta_3| <= gamma'(3), likewise Y, and
// F = fl(X - Y) = (X - Y)(1 + delta). So |F - e| <= (u' + gamma'(3) / (1 - gamma'(3)))
// (|X| + |Y|), about 8u (|X| + |Y|); kDet2Err = 16u leaves a factor of almost 2 on top.
// A product that underflows adds an absolute error below 2^-1074; requiring |X| + |Y| >=
// 2^-900 makes that negligible against the slack. An overflow makes X, Y or the bound
// infinite or NaN, and the comparisons below are then false: Uncertain.
constexpr double kDet2Err = 16 * kUnitRoundoffD;
static_assert(kDet2Err >= 1.99 * (2 * kUnitRoundoffD + gamma_d(6) / (1 - gamma_d(6))));
inline Sign det2_filtered(double u1, double v1, double u2, double v2) {
  const double X = u1 * v1, Y = u2 * v2, F = X - Y;
  const double mag = std::fabs(X) + std::fabs(Y);
  if (!(mag >= 0x1p-900)) return Sign::Uncertain;
  return sign_with_bound(F, kDet2Err * mag);
}

// Sign of det[b - a, c - a, d - a] (ExactPredicates::orientation), filtered. Computed as
// n . q with e1 = b - a, e2 = c - a, n = e1 x e2, q = d - a. Error bound: each of the six
// monomials of the exact determinant (e.g. (b-a)_y (c-a)_z (d-a)_x) reaches the result
// through at most 8 roundings (3 differences, the product e1y e2z, the subtraction in
// n_x, the product n_x q_x, two additions), so |D - det| <= gamma'(8) S with S the sum of
// the monomials' absolute values. The permanent P (the same monomials in absolute value,
// summed in double) also carries at most 8 roundings per monomial, so S <= P / (1 -
// gamma'(8)), and |D - det| <= gamma'(8) / (1 - gamma'(8)) P, about 16u P. kOrient3dErr
// = 24u leaves room for the underflow terms: with every difference at most 2^301 in
// magnitude (checked), products stay below 2^903 (no overflow) and an underflowing
// product contributes at most 2^-1075 * 2^302 * 4 < 2^-770 absolutely, below 2^-70 P once
// P >= 2^-700 (checked).
constexpr double kOrient3dErr = 24 * kUnitRoundoffD;
static_assert(kOrient3dErr >= 1.4 * gamma_d(16) / (1 - gamma_d(16)));

// Four points with one coordinate exactly equal lie in an axis-aligned plane: their
// determinant has a zero column, so it is exactly 0.
inline bool axis_coplanar(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  for (int k = 0; k < 3; ++k)
    if (a[k] == b[k] && a[k] == c[k] && a[k] == d[k]) return true;
  return false;
}
inline Sign orient3d_filtered(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  const double e1x = b.x - a.x, e1y = b.y - a.y, e1z = b.z - a.z;
  const double e2x = c.x - a.x, e2y = c.y - a.y, e2z = c.z - a.z;
  const double qx = d.x - a.x, qy = d.y - a.y, qz = d.z - a.z;
  // Differences of finite doubles are never NaN (at worst infinite), so std::max is safe.
  const double m = std::max({std::fabs(e1x), std::fabs(e1y), std::fabs(e1z), std::fabs(e2x), std::fabs(e2y),
                             std::fabs(e2z), std::fabs(qx), std::fabs(qy), std::fabs(qz)});
  if (!(m <= 0x1p301)) return axis_coplanar(a, b, c, d) ? Sign::Zero : Sign::Uncertain;
  const double a1 = e1y * e2z, a2 = e1z * e2y, b1 = e1z * e2x, b2 = e1x * e2z, c1 = e1x * e2y, c2 = e1y * e2x;
  const double D = (a1 - a2) * qx + (b1 - b2) * qy + (c1 - c2) * qz;
  const double P = (std::fabs(a1) + std::fabs(a2)) * std::fabs(qx) + (std::fabs(b1) + std::fabs(b2)) * std::fabs(qy) +
                   (std::fabs(c1) + std::fabs(c2)) * std::fabs(qz);
  if (P >= 0x1p-700) {
    const Sign s = sign_with_bound(D, kOrient3dErr * P);
    if (is_certain(s)) return s;
  }
  return axis_coplanar(a, b, c, d) ? Sign::Zero : Sign::Uncertain;
}

// False when the line through a and b certainly misses the closed box [lo, hi] (so no
// point of the box lies on segment ab); true when it may meet it. For each pair of axes
// (i, j), f(p) = (p_i - a_i) d_j - (p_j - a_j) d_i (d = b - a) vanishes on the line and
// is linear in p: its extreme values over the box are at the corners picked by the signs
// of d (exact: a difference of doubles has the sign of the exact difference). If the
// minimum is certainly positive or the maximum certainly negative (det2_filtered), the line
// misses the box. With lo == hi == p this is a filtered collinearity test of p.
inline bool line_may_meet_box(const Vec3d& a, const Vec3d& b, const Vec3d& lo, const Vec3d& hi) {
  const Vec3d d = b - a;
  for (int i = 0; i < 3; ++i) {
    const int j = (i + 1) % 3;
    // Minimum of f: p_i at the end that minimises (p_i - a_i) d_j, p_j at the end that
    // maximises (p_j - a_j) d_i; the maximum of f takes the other ends.
    const double pi_min = d[j] >= 0 ? lo[i] : hi[i], pj_min = d[i] >= 0 ? hi[j] : lo[j];
    const double pi_max = d[j] >= 0 ? hi[i] : lo[i], pj_max = d[i] >= 0 ? lo[j] : hi[j];
    if (det2_filtered(pi_min - a[i], d[j], pj_min - a[j], d[i]) == Sign::Positive) return false;
    if (det2_filtered(pi_max - a[i], d[j], pj_max - a[j], d[i]) == Sign::Negative) return false;
  }
  return true;
}

// Exact predicates with the filters above in front of `ex`. Thread-safe when `ex` is.
class FilteredPredicates {
 public:
  explicit FilteredPredicates(const ExactPredicates& ex) : ex_(ex) {}
  const ExactPredicates& exact() const { return ex_; }

  int orientation(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) const {
    const Sign s = orient3d_filtered(a, b, c, d);
    return is_certain(s) ? int(s) : ex_.orientation(a, b, c, d);
  }
  // a, b, c on one line: false as soon as one component of (b - a) x (c - a) is
  // certainly non-zero.
  bool collinear(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
    for (int i = 0; i < 3; ++i) {
      const int j = (i + 1) % 3, k = (i + 2) % 3;
      if (is_certain(det2_filtered(b[j] - a[j], c[k] - a[k], b[k] - a[k], c[j] - a[j]))) return false;
    }
    return ex_.collinear(a, b, c);
  }
  // Closed segment [p, q] meets the closed, non-degenerate triangle (a, b, c); p != q.
  bool segment_triangle_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                                  const Vec3d& c) const;
  // Closed non-degenerate triangles (p, q, r) and (a, b, c) meet.
  bool triangles_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& r, const Vec3d& a, const Vec3d& b,
                           const Vec3d& c) const;

  // Coplanar predicates (ExactPredicates::coplanar_side and CGAL's coplanar sub-cases),
  // decided in the projection of the common plane onto the coordinate plane that drops
  // an axis along which the plane's normal is non-zero: that projection is a bijection
  // of the plane, so every 2D orientation there is the in-plane orientation times one
  // fixed sign, which the algorithms below never depend on.
  //
  // For coplanar a, b, p, q with a, b, p not collinear: +1 when q is on p's side of line
  // ab, 0 on the line, -1 on the other side.
  int coplanar_side(const Vec3d& a, const Vec3d& b, const Vec3d& p, const Vec3d& q) const;
  // Axis to drop for the plane of the non-collinear a, b, c.
  int plane_axis(const Vec3d& a, const Vec3d& b, const Vec3d& c) const;
  // Sign of the 2D orientation of p, q, r with axis `ax` dropped: filtered, else exact as
  // the 3D orientation of the points lifted to z = 0 plus (p, 1), whose determinant is
  // that 2D determinant.
  int orient2d(const Vec3d& p, const Vec3d& q, const Vec3d& r, int ax) const {
    const int u = (ax + 1) % 3, w = (ax + 2) % 3;
    const Sign s = det2_filtered(q[u] - p[u], r[w] - p[w], q[w] - p[w], r[u] - p[u]);
    if (is_certain(s)) return int(s);
    // Three points sharing one 2D coordinate exactly are collinear.
    if ((p[u] == q[u] && p[u] == r[u]) || (p[w] == q[w] && p[w] == r[w])) return 0;
    return ex_.orientation(Vec3d(p[u], p[w], 0), Vec3d(q[u], q[w], 0), Vec3d(r[u], r[w], 0), Vec3d(p[u], p[w], 1));
  }
  // CGAL's coplanar triangle/triangle and segment/triangle tests over orient2d.
  bool coplanar_triangles_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& r, const Vec3d& a, const Vec3d& b,
                                    const Vec3d& c) const;
  bool coplanar_segment_triangle_intersect(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b,
                                           const Vec3d& c) const;

 private:
  const ExactPredicates& ex_;
};

}  // namespace visgate::mesh
