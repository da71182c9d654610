// Exact sign of the 3D orientation of four float32 points, for the few decisions of
// plucker-bsp that a float error bound leaves open and that change a whole region
// rather than a sliver of it: which side of a blocker's plane a receiver lies on when it
// is within rounding of that plane (fuzz_plucker 68d82337...: a receiver 6e-9 below a
// face, every segment to the light blocked; the float test called it "on the face" and
// skipped the face, fraction 1 instead of 0).
//
// Guarantee: exact for every finite float input. Shewchuk's expansion arithmetic ("Adaptive
// precision floating-point arithmetic and fast robust geometric predicates", 1997) in
// double: each difference is an exact two-term expansion (Two-Diff), each product of
// three such components an exact four-term expansion (Two-Product twice), and the 192
// terms of det[b - a, c - a, d - a] are summed exactly (Grow-Expansion). Float inputs keep
// every intermediate inside double's range: |products| <= 2^387 and nonzero
// products and their roundoff terms >= 2^-500, far from overflow and underflow.
// No CGAL (DESIGN section 1: lib never includes it); costs microseconds, so callers
// use it only where the float bound is undecided.
#pragma once

#include "lib/geom/vec.h"

namespace visgate::plucker {

// Sign of det[b - a, c - a, d - a] (+1, 0, -1): positive when d lies on the side of the
// plane (a, b, c) that (b - a) x (c - a) points to (lib/geom/predicates.h orient3d).
int orient3d_exact_sign(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d);

}  // namespace visgate::plucker
