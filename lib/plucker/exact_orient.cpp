// The region oracle's exact light plane by expansion arithmetic; see exact_orient.h.
#include "lib/plucker/exact_orient.h"

#include <cmath>
#include <vector>

#include "lib/geom/error_bounds.h"
#include "lib/geom/expansion.h"

namespace visgate::plucker {

namespace {

using Expansion = expansion::Small;  // nonoverlapping, increasing magnitude, no zeros

using expansion::add_product;
using expansion::add_scaled;
using expansion::estimate;
using expansion::float_difference;
using expansion::two_product;
using expansion::two_sum;

// Grow-Expansion on a vector (lib/geom/expansion.h grow_vector): e += b exactly.
inline void grow(Expansion& e, double b) { expansion::grow_vector(e, b); }

}  // namespace

LiftedLight::LiftedLight(const Vec3f* poly, int m, int u, int v) : m_(m), u_(u), v_(v), w_(3 - u - v) {
  for (int k = 0; k < 3; ++k) {
    n_[k] = expansion::newell_component<Expansion>(poly, size_t(m), k);
    nd_[k] = estimate(n_[k]);
    Expansion s;  // S_k = sum_i P_i[k]
    for (int i = 0; i < m; ++i) grow(s, double(poly[i][k]));
    add_product(ns_exact_, n_[k], s);
  }
  ns_ = estimate(ns_exact_);
  nw_sign_ = n_[w_].empty() || n_[w_].back() > 0.0 ? 1 : -1;
}

LiftedPlane LiftedLight::plane(const Vec3f& p, const Vec3f& q1, const Vec3f& q2) const {
  // In double with forward error bounds (kU = 2^-53; each bound generous by a factor
  // of about 2). d = q - p: exact or rounded once (|e| <= u |d|). c = d1 x d2: each
  // product's rounding plus the d's, |e_c| <= 4 u (|d1_k1 d2_k2| + |d1_k2 d2_k1|). The
  // rounded N_k and N . S are within 2 u of the exact values (expansions rounded).
  constexpr double kU = kUnitRoundoffD;
  LiftedPlane pl;
  pl.p = p;
  pl.q1 = q1;
  pl.q2 = q2;
  double d1[3], d2[3], c[3], ecm[3];
  for (int k = 0; k < 3; ++k) {
    d1[k] = double(q1[k]) - double(p[k]);
    d2[k] = double(q2[k]) - double(p[k]);
  }
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    const double x = d1[k1] * d2[k2], y = d1[k2] * d2[k1];
    c[k] = x - y;
    ecm[k] = 4.0 * kU * (std::abs(x) + std::abs(y));
  }
  const double m = double(m_);
  const double nw = nd_[w_], enw = 2.0 * kU * std::abs(nw);
  auto coefficient = [&](int axis, double& val, double& err) {
    // m (N_w c_axis - N_axis c_w)
    const double na = nd_[axis], ena = 2.0 * kU * std::abs(na);
    const double x = nw * c[axis], y = na * c[w_];
    val = m * (x - y);
    err = m * (std::abs(nw) * ecm[axis] + enw * std::abs(c[axis]) + std::abs(na) * ecm[w_] + ena * std::abs(c[w_]) +
               4.0 * kU * (std::abs(x) + std::abs(y)));
  };
  coefficient(u_, pl.b, pl.eb);
  coefficient(v_, pl.c, pl.ec);
  // A = c_w (N . S) - m N_w (c . p).
  double cp = 0.0, ecp = 0.0;
  for (int k = 0; k < 3; ++k) {
    cp += c[k] * double(p[k]);
    ecp += (ecm[k] + 4.0 * kU * std::abs(c[k])) * std::abs(double(p[k]));
  }
  const double x = c[w_] * ns_, y = m * nw * cp;
  pl.a = x - y;
  pl.ea = ecm[w_] * std::abs(ns_) + std::abs(c[w_]) * 2.0 * kU * std::abs(ns_) + m * std::abs(nw) * ecp +
          m * enw * std::abs(cp) + 4.0 * kU * (std::abs(x) + std::abs(y));
  return pl;
}

