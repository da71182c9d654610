// Plücker geometry for the lazy BSP (paper 002 sections 3.1-3.3): oriented lines, the
// side operator in its Plücker and determinant forms, the line/polygon stabbing test by
// consistent orientation (section 3.2), and the orientation of the lines stabbing an
// occluder and the light against a hyperplane from the occluder's vvset (Theorem 1).
//
// Orientation convention used everywhere in lib/plucker: every line is oriented from the
// receiver side towards the light. A line stabs a convex polygon v0..vn-1 whose normal
// (v1 - v0) x (v2 - v0) points towards the light side iff side(line, line(vk, vk+1)) > 0
// for every edge k (section 3.2, Figure 2).
//
// Precision: the float32 forms (side_sign, segment_blocked, vvset_orientation) decide
// every sign with a forward error bound (kDetErr below): a value within the bound is
// Sign::Uncertain (lib/geom/sign.h), never given a sign it may not have. Signs outside
// the bound are exact for the float inputs; callers treat Uncertain conservatively.
// The double forms (EdgeFan, the Vec3d edge_plane_normal_err) are the same with
// double's unit roundoff, for the solver's double local coordinates.
#pragma once

#include <cstdint>
#include <type_traits>
#include <vector>

#include "lib/geom/error_bounds.h"
#include "lib/geom/plucker.h"
#include "lib/geom/sign.h"
#include "lib/geom/vec.h"

