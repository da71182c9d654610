// Exact 3D orientation of float32 points, for the decisions of plucker-bsp that float
// rounding cannot make and that change a whole region rather than a sliver of it: which
// side of a blocker's plane a receiver lies on when it is within rounding of that plane
// (fuzz_plucker 68d82337...: a receiver 6e-9 below a face, every segment to the light
// blocked; float called it "on the face" and skipped the face), and, for such a receiver,
// which light points the face hides (plucker_solver.cpp, exact near-plane path).
//
// Guarantee: exact for every finite float input. Shewchuk's expansion arithmetic
// ("Adaptive precision floating-point arithmetic and fast robust geometric predicates",
// 1997) in double: a point is the exact sum hi + lo of a float and a double vector (lo =
// 0 for an input point; a fragment vertex in a light's local frame is origin + local,
// summed exactly), each coordinate difference is an exact expansion (Two-Sum), each product of
// three components an exact expansion (Two-Product by fused multiply-add), and the terms
// of det[b - a, c - a, d - a] are summed exactly (Grow-Expansion). Float inputs keep every
// intermediate inside double's range: products of three differences of floats are below
// 2^390, and nonzero products and their roundoff terms above 2^-500, far from overflow
// and underflow. No CGAL (DESIGN section 1: lib never includes it). Costs microseconds:
// callers use it only where a float bound leaves a decision open.
#pragma once

#include "lib/geom/vec.h"

namespace visgate::plucker {

// A point as the exact sum of a float vector and a double vector (an input point:
// lo = 0; a fragment vertex: the light's local origin plus its local coordinates).
struct SumPoint {
  Vec3f hi{};
  Vec3d lo{};
  SumPoint() = default;
  SumPoint(const Vec3f& h) : hi(h) {}  // NOLINT: an input point is its own sum
  SumPoint(const Vec3f& h, const Vec3d& l) : hi(h), lo(l) {}
};

struct ExactOrient {
  int sign = 0;        // sign of det[b - a, c - a, d - a]: exact
  double value = 0.0;  // the determinant rounded to double (within a few ulps)
};

// det[b - a, c - a, d - a], positive when d lies on the side of the plane (a, b, c)
// that (b - a) x (c - a) points to (lib/geom/predicates.h orient3d).
ExactOrient orient3d_exact(const SumPoint& a, const SumPoint& b, const SumPoint& c, const SumPoint& d);

// The same, filtered: evaluated first in double (d rounded to double from hi + lo)
// against a forward error bound (twice Shewchuk's orient3d errboundA (7 + 56 u) u of the
// permanent, plus the rounding of d moved through |(b - a) x (c - a)|_1), exact only
// when that leaves the sign open. Same sign as orient3d_exact; the value is then the
// double evaluation (within its bound of the exact one).
ExactOrient orient3d_filtered(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& d);

// The same with the value accurate to 2^-30 relative: the double evaluation only where
// its bound is below 2^-30 of it, else the exact expansion (rounded within a few ulps).
// For callers that interpolate with the value (the exact near-plane path splits
// fragments where it changes sign): a filtered value decides the sign but may be off
// by most of itself (fuzz_plucker 6b11d2a3: a receiver 5.8e22 away at a grazing angle,
// split points moved far enough to leave 0.1% of a light visible that a pouch hides).
ExactOrient orient3d_accurate(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& d);

// Its sign for plain float points.
int orient3d_exact_sign(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d);

// The exact side of x against the plane the region oracle takes as a light's plane
// (oracle/region_oracle.h "Exact frame": the Newell normal N = sum v_i x v_(i+1) of the m
// float vertices, through their exact centroid c): the sign of N . (x - c), computed as
// the sign of N . (m x - sum v_i), exactly (the same expansions; m x is exact for m <
// 2^29). For a light that is not exactly planar this is the side the oracle's fraction
// is defined on; plane tests in float cannot decide it for a receiver within the
// light's rounding bound (a light 5.5e6 long has a bound above 2 at its base, fuzz_plucker
// crash-61c69374...).
int newell_side_exact(const Vec3f* poly, int m, const Vec3f& x);

}  // namespace visgate::plucker