void LiftedLight::make_exact(LiftedPlane& pl) const {
  const Vec3f &p = pl.p, &q1 = pl.q1, &q2 = pl.q2;
  // c = (q1 - p) x (q2 - p), exactly.
  Expansion d1[3], d2[3], c[3];
  for (int k = 0; k < 3; ++k) {
    d1[k] = float_difference(q1[k], p[k]);
    d2[k] = float_difference(q2[k], p[k]);
  }
  for (int k = 0; k < 3; ++k) {
    const int k1 = (k + 1) % 3, k2 = (k + 2) % 3;
    add_product(c[k], d1[k1], d2[k2]);
    add_product(c[k], d1[k2], d2[k1], -1.0);
  }
  const double m = double(m_);
  const Expansion& nw = n_[w_];
  // B = m (N_w c_u - N_u c_w), C = m (N_w c_v - N_v c_w).
  Expansion t;
  add_product(t, nw, c[u_]);
  add_product(t, n_[u_], c[w_], -1.0);
  add_scaled(pl.xb, t, m);
  t.clear();
  add_product(t, nw, c[v_]);
  add_product(t, n_[v_], c[w_], -1.0);
  add_scaled(pl.xc, t, m);
  // A = c_w (N . S) - m N_w (c . p).
  Expansion cp, x;
  add_product(pl.xa, c[w_], ns_exact_);
  for (int k = 0; k < 3; ++k) add_scaled(cp, c[k], double(p[k]));
  add_product(x, nw, cp);
  add_scaled(pl.xa, x, m, -1.0);
  // value()'s second stage: each coefficient as its two largest components plus the
  // others, whose sum is bounded by the sum of their magnitudes (rounded up by the
  // factor: at most 2^10 components, each addition rounding by 2^-53).
  const Expansion* xs[3] = {&pl.xa, &pl.xb, &pl.xc};
  for (int k = 0; k < 3; ++k) {
    const Expansion& e = *xs[k];
    const size_t n = e.size();
    pl.top[k][0] = n > 0 ? e[n - 1] : 0.0;
    pl.top[k][1] = n > 1 ? e[n - 2] : 0.0;
    double r = 0.0;
    for (size_t i = 0; i + 2 < n; ++i) r += std::abs(e[i]);
    pl.rest[k] = r * (1.0 + 0x1p-40);
  }
  pl.exact_ready = true;
}

double LiftedLight::double_value(const LiftedPlane& pl, float hu, double lu, float hv, double lv, double& err) {
  // g = a + b hu + b lu + c hv + c lv in double, off by the coefficients' bounds times
  // |u|, |v| plus the rounding of four products and four sums (8 u of the terms).
  constexpr double kU = kUnitRoundoffD;
  const double t0 = pl.b * double(hu), t1 = pl.b * lu, t2 = pl.c * double(hv), t3 = pl.c * lv;
  const double g = pl.a + t0 + t1 + t2 + t3;
  err = pl.ea + pl.eb * (std::abs(double(hu)) + std::abs(lu)) + pl.ec * (std::abs(double(hv)) + std::abs(lv)) +
        8.0 * kU * (std::abs(pl.a) + std::abs(t0) + std::abs(t1) + std::abs(t2) + std::abs(t3));
  return g;
}

ExactOrient LiftedLight::sign(LiftedPlane& pl, float hu, double lu, float hv, double lv) const {
  double err = 0.0;
  const double g = double_value(pl, hu, lu, hv, lv, err);
  if (std::abs(g) > err) return ExactOrient{(g > 0.0 ? 1 : -1) * nw_sign_, double(nw_sign_) * g};
  return value(pl, hu, lu, hv, lv);
}

