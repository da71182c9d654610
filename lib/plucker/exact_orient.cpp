// Exact orientation of float points by expansion arithmetic; see exact_orient.h.
#include "lib/plucker/exact_orient.h"

#include <cmath>
#include <vector>

namespace visgate::plucker {

namespace {

// Two-Sum: a + b = x + y exactly, x = fl(a + b) (Knuth; valid in round-to-nearest).
inline void two_sum(double a, double b, double& x, double& y) {
  x = a + b;
  double bv = x - a;
  double av = x - bv;
  y = (a - av) + (b - bv);
}

// Two-Product: a * b = x + y exactly, with the fused multiply-add giving the roundoff
// (std::fma is exact: it rounds a * b - x once, and that value is representable).
inline void two_product(double a, double b, double& x, double& y) {
  x = a * b;
  y = std::fma(a, b, -x);
}

// Grow-Expansion: adds b to the nonoverlapping expansion e (increasing magnitude),
// keeping it nonoverlapping; zero components are dropped.
void grow(std::vector<double>& e, double b) {
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

}  // namespace

int orient3d_exact_sign(const Vec3f& af, const Vec3f& bf, const Vec3f& cf, const Vec3f& df) {
  // Differences u = b - a, v = c - a, w = d - a as exact two-term expansions.
  double u[3][2], v[3][2], w[3][2];
  for (int k = 0; k < 3; ++k) {
    two_sum(double(bf[k]), -double(af[k]), u[k][0], u[k][1]);
    two_sum(double(cf[k]), -double(af[k]), v[k][0], v[k][1]);
    two_sum(double(df[k]), -double(af[k]), w[k][0], w[k][1]);
  }
  // det[u, v, w] = sum over the permutations (i, j, k) of sign * u_i v_j w_k.
  static const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  std::vector<double> sum;
  sum.reserve(64);
  for (int p = 0; p < 6; ++p) {
    const double sign = p < 3 ? 1.0 : -1.0;
    const int i = perm[p][0], j = perm[p][1], k = perm[p][2];
    for (int a = 0; a < 2; ++a)
      for (int b = 0; b < 2; ++b)
        for (int c = 0; c < 2; ++c) {
          double x, y;
          two_product(u[i][a], v[j][b], x, y);
          double t[4];
          two_product(x, w[k][c], t[0], t[1]);
          two_product(y, w[k][c], t[2], t[3]);
          for (double term : t)
            if (term != 0.0) grow(sum, sign * term);
        }
  }
  // The largest component of a nonoverlapping expansion carries its sign.
  if (sum.empty()) return 0;
  return sum.back() > 0.0 ? 1 : (sum.back() < 0.0 ? -1 : 0);
}

}  // namespace visgate::plucker
