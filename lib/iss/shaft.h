// Shaft geometry of the ISS algorithm (paper 000 section 4.4.1): the convex hull of a
// receiver-node box and a light-node box as an intersection of half-spaces, built from
// the three 2D projections (Figure 4.3), its main axis and clip planes (section 4.5),
// and the conservative geometric predicates every other ISS routine relies on.
//
// Guarantee (conservative): every predicate named `may_*` answers true whenever the
// exact answer on the stored inputs is true. Planes are evaluated in double on float32
// (or double clip-vertex) inputs and a point counts as outside a plane only when it is
// beyond it by more than `tolerance(plane)` = 2^-40 * |n|_1 * S, S the largest absolute
// coordinate of the scene. Derivation: n.p - d over coordinates bounded by S has a
// rounding error below 8 * 2^-53 * |n|_1 * S (three products, two sums, d itself rounded
// once), so 2^-40 leaves a factor 2^10 of slack, which also covers clip vertices that are
// off their exact position by a few double ulps. The price is that touching or nearly
// touching geometry counts as intersecting, which only ever makes ISS subdivide more.
#pragma once

#include <array>
#include <cstdint>

#include "lib/geom/aabb.h"
#include "lib/geom/plane.h"
#include "lib/geom/vec.h"

namespace visgate::iss {

// A plane of lib/geom (n.x = d, n not normalised) with the conservative evaluation
// margin of the file comment: a point is beyond it only when eval(p) > tol.
struct ConservativePlane : Planed {
  double tol = 0.0;
};

// The empty box ISS starts its blocker boxes from: +-1e300 rather than AABBd's
// infinities, so that plane evaluations of an empty box's corners stay finite (with
// infinite corners, 0 * inf in an axis plane's dot product would be NaN, and every
// comparison with it false).
inline AABBd empty_box() {
  AABBd b;
  b.lo = Vec3d(1e300, 1e300, 1e300);
  b.hi = Vec3d(-1e300, -1e300, -1e300);
  return b;
}

// A float box in double (exact).
inline AABBd to_double(const AABB& b) {
  AABBd d;
  d.lo = to_double(b.lo);
  d.hi = to_double(b.hi);
  return d;
}

// Main axis of a pair of disjoint boxes: the axis with the widest gap; dir = +1 when the
// receiver box lies below the light box on it, -1 otherwise; -1 axis when they overlap.
struct MainAxis {
  int axis = -1;
  int dir = 1;
};
MainAxis choose_main_axis(const AABB& receiver, const AABB& light);

class ShaftGeometry {
 public:
  // Hull of the two boxes. `scale` is S of the file comment. `axis` may be -1 for
  // overlapping boxes (pre-traversal): then clip planes and extrusions are undefined.
  ShaftGeometry(const AABB& receiver, const AABB& light, MainAxis axis, double scale);
  ShaftGeometry() : scale_(1.0) {}

  const AABBd& receiver() const { return r_; }
  const AABBd& light() const { return l_; }
  int main_axis() const { return axis_.axis; }
  int dir() const { return axis_.dir; }
  // Clip planes (section 4.5): the outer faces of the two boxes along the main axis, so
  // the slab [clip_lo, clip_hi] only shrinks when a node is split.
  double clip_lo() const { return clip_lo_; }
  double clip_hi() const { return clip_hi_; }
  double scale() const { return scale_; }
  int plane_count() const { return count_; }
  // Plane i, read from the plane arrays (the only copy of the planes).
  ConservativePlane plane(int i) const {
    ConservativePlane p;
    p.n = Vec3d(soa_.v[0][i], soa_.v[1][i], soa_.v[2][i]);
    p.d = soa_.v[3][i];
    p.tol = soa_.v[4][i];
    return p;
  }
  // Component c (0..4: n.x, n.y, n.z, d, tol) of planes 0..plane_count() - 1, the
  // arrays plane(i) reads.
  const double* plane_array(int c) const { return soa_.v[c]; }

  bool may_contain_point(const Vec3d& p) const;
  bool may_intersect_segment(const Vec3d& a, const Vec3d& b) const;
  bool may_intersect_triangle(const Vec3d& a, const Vec3d& b, const Vec3d& c) const;
  // The two halves of may_intersect_triangle (it is true iff both are false), so that
  // callers can put a cheaper test between them.
  bool separated_by_shaft_plane(const Vec3d& a, const Vec3d& b, const Vec3d& c) const;
  bool separated_by_triangle_plane(const Vec3d& a, const Vec3d& b, const Vec3d& c) const;
  bool may_intersect_box(const AABBd& b) const;
  // The extended region E = hull + the receiver box's outer face extruded away from
  // the light + the light box's outer face extruded away from the receiver. E shrinks
  // with every sub-shaft; patch simplification (4.7.5) keeps every collapsed triangle
  // outside E so that clamping (4.5) never projects blocker parts onto a node face.
  bool may_intersect_extended(const Vec3d& a, const Vec3d& b, const Vec3d& c) const;
  // Distance from p to the shaft boundary (positive inside and outside), for CHOOSE-SPLIT.
  double boundary_distance(const Vec3d& p) const;
  // The test segment of section 4.6.2: centre of the receiver box's outer face to the
  // centre of the light box's outer face.
  void test_segment(Vec3d& q_receiver, Vec3d& q_light) const;

 private:
  void add_plane(const Vec3d& n, double d);
  bool prism_may_intersect(const AABBd& face_box, int away_sign, const Vec3d& a, const Vec3d& b, const Vec3d& c) const;

  AABBd r_, l_;
  MainAxis axis_;
  double scale_;
  double clip_lo_ = 0, clip_hi_ = 0;
  static constexpr int kMaxPlanes = 18;  // 6 box planes + at most 4 oblique per projection
  int count_ = 0;
  // The planes as arrays of n.x, n.y, n.z, d and tol, so that the predicates evaluate
  // four planes per vector; plane(i) reads them back. The slots from count_ up to the
  // next multiple of 4 hold a plane that never separates (n = 0, d = 0, tol = +inf:
  // every evaluation is -inf). The rest are never read and left unwritten: a shaft is
  // built per node pair (and four per split choice), and zero-filling the arrays cost
  // more than the planes they hold. Kept only in this layout (not also as an array of
  // planes), which halves the bytes a shaft writes and copies (section 4.13).
  static constexpr int kSoaSlots = 20;
  union SoaSlots {
    SoaSlots() {}
    double v[5][kSoaSlots];
  };
  SoaSlots soa_;
};

// Plane through three points in double with its tolerance for coordinates up to `scale`.
ConservativePlane plane_through(const Vec3d& a, const Vec3d& b, const Vec3d& c, double scale);

// Open-segment / triangle test in double (touching the interior of the segment counts
// as a hit, an endpoint on the triangle does not), used by the custom ray caster for
// node triangles and inconsistent patches: plane sides from the triangle's normal, the
// crossing point from the nearer endpoint, a closed 2D point-in-triangle test relative
// to the vertices. Float-exact inputs, double evaluation: wrong only for relations
// within double rounding (~1e-16 of the segment, relative) of a degenerate
// configuration, also for triangles far smaller than their distance to the segment.
bool segment_hits_triangle_d(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c);
// Segment / box overlap (slab test) with the box grown by `grow`.
bool segment_may_hit_box(const Vec3d& p, const Vec3d& q, const AABBd& box, double grow);

}  // namespace visgate::iss
