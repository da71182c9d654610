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
    Vec3f pa = a - occ[i], pb = b - occ[i];
    Vec3f nrm = cross(pa, pb);
    float scale = kDetErr * norm1(pa) * norm1(pb);
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

}  // namespace visgate::plucker
