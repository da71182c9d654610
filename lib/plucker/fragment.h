// Light fragments (paper 002 section 4.2): convex pieces of the light polygon, split by
// the plane through the query point and a node's line (Figure 6), plus the measures the
// soft-shadow framework takes on them (section 4.4): area, point-in-fragment and the
// analytic Lambert irradiance [NN85].
//
// Precision: double throughout, on double local coordinates computed from the float32
// inputs (fragment vertices are points of the light in its local frame; query points and
// occluders the solver's local coordinates). Float fragments are not enough: on a long
// light u |x| at its far end is a visible part of its area. Planes through a query point
// and a node's line are evaluated against forward error bounds (a vertex within the
// bound lies "on" the plane and goes to both pieces).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <span>
#include <vector>

#include "lib/geom/vec.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace visgate::plucker {

// Result of classifying a fragment against the plane through r and the line a -> b,
// i.e. of the lines r -> x, x in the fragment, against the hyperplane of a -> b.
enum class SplitResult : uint8_t {
  Positive,   // all lines side >= 0 (some > 0): the whole fragment goes left
  Negative,   // all lines side <= 0 (some < 0): the whole fragment goes right
  Both,       // mixed: `pos` and `neg` receive the two convex pieces
  OnLine,     // degenerate: r lies on the line a -> b, every line r -> x meets it: side
              // is 0 for all; callers send the fragment right (Negative), see bsp.h
  ZeroArea,   // degenerate: every vertex lies on the plane, the fragment is a segment
};

// The plane through a query point r and a node's line a -> b, computed once and used for
// many fragments (bsp.cpp caches it per query and occluder edge). The construction and
// its bounds are derived in fragment.cpp: the normal N from the two shortest of a - r,
// b - r, b - a with per-component error bounds (r on the line when every component is
// within its bound), evaluated as (x - base) . N through the one of r, a, b nearest to
// the light's centroid. Every vertex x the plane judges is a vertex of a fragment, a
// convex piece of the light polygon with its vertices interpolated on its edges, so
// |x - base|_1 <= |centroid - base|_1 + radius1 and |x|_inf <= mag (LightBounds): the
// error bound of (x - base) . N is one number per plane (fragment.cpp).
struct LightBounds {
  Vec3d centroid;
  double radius1 = 0.0;  // max |l_j - centroid|_1 over the polygon's vertices
  double mag = 0.0;      // max |l_j|_inf
  // Of the polygon (n vertices), both maxima rounded up by 2^-50 relative (an
  // interpolated vertex exceeds its edge's ends by rounding only).
  static LightBounds of(const Vec3d* poly, int n);
  // |centroid - p|_1, summed as node_plane sums it (its base choice and bound).
  double dist1(const Vec3d& p) const {
    const Vec3d d = centroid - p;
    return std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  }
};

struct NodePlane {
  Vec3d n, base;
  double bound = 0.0;  // |(x - base) . N| <= bound: x on the plane (fragment.cpp)
  bool on_line = false;
};

NodePlane node_plane(const Vec3d& r, const Vec3d& a, const Vec3d& b, const LightBounds& light);
// The same plane, bit for bit, with dr, da, db = light.dist1(r), dist1(a), dist1(b) given:
// callers that meet the same points in many planes (the tree's occluder vertices, a
// query's r) compute them once.
NodePlane node_plane(const Vec3d& r, const Vec3d& a, const Vec3d& b, const LightBounds& light, double dr, double da,
                     double db);