namespace visgate::plucker {

// Error bound of det[d, a, b] = d . (a x b) where d, a, b are float differences of float
// inputs (e.g. d = x - p, a = a' - p, b = b' - p, or b = b' - a', edge_plane_normal): 3 roundings in the differences, 2 in each cross
// component (product, difference), 1 in the product with d, 2 in the sum of three terms:
// 8 roundings, (1 + u)^8 - 1 < 8.01 u, relative to the permanent sum |d_i a_j b_k| over
// the six terms, which is at most |d|_1 |a|_1 |b|_1. The bound itself is evaluated in
// float with at most 9 more roundings of non-negative terms (factor >= 1 - 9.1u), so
// 12 u |d|_1 |a|_1 |b|_1 (Shewchuk's orient3d errboundA is (7 + 56u) u) is safe.
constexpr float kDetErr = 12.0f * kUnitRoundoffF;
// Error bound of one component of a x b (a, b float differences): 2 difference
// roundings per factor pair, 1 product, 1 subtraction: < 4.01 u of |a|_1 |b|_1; doubled.
constexpr float kCrossErr = 8.0f * kUnitRoundoffF;

inline float norm1(const Vec3f& v) { return std::abs(v.x) + std::abs(v.y) + std::abs(v.z); }
inline double norm1(const Vec3d& v) { return std::abs(v.x) + std::abs(v.y) + std::abs(v.z); }

// The normal of the plane through p and the line a -> b, (a - p) x (b - p), computed as
// the cross product of the two shortest of a - p, b - p and b - a (in exact arithmetic
// (a - p) x (b - p) = (a - p) x (b - a) = (b - p) x (b - a)); `scale` receives the
// product of their 1-norms, the scale of its rounding error (kCrossErr per component;
// with a third float difference d, kDetErr |d|_1 scale for d . N). For a short edge far
// from p this is |a - p| |b - a| instead of |a - p| |b - p|: the plane is then known
// to the precision of the geometry, not to u |a - p| / |b - a| (a short edge far from a
// receiver is undecided in the textbook form).
inline Vec3f edge_plane_normal(const Vec3f& p, const Vec3f& a, const Vec3f& b, float& scale) {
  Vec3f pa = a - p, pb = b - p, ab = b - a;
  float na = norm1(pa), nb = norm1(pb), nab = norm1(ab);
  if (nab >= na && nab >= nb) {
    scale = na * nb;
    return cross(pa, pb);
  }
  if (nb >= na) {
    scale = na * nab;
    return cross(pa, ab);
  }
  scale = nb * nab;
  return cross(pb, ab);
}

// The same normal with a per-component error bound: err_i = kCrossErr times the
// permanent of component i of u x v (|u_y v_z| + |u_z v_y| for x, ...), for the two
// vectors u, v actually crossed. |u|_1 |v|_1 bounds every permanent, but for two long,
// nearly parallel vectors (an edge far from p and nearly in line with it) it is
// dominated by the product of their long components, which no cross component holds, and
// would call r "on the line" where the permanents decide.
// Float (kCrossErr) or double (the same 8 u in double: u_d for u; points in the solver's
// double local coordinates).
template <class T>
inline Vec3<T> edge_plane_normal_err(const Vec3<T>& p, const Vec3<T>& a, const Vec3<T>& b, Vec3<T>& err) {
  static_assert(std::is_same_v<T, float> || std::is_same_v<T, double>);
  constexpr T kErr = std::is_same_v<T, float> ? T(kCrossErr) : T(8.0 * kUnitRoundoffD);
  Vec3<T> pa = a - p, pb = b - p, ab = b - a;
  T na = norm1(pa), nb = norm1(pb), nab = norm1(ab);
  const Vec3<T>* u = &pa;
  const Vec3<T>* v = &pb;
  if (!(nab >= na && nab >= nb)) {
    if (nb >= na) v = &ab;
    else u = &pb, v = &ab;
  }
  err = Vec3<T>(std::abs(u->y * v->z) + std::abs(u->z * v->y), std::abs(u->z * v->x) + std::abs(u->x * v->z),
                std::abs(u->x * v->y) + std::abs(u->y * v->x)) *
        kErr;
  return cross(*u, *v);
}
inline double dot_err(const Vec3d& d, const Vec3d& nrm, const Vec3d& err) {
  constexpr double k = 8.0 * kUnitRoundoffD;
  return std::abs(d.x) * (err.x + k * std::abs(nrm.x)) + std::abs(d.y) * (err.y + k * std::abs(nrm.y)) +
         std::abs(d.z) * (err.z + k * std::abs(nrm.z));
}
inline bool on_line(const Vec3d& nrm, const Vec3d& err) {
  return std::abs(nrm.x) <= err.x && std::abs(nrm.y) <= err.y && std::abs(nrm.z) <= err.z;
}

// The error bound of d . N for d a float difference and N from edge_plane_normal_err:
// N's component errors times |d_i|, plus the rounding of d and of the dot product
// (5 roundings of sum |d_i N_i|, counted as 8 u).
inline float dot_err(const Vec3f& d, const Vec3f& nrm, const Vec3f& err) {
  return std::abs(d.x) * (err.x + 8.0f * kUnitRoundoffF * std::abs(nrm.x)) +
         std::abs(d.y) * (err.y + 8.0f * kUnitRoundoffF * std::abs(nrm.y)) +
         std::abs(d.z) * (err.z + 8.0f * kUnitRoundoffF * std::abs(nrm.z));
}

// r on the line a -> b within rounding: every component of the computed normal within
// its error bound.
inline bool on_line(const Vec3f& nrm, const Vec3f& err) {
  return std::abs(nrm.x) <= err.x && std::abs(nrm.y) <= err.y && std::abs(nrm.z) <= err.z;
}

// The base point for evaluating det[x - p, a - p, b - p] = (x - base) . N with
// N = edge_plane_normal(p, a, b): any of p, a, b gives the same determinant (N is
// orthogonal to a - p, b - p and b - a), and the computed plane is held to the rounding
// of N's direction times |x - base|, so the one nearest to x (1-norm, x a representative
// point of those evaluated) is used: for a receiver p far from the light, (x - p) . N
// cancels, and for an occluder vertex a far from the light, (x - a) . N does.
template <class T, class U>
inline const Vec3<T>& nearest_base(const Vec3<T>& p, const Vec3<T>& a, const Vec3<T>& b, const Vec3<U>& xu) {
  Vec3<T> x(xu);
  auto n1 = [](const Vec3<T>& v) { return std::abs(v.x) + std::abs(v.y) + std::abs(v.z); };
  T dp = n1(x - p), da = n1(x - a), db = n1(x - b);
  if (dp <= da && dp <= db) return p;
  return da <= db ? a : b;
}

// side(line(p, x), line(a, b)) = det[x - p, a - p, b - p] (lib/geom/plucker.h), with its
// sign decided against kDetErr (Uncertain within it). Translation invariant, so far-from-origin inputs keep
// their relative precision. Evaluated as (x - base) . N with N = edge_plane_normal_err(p,
// a, b) and the base of nearest_base, so a point far from the other three costs no
// precision (fragment.cpp, kDotErr), decided against dot_err.
inline Sign side_sign(const Vec3f& p, const Vec3f& x, const Vec3f& a, const Vec3f& b) {
  Vec3f d = x - nearest_base(p, a, b, x);
  Vec3f err;
  Vec3f nrm = edge_plane_normal_err(p, a, b, err);
  float s = dot(d, nrm);
  float bound = dot_err(d, nrm, err);
  return sign_with_bound(s, bound);
}

// Section 3.2: the line stabs the convex polygon (its interior, properly) iff its
// orientation against every edge line is the same strict sign. Plücker form with
// precomputed edge coordinates; float, no error bound (used for checks and tests; the
// BSP uses side_sign).
bool line_stabs_polygon(const Plucker& line, const Vec3f* poly, int n);

// Theorem 1 (section 3.3). The vvset of an occluder O (vertices o_i, i < n) and the light
// L (vertices l_j, j < m) is the set of lines o_i -> l_j; it is stored as the directions
// dir[i * m + j] = l_j - o_i. The orientation of all lines stabbing O and L against the
// line a -> b is Positive if every vvset line is strictly positive, Negative if every one
// is strictly negative, Mixed otherwise (including any value within the error bound):
// conservative, never Positive or Negative for a set that has a line of the other sign.
enum class Orientation : uint8_t { Positive, Negative, Mixed };

// Theorem 1 against one fixed line a -> b, its part computed once (bsp.cpp develop: every
// occluder of a leaf is tested against the same few edge lines of the merged occluder).
// For fixed points p_k (the light's vertices, or the corners of a receiver region) let
// W_k = (p_k - a) x (b - a). With every point taken relative to a (x' = x - a, ...),
//   side(x -> p_k, a -> b) = det[p_k - x, a - x, b - x] = det[p'_k - x', -x', b' - x']
//                          = -det[p'_k, x', b'] = x' . (p'_k x b') = (x - a) . W_k,
// and side(p_k -> x, a -> b) = -(x - a) . W_k. The value has the form d . (u x v) of
// kDetErr with d = x - a, u = p_k - a, v = b - a: its sign is decided against
// kDetErr |x - a|_1 |p_k - a|_1 |b - a|_1, as vvset_orientation decides its own.
// Evaluated in double on double points (the solver's local coordinates, bsp.h), with the
// bound kDetErr scaled to double's unit roundoff.
struct EdgeFan {
  Vec3d a{};
  std::vector<Vec3d> w;       // W_k
  std::vector<double> scale;  // 12 u_d |p_k - a|_1 |b - a|_1
  // The same W_k and scale_k as separate coordinate arrays, padded to an even count by
  // repeating the last entry (it decides as the entry it repeats): orientation takes two
  // entries at a time with SSE2.
  std::vector<double> wx, wy, wz, ws;
  void set(const Vec3d& a, const Vec3d& b, const Vec3d* p, int m);
  // The light's vertices as points.
  void set(const Vec3d& a, const Vec3d& b, const Vec3f* p, int m);
  // The orientation of the lines x_i -> p_k (toward = true) or p_k -> x_i (toward =
  // false), i < n, against a -> b: Positive / Negative when every value is strictly of
  // that sign beyond its bound, else Mixed (conservative, like vvset_orientation).
  Orientation orientation(const Vec3d* x, int n, bool toward) const;
};

// DESIGN section 3 for one triangle: the open segment r -> s crosses the triangle
// (a, b, c) properly, i.e. r and s are strictly on opposite sides of its plane and the
// line r -> s has the same strict sign against its three edge lines (section 3.2).
// Every sign is decided against kDetErr; an undecided sign (within rounding of a touch
// or of a zero-area triangle) counts as "not blocked". Float: wrong only for relations
// within the determinant's rounding of a degenerate configuration.
bool segment_blocked(const Vec3f& r, const Vec3f& s, const Vec3f& a, const Vec3f& b, const Vec3f& c);

Orientation vvset_orientation(const Vec3f* occ, int n, const Vec3f* dir, int m, const Vec3f& a, const Vec3f& b);

}  // namespace visgate::plucker
