// Shewchuk's expansion arithmetic in double ("Adaptive precision floating-point arithmetic
// and fast robust geometric predicates", 1997), the pieces the exact predicates share:
// lib/geom/predicates.h orient2d_exact_sign and lib/plucker/exact_orient.cpp. Valid in
// round-to-nearest without overflow or underflow (the callers bound their inputs).
#pragma once

#include <cmath>
#include <vector>

#include <boost/container/small_vector.hpp>

namespace visgate::expansion {

// An expansion whose components live inline up to 16 (a Newell component of a polygon of
// up to 8 vertices, a product of two short expansions), on the heap beyond: the exact
// paths of plucker-bsp form them per plane and per evaluation, and as std::vector they
// were 7% of fuzz_plucker's allocations (ASan's allocator is a quarter of its samples).
using Small = boost::container::small_vector<double, 16>;

// Two-Sum: a + b = x + y exactly, x = fl(a + b) (Knuth).
inline void two_sum(double a, double b, double& x, double& y) {
  x = a + b;
  const double bv = x - a;
  const double av = x - bv;
  y = (a - av) + (b - bv);
}

// Two-Product: a * b = x + y exactly; the fused multiply-add rounds a * b - x once, and
// that value is representable.
inline void two_product(double a, double b, double& x, double& y) {
  x = a * b;
  y = std::fma(a, b, -x);
}

// Grow-Expansion on a fixed array e[0..n) (nonoverlapping, increasing magnitude, no
// zeros) with room for n + 1 components: e += b exactly, zero components dropped.
inline void grow(double* e, int& n, double b) {
  double q = b;
  int out = 0;
  for (int i = 0; i < n; ++i) {
    double x, y;
    two_sum(q, e[i], x, y);
    q = x;
    if (y != 0.0) e[out++] = y;
  }
  n = out;
  if (q != 0.0) e[n++] = q;
}

// The same on a vector (any length; V: std::vector<double> or Small), and the expansion's
// value rounded within a few ulps (components summed from the smallest).
template <class V>
inline void grow_vector(V& e, double b) {
  double q = b;
  size_t out = 0;
  for (size_t i = 0; i < e.size(); ++i) {
    double x, y;
    two_sum(q, e[i], x, y);
    q = x;
    if (y != 0.0) e[out++] = y;
  }
  e.resize(out);
  if (q != 0.0) e.push_back(q);
}

// Component k of a polygon's Newell normal, sum_i (a[k1] b[k2] - a[k2] b[k1]) over its
// edges (a, b), as an exact expansion: for float coordinates each product is exact in
// double and the sum is grown exactly. P: any point type with operator[] over floats;
// V: the expansion's container.
template <class V = std::vector<double>, class P>
V newell_component(const P* poly, size_t m, int k) {
  const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
  V e;
  for (size_t i = 0; i < m; ++i) {
    const P& a = poly[i];
    const P& b = poly[(i + 1) % m];
    grow_vector(e, double(a[k1]) * double(b[k2]));
    grow_vector(e, -double(a[k2]) * double(b[k1]));
  }
  return e;
}

template <class V>
inline double estimate(const V& e) {
  double v = 0.0;
  for (double x : e) v += x;
  return v;
}

}  // namespace visgate::expansion
