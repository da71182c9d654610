// The exact light plane of the region oracle, for the decisions of plucker-bsp that float
// rounding cannot make and that change a whole region rather than a sliver of it: which
// light points a triangle hides from a receiver within rounding of its plane (the exact
// near-plane path, subtract.h), which side of the light's plane a point lies on, and
// which axis the oracle drops for the light's frame. The exact orientation of float
// points itself is lib/geom/predicates.h orient3d_exact.
//
// Guarantee: exact for every finite float input, by Shewchuk's expansion arithmetic
// (lib/geom/expansion.h) in double. No CGAL (DESIGN section 1: lib never includes it).
// Costs microseconds: callers use it only where a float bound leaves a decision open.
#pragma once

#include <vector>

#include "lib/geom/expansion.h"
#include "lib/geom/predicates.h"
#include "lib/geom/vec.h"
#include "lib/plucker/lines.h"

namespace visgate::plucker {

// One plane's affine function over the lifted light (LiftedLight::plane). The
// coefficients in double with forward error bounds answer most evaluations; the exact
// expansions are formed on the first evaluation those bounds leave open (an edge-on
// receiver: B and C cancel).
struct LiftedPlane {
  double a = 0, b = 0, c = 0, ea = 0, eb = 0, ec = 0;  // A, B, C rounded, and bounds
  Vec3f p{}, q1{}, q2{};
  bool exact_ready = false;
  expansion::Small xa, xb, xc;  // exact A, B, C (once exact_ready)
  // Their two largest components and a bound on the sum of the others (value()'s
  // second stage), set with them.
  double top[3][2] = {{0, 0}, {0, 0}, {0, 0}}, rest[3] = {0, 0, 0};
};

// The light's exact plane, parametrised by two coordinate axes: the region oracle's light
// (oracle/region_oracle.h "Exact frame") is the polygon of its float vertices' (u, v)
// coordinates lifted along the third axis w onto the plane of the Newell normal
// N = sum P_i x P_(i+1) through the exact centroid S / m (S = sum P_i). A point of it is
// X(u, v) = (u, v, w(u, v)) with m N_w w = N . S - m N_u u - m N_v v.
//
// For a plane through a float point p with normal c = (q1 - p) x (q2 - p) (q1, q2
// float), orient3d(p, q1, q2, X) = c . (X - p) is affine in (u, v); times m N_w it is
//   g(u, v) = B u + C v + A,  B = m (N_w c_u - N_u c_w),  C = m (N_w c_v - N_v c_w),
//   A = c_w (N . S) - m N_w (c . p),
// with A, B, C exact expansions of float products (degree 4 and 5). LiftedLight::value
// evaluates sign(N_w) g exactly (the sign of orient3d(p, q1, q2, X) for the exact lifted
// point X of (u, v)) and rounds it within a few ulps.
//
// Why: a fragment vertex kept as a 3D double point lies up to its rounding (1e-17 of its
// coordinates) off the light's plane; seen from a receiver within that distance of the
// plane (an edge-on light), that offset decides which side of a plane through the
// receiver and a triangle edge the vertex is on (test
// ReceiverWithinRoundingOfATiltedLightsPlaneUsesTheExactLift). On (u, v) and the exact
// lift the answer is the region oracle's.
//
// Range: with float inputs every term stays within double's range (below 2^660; the
// float products and their roundoffs above 2^-960). The double parts lu, lv of a
// fragment vertex are local coordinates; a product B lu whose roundoff falls below
// 2^-1074 loses it (lu below about 2^-250 of B's scale), an error far below any area.
class LiftedLight {
 public:
  LiftedLight() = default;
  // poly: the light's m float vertices; u, v: the parameter axes (w = 3 - u - v must
  // have N_w != 0, true for the axis of the largest normal component).
  LiftedLight(const Vec3f* poly, int m, int u, int v);
  int u() const { return u_; }
  int v() const { return v_; }
  bool valid() const { return m_ > 0; }

