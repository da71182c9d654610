// Shewchuk's expansion arithmetic in double ("Adaptive precision floating-point arithmetic
// and fast robust geometric predicates", 1997), the one copy every exact predicate uses:
// lib/geom/predicates.h (orient2d_exact, orient3d_exact), lib/plucker/exact_orient.cpp
// (the lifted light plane, the Newell side) and the region oracle's exact frame. Valid in
// round-to-nearest without overflow or underflow (the callers bound their inputs).
#pragma once

#include <cmath>
#include <vector>

#include <boost/container/small_vector.hpp>

namespace visgate::expansion {

// An expansion whose components live inline up to 16 (a Newell component of a polygon of
// up to 8 vertices, a product of two short expansions), on the heap beyond: the exact
// paths of plucker-bsp form them per plane and per evaluation, where heap vectors showed
// in the allocator's profile.
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

// Scale-Expansion with zero elimination (Shewchuk's scale_expansion_zeroelim, Two-Product
// by fused multiply-add): h = e * b exactly, in one pass over e[0..n); returns h's length
// (at most 2n; 0 for zero). e nonoverlapping (and strongly nonoverlapping, as every
// expansion these routines and grow make in round-to-nearest-even), increasing
// magnitude, no zeros; h the same. h must not overlap e.
inline int scale_expansion(const double* e, int n, double b, double* h) {
  if (n == 0 || b == 0.0) return 0;
  int out = 0;
  double q, hh;
  two_product(e[0], b, q, hh);
  if (hh != 0.0) h[out++] = hh;
  for (int i = 1; i < n; ++i) {
    double p1, p0, sum;
    two_product(e[i], b, p1, p0);
    two_sum(q, p0, sum, hh);
    if (hh != 0.0) h[out++] = hh;
    q = p1 + sum;  // Fast-Two-Sum: |p1| >= |sum|
    hh = sum - (q - p1);
    if (hh != 0.0) h[out++] = hh;
  }
  if (q != 0.0) h[out++] = q;
  return out;
}

// Fast-Expansion-Sum with zero elimination (Shewchuk's fast_expansion_sum_zeroelim):
// h = e + f exactly, merging the components in order of magnitude in one pass; returns
// h's length (at most ne + nf). Inputs as for scale_expansion; h must not overlap them.
inline int sum_expansions(const double* e, int ne, const double* f, int nf, double* h) {
  if (ne + nf == 0) return 0;
  int i = 0, j = 0, out = 0;
  double q, qn, hh;
  // The smaller in magnitude of e[i] and f[j] goes first (Shewchuk's comparison).
  auto e_first = [](double ei, double fj) { return (fj > ei) == (fj > -ei); };
  if (j == nf || (i < ne && e_first(e[i], f[j]))) q = e[i++];
  else q = f[j++];
  if (i < ne && j < nf) {  // Fast-Two-Sum for the second: |next| >= |q|
    const double next = e_first(e[i], f[j]) ? e[i++] : f[j++];
    qn = next + q;
    hh = q - (qn - next);
    q = qn;
    if (hh != 0.0) h[out++] = hh;
    while (i < ne && j < nf) {
      two_sum(q, e_first(e[i], f[j]) ? e[i++] : f[j++], qn, hh);
      q = qn;
      if (hh != 0.0) h[out++] = hh;
    }
  }
  for (; i < ne; ++i) {
    two_sum(q, e[i], qn, hh);
    q = qn;
    if (hh != 0.0) h[out++] = hh;
  }
  for (; j < nf; ++j) {
    two_sum(q, f[j], qn, hh);
    q = qn;
    if (hh != 0.0) h[out++] = hh;
  }
  if (q != 0.0) h[out++] = q;
  return out;
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

// out += sign * e * x for a double x, exactly: Scale-Expansion, then one merging
// Fast-Expansion-Sum, linear in the lengths, in a per-thread scratch buffer so that
// intermediate lengths beyond Small's inline 16 allocate nothing. sign is +-1, so
// sign * x is exact.
inline void add_scaled(Small& out, const Small& e, double x, double sign = 1.0) {
  if (x == 0.0 || e.empty()) return;
  thread_local std::vector<double> scratch;
  const size_t ns = 2 * e.size(), nh = out.size() + ns;
  if (scratch.size() < ns + nh) scratch.resize(ns + nh);
  double* s = scratch.data();
  double* h = s + ns;
  const int n_s = scale_expansion(e.data(), int(e.size()), sign * x, s);
  const int n_h = sum_expansions(out.data(), int(out.size()), s, n_s, h);
  out.assign(h, h + n_h);
}

// out += sign * e * f, exactly.
inline void add_product(Small& out, const Small& e, const Small& f, double sign = 1.0) {
  for (double x : f) add_scaled(out, e, x, sign);
}

// a - b for floats, exactly (Two-Sum: at most two components).
inline Small float_difference(float a, float b) {
  Small e;
  double x, y;
  two_sum(double(a), -double(b), x, y);
  if (y != 0.0) e.push_back(y);
  if (x != 0.0) e.push_back(x);
  return e;
}

// The expansion's value rounded within a few ulps (components summed from the smallest).
template <class V>
inline double estimate(const V& e) {
  double v = 0.0;
  for (double x : e) v += x;
  return v;
}

}  // namespace visgate::expansion
