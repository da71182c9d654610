// Clamping (paper 000 section 4.5), the blocking test BLOCKS-SHAFT (4.6, Figure 4.18) with
// its guards, and BLOCKS-RAY of the custom ray caster (4.10).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"

namespace visgate::iss {

namespace {

// Clamps the directed edge p0 -> p1 to the slab lo <= x[ax] <= hi (section 4.5): split
// where it pierces a clip plane, project the outside parts orthogonally onto the plane.
int clamp_edge(const Vec3d& p0, const Vec3d& p1, int ax, double lo, double hi, Vec3d* out) {
  double ts[2], cs[2];
  int nt = 0;
  double a0 = p0[ax], a1 = p1[ax];
  // The planes in the order the edge meets them: by its direction, not by the rounded
  // parameters, which tie when both planes are within an ulp of an endpoint (t = 1 for
  // both): the split points were then emitted lower plane first on a descending edge,
  // a zig-zag through the slab.
  double first = a0 <= a1 ? lo : hi, second = a0 <= a1 ? hi : lo;
  for (double c : {first, second}) {
    if ((a0 < c && a1 > c) || (a0 > c && a1 < c)) {
      ts[nt] = (c - a0) / (a1 - a0);
      cs[nt++] = c;
    }
  }
  int n = 0;
  out[n++] = p0;
  for (int i = 0; i < nt; ++i) {
    // The split point lies on its clip plane by definition, so its main-axis coordinate
    // is the plane's, not that of p0 + (p1 - p0) t evaluated in double: for t within an
    // ulp of 1 (a clip plane 1e-33 from an endpoint, relative to the edge's length:
    // a light node 3e-33 above the receivers' plane) that expression is the endpoint
    // itself, the clamp below kept it on the far side of the slab, and the clamped
    // boundary cut diagonally through the slab, changing its winding number about the
    // test line (corpus/iss/other, grid-snapped-19532).
    // The cross coordinates come from the endpoint nearer to the plane, so their error
    // is a few ulps of that endpoint's distance from it.
    double c = cs[i];
    Vec3d x = ts[i] <= 0.5 ? p0 + (p1 - p0) * ts[i] : p1 + (p0 - p1) * ((c - a1) / (a0 - a1));
    x[ax] = c;
    out[n++] = x;
  }
  out[n++] = p1;
  for (int i = 0; i < n; ++i) out[i][ax] = std::min(hi, std::max(lo, out[i][ax]));
  return n;
}

struct TestPlanes {
  Vec3d q, na, nb;
  double pa(const Vec3d& v) const { return dot(na, v - q); }
  double pb(const Vec3d& v) const { return dot(nb, v - q); }
};

// CONSTRUCT-TEST-PLANES: two planes meeting in the test line q1 q2 (Figure 4.14).
TestPlanes make_test_planes(const Vec3d& q1, const Vec3d& q2) {
  TestPlanes t;
  t.q = q1;
  Vec3d d = q2 - q1;
  Vec3d ad = vabs(d);
  int k = (ad.x <= ad.y && ad.x <= ad.z) ? 0 : (ad.y <= ad.z ? 1 : 2);
  Vec3d ek(0, 0, 0);
  ek[k] = 1.0;
  t.na = normalize(cross(d, ek));
  t.nb = normalize(cross(d, t.na));
  return t;
}

// Lines 16-32 of Figure 4.18 for one directed edge, in half units.
int winding_update(const TestPlanes& tp, const Vec3d& v0, const Vec3d& v1) {
  double d0 = tp.pa(v0), d1 = tp.pa(v1);
  auto sgn = [](double x) { return (x > 0) - (x < 0); };
  if (sgn(d0) == sgn(d1)) return 0;
  double f0 = tp.pb(v0), f1 = tp.pb(v1);
  if (f0 < 0 && f1 < 0) return 0;
  if ((d0 < d1) == (d0 * f1 > d1 * f0)) return 0;
  int adjust = (d0 == 0 || d1 == 0) ? 1 : 2;
  return d0 > d1 ? -adjust : adjust;
}

// True when the part of edge p0 p1 beyond the clip plane x[ax] = plane (below it when
// `below`), projected along the main axis onto the plane, may meet the rectangle `face`
// (the node's outer face there) grown by `tol` in the two other axes. Liang-Barsky in
// the plane, closed comparisons; the crossing parameter's rounding is far inside tol.
bool beyond_part_meets_face(const Vec3d& p0, const Vec3d& p1, int ax, double plane, bool below, const AABBd& face,
                            double tol) {
  const double a = below ? plane - p0[ax] : p0[ax] - plane, b = below ? plane - p1[ax] : p1[ax] - plane;
  if (!(a > 0) && !(b > 0)) return false;  // nothing beyond: no clamping
  double t0 = 0.0, t1 = 1.0;
  if (!(a > 0)) t0 = a / (a - b);
  else if (!(b > 0)) t1 = a / (a - b);
  const int u = (ax + 1) % 3, v = (ax + 2) % 3;
  for (int k : {u, v}) {
    const double o = p0[k], d = p1[k] - p0[k], lo = face.lo[k] - tol, hi = face.hi[k] + tol;
    if (d == 0) {
      if (o < lo || o > hi) return false;
      continue;
    }
    double ta = (lo - o) / d, tb = (hi - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

int clamped_winding(const TestPlanes& tp, const Vec3d& p0, const Vec3d& p1, int ax, double lo, double hi) {
  Vec3d pts[4];
  int n = clamp_edge(p0, p1, ax, lo, hi, pts);
  int w = 0;
  for (int i = 0; i + 1 < n; ++i) w += winding_update(tp, pts[i], pts[i + 1]);
  return w;
}

}  // namespace

AABBd clamp_box(const AABBd& box, int axis, double lo, double hi) {
  AABBd c = box;
  if (c.empty() || axis < 0) return c;
  c.lo[axis] = std::min(hi, std::max(lo, box.lo[axis]));
  c.hi[axis] = std::min(hi, std::max(lo, box.hi[axis]));
  return c;
}

AABBd clamped_box(const AABBd& box, const ShaftGeometry& g) {
  return clamp_box(box, g.main_axis(), g.clip_lo(), g.clip_hi());
}

bool can_block_shaft(const AABBd& box, const ShaftGeometry& g) {
  // The winding number is computed for the boundary clamped to the slab between the
  // clip planes (section 4.5), which lies in the clamped box. For every segment from
  // the receiver box's outer face to the light box's outer face, the winding of the
  // clamped boundary about it equals the (constant) intersection number of blockers.h,
  // so a nonzero winding needs the clamped box to meet every such segment; three are
  // tested: the test segment and the segments between the two faces' low corners and
  // between their high corners, each grown by the plane tolerance of shaft.h.
  // Neither the unclamped box nor segments from other corners of the node boxes will
  // do: a boundary entirely below the receiver's clip plane, of a surface reaching up
  // through the shaft, is clamped onto that plane around the test segment's end, and
  // a segment from the top of the receiver box passes above it (corpus/iss/other,
  // on-surface-110).
  AABBd c = clamped_box(box, g);
  Vec3d q1, q2;
  g.test_segment(q1, q2);
  int ax = g.main_axis();
  Vec3d r_lo = g.receiver().lo, r_hi = g.receiver().hi, l_lo = g.light().lo, l_hi = g.light().hi;
  r_lo[ax] = r_hi[ax] = q1[ax];  // the outer faces, on the clip planes
  l_lo[ax] = l_hi[ax] = q2[ax];
  double grow = 0x1p-40 * g.scale();
  return segment_may_hit_box(q1, q2, c, grow) && segment_may_hit_box(r_lo, l_lo, c, grow) &&
         segment_may_hit_box(r_hi, l_hi, c, grow);
}

bool blocks_shaft(const Surface& s, const ShaftGeometry& g) { return blocking_test(s, g) == BlockTest::Blocked; }

BlockTest blocking_test(const Surface& s, const ShaftGeometry& g) {
  // A shaft whose boxes are closer on the main axis than 2^-30 of the scale is thinner
  // than the tolerances of its planes (2^-40 of the scale, shaft.h) allow to resolve: its
  // test line and clamped boundaries lie in a slab where the winding number's signs are
  // rounding (products of such differences underflow). Its relations go to the rays.
  if (shaft_too_thin(g)) return BlockTest::Unknown;
  if (stands_beyond_clip_planes(s, g)) return BlockTest::Unknown;
  // Line 1, CAN-BLOCK-SHAFT.
  if (!can_block_shaft(s.box, g)) return BlockTest::Clear;
  Vec3d q1, q2;
  g.test_segment(q1, q2);
  // Lines 3-7: a boundary edge inside the shaft means a hole.
  for (const RawEdge& re : s.raw)
    if ((re.nb[0] == kNoPatch || re.nb[1] == kNoPatch) && re.inside) return BlockTest::Clear;
  // Lines 8-34: winding number of the clamped boundary around the test line.
  TestPlanes tp = make_test_planes(q1, q2);
  int ax = g.main_axis();
  // Clamping (section 4.5) moves a boundary part beyond a clip plane onto that plane,
  // sweeping only through space beyond it; shaft segments meet the plane only where
  // they end, on the node's outer face. So the winding about every shaft segment is the
  // one of the unclamped geometry unless a clamped part lands on that face: then it is
  // not (corpus/iss/other/bef549c1...), and the shaft is not called blocked (its
  // relations go to sub-shafts and rays).
  const double face_tol = 0x1p-40 * g.scale();
  const AABBd& lo_face = g.dir() > 0 ? g.receiver() : g.light();
  const AABBd& hi_face = g.dir() > 0 ? g.light() : g.receiver();
  int winding = 0;  // in halves
  for (const RawEdge& re : s.raw) {
    if (re.nb[0] != kNoPatch && re.nb[1] != kNoPatch) continue;  // double edge
    bool owner_is_1 = re.nb[1] != kNoPatch;
    const Vec3d& v0 = owner_is_1 ? re.v[0] : re.v[1];
    const Vec3d& v1 = owner_is_1 ? re.v[1] : re.v[0];
    if (beyond_part_meets_face(v0, v1, ax, g.clip_lo(), true, lo_face, face_tol) ||
        beyond_part_meets_face(v0, v1, ax, g.clip_hi(), false, hi_face, face_tol))
      return BlockTest::Unknown;
    winding += clamped_winding(tp, v0, v1, ax, g.clip_lo(), g.clip_hi());
  }
  return winding != 0 ? BlockTest::Blocked : BlockTest::Clear;
}

bool misses_slab(const AABBd& box, int axis, double lo, double hi, bool touching_misses) {
  const double blo = box.lo[axis], bhi = box.hi[axis];
  return bhi < lo || blo > hi || (touching_misses && (bhi <= lo || blo >= hi));
}

double main_axis_gap(const ShaftGeometry& g) {
  const int a = g.main_axis();
  // Receiver below the light when dir > 0.
  return g.dir() > 0 ? g.light().lo[a] - g.receiver().hi[a] : g.receiver().lo[a] - g.light().hi[a];
}

bool shaft_too_thin(const ShaftGeometry& g) {
  return g.main_axis() < 0 || !(main_axis_gap(g) > 0x1p-30 * g.scale());
}

bool beyond_clip_planes(const AABBd& box, const ShaftGeometry& g) {
  const int a = g.main_axis();
  if (a < 0 || box.empty()) return false;
  return misses_slab(box, a, g.clip_lo(), g.clip_hi(), main_axis_gap(g) > 0.0);
}

bool stands_beyond_clip_planes(const Surface& s, const ShaftGeometry& g) {
  return beyond_clip_planes(s.box, g) && !beyond_clip_planes(s.hull, g);
}

bool blocks_ray(const BlockerContext& ctx, const Surface& s, int ax, const Vec3d& r, const Vec3d& l) {
  double lo = std::min(r[ax], l[ax]), hi = std::max(r[ax], l[ax]);
  // The patch boundaries are clamped to the ray's extent on the main axis below, so
  // the early exit tests the box clamped the same way (see can_block_shaft).
  if (!segment_may_hit_box(r, l, clamp_box(s.box, ax, lo, hi), 0x1p-40 * ctx.scale)) return false;
  TestPlanes tp = make_test_planes(r, l);
  for (const Patch& p : s.patches) {
    if (p.facing == Facing::Inconsistent && p.tri >= 0) {
      uint32_t t = uint32_t(p.tri);
      if (segment_hits_triangle_d(r, l, corner_d(*ctx.mesh, t, 0), corner_d(*ctx.mesh, t, 1), corner_d(*ctx.mesh, t, 2)))
        return true;
      continue;
    }
    int w = 0;
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Edge& e = s.edges[k];
      w += clamped_winding(tp, edge_vertex(s, e, 0), edge_vertex(s, e, 1), ax, lo, hi);
    }
    if (w != 0) return true;
  }
  return false;
}

}  // namespace visgate::iss