// +1 / -1 when split_fragment(pl, ...) would find every vertex of a fragment lying in
// the box [lo, hi] strictly positive / negative (so it would return Positive /
// Negative), 0 when the box does not show it; the BSP walk skips the vertices then.
// Why it holds: for x in the box the exact s(x) = (x - base) . N >= L = sum_i N_i (c_i -
// base_i), c the corner minimising it, computed here with error < 5 u_d t, t = sum_i
// |N_i| max|B_i - base_i|; split_fragment's fl(s(x)) errs by < 4.01 u_d |N|_inf |x -
// base|_1. For a box around fragment vertices (widened by far less than d1) each max|B_i
// - base_i| <= d1 = max |x - base|_1 over fragment vertices (LightBounds), so t <= 3
// |N|_inf d1 (1 + tiny), while pl.bound >= 8 u_d |N|_inf d1 (node_plane): the errors
// stay below 4 bound, and computed L > 8 bound gives fl(s(x)) > bound at every vertex.
// With SSE2 the x and y terms are taken two lanes at a time: the same products, minima,
// maxima and sums in the same order (_mm_min_pd(b, a) is std::min(a, b), NaNs included),
// so the same answer with about two thirds of the instructions (the walk's hottest test).
inline int box_side(const NodePlane& pl, const Vec3d& lo, const Vec3d& hi) {
  if (pl.on_line) return 0;
#if defined(__SSE2__)
  static_assert(sizeof(Vec3d) == 3 * sizeof(double));
  const __m128d n = _mm_loadu_pd(&pl.n.x), base = _mm_loadu_pd(&pl.base.x);
  const __m128d a = _mm_mul_pd(n, _mm_sub_pd(_mm_loadu_pd(&lo.x), base));
  const __m128d b = _mm_mul_pd(n, _mm_sub_pd(_mm_loadu_pd(&hi.x), base));
  const double az = pl.n.z * (lo.z - pl.base.z), bz = pl.n.z * (hi.z - pl.base.z);
  const double m = 8.0 * pl.bound;
  const __m128d mn = _mm_min_pd(b, a);
  if (_mm_cvtsd_f64(mn) + _mm_cvtsd_f64(_mm_unpackhi_pd(mn, mn)) + std::min(az, bz) > m) return 1;
  const __m128d mx = _mm_max_pd(b, a);
  if (_mm_cvtsd_f64(mx) + _mm_cvtsd_f64(_mm_unpackhi_pd(mx, mx)) + std::max(az, bz) < -m) return -1;
  return 0;
#else
  const double ax = pl.n.x * (lo.x - pl.base.x), bx = pl.n.x * (hi.x - pl.base.x);
  const double ay = pl.n.y * (lo.y - pl.base.y), by = pl.n.y * (hi.y - pl.base.y);
  const double az = pl.n.z * (lo.z - pl.base.z), bz = pl.n.z * (hi.z - pl.base.z);
  const double m = 8.0 * pl.bound;
  if (std::min(ax, bx) + std::min(ay, by) + std::min(az, bz) > m) return 1;
  if (std::max(ax, bx) + std::max(ay, by) + std::max(az, bz) < -m) return -1;
  return 0;
#endif
}

// A box as centre c and half-widths h: the points x with |x_i - c_i| <= h_i (the stored
// doubles taken exactly). The BSP walk's per-piece box (bsp.cpp): box_side below needs
// one product a coordinate for the centre and one for the half-width, against two and a
// minimum and maximum for the corners.
struct CenterBox {
  Vec3d c, h;
  // [lo, hi] widened by at least w / 2 on every side, for w >= 2^-48 (|lo|_inf + |hi|_inf):
  // the roundings of c and h are below 2 u_d (|lo_i| + |hi_i|) + u_d w per side. NaN lo or
  // hi (the box of no point) give a NaN box, which box_side decides nothing with.
  static CenterBox of(const Vec3d& lo, const Vec3d& hi, double w) {
    return CenterBox{(lo + hi) * 0.5, (hi - lo) * 0.5 + Vec3d(w, w, w)};
  }
};

