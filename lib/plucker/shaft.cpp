// Haines' shaft culling (paper 002 section 4.4 implementation details); see shaft.h.
#include "lib/plucker/shaft.h"

#include <cmath>

#include "lib/geom/haines_shaft.h"

namespace visgate::plucker {

Shaft::Shaft(const AABB& a, const AABB& b) {
  Vec3d alo = to_double(a.lo), ahi = to_double(a.hi), blo = to_double(b.lo), bhi = to_double(b.hi);
  lo_ = vmin(alo, blo);
  hi_ = vmax(ahi, bhi);
  Vec3d ext = hi_ - lo_;
  double scale = max_component(ext) + std::max(max_component(vabs(lo_)), max_component(vabs(hi_)));
  margin_ = scale * 0x1p-20;
  // For each projection (i, j) and corner (lib/geom/haines_shaft.h), the plane through
  // the box edges at that corner (parallel to the third axis) is a shaft plane when it
  // supports both boxes, i.e. every corner of both boxes' (i, j) projections lies on its
  // inner side. Testing the support directly keeps the construction conservative
  // whatever the relative placement of the boxes. Unlike ISS's shaft, axis-parallel
  // lines are kept too (as planes that repeat a face of the bounding box).
  AABBd da, db;  // the boxes as given (no reordering of lo and hi)
  da.lo = alo;
  da.hi = ahi;
  db.lo = blo;
  db.hi = bhi;
  for_each_shaft_corner_line(da, db, [&](const ShaftCornerLine& line) {
    const int i = line.i, j = line.j;
    const double ai = line.ai, aj = line.aj, bi = line.bi, bj = line.bj;
    const double di = bi - ai, dj = bj - aj;
    if (di == 0.0 && dj == 0.0) return;
    // Normal perpendicular to the edge-to-edge direction, pointing towards the corner.
    double ni = dj, nj = -di;
    const double wi = line.corner & 1 ? 1.0 : -1.0, wj = line.corner & 2 ? 1.0 : -1.0;
    if (ni * wi + nj * wj < 0.0) { ni = -ni; nj = -nj; }
    const double off = ni * ai + nj * aj;
    bool supports = true;
    for (int c = 0; c < 4 && supports; ++c) {
      double pi_a = (c & 1) ? ahi[i] : alo[i], pj_a = (c & 2) ? ahi[j] : alo[j];
      double pi_b = (c & 1) ? bhi[i] : blo[i], pj_b = (c & 2) ? bhi[j] : blo[j];
      double tol = 1e-12 * (std::abs(ni) + std::abs(nj)) * scale;
      if (ni * pi_a + nj * pj_a - off > tol || ni * pi_b + nj * pj_b - off > tol) supports = false;
    }
    if (!supports) return;
    Planed p;
    p.n = Vec3d(0, 0, 0);
    p.n[i] = ni;
    p.n[j] = nj;
    double len = std::sqrt(ni * ni + nj * nj);
    p.n = p.n / len;
    p.d = off / len;
    planes_.push_back(p);
  });
}

bool Shaft::culls(const Vec3f& p0, const Vec3f& p1, const Vec3f& p2) const {
  Vec3d q[3] = {to_double(p0), to_double(p1), to_double(p2)};
  for (int ax = 0; ax < 3; ++ax) {
    if (q[0][ax] < lo_[ax] - margin_ && q[1][ax] < lo_[ax] - margin_ && q[2][ax] < lo_[ax] - margin_) return true;
    if (q[0][ax] > hi_[ax] + margin_ && q[1][ax] > hi_[ax] + margin_ && q[2][ax] > hi_[ax] + margin_) return true;
  }
  for (const Planed& p : planes_) {
    if (p.eval(q[0]) > margin_ && p.eval(q[1]) > margin_ && p.eval(q[2]) > margin_) return true;
  }
  return false;
}

bool Shaft::culls_box(const Vec3f& lo, const Vec3f& hi) const {
  Vec3d l = to_double(lo), h = to_double(hi);
  for (int ax = 0; ax < 3; ++ax)
    if (h[ax] < lo_[ax] - margin_ || l[ax] > hi_[ax] + margin_) return true;
  for (const Planed& p : planes_) {
    Vec3d c(p.n.x >= 0 ? l.x : h.x, p.n.y >= 0 ? l.y : h.y, p.n.z >= 0 ? l.z : h.z);
    if (p.eval(c) > margin_) return true;
  }
  return false;
}

}  // namespace visgate::plucker
