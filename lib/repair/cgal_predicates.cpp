// CGAL implementation of the mesh-repair exact predicates (see cgal_predicates.h).
#include "lib/repair/cgal_predicates.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Exact_rational.h>
#include <CGAL/Interval_nt.h>

namespace visgate::mesh {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using Q = CGAL::Exact_rational;
using I = CGAL::Interval_nt<false>;  // needs the rounding mode set upwards (protector below)

inline P3 pt(const Vec3d& v) { return P3(v.x, v.y, v.z); }
inline int sgn(CGAL::Sign s) { return s == CGAL::POSITIVE ? 1 : (s == CGAL::NEGATIVE ? -1 : 0); }

template <class N>
N det3(const N& ax, const N& ay, const N& az, const N& bx, const N& by, const N& bz, const N& cx, const N& cy,
       const N& cz) {
  return ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
}

// det[a - o, b - o, c - o] over number type N, from exact double input.
template <class N>
N tet_volume6(const Vec3d& o, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  N ox(o.x), oy(o.y), oz(o.z);
  return det3<N>(N(a.x) - ox, N(a.y) - oy, N(a.z) - oz, N(b.x) - ox, N(b.y) - oy, N(b.z) - oz, N(c.x) - ox,
                 N(c.y) - oy, N(c.z) - oz);
}

}  // namespace

bool CgalExactPredicates::collinear(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  return CGAL::collinear(pt(a), pt(b), pt(c));
}

int CgalExactPredicates::orientation(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) const {
  return sgn(CGAL::orientation(pt(a), pt(b), pt(c), pt(d)));
}

int CgalExactPredicates::coplanar_side(const Vec3d& a, const Vec3d& b, const Vec3d& p, const Vec3d& q) const {
  return sgn(CGAL::coplanar_orientation(pt(a), pt(b), pt(p), pt(q)));
}

bool CgalExactPredicates::segment_triangle_intersect(const Vec3d& s0, const Vec3d& s1, const Vec3d& t0,
                                                     const Vec3d& t1, const Vec3d& t2) const {
  return CGAL::do_intersect(K::Segment_3(pt(s0), pt(s1)), K::Triangle_3(pt(t0), pt(t1), pt(t2)));
}

bool CgalExactPredicates::triangles_intersect(const Vec3d& a0, const Vec3d& a1, const Vec3d& a2, const Vec3d& b0,
                                              const Vec3d& b1, const Vec3d& b2) const {
  return CGAL::do_intersect(K::Triangle_3(pt(a0), pt(a1), pt(a2)), K::Triangle_3(pt(b0), pt(b1), pt(b2)));
}

int CgalExactPredicates::compare_distance(const Vec3d& p, const Vec3d& q, double t) const {
  {
    CGAL::Protect_FPU_rounding<true> guard;
    I dx = I(p.x) - I(q.x), dy = I(p.y) - I(q.y), dz = I(p.z) - I(q.z);
    I d2 = CGAL::square(dx) + CGAL::square(dy) + CGAL::square(dz);
    I t2 = CGAL::square(I(t));
    if (d2.sup() < t2.inf()) return -1;
    if (d2.inf() > t2.sup()) return 1;
  }
  Q dx = Q(p.x) - Q(q.x), dy = Q(p.y) - Q(q.y), dz = Q(p.z) - Q(q.z);
  Q d2 = dx * dx + dy * dy + dz * dz, t2 = Q(t) * Q(t);
  return d2 < t2 ? -1 : (d2 > t2 ? 1 : 0);
}

int CgalExactPredicates::volume_sign(const std::vector<Vec3d>& v, const std::vector<std::array<uint32_t, 3>>& tris,
                                     const std::vector<uint32_t>& subset) const {
  if (subset.empty()) return 0;
  // Reference point: a vertex of the surface, which keeps the interval terms small.
  const Vec3d& o = v[tris[subset[0]][0]];
  {
    CGAL::Protect_FPU_rounding<true> guard;
    I sum(0);
    for (uint32_t t : subset) sum += tet_volume6<I>(o, v[tris[t][0]], v[tris[t][1]], v[tris[t][2]]);
    if (sum.inf() > 0) return 1;
    if (sum.sup() < 0) return -1;
  }
  Q sum(0);
  for (uint32_t t : subset) sum += tet_volume6<Q>(o, v[tris[t][0]], v[tris[t][1]], v[tris[t][2]]);
  return CGAL::sign(sum) == CGAL::POSITIVE ? 1 : (CGAL::sign(sum) == CGAL::NEGATIVE ? -1 : 0);
}

}  // namespace visgate::mesh