// box_side's answer from a CenterBox: +1 / -1 only when split_fragment(pl, ...) would
// return Positive / Negative for every fragment with its vertices in the box.
// Why it holds: for x in the box s(x) = (x - base) . N >= L = sum_i N_i (c_i - base_i) -
// sum_i |N_i| h_i. Computed, the first sum errs by < 4.01 u_d sum_i |N_i| |c_i - base_i|
// (a difference, a product, two sums), the second by < 3.01 u_d sum_i |N_i| h_i, and
// their difference is rounded once; |c_i - base_i| + h_i is the largest |x_i - base_i|
// over the box, at most d1 (1 + tiny) for a box around fragment vertices widened by far
// less than d1 (as for box_side above), so the errors stay below 12.1 u_d |N|_inf d1 <=
// 1.52 bound (node_plane: bound >= 8 u_d |N|_inf d1), and computed L > 8 bound gives
// s(x) > 6.4 bound, so fl(s(x)) > bound at every vertex (its error is < 0.51 bound).
// Symmetric for -1 with the upper value. With SSE2 the x and y terms two lanes at a time,
// summed in the scalar form's order.
inline int box_side(const NodePlane& pl, const CenterBox& b) {
  if (pl.on_line) return 0;
#if defined(__SSE2__)
  const __m128d n = _mm_loadu_pd(&pl.n.x);
  const __m128d s = _mm_mul_pd(n, _mm_sub_pd(_mm_loadu_pd(&b.c.x), _mm_loadu_pd(&pl.base.x)));
  const __m128d r = _mm_mul_pd(_mm_andnot_pd(_mm_set1_pd(-0.0), n), _mm_loadu_pd(&b.h.x));
  const __m128d t = _mm_add_pd(_mm_unpacklo_pd(s, r), _mm_unpackhi_pd(s, r));  // (s_x + s_y, r_x + r_y)
  const double sc = _mm_cvtsd_f64(t) + pl.n.z * (b.c.z - pl.base.z);
  const double rr = _mm_cvtsd_f64(_mm_unpackhi_pd(t, t)) + std::abs(pl.n.z) * b.h.z;
#else
  const double sc = pl.n.x * (b.c.x - pl.base.x) + pl.n.y * (b.c.y - pl.base.y) + pl.n.z * (b.c.z - pl.base.z);
  const double rr = std::abs(pl.n.x) * b.h.x + std::abs(pl.n.y) * b.h.y + std::abs(pl.n.z) * b.h.z;
#endif
  const double m = 8.0 * pl.bound;
  if (sc - rr > m) return 1;
  if (sc + rr < -m) return -1;
  return 0;
}

// Splits the convex polygon `poly` (n vertices) by the plane through r and a -> b.
// With Both, `pos` and `neg` are overwritten with the pieces (each >= 3 vertices, or
// empty when rounding leaves fewer; a piece of fewer than 3 vertices has zero area).
// r, a, b in double (the solver's local coordinates), the fragment in float.
SplitResult split_fragment(const Vec3d& r, const Vec3d& a, const Vec3d& b, const Vec3d* poly, int n,
                           std::vector<Vec3d>& pos, std::vector<Vec3d>& neg);

// The classification of split_fragment without building the pieces (Both: mixed).
SplitResult classify_fragment(const Vec3d& r, const Vec3d& a, const Vec3d& b, const Vec3d* poly, int n);

// The same against a precomputed plane (node_plane).
SplitResult split_fragment(const NodePlane& plane, const Vec3d* poly, int n, std::vector<Vec3d>& pos,
                           std::vector<Vec3d>& neg);
// (x - pl.base) . pl.n, the value classify_fragment and split_fragment take at a fragment
// vertex, as dot(x - base, n) computes it: (d_x n_x + d_y n_y) + d_z n_z. With SSE2 the
// x and y differences and products two lanes at a time (the same operations, summed in
// the same order, so the same bits): the two loops are a fifth of a dense mesh's solve
// (callgrind, CGAL's bunny). (Two vertices a step, one per lane, cost more: fragments
// have about four vertices, and the plane's six broadcasts outweigh the savings.)
struct PlaneValue {
#if defined(__SSE2__)
  __m128d base_xy, n_xy;
  double base_z, n_z;
  explicit PlaneValue(const NodePlane& pl)
      : base_xy(_mm_loadu_pd(&pl.base.x)), n_xy(_mm_loadu_pd(&pl.n.x)), base_z(pl.base.z), n_z(pl.n.z) {}
  double operator()(const Vec3d& x) const {
    static_assert(sizeof(Vec3d) == 3 * sizeof(double));
    const __m128d p = _mm_mul_pd(_mm_sub_pd(_mm_loadu_pd(&x.x), base_xy), n_xy);
    return (_mm_cvtsd_f64(p) + _mm_cvtsd_f64(_mm_unpackhi_pd(p, p))) + (x.z - base_z) * n_z;
  }
#else
  Vec3d base, n;
  explicit PlaneValue(const NodePlane& pl) : base(pl.base), n(pl.n) {}
  double operator()(const Vec3d& x) const { return dot(x - base, n); }
#endif
};

