// Shaft geometry and conservative predicates (paper 000 sections 4.4.1, 4.5; see shaft.h).
#include "lib/iss/shaft.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "lib/base/cpu_features.h"

#include "lib/geom/predicates.h"

namespace visgate::iss {

namespace {

constexpr double kTolFactor = 0x1p-40;  // derivation in shaft.h

double l1(const Vec3d& n) { return std::abs(n.x) + std::abs(n.y) + std::abs(n.z); }

}  // namespace

MainAxis choose_main_axis(const AABB& receiver, const AABB& light) {
  MainAxis m;
  double best = 0.0;
  for (int k = 0; k < 3; ++k) {
    double up = double(light.lo[k]) - double(receiver.hi[k]);    // receiver below light
    double down = double(receiver.lo[k]) - double(light.hi[k]);  // receiver above light
    if (up > best) { best = up; m.axis = k; m.dir = 1; }
    if (down > best) { best = down; m.axis = k; m.dir = -1; }
  }
  return m;
}

ConservativePlane plane_through(const Vec3d& a, const Vec3d& b, const Vec3d& c, double scale) {
  ConservativePlane p;
  p.n = cross(b - a, c - a);
  p.d = dot(p.n, a);
  p.tol = kTolFactor * l1(p.n) * scale;
  return p;
}

void ShaftGeometry::add_plane(const Vec3d& n, double d) {
  soa_.v[0][count_] = n.x;
  soa_.v[1][count_] = n.y;
  soa_.v[2][count_] = n.z;
  soa_.v[3][count_] = d;
  soa_.v[4][count_] = kTolFactor * l1(n) * scale_;
  ++count_;
}

ShaftGeometry::ShaftGeometry(const AABB& receiver, const AABB& light, MainAxis axis, double scale)
    : r_(to_double(receiver)), l_(to_double(light)), axis_(axis), scale_(scale) {
  // Axis-aligned planes: the common bounding box.
  AABBd all = r_;
  all.extend(l_);
  for (int k = 0; k < 3; ++k) {
    Vec3d n(0, 0, 0);
    n[k] = 1.0;
    add_plane(n, all.hi[k]);
    n[k] = -1.0;
    add_plane(n, -all.lo[k]);
  }
  // Oblique planes: supporting lines of the 2D hull of the two projected rectangles
  // that pass through one corner of each (Figure 4.3b; lib/geom/haines_shaft.h). Differences of float
  // coordinates are exact in double, so the support test is exact up to one rounding
  // per product; a plane that fails it only makes the shaft larger (conservative).
  // A duplicate can only come from the same projection: planes of two projections have
  // normals (n_i, n_j, 0) and (n_i', 0, n_k') (say) with every listed component a
  // non-zero difference of floats, so their cross product has no zero component
  // (products of such differences neither underflow nor overflow in double).
  // The loops are those of for_each_shaft_corner_line (projections (0,1), (0,2), (1,2),
  // corners 0..3), written out so that each projection's rectangle bounds are read once
  // rather than per corner line and candidate (the constructor runs for every shaft and
  // CHOOSE-SPLIT candidate). Same planes, same order, same bits.
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const int first_of_projection = count_;
      // Each rectangle's smaller and larger coordinate on both axes (for dmax below).
      const double rx0 = std::min(r_.lo[i], r_.hi[i]), rx1 = std::max(r_.lo[i], r_.hi[i]);
      const double ry0 = std::min(r_.lo[j], r_.hi[j]), ry1 = std::max(r_.lo[j], r_.hi[j]);
      const double lx0 = std::min(l_.lo[i], l_.hi[i]), lx1 = std::max(l_.lo[i], l_.hi[i]);
      const double ly0 = std::min(l_.lo[j], l_.hi[j]), ly1 = std::max(l_.lo[j], l_.hi[j]);
      for (int corner = 0; corner < 4; ++corner) {
        const double px = corner & 1 ? r_.hi[i] : r_.lo[i], py = corner & 2 ? r_.hi[j] : r_.lo[j];
        const double qx = corner & 1 ? l_.hi[i] : l_.lo[i], qy = corner & 2 ? l_.hi[j] : l_.lo[j];
        const double dx = qx - px, dy = qy - py;
        if (dx == 0.0 || dy == 0.0) continue;  // axis-aligned: covered by the box
        // Line normal (dy, -dx); pick the sign that puts every corner on the <= side.
        for (double sg : {1.0, -1.0}) {
          double nx = sg * dy, ny = -sg * dx;
          // Support test with a rounding margin: the line passes through both corners
          // exactly, but n.q rounds differently for the second corner, and a strict test
          // rejected the true hull edge about half of the time (leaving a much larger
          // shaft). d is then raised to the largest computed n.c over the eight corners,
          // so every corner is on the <= side as evaluated, and the plane tolerance of
          // eval() covers the rounding of n.c (file comment of shaft.h); the plane stays
          // conservative. The margin 2^-40 |n|_1 S is the same bound.
          // The largest computed n.c over a rectangle's four corners is the one at the
          // corner the signs of n pick (nx, ny != 0 here): fl(fl(nx x) + fl(ny y)) is
          // monotone in x and in y, rounding being monotone, so no other corner gives a
          // larger double. Bit for bit the maximum of all eight evaluations (test
          // IssShaft.ObliquePlaneOffsetIsTheLargestEvaluatedCornerValue).
          double d = nx * px + ny * py;
          const bool ux = nx > 0, uy = ny > 0;
          double dmax = std::max({d, nx * (ux ? rx1 : rx0) + ny * (uy ? ry1 : ry0),
                                  nx * (ux ? lx1 : lx0) + ny * (uy ? ly1 : ly0)});
          if (dmax - d > kTolFactor * (std::abs(nx) + std::abs(ny)) * scale_) continue;
          d = dmax;
          Vec3d n(0, 0, 0);
          n[i] = nx;
          n[j] = ny;
          // Parallel and same direction: both normals lie in the (i, j) plane, so the
          // cross product's only component that can be non-zero is the one on the third
          // axis (the other two are differences of products with exact zeros).
          bool dup = false;
          for (int k = first_of_projection; k < count_; ++k) {
            const ConservativePlane o = plane(k);
            if (o.n[i] * ny - o.n[j] * nx == 0.0 && dot(o.n, n) > 0 && o.d * l1(n) == d * l1(o.n)) dup = true;
          }
          if (!dup && count_ < kMaxPlanes) add_plane(n, d);
        }
      }
    }
  for (int i = count_; i % 4 != 0; ++i) {  // never separating (see soa_)
    soa_.v[0][i] = soa_.v[1][i] = soa_.v[2][i] = soa_.v[3][i] = 0.0;
    soa_.v[4][i] = std::numeric_limits<double>::infinity();
  }
  if (axis_.axis >= 0) {
    int a = axis_.axis;
    if (axis_.dir > 0) {
      clip_lo_ = r_.lo[a];
      clip_hi_ = l_.hi[a];
    } else {
      clip_lo_ = l_.lo[a];
      clip_hi_ = r_.hi[a];
    }
  }
}

