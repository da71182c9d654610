// Plücker coordinates of oriented lines and the side operator (paper 002 section 3.1).
//
// The line through p then q has coordinates (u, v) with u = q - p and v = p x q
// (paper 002 section 3.3 writes pi_l = (l0..l5) = (u, v)). The side operator is
//   side(l, r) = l3 r0 + l4 r1 + l5 r2 + l0 r3 + l1 r4 + l2 r5 = u_l . v_r + v_l . u_r,
// zero iff the lines meet or are parallel; its sign gives their relative orientation.
// Written once over the number type: float32 in plucker-bsp (lib/plucker/lines.h),
// double in the tests; the oracles decide with CGAL's predicates and do not use it.
#pragma once

#include "lib/geom/vec.h"

namespace visgate {

template <class T>
struct PluckerT {
  Vec3<T> u{}, v{};
  static PluckerT through(const Vec3<T>& p, const Vec3<T>& q) { return {q - p, cross(p, q)}; }
  PluckerT reversed() const { return {-u, -v}; }
};
using Plucker = PluckerT<float>;
using Pluckerd = PluckerT<double>;

template <class T>
T side(const PluckerT<T>& l, const PluckerT<T>& r) {
  return dot(l.u, r.v) + dot(l.v, r.u);
}

// Identity used throughout: side(line(p,q), line(a,b)) = det[q-p, a-p, b-p].
// Derivation: det = (q-p).((a-p) x (b-p)) = (q-p).(a x b) - (q-p).(a x p) - (q-p).(p x b);
// (q-p).(a x p) = q.(a x p) = a.(p x q) and (q-p).(p x b) = q.(p x b) = -b.(p x q), so
// det = (q-p).(a x b) + (p x q).(b - a) = u_l . v_r + v_l . u_r = side. The determinant
// form is translation invariant and better conditioned, so float predicates use it; the
// Plücker form is kept where hyperplanes are reused across many queries (the BSP).

}  // namespace visgate
