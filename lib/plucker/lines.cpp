// Plücker geometry (paper 002 sections 3.1-3.3); see lines.h.
#include "lib/plucker/lines.h"

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
  for (int k = 0; k < m; ++k) {
    Vec3d pa = p[k] - a;
    w[size_t(k)] = cross(pa, ab);
    scale[size_t(k)] = kDetErrD * (std::abs(pa.x) + std::abs(pa.y) + std::abs(pa.z)) * nab;
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