bool ShaftGeometry::may_contain_point(const Vec3d& p) const {
  for (int i = 0; i < count_; ++i) {
    const ConservativePlane pl = plane(i);
    if (pl.eval(p) > pl.tol) return false;
  }
  return true;
}

namespace {

typedef double V4 __attribute__((vector_size(32)));
typedef int64_t M4 __attribute__((vector_size(32)));

// Planes g..g+3 of the plane arrays (ShaftGeometry::soa_; padded to a multiple of four
// with planes that never separate).
struct Planes4 {
  V4 nx, ny, nz, d, tol;
};
__attribute__((always_inline)) inline Planes4 load_planes(const double (*v)[20], int g) {
  Planes4 P;
  std::memcpy(&P.nx, v[0] + g, sizeof P.nx);
  std::memcpy(&P.ny, v[1] + g, sizeof P.ny);
  std::memcpy(&P.nz, v[2] + g, sizeof P.nz);
  std::memcpy(&P.d, v[3] + g, sizeof P.d);
  std::memcpy(&P.tol, v[4] + g, sizeof P.tol);
  return P;
}

// may_intersect_segment's body over the plane arrays (ShaftGeometry::soa_), four planes
// per vector: plane values of both end points, each n.p - d - tol in the operation
// order of eval() (n.x a.x + n.y a.y, + n.z a.z, - d, - tol), so the same bits as the
// scalar loop it replaces (the build has -ffp-contract=off: no fused multiply-add). A
// plane with both ends beyond it separates; then Cyrus-Beck over the planes the segment
// crosses, in plane order. The answer does not depend on the order: t0 only rises and
// t1 only falls, so the interval test fails at some plane iff it fails with the final
// t0 and t1.
__attribute__((always_inline)) inline bool segment_body(const double (*v)[20], int count, const Vec3d& a,
                                                        const Vec3d& b) {
  alignas(32) double ea_all[20], eb_all[20];
  const double ax = a.x, ay = a.y, az = a.z, bx = b.x, by = b.y, bz = b.z;
  for (int g = 0; g < count; g += 4) {
    const Planes4 P = load_planes(v, g);
    const V4 &nx = P.nx, &ny = P.ny, &nz = P.nz, &d = P.d, &tol = P.tol;
    const V4 ea = (((nx * ax + ny * ay) + nz * az) - d) - tol;
    const V4 eb = (((nx * bx + ny * by) + nz * bz) - d) - tol;
    const M4 out = (ea > 0.0) & (eb > 0.0);
    if ((out[0] | out[1] | out[2] | out[3]) != 0) return false;
    std::memcpy(ea_all + g, &ea, sizeof ea);
    std::memcpy(eb_all + g, &eb, sizeof eb);
  }
  double t0 = 0.0, t1 = 1.0;
  for (int i = 0; i < count; ++i) {
    const double ea = ea_all[i], eb = eb_all[i];
    if (ea <= 0 && eb <= 0) continue;
    double t = ea / (ea - eb);
    if (ea > 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
    // Interval test with slack for the division's rounding (relative 2^-50).
    if (t0 > t1 + 0x1p-40) return false;
  }
  return true;
}

// may_intersect_box's body, four planes per vector: per plane the box corner nearest to
// the plane's inside (lo where n_k > 0, else hi) and its value n.q - d in eval()'s order,
// beyond tol: the box is outside. The same bits and answer as the scalar loop (the
// answer is whether any plane rejects, whatever the order).
__attribute__((always_inline)) inline bool box_body(const double (*v)[20], int count, const AABBd& b) {
  for (int g = 0; g < count; g += 4) {
    const Planes4 P = load_planes(v, g);
    const V4 &nx = P.nx, &ny = P.ny, &nz = P.nz, &d = P.d, &tol = P.tol;
    const V4 lox = {b.lo.x, b.lo.x, b.lo.x, b.lo.x}, hix = {b.hi.x, b.hi.x, b.hi.x, b.hi.x};
    const V4 loy = {b.lo.y, b.lo.y, b.lo.y, b.lo.y}, hiy = {b.hi.y, b.hi.y, b.hi.y, b.hi.y};
    const V4 loz = {b.lo.z, b.lo.z, b.lo.z, b.lo.z}, hiz = {b.hi.z, b.hi.z, b.hi.z, b.hi.z};
    const V4 qx = nx > 0.0 ? lox : hix, qy = ny > 0.0 ? loy : hiy, qz = nz > 0.0 ? loz : hiz;
    const V4 e = ((nx * qx + ny * qy) + nz * qz) - d;
    const M4 out = e > tol;
    if ((out[0] | out[1] | out[2] | out[3]) != 0) return false;
  }
  return true;
}

// separated_by_shaft_plane's body, four planes per vector: some plane with eval() beyond
// tol at all three vertices (the answer of the scalar loop, whatever the order).
__attribute__((always_inline)) inline bool triangle_body(const double (*v)[20], int count, const Vec3d& a,
                                                         const Vec3d& b, const Vec3d& c) {
  for (int g = 0; g < count; g += 4) {
    const Planes4 P = load_planes(v, g);
    const V4 &nx = P.nx, &ny = P.ny, &nz = P.nz, &d = P.d, &tol = P.tol;
    const V4 ea = ((nx * a.x + ny * a.y) + nz * a.z) - d;
    const V4 eb = ((nx * b.x + ny * b.y) + nz * b.z) - d;
    const V4 ec = ((nx * c.x + ny * c.y) + nz * c.z) - d;
    const M4 out = (ea > tol) & (eb > tol) & (ec > tol);
    if ((out[0] | out[1] | out[2] | out[3]) != 0) return true;
  }
  return false;
}

bool triangle_default(const double (*v)[20], int count, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return triangle_body(v, count, a, b, c);
}

bool box_default(const double (*v)[20], int count, const AABBd& b) { return box_body(v, count, b); }

bool segment_default(const double (*v)[20], int count, const Vec3d& a, const Vec3d& b) {
  return segment_body(v, count, a, b);
}
#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx2"))) bool segment_avx2(const double (*v)[20], int count, const Vec3d& a, const Vec3d& b) {
  return segment_body(v, count, a, b);
}
__attribute__((target("avx2"))) bool box_avx2(const double (*v)[20], int count, const AABBd& b) {
  return box_body(v, count, b);
}
__attribute__((target("avx2"))) bool triangle_avx2(const double (*v)[20], int count, const Vec3d& a, const Vec3d& b,
                                                   const Vec3d& c) {
  return triangle_body(v, count, a, b, c);
}
// VISGATE_ISS_NO_AVX2 selects the default build, as for leaf_rays.cpp's kernels.
bool shaft_avx2() {
  static const bool avx2 = avx2_enabled("VISGATE_ISS_NO_AVX2");
  return avx2;
}
#endif

}  // namespace