// classify_fragment against a precomputed plane, inline: the near loop (subtract.cpp)
// classifies a fragment against each edge plane of a polygon whose shadow box meets it,
// about 45 times a call on CGAL's bunny.
inline SplitResult classify_fragment(const NodePlane& pl, const Vec3d* poly, int n) {
  // Same signs as split_fragment.
  if (pl.on_line) return SplitResult::OnLine;
  const PlaneValue value(pl);
  const double bound = pl.bound;
  bool pos = false, neg = false;
  for (int k = 0; k < n; ++k) {
    const double s = value(poly[k]);
    pos |= s > bound;
    neg |= s < -bound;
    if (pos && neg) return SplitResult::Both;  // the remaining vertices cannot change it
  }
  if (pos) return SplitResult::Positive;
  if (neg) return SplitResult::Negative;
  return SplitResult::ZeroArea;
}

// The same split into caller buffers, each with room for 2n vertices (a piece holds each
// vertex at most once and at most one crossing per edge): `npos` and `nneg` receive the
// pieces' sizes (0 when rounding leaves fewer than 3). Identical arithmetic to the
// vector form; the BSP walk writes the pieces straight into its work list with it (no
// per-vertex capacity checks, no copies of the pieces).
SplitResult split_fragment(const NodePlane& plane, const Vec3d* poly, int n, Vec3d* pos, int& npos, Vec3d* neg,
                           int& nneg);
// The same, except that a Both split whose chord (the vertices both pieces get: those
// within the bound of the plane and the edges' crossings, at most 4) lies beyond the
// plane `side` (every chord vertex below minus side's bound) is flagged: `off` set and no
// pieces (npos = nneg = 0; subtract.cpp puts such a cut off). Otherwise `off` false and
// the result and pieces of split_fragment, bit for bit.
SplitResult split_fragment(const NodePlane& plane, const NodePlane& side, const Vec3d* poly, int n, Vec3d* pos,
                           int& npos, Vec3d* neg, int& nneg, bool& off);

// Keeps the part of `poly` where value >= 0 (keep_nonneg) or value <= 0, given one value
// per vertex of an affine function; the result may be empty. Used to clip occluders to
// the slab between a receiver and the light (DESIGN section 3). Values and the new
// vertices are computed in double (callers evaluate the affine function in double on
// the float vertices) and each new vertex is rounded once to float: a float
// interpolation along an edge of length E errs by u E, which for an edge from a vertex
// far away puts the clipped occluder visibly off at a small light.
// With `on_plane`, on_plane[k] tells whether output vertex k lies on the plane value = 0
// (an interpolated vertex, or an input vertex whose value is exactly 0).
void clip_by_values(const Vec3f* poly, const double* values, int n, bool keep_nonneg, std::vector<Vec3f>& out,
                    std::vector<uint8_t>* on_plane = nullptr);
// The same for polygons in double (occluders in the solver's local coordinates): new
// vertices are not rounded.
void clip_by_values(const Vec3d* poly, const double* values, int n, bool keep_nonneg, std::vector<Vec3d>& out,
                    std::vector<uint8_t>* on_plane = nullptr);
// The same into caller buffers with room for 2n entries (on_plane may be null): returns
// the output's size, 0 when fewer than 3 vertices remain.
int clip_by_values(const Vec3d* poly, const double* values, int n, bool keep_nonneg, Vec3d* out, uint8_t* on_plane);

// Area of a planar polygon (Newell, double).
double polygon_area(const Vec3d* poly, int n);