ExactOrient LiftedLight::value(LiftedPlane& pl, float hu, double lu, float hv, double lv) const {
  // Double first (double_value), accepted when its bound is below 2^-30 of it.
  double err = 0.0;
  const double g = double_value(pl, hu, lu, hv, lv, err);
  if (std::abs(g) * 0x1p-30 > err) return ExactOrient{(g > 0.0 ? 1 : -1) * nw_sign_, double(nw_sign_) * g};
  if (!pl.exact_ready) make_exact(pl);
  {
    // Second stage: A' + B' u + C' v with A', B', C' the two leading components of the
    // exact coefficients, as 20 exact terms (Two-Product by fused multiply-add; a
    // product below 2^-969 may lose its low part to underflow, at most 2^-1074 each),
    // summed by Sum2 (Ogita, Rump and Oishi, "Accurate sum and dot product", 2005:
    // |res - sum| <= u |sum| + gamma_(n-1)^2 sum |p_i|, gamma_k = k u / (1 - k u)),
    // plus the omitted components: |A - A'| + |B - B'| |u| + |C - C'| |v|. Accepted
    // when that total is below (2^-30 - 2^-52) |res|: then res has the sign of g and is
    // within 2^-30 of it. Where the double evaluation above cancels (edge-on receivers),
    // this answers without growing expansions.
    const double mult[5] = {1.0, double(hu), lu, double(hv), lv};
    const int coef[5] = {0, 1, 1, 2, 2};
    double p[20];
    int np = 0;
    for (int t = 0; t < 5; ++t)
      for (int c = 0; c < 2; ++c) {
        double x, y;
        two_product(pl.top[coef[t]][c], mult[t], x, y);
        p[np++] = x;
        p[np++] = y;
      }
    double sum = p[0], comp = 0.0, mag = std::abs(p[0]);
    for (int i = 1; i < np; ++i) {
      double x, y;
      two_sum(sum, p[i], x, y);
      sum = x;
      comp += y;
      mag += std::abs(p[i]);
    }
    const double res = sum + comp;
    constexpr double kGamma = gamma_d(19);
    const double trunc = pl.rest[0] + pl.rest[1] * (std::abs(double(hu)) + std::abs(lu)) +
                         pl.rest[2] * (std::abs(double(hv)) + std::abs(lv));
    const double bound = (kGamma * kGamma * mag + trunc) * (1.0 + 0x1p-40) + 20.0 * 0x1p-1074;
    if (std::isfinite(res) && std::isfinite(bound) && std::abs(res) * (0x1p-30 - 0x1p-52) > bound)
      return ExactOrient{(res > 0.0 ? 1 : -1) * nw_sign_, double(nw_sign_) * res};
  }
  // Third stage: the exact expansion, where the vertex lies exactly on the plane (a zero
  // the second stage cannot certify; coefficients of a few components, add_scaled
  // linear in their lengths).
  thread_local Expansion e;
  e = pl.xa;
  add_scaled(e, pl.xb, double(hu));
  add_scaled(e, pl.xb, lu);
  add_scaled(e, pl.xc, double(hv));
  add_scaled(e, pl.xc, lv);
  ExactOrient r;
  if (e.empty()) return r;
  r.sign = (e.back() > 0.0 ? 1 : -1) * nw_sign_;
  r.value = double(nw_sign_) * estimate(e);
  return r;
}

int newell_side_exact(const Vec3f* poly, int m, const Vec3f& x) {
  // N_k = sum_i (v_i[k1] v_(i+1)[k2] - v_i[k2] v_(i+1)[k1]): products of two floats are
  // exact in double (48 bits), summed exactly. d_k = m x_k - sum_i v_i[k]: m x_k is exact
  // (24 + 29 bits), summed exactly. N . d: every product of two components by
  // Two-Product, summed exactly. Magnitudes stay within double's range for float inputs
  // (|N_k| < 2^260, |d_k| < 2^160; nonzero terms above 2^-600).
  Expansion n[3], d[3];
  for (int k = 0; k < 3; ++k) {
    n[k] = expansion::newell_component<Expansion>(poly, size_t(m), k);
    for (int i = 0; i < m; ++i) grow(d[k], -double(poly[i][k]));
    grow(d[k], double(m) * double(x[k]));
  }
  Expansion sum;
  for (int k = 0; k < 3; ++k)
    for (double p : n[k])
      for (double q : d[k]) {
        double hi, lo;
        two_product(p, q, hi, lo);
        if (hi != 0.0) grow(sum, hi);
        if (lo != 0.0) grow(sum, lo);
      }
  if (sum.empty()) return 0;
  return sum.back() > 0.0 ? 1 : -1;
}

int newell_dominant_axis(const Vec3f* poly, int m) {
  Expansion mag[3];  // |N_k|: the expansion, negated when its leading component is negative
  for (int k = 0; k < 3; ++k) {
    mag[k] = expansion::newell_component<Expansion>(poly, size_t(m), k);
    if (!mag[k].empty() && mag[k].back() < 0.0)
      for (double& c : mag[k]) c = -c;
  }
  int best = 0;
  for (int j = 1; j < 3; ++j) {
    Expansion diff = mag[j];  // |N_j| - |N_best|, exactly
    for (double c : mag[best]) grow(diff, -c);
    if (!diff.empty() && diff.back() > 0.0) best = j;
  }
  return best;
}

}  // namespace visgate::plucker
