// Shewchuk's expansion arithmetic in double ("Adaptive precision floating-point arithmetic
// and fast robust geometric predicates", 1997), the pieces the exact predicates share:
// lib/geom/predicates.h orient2d_exact_sign and lib/plucker/exact_orient.cpp. Valid in
// round-to-nearest without overflow or underflow (the callers bound their inputs).
#pragma once

#include <cmath>
#include <vector>

namespace visgate::expansion {

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

// The same on a vector (any length), and the expansion's value rounded within a few
// ulps (components summed from the smallest).
inline void grow_vector(std::vector<double>& e, double b) {
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

inline double estimate(const std::vector<double>& e) {
  double v = 0.0;
  for (double x : e) v += x;
  return v;
}

}  // namespace visgate::expansion