// The two kept axes (u, v) of the projection of the light plane that drops the axis where
// the light normal is largest (not a Frame3d: no origin, no rotation, coordinates are the
// points' own); `flip` makes counter-clockwise (about the light normal) polygons positive
// in 2D.
struct UVAxes {
  int u = 0, v = 1;
  bool flip = false;
  static UVAxes from_normal(const Vec3f& n);
};

// Coordinate i (0, 1, 2) of a Vec3d as a member pointer: one load at a fixed offset,
// where Vec3d::operator[] branches on i (the hot loops over fragment vertices).
inline double Vec3d::*axis_member(int i) { return i == 0 ? &Vec3d::x : (i == 1 ? &Vec3d::y : &Vec3d::z); }

// A box in the (u, v) coordinates of UVAxes (of the 3D points). Used only to skip work
// that cannot change a result: two fragments whose boxes are disjoint are disjoint.
struct UVBox {
  double ulo = 0, uhi = -1, vlo = 0, vhi = -1;  // empty by default
  static UVBox of(const UVAxes& f, const Vec3d* poly, int n);
  static UVBox everything();
  bool overlaps(const UVBox& b) const { return ulo <= b.uhi && b.ulo <= uhi && vlo <= b.vhi && b.vlo <= vhi; }
  bool contains(double u, double v) const { return u >= ulo && u <= uhi && v >= vlo && v <= vhi; }
  // Inline: the fragment lists' indexes extend boxes per piece (subtract.h FragmentRuns).
  void extend(const UVBox& b) {
    if (b.ulo > b.uhi) return;
    if (ulo > uhi) {
      *this = b;
      return;
    }
    ulo = std::min(ulo, b.ulo);
    uhi = std::max(uhi, b.uhi);
    vlo = std::min(vlo, b.vlo);
    vhi = std::max(vhi, b.vhi);
  }
};

// Boxes bucketed by a g x g grid over a box that holds them all, so that a point reads
// only its cell's list: cell indices floor((x - x0) / w), clamped, are monotone in x, so
// a point inside a box falls in a cell of the box's cell range; a cell lists every box
// that meets it, in increasing index. A flat `all` gives one cell holding every box.
struct UVBoxGrid {
  int grid = 0;
  double u0 = 0, v0 = 0, wu = 1, wv = 1;
  std::vector<uint32_t> start, items, fill;

  // box(k) for k < n: the boxes; g >= 1.
  template <class BoxAt>
  void build(const UVBox& all, int g, size_t n, BoxAt&& box) {
    grid = g;
    u0 = all.ulo, v0 = all.vlo;
    wu = (all.uhi - all.ulo) / g, wv = (all.vhi - all.vlo) / g;
    if (!(wu > 0.0) || !(wv > 0.0)) grid = 1, wu = wv = 1.0;
    start.assign(size_t(grid) * size_t(grid) + 1, 0u);
    for (int pass = 0; pass < 2; ++pass) {
      for (size_t k = 0; k < n; ++k) {
        const UVBox& b = box(k);
        const int cu0 = cell(b.ulo, u0, wu), cu1 = cell(b.uhi, u0, wu), cv0 = cell(b.vlo, v0, wv),
                  cv1 = cell(b.vhi, v0, wv);
        for (int cv = cv0; cv <= cv1; ++cv)
          for (int cu = cu0; cu <= cu1; ++cu) {
            const size_t ci = size_t(cv) * size_t(grid) + size_t(cu);
            if (pass == 0) ++start[ci + 1];
            else items[fill[ci]++] = uint32_t(k);
          }
      }
      if (pass == 0) {
        for (size_t ci = 1; ci < start.size(); ++ci) start[ci] += start[ci - 1];
        items.resize(start.back());
        fill.assign(start.begin(), start.end() - 1);
      }
    }
  }
  // The indices of the boxes that may contain (u, v).
  std::span<const uint32_t> at(double u, double v) const {
    const size_t ci = size_t(cell(v, v0, wv)) * size_t(grid) + size_t(cell(u, u0, wu));
    return {items.data() + start[ci], start[ci + 1] - start[ci]};
  }
  void clear() {
    grid = 0;
    start.clear();
    items.clear();
    fill.clear();
  }