bool ShaftGeometry::may_intersect_segment(const Vec3d& a, const Vec3d& b) const {
  // Cyrus-Beck clipping of the parameter interval against every plane, each plane
  // moved outwards by its tolerance (segment_body). The hot predicate of
  // classify_edges.
  static_assert(kSoaSlots == 20, "segment_body's arrays");
#if defined(__GNUC__) && defined(__x86_64__)
  if (shaft_avx2()) return segment_avx2(soa_.v, count_, a, b);
#endif
  return segment_default(soa_.v, count_, a, b);
}

bool ShaftGeometry::may_intersect_triangle(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  return !separated_by_shaft_plane(a, b, c) && !separated_by_triangle_plane(a, b, c);
}

bool ShaftGeometry::separated_by_shaft_plane(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  // Some plane with all three vertices beyond it (triangle_body).
#if defined(__GNUC__) && defined(__x86_64__)
  if (shaft_avx2()) return triangle_avx2(soa_.v, count_, a, b, c);
#endif
  return triangle_default(soa_.v, count_, a, b, c);
}

bool ShaftGeometry::separated_by_triangle_plane(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  // Every corner of both boxes strictly on one side of the triangle's plane. Per box,
  // the smallest and the largest plane value over its eight corners, as evaluated, are
  // those of the two corners the signs of the normal pick: eval() is monotone in each
  // coordinate (each rounded operation is; classify_box_plane in blockers.h makes the
  // same argument), so these four evaluations give the answer of all sixteen.
  ConservativePlane tp = plane_through(a, b, c, scale_);
  if (tp.n == Vec3d(0, 0, 0)) return false;
  auto corner = [&](const AABBd& box, bool high) {
    auto pick = [&](double n, double lo, double hi) { return (n > 0) == high ? std::max(lo, hi) : std::min(lo, hi); };
    return Vec3d(pick(tp.n.x, box.lo.x, box.hi.x), pick(tp.n.y, box.lo.y, box.hi.y), pick(tp.n.z, box.lo.z, box.hi.z));
  };
  if (tp.eval(corner(r_, false)) > tp.tol && tp.eval(corner(l_, false)) > tp.tol) return true;
  return tp.eval(corner(r_, true)) < -tp.tol && tp.eval(corner(l_, true)) < -tp.tol;
}

