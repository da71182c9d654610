// Plücker geometry (paper 002 sections 3.1-3.3); see lines.h.
#include "lib/plucker/lines.h"

#include <algorithm>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace visgate::plucker {

bool line_stabs_polygon(const Plucker& line, const Vec3f* poly, int n) {
  int pos = 0, neg = 0;
  for (int k = 0; k < n; ++k) {
    float s = side(line, Plucker::through(poly[k], poly[(k + 1) % n]));
    pos += s > 0.0f;
    neg += s < 0.0f;
  }
  return pos == n || neg == n;
}

Orientation vvset_orientation(const Vec3f* occ, int n, const Vec3f* dir, int m, const Vec3f& a, const Vec3f& b) {
  // side(o_i -> l_j, a -> b) = det[l_j - o_i, a - o_i, b - o_i]: one cross product per
  // occluder vertex, one dot product per vvset line (section 3.3, Theorem 1).
  bool pos = false, neg = false;
  for (int i = 0; i < n; ++i) {
    float scale = 0.0f;
    Vec3f nrm = edge_plane_normal(occ[i], a, b, scale);
    scale *= kDetErr;
    const Vec3f* d = dir + size_t(i) * size_t(m);
    for (int j = 0; j < m; ++j) {
      float s = dot(d[j], nrm);
      float bound = scale * norm1(d[j]);
      if (s > bound) pos = true;
      else if (s < -bound) neg = true;
      else return Orientation::Mixed;
      if (pos && neg) return Orientation::Mixed;
    }
  }
  return pos ? Orientation::Positive : Orientation::Negative;
}

void EdgeFan::set(const Vec3d& a_, const Vec3d& b, const Vec3d* p, int m) {
  constexpr double kDetErrD = 12.0 * kUnitRoundoffD;
  a = a_;
  Vec3d ab = b - a;
  double nab = std::abs(ab.x) + std::abs(ab.y) + std::abs(ab.z);
  w.resize(size_t(m));
  scale.resize(size_t(m));
  const size_t m2 = (size_t(m) + 1) & ~size_t(1);
  wx.resize(m2);
  wy.resize(m2);
  wz.resize(m2);
  ws.resize(m2);
  for (int k = 0; k < m; ++k) {
    Vec3d pa = p[k] - a;
    const Vec3d wk = cross(pa, ab);
    const double sk = kDetErrD * (std::abs(pa.x) + std::abs(pa.y) + std::abs(pa.z)) * nab;
    w[size_t(k)] = wk;
    scale[size_t(k)] = sk;
    wx[size_t(k)] = wk.x, wy[size_t(k)] = wk.y, wz[size_t(k)] = wk.z, ws[size_t(k)] = sk;
  }
  if (m2 > size_t(m)) {  // the padding repeats the last entry
    const size_t l = size_t(m) - 1;
    wx[l + 1] = wx[l], wy[l + 1] = wy[l], wz[l + 1] = wz[l], ws[l + 1] = ws[l];
  }
}

void EdgeFan::set(const Vec3d& a_, const Vec3d& b, const Vec3f* p, int m) {
  Vec3d buf[16];
  std::vector<Vec3d> heap;
  Vec3d* q = buf;
  if (m > 16) {
    heap.resize(size_t(m));
    q = heap.data();
  }
  for (int k = 0; k < m; ++k) q[k] = to_double(p[k]);
  set(a_, b, q, m);
}

Orientation EdgeFan::orientation(const Vec3d* x, int n, bool toward) const {
  bool pos = false, neg = false;
  const size_t m = w.size();
  const double sign = toward ? 1.0 : -1.0;  // exact: negation
#if defined(__SSE2__)
  // Two entries at a time: per lane the scalar loop's value sign * dot(d, W_k) (the same
  // products and sums in its order) and bound; the answer (Mixed at an undecided value or
  // at both signs, else the one sign) does not depend on the order the values are met.
  if (m > 0 && wx.size() == ((m + 1) & ~size_t(1))) {
    const size_t m2 = wx.size();
    const __m128d sg = _mm_set1_pd(sign), neg0 = _mm_set1_pd(-0.0);
    int mpos = 0, mneg = 0;
    for (int i = 0; i < n; ++i) {
      const Vec3d d = x[i] - a;
      const double nd = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
      const __m128d dx = _mm_set1_pd(d.x), dy = _mm_set1_pd(d.y), dz = _mm_set1_pd(d.z), ndv = _mm_set1_pd(nd);
      for (size_t k = 0; k < m2; k += 2) {
        const __m128d v = _mm_add_pd(_mm_add_pd(_mm_mul_pd(dx, _mm_loadu_pd(&wx[k])), _mm_mul_pd(dy, _mm_loadu_pd(&wy[k]))),
                                     _mm_mul_pd(dz, _mm_loadu_pd(&wz[k])));
        const __m128d s = _mm_mul_pd(sg, v);
        const __m128d bound = _mm_mul_pd(_mm_loadu_pd(&ws[k]), ndv);
        const int p = _mm_movemask_pd(_mm_cmpgt_pd(s, bound));
        const int q = _mm_movemask_pd(_mm_cmplt_pd(s, _mm_xor_pd(bound, neg0)));
        if ((p | q) != 3) return Orientation::Mixed;
        mpos |= p;
        mneg |= q;
        if (mpos != 0 && mneg != 0) return Orientation::Mixed;
      }
    }
    return mpos != 0 ? Orientation::Positive : Orientation::Negative;
  }
#endif
  for (int i = 0; i < n; ++i) {
    Vec3d d = x[i] - a;
    double nd = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
    for (size_t k = 0; k < m; ++k) {
      double s = sign * dot(d, w[k]);
      double bound = scale[k] * nd;
      if (s > bound) pos = true;
      else if (s < -bound) neg = true;
      else return Orientation::Mixed;
      if (pos && neg) return Orientation::Mixed;
    }
  }
  return pos ? Orientation::Positive : Orientation::Negative;
}

bool segment_blocked(const Vec3f& r, const Vec3f& s, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  // Plane sides: det[r - a, b - a, c - a] and det[s - a, b - a, c - a].
  Sign sr = side_sign(a, r, b, c);
  if (sr == Sign::Uncertain) return false;
  Sign ss = side_sign(a, s, b, c);
  if (ss == Sign::Uncertain || ss == sr) return false;
  // Edge lines: det[s - r, v_k - r, v_k+1 - r] = side(r -> s, v_k -> v_k+1).
  Sign e0 = side_sign(r, s, a, b);
  if (e0 == Sign::Uncertain) return false;
  return side_sign(r, s, b, c) == e0 && side_sign(r, s, c, a) == e0;
}

}  // namespace visgate::plucker