 private:
  int cell(double x, double x0, double w) const {
    const double c = std::floor((x - x0) / w);
    return c < 0.0 ? 0 : (c >= double(grid - 1) ? grid - 1 : int(c));
  }
};

// The light's plane in a local frame: n . x = 0 (the frame's origin is a light vertex),
// the light's own vertices within plane_tol of it, `extent` its largest box side.
struct LightPlane {
  Vec3f n{};
  float plane_tol = 0.0f;
  float extent = 0.0f;
  UVAxes axes;
  // The plane in double: nd . x = h0, nd = n in double and h0 = 0 when it passes through
  // the local origin (a light vertex). A light whose float vertices are not coplanar is
  // lifted onto its Newell plane: nd is then its unit Newell normal in double and h0
  // that of the lifted origin vertex (local_light.cpp make_local_light). Zero nd: n.
  Vec3d nd{0, 0, 0};
  double h0 = 0.0;
};

// A box holding the shadow of the convex polygon q (n vertices) cast from r onto the
// light, in the light's UVAxes, or UVBox::everything() when a vertex of q is not
// between r and the light plane by at least 2^-10 of r's height (its projection is then
// unbounded or too far out to bound usefully). Central projection onto n . x = 0:
// x = r + (p - r) t, t = h(r) / (h(r) - h(p)) with h(x) = n . x, computed in double from
// the float vertices, accepted when h(p) / h(r) <= 1 - 2^-10 (so 0 < t <= 2^10).
// Margin: the fragments lie on the float light polygon, within plane_tol of that plane,
// so a ray meets them within plane_tol (1 + |x - r|_1 / |h(r)|) of x (the in-plane
// offset of a height change along the ray), doubled twice; plus 2^-16 of the coordinates
// for the double rounding (about 1e-16 relative, times t <= 2^10). Conservative: it only
// makes the box larger than the shadow. Used to skip a polygon whose shadow cannot meet
// a fragment (two disjoint boxes: disjoint convex sets).
UVBox shadow_box(const LightPlane& lp, const Vec3d& r, const Vec3d* q, size_t n);

// shadow_box in steps, for callers that reuse a vertex's projection across polygons
// (the same floats: shadow_box is this loop). of(): r's height; project(p): p's two
// coordinates and spread numerator, unbounded when p fails shadow_box's height test;
// box(): the margin over the extremes and the largest spread numerator.
struct ShadowFrame {
  struct Vertex {
    double u = 0.0, v = 0.0, spread = 0.0;
    bool bounded = false;
  };
  Vec3d nd;
  const Vec3d* r = nullptr;  // the receiver (not copied: the frame lives within r's scope)
  double hr = 0.0;
  double Vec3d::*fu = &Vec3d::x;
  double Vec3d::*fv = &Vec3d::y;
  bool bounded = false;  // false: every box is UVBox::everything()
  static ShadowFrame of(const LightPlane& lp, const Vec3d& r) {
    ShadowFrame f;
    f.nd = (lp.nd.x != 0.0 || lp.nd.y != 0.0 || lp.nd.z != 0.0) ? lp.nd : to_double(lp.n);
    f.r = &r;
    f.hr = dot(f.nd, r) - lp.h0;
    f.bounded = std::abs(f.hr) > 0.0;
    f.fu = axis_member(lp.axes.u), f.fv = axis_member(lp.axes.v);
    return f;
  }
  Vertex project(const LightPlane& lp, const Vec3d& p) const {
    Vertex x;
    const double hp = dot(nd, p) - lp.h0;
    if (!(hp / hr <= 1.0 - 0x1p-10)) return x;
    const Vec3d& rd = *r;
    const double t = hr / (hr - hp);
    // The two coordinates of rd + (p - rd) t the box uses, each as that sum computes it.
    x.u = rd.*fu + (p.*fu - rd.*fu) * t, x.v = rd.*fv + (p.*fv - rd.*fv) * t;
    x.spread = std::abs(x.u - rd.*fu) + std::abs(x.v - rd.*fv);
    x.bounded = true;
    return x;
  }
  // The extremes of projected vertices (add) or bounds of them, for box().
  struct Extent {
    double ulo = HUGE_VAL, uhi = -HUGE_VAL, vlo = HUGE_VAL, vhi = -HUGE_VAL, spread = 0.0;
    void add(const Vertex& x) {
      ulo = std::min(ulo, x.u), uhi = std::max(uhi, x.u), vlo = std::min(vlo, x.v), vhi = std::max(vhi, x.v);
      spread = std::max(spread, x.spread);
    }
  };
  UVBox box(const LightPlane& lp, const Extent& e) const {
    // One division: a rounded division by |hr| > 0 is monotone, so the largest quotient is
    // the largest numerator's (0 for no vertex).
    const double spread = e.spread / std::abs(hr);
    const double mag = std::max({std::abs(e.ulo), std::abs(e.uhi), std::abs(e.vlo), std::abs(e.vhi), double(lp.extent)});
    const double margin = double(lp.plane_tol) * 4.0 * (1.0 + spread) + mag * 0x1p-16;
    return UVBox{float(e.ulo - margin), float(e.uhi + margin), float(e.vlo - margin), float(e.vhi + margin)};
  }
};