  // The affine function of the plane through p with normal (q1 - p) x (q2 - p).
  LiftedPlane plane(const Vec3f& p, const Vec3f& q1, const Vec3f& q2) const;
  // sign(N_w) g at u = hu + lu, v = hv + lv: exact sign, value within 2^-30 (the double
  // evaluation where its bound allows that, then a compensated sum of the exact
  // coefficients' two leading components with its error bound, else the exact
  // expansion rounded).
  ExactOrient value(LiftedPlane& pl, float hu, double lu, float hv, double lv) const;
  // The same exact sign, with a value that is only the double evaluation's (not within
  // 2^-30) when its error bound decides the sign, else value()'s: for decisions that
  // read the sign alone (most evaluations that need more than the double stage for
  // 2^-30 have a certain sign in double).
  ExactOrient sign(LiftedPlane& pl, float hu, double lu, float hv, double lv) const;

 private:
  void make_exact(LiftedPlane& pl) const;
  // The double evaluation of g and its forward error bound.
  static double double_value(const LiftedPlane& pl, float hu, double lu, float hv, double lv, double& err);
  expansion::Small n_[3];       // Newell normal N, exact
  expansion::Small ns_exact_;   // N . S (S the vertex sum), exact: every plane's A uses it
  double nd_[3] = {0, 0, 0}, ns_ = 0;  // N and N . S rounded (within a few ulps)
  int m_ = 0, u_ = 0, v_ = 1, w_ = 2, nw_sign_ = 1;
};

// The exact side of x against the plane the region oracle takes as a light's plane
// (oracle/region_oracle.h "Exact frame": the Newell normal N = sum v_i x v_(i+1) of the m
// float vertices, through their exact centroid c): the sign of N . (x - c), computed as
// the sign of N . (m x - sum v_i), exactly (the same expansions; m x is exact for m <
// 2^29). For a light that is not exactly planar this is the side the oracle's fraction
// is defined on; plane tests in float cannot decide it for a receiver within the
// light's rounding bound, which grows with the light's length (test
// ReceiverBelowALongLightUndecidedInFloat).
int newell_side_exact(const Vec3f* poly, int m, const Vec3f& x);

// The axis the region oracle drops for a light's frame (oracle/region_oracle.h "Exact
// frame"): k with the largest |N_k| of the exact Newell normal of the m float vertices,
// the lowest such k on a tie (k = 0, then j = 1, 2 replaces it when |N_j| > |N_k|). For
// a light that is not exactly planar the lifted polygon depends on it; the rounded
// normal cannot tell components that differ by less than its rounding (test
// NonPlanarLightIsLiftedAlongTheOraclesAxis).
int newell_dominant_axis(const Vec3f* poly, int m);

// The side of p against the plane of the float triangle a, b, c (the sign of
// orient3d(a, b, c, p)) in double, from ad = a, the normal n = (b - a) x (c - a) and
// s12 = |b - a|_1 |c - a|_1 (shared over many points): the differences are exact or
// rounded once, n's components carry at most 2 u_d s12, and (p - a) . n, with p - a =
// (hi - a) + lo rounded by u_d of |hi - a|_1 + |lo|_1 =: D, errs by less than 16 u_d D
// s12; a value beyond 2^-40 of D s12 (2^9 times the error) has the exact sign. 0: open
// (also when that bound is so small that underflow may have taken digits).
inline int plane_side_filtered(const Vec3d& ad, const Vec3d& n, double s12, const SumPoint& p) {
  const Vec3d h = to_double(p.hi) - ad;
  const double v = dot(h + p.lo, n), bound = 0x1p-40 * (norm1(h) + norm1(p.lo)) * s12;
  if (!(bound > 0x1p-900)) return 0;
  return v > bound ? 1 : (v < -bound ? -1 : 0);
}

// The same side where plane_side_filtered left it open: orient3d_filtered, then exact.
inline int plane_side_rest(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& p) {
  Sign sg = orient3d_filtered(a, b, c, p);
  if (sg == Sign::Uncertain) sg = sign_of_int(orient3d_exact_value(SumPoint(a), SumPoint(b), SumPoint(c), p).sign);
  return sg == Sign::Positive ? 1 : (sg == Sign::Negative ? -1 : 0);
}

}  // namespace visgate::plucker