bool ShaftGeometry::may_intersect_box(const AABBd& b) const {
  // Per plane, the box corner nearest to the plane's inside (box_body).
#if defined(__GNUC__) && defined(__x86_64__)
  if (shaft_avx2()) return box_avx2(soa_.v, count_, b);
#endif
  return box_default(soa_.v, count_, b);
}

bool ShaftGeometry::prism_may_intersect(const AABBd& face_box, int away_sign, const Vec3d& a, const Vec3d& b,
                                        const Vec3d& c) const {
  // Prism = face rectangle (face_box flattened on the main axis) swept along
  // away_sign * e_axis to infinity. Separated by one of its five planes?
  int ax = axis_.axis;
  for (int k = 0; k < 3; ++k) {
    if (k == ax) {
      double f = face_box.lo[k];  // the face coordinate (lo == hi on this axis)
      double tol = kTolFactor * scale_;
      // Inside the prism means away_sign * (x - f) >= 0.
      if (away_sign * (a[k] - f) < -tol && away_sign * (b[k] - f) < -tol && away_sign * (c[k] - f) < -tol)
        return false;
      continue;
    }
    double tol = kTolFactor * scale_;
    if (a[k] > face_box.hi[k] + tol && b[k] > face_box.hi[k] + tol && c[k] > face_box.hi[k] + tol) return false;
    if (a[k] < face_box.lo[k] - tol && b[k] < face_box.lo[k] - tol && c[k] < face_box.lo[k] - tol) return false;
  }
  // Separated by the triangle's plane: the face corners strictly on one side and the
  // sweep direction not leading back towards the plane.
  ConservativePlane tp = plane_through(a, b, c, scale_);
  if (tp.n == Vec3d(0, 0, 0)) return true;
  int i1 = (ax + 1) % 3, i2 = (ax + 2) % 3;
  bool all_pos = true, all_neg = true;
  for (int q = 0; q < 4; ++q) {
    Vec3d p;
    p[ax] = face_box.lo[ax];
    p[i1] = q & 1 ? face_box.hi[i1] : face_box.lo[i1];
    p[i2] = q & 2 ? face_box.hi[i2] : face_box.lo[i2];
    double e = tp.eval(p);
    if (!(e > tp.tol)) all_pos = false;
    if (!(e < -tp.tol)) all_neg = false;
  }
  double sweep = away_sign * tp.n[ax];
  if (all_pos && sweep >= 0) return false;
  if (all_neg && sweep <= 0) return false;
  return true;
}