// shadow_box of the box [lo, hi]'s eight corners, or a box holding it, from the t of six
// corners instead of eight projections: every rounded step there (the dot product, the
// differences, the quotients and products) is monotone in its inputs, so the corners'
// computed heights lie between those of the two corners picked by n's signs (up, dn),
// and among the four corners sharing a coordinate u, (u - r_u) t is extreme at their
// largest and least t (up's and dn's with that u swapped in); the spread and the largest
// coordinate are bounded by the extremes, and the margin is monotone in both. The same
// UVBox::everything() condition (the largest hp / hr is at up).
UVBox shadow_box_of_box(const LightPlane& lp, const Vec3d& r, const Vec3d& lo, const Vec3d& hi);

// Point in a convex fragment on the light plane (counter-clockwise about the light
// normal), boundary included: orientation of p against each edge in the 2D frame,
// accepted when >= -bound with the float bound of a 2D orientation (see fragment.cpp).
// `slack` is the position uncertainty of the fragment's vertices (absolute, per
// coordinate; 0 for exact input polygons): fragment vertices are interpolations,
// so a convex fragment is stored convex only up to slack, and where two computed
// vertices nearly coincide their edge's direction is noise (measured: a 6e-6 long edge
// of a columns fragment, whose line put a sample 1e-3 inside the fragment "outside").
// The bound then grows by the orientation's change under such a move,
// 2 slack (|p_u - a_u| + |p_v - a_v|) + slack (|e_u| + |e_v|): a short edge's line
// constrains only points near it. Far from every edge the answer is unchanged; callers
// that need a tight outer limit test a box first (shade_receiver.cpp sample_bits).
bool point_in_fragment(const UVAxes& f, const Vec3d* poly, int n, const Vec3d& p, double slack = 0.0);

// atan2(y, x) for y >= 0, in [0, pi] (lambert_irradiance's angles theta_k, in fewer
// instructions than std::atan2): within 2^-50 min(1, theta) of the exact angle theta of
// the double inputs (about 2 ulps; measured against long double atan2l, test
// EdgeAngleIsWithinItsBoundOfAtan2), so each edge term theta_k nr . gamma_k of the
// irradiance moves by at most that (|nr . gamma_k| <= 1): far below anything the
// irradiance is compared with, and the fraction, bits and fragments do not use it.
double edge_angle(double y, double x);

// Lambert irradiance at r with unit normal nr from a uniformly emitting polygon of unit
// radiance (Nishita-Nakamae: E = 1/2 sum_k theta_k (nr . gamma_k)), the polygon first
// clipped to the receiver's upper half-space nr . (x - r) >= 0. Double precision.
double lambert_irradiance(const Vec3d& r, const Vec3f& nr, const Vec3d* poly, int n);

}  // namespace visgate::plucker
