// The filtered and exact 3D orientations (see predicates.h).
#include "lib/geom/predicates.h"

#include <cmath>

#include "lib/geom/error_bounds.h"

namespace visgate {

namespace {

// An expansion of at most four components: a coordinate difference.
struct Diff {
  double c[4];
  int n = 0;
};

// The exact difference of two points' coordinates k as an expansion: (a.hi + a.lo) -
// (b.hi + b.lo), four doubles summed exactly.
Diff difference(const SumPoint& a, const SumPoint& b, int k) {
  using expansion::grow;
  Diff e;
  grow(e.c, e.n, double(a.hi[k]));
  grow(e.c, e.n, double(a.lo[k]));
  grow(e.c, e.n, -double(b.hi[k]));
  grow(e.c, e.n, -double(b.lo[k]));
  return e;
}

}  // namespace

ExactOrient orient3d_exact_value(const SumPoint& a, const SumPoint& b, const SumPoint& c, const SumPoint& d) {
  using expansion::grow;
  using expansion::two_product;
  Diff u[3], v[3], w[3];
  for (int k = 0; k < 3; ++k) {
    u[k] = difference(b, a, k);
    v[k] = difference(c, a, k);
    w[k] = difference(d, a, k);
  }
  // det[u, v, w] = sum over the permutations (i, j, k) of sign * u_i v_j w_k, each
  // product expanded over the components: at most 6 * 4 * 4 * 4 * 4 terms, so the sum
  // never has more components than that. Fixed arrays: no allocation.
  static const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  constexpr int kMaxTerms = 6 * 4 * 4 * 4 * 4;
  double sum[kMaxTerms + 1];
  int n = 0;
  for (int p = 0; p < 6; ++p) {
    const double sign = p < 3 ? 1.0 : -1.0;
    const Diff &ui = u[perm[p][0]], &vj = v[perm[p][1]], &wk = w[perm[p][2]];
    for (int i = 0; i < ui.n; ++i)
      for (int j = 0; j < vj.n; ++j) {
        double x, y;
        two_product(ui.c[i], vj.c[j], x, y);
        for (int k = 0; k < wk.n; ++k) {
          double t[4];
          two_product(x, wk.c[k], t[0], t[1]);
          two_product(y, wk.c[k], t[2], t[3]);
          for (double term : t)
            if (term != 0.0) grow(sum, n, sign * term);
        }
      }
  }
  ExactOrient r;
  if (n == 0) return r;
  // The largest component of a nonoverlapping expansion carries its sign; summing the
  // components from the smallest rounds the value to within a few ulps (each component
  // is below an ulp of the next).
  r.sign = sum[n - 1] > 0.0 ? 1 : -1;
  for (int i = 0; i < n; ++i) r.value += sum[i];
  return r;
}

Sign orient3d_filtered(const Vec3f& af, const Vec3f& bf, const Vec3f& cf, const SumPoint& d) {
  constexpr double kU = kUnitRoundoffD;
  Vec3d a = to_double(af);
  Vec3d u = to_double(bf) - a, v = to_double(cf) - a;
  Vec3d dd = to_double(d.hi) + d.lo;
  Vec3d w = dd - a;
  Vec3d uv = cross(u, v);
  double val = dot(uv, w);
  double perm = std::abs(w.x) * (std::abs(u.y * v.z) + std::abs(u.z * v.y)) +
                std::abs(w.y) * (std::abs(u.z * v.x) + std::abs(u.x * v.z)) +
                std::abs(w.z) * (std::abs(u.x * v.y) + std::abs(u.y * v.x));
  // The differences u, v, w are exact or rounded once (relative u each); the rounding
  // of dd (u |dd|_inf per coordinate) enters through the first-order term.
  const double bound = 2.0 * (7.0 + 56.0 * kU) * kU * perm +
                       2.0 * (std::abs(uv.x) + std::abs(uv.y) + std::abs(uv.z)) * kU * max_component(vabs(dd));
  return sign_with_bound(val, bound);
}

}  // namespace visgate