bool ShaftGeometry::may_intersect_extended(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
  if (may_intersect_triangle(a, b, c)) return true;
  int ax = axis_.axis;
  // Receiver's outer face, extruded away from the light; light's outer face likewise.
  AABBd rf = r_, lf = l_;
  if (axis_.dir > 0) {
    rf.hi[ax] = rf.lo[ax];
    lf.lo[ax] = lf.hi[ax];
  } else {
    rf.lo[ax] = rf.hi[ax];
    lf.hi[ax] = lf.lo[ax];
  }
  if (prism_may_intersect(rf, -axis_.dir, a, b, c)) return true;
  if (prism_may_intersect(lf, axis_.dir, a, b, c)) return true;
  return false;
}

double ShaftGeometry::boundary_distance(const Vec3d& p) const {
  double inside = 1e300, outside = 0.0;
  bool is_out = false;
  for (int i = 0; i < count_; ++i) {
    const ConservativePlane pl = plane(i);
    double e = pl.eval(p) / length(pl.n);
    if (e > 0) {
      is_out = true;
      outside = std::max(outside, e);
    } else {
      inside = std::min(inside, -e);
    }
  }
  return is_out ? outside : inside;
}

void ShaftGeometry::test_segment(Vec3d& q_receiver, Vec3d& q_light) const {
  int ax = axis_.axis;
  q_receiver = (r_.lo + r_.hi) * 0.5;
  q_light = (l_.lo + l_.hi) * 0.5;
  q_receiver[ax] = axis_.dir > 0 ? r_.lo[ax] : r_.hi[ax];
  q_light[ax] = axis_.dir > 0 ? l_.hi[ax] : l_.lo[ax];
}

bool segment_hits_triangle_d(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  // The plane must be crossed strictly inside the open segment. The normal comes from
  // the triangle alone, so its relative error is ~1e-16 whatever the endpoints' distance.
  Vec3d n = cross(b - a, c - a);
  double s1 = dot(n, p - a), s2 = dot(n, q - a);
  if (!((s1 > 0 && s2 < 0) || (s1 < 0 && s2 > 0))) return false;
  // The crossing point, from the endpoint nearer to the plane (its error is then ~1e-16
  // of that endpoint's distance), then a closed point-in-triangle test in the
  // projection that drops n's dominant axis, with every difference taken from a
  // triangle vertex. Orientations of the segment against the edges, det(q - p, a - p,
  // b - p), would take differences from p instead: for a triangle much smaller than
  // its distance to p they round to zero (a 1e-45-wide sliver 1.4 units away) and the
  // test would take every such triangle as touched.
  Vec3d x = std::abs(s1) <= std::abs(s2) ? p + (q - p) * (s1 / (s1 - s2)) : q + (p - q) * (s2 / (s2 - s1));
  // The closed test first requires x in the triangle's box (point_in_triangle_closed,
  // lib/geom/predicates.h): on a sliver a point on the line of its long edges, far
  // beyond it, passes the sign test alone (corpus/iss/sliver/c979ba88...).
  return point_in_triangle_closed(a, b, c, n, x);
}

bool segment_may_hit_box(const Vec3d& p, const Vec3d& q, const AABBd& box, double grow) {
  double t0 = 0.0, t1 = 1.0;
  for (int k = 0; k < 3; ++k) {
    double lo = box.lo[k] - grow, hi = box.hi[k] + grow;
    double d = q[k] - p[k];
    if (d == 0.0) {
      if (p[k] < lo || p[k] > hi) return false;
      continue;
    }
    double ta = (lo - p[k]) / d, tb = (hi - p[k]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1 + 0x1p-40) return false;
  }
  return true;
}

}  // namespace visgate::iss
