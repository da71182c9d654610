// Light fragments (paper 002 section 4.2, Figure 6); see fragment.h.
#include "lib/plucker/fragment.h"

#include <algorithm>
#include <cmath>
#include <limits>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lib/geom/error_bounds.h"
#include "lib/plucker/lines.h"

namespace visgate::plucker {

// Loops over a fragment's vertices are left scalar where GCC would vectorise them:
// fragments have about four vertices, and the vector loop's set-up and remainder cost
// more instructions than it saves (callgrind, columns: split_fragment 145M -> 115M).
// Code generation only; the arithmetic is the same (-ffp-contract=off, no reassociation).
#if defined(__GNUC__) && !defined(__clang__)
#define VG_SCALAR_LOOPS [[gnu::optimize("no-tree-loop-vectorize")]]
#else
#define VG_SCALAR_LOOPS
#endif

namespace {
constexpr int kMaxStack = 64;
// Unit roundoff of double.
constexpr double kUd = kUnitRoundoffD;

// makePlane(xyz, hyperplane) (Algorithm 1 line 18) in double: the plane through r and
// the line a -> b, N = (a - r) x (b - r), from the float inputs in double (the data stay
// float32; the plane is evaluated in double, as ISS evaluates its predicates: in float a
// node's plane is known only to u = 6e-8 of the distance from its base to the light,
// which moves the shadow edges of a small light seen past distant occluders by more
// than the tolerance).
// N is the cross product of the two shortest of a - r, b - r, b - a (lines.h
// edge_plane_normal: (a - r) x (b - r) = (a - r) x (b - a) = (b - r) x (b - a)), with a
// per-component error bound 8 u_d times the component's permanent (lines.h
// edge_plane_normal_err): r is on the node's line when every component is within it.
// Signs against the computed plane: N is taken as exact and only the evaluation of
// d . N is bounded (1 rounding in d, 1 per product, 2 in the sum: < 4.01 u_d
// sum |d_i N_i| <= 4.01 u_d |d|_1 |N|_inf; doubled), so every fragment is split
// consistently by one plane, and "zero area" means inside that plane up to evaluation.
// The plane is evaluated through the one of r, a, b nearest to the light's centroid
// (lines.h nearest_base; (x - a) . N = (x - r) . N because N is orthogonal to a - r), so
// every vertex of every fragment is judged against the same plane: for a receiver far
// from the light x - r is -r to within rounding and (x - r) . N cancels catastrophically.
// The bound of d . N is 8 u_d |N|_inf |d|_1 (its evaluation) plus 2 u_d |N|_1 |x|_inf: a
// fragment vertex x was rounded (when it was interpolated) by up to u_d |x_i| per
// coordinate, so a vertex within that of the plane is on it. Both are taken at their
// largest over the light polygon (fragment.h LightBounds: |d|_1 <= |centroid - base|_1 +
// radius1, |x|_inf <= mag), one number per plane rather than per-vertex norms (a
// measurable part of the loop's instructions). The tolerance so grows to rounding of the light's size, far below
// every fragment the comparator or the fraction can see. Without the vertex term, vertices
// that lie on a plane only to float precision (shared boundaries of earlier splits) were
// split off as slivers: measured on columns, 6x the developments and 2.3x the fragments.

// The point where the edge p0 -> p1 crosses value 0, given the values s0, s1 of an
// affine function at its ends (opposite signs): interpolated from the end nearer the
// plane (smaller |s|), p_near + (p_far - p_near) s_near / (s_near - s_far). From the far
// end, p0 + (p1 - p0) t with t = s0 / (s0 - s1) close to 1 loses everything below u_d of
// the edge's length: for a triangle with a vertex far away, clipped at the light plane,
// t rounds to 1 and the crossing lands far from the plane. From the near end the
// error is u_d times the distance to the crossing. The choice depends only on the two
// ends, not on the direction the edge is walked in (ties broken by the coordinates), so
// the two polygons sharing an edge get the same point.
template <class P>
[[gnu::always_inline]] inline Vec3d edge_crossing(const P& a, const P& b, double sa, double sb) {
  const double aa = std::abs(sa), ab = std::abs(sb);
  bool from_a = aa < ab;
  if (aa == ab) from_a = a.x < b.x || (a.x == b.x && (a.y < b.y || (a.y == b.y && a.z <= b.z)));
  const Vec3d pa(a), pb(b);
  return from_a ? pa + (pb - pa) * (sa / (sa - sb)) : pb + (pa - pb) * (sb / (sb - sa));
}

}  // namespace

LightBounds LightBounds::of(const Vec3d* poly, int n) {
  LightBounds lb;
  if (n <= 0) return lb;
  Vec3d c(0, 0, 0);
  for (int k = 0; k < n; ++k) c += poly[k];
  lb.centroid = c / double(n);
  for (int k = 0; k < n; ++k) {
    const Vec3d d = poly[k] - lb.centroid;
    lb.radius1 = std::max(lb.radius1, std::abs(d.x) + std::abs(d.y) + std::abs(d.z));
    lb.mag = std::max(lb.mag, max_component(vabs(poly[k])));
  }
  lb.radius1 *= 1.0 + 0x1p-50;
  lb.mag *= 1.0 + 0x1p-50;
  return lb;
}

NodePlane node_plane(const Vec3d& r, const Vec3d& a, const Vec3d& b, const LightBounds& light) {
  return node_plane(r, a, b, light, light.dist1(r), light.dist1(a), light.dist1(b));
}

NodePlane node_plane(const Vec3d& r, const Vec3d& a, const Vec3d& b, const LightBounds& light, double dr, double da,
                     double db) {
  NodePlane p;
  // lines.h edge_plane_normal_err: N from the two shortest of a - r, b - r, b - a, and r
  // on the line when every component of N is within its error bound 8 u_d (|u_j v_k| +
  // |u_k v_j|); the bounds are computed component by component and only until one
  // component exceeds its own (the same values and the same answer).
  const Vec3d pa = a - r, pb = b - r, ab = b - a;
  const double na = norm1(pa), nb = norm1(pb), nab = norm1(ab);
  const Vec3d* u = &pa;
  const Vec3d* v = &pb;
  if (!(nab >= na && nab >= nb)) {
    if (nb >= na) v = &ab;
    else u = &pb, v = &ab;
  }
  p.n = cross(*u, *v);
  constexpr double ke = 8.0 * kUnitRoundoffD;
  p.on_line = std::abs(p.n.x) <= (std::abs(u->y * v->z) + std::abs(u->z * v->y)) * ke &&
              std::abs(p.n.y) <= (std::abs(u->z * v->x) + std::abs(u->x * v->z)) * ke &&
              std::abs(p.n.z) <= (std::abs(u->x * v->y) + std::abs(u->y * v->x)) * ke;
  // nearest_base (lines.h) against the centroid, keeping the chosen 1-norm |centroid -
  // base|_1 for the bound.
  double dn = 0.0;
  if (dr <= da && dr <= db) p.base = r, dn = dr;
  else if (da <= db) p.base = a, dn = da;
  else p.base = b, dn = db;
  const double d1 = dn * (1.0 + 0x1p-50) + light.radius1;
  p.bound = 8.0 * kUd * max_component(vabs(p.n)) * d1 +
            2.0 * kUd * (std::abs(p.n.x) + std::abs(p.n.y) + std::abs(p.n.z)) * light.mag;
  return p;
}

SplitResult classify_fragment(const Vec3d& r, const Vec3d& a, const Vec3d& b, const Vec3d* poly, int n) {
  return classify_fragment(node_plane(r, a, b, LightBounds::of(poly, n)), poly, n);
}

SplitResult split_fragment(const Vec3d& r, const Vec3d& a, const Vec3d& b, const Vec3d* poly, int n,
                           std::vector<Vec3d>& pos, std::vector<Vec3d>& neg) {
  return split_fragment(node_plane(r, a, b, LightBounds::of(poly, n)), poly, n, pos, neg);
}

SplitResult split_fragment(const NodePlane& pl, const Vec3d* poly, int n, std::vector<Vec3d>& pos,
                           std::vector<Vec3d>& neg) {
  if (pos.size() < size_t(2 * n)) pos.resize(size_t(2 * n));
  if (neg.size() < size_t(2 * n)) neg.resize(size_t(2 * n));
  int np = 0, nn = 0;
  const SplitResult s = split_fragment(pl, poly, n, pos.data(), np, neg.data(), nn);
  if (s == SplitResult::Both) {
    pos.resize(size_t(np));
    neg.resize(size_t(nn));
  }
  return s;
}

namespace {
// split_fragment's steps; with kSide, the flag of the overload below against *side.
template <bool kSide>
[[gnu::always_inline]] VG_SCALAR_LOOPS inline SplitResult split_pieces(const NodePlane& pl, const NodePlane* side,
                                                                       const Vec3d* poly, int n, Vec3d* pos, int& npos,
                                                                       Vec3d* neg, int& nneg, bool& off) {
  // det[x - r, a - r, b - r] = (x - base) . N = side(line(r, x), line(a, b)) (node_plane).
  // Query point on the node's line: N vanishes within its error bound.
  if (pl.on_line) return SplitResult::OnLine;

  double val_buf[kMaxStack];  // NOLINT
  double* val = val_buf;
  if (n > kMaxStack) {
    thread_local std::vector<double> val_heap;  // rare: fragments of more than 64 vertices
    val_heap.resize(size_t(n));
    val = val_heap.data();
  }
  int cpos = 0, cneg = 0;
  const PlaneValue value(pl);
  const double bound = pl.bound;
  for (int k = 0; k < n; ++k) {
    double s = value(poly[k]);
    if (s > bound) ++cpos;
    else if (s < -bound) ++cneg;
    else s = 0.0;  // on the plane within the error bound: belongs to both pieces
    val[k] = s;
  }
  if (cneg == 0 && cpos == 0) return SplitResult::ZeroArea;
  if (cneg == 0) return SplitResult::Positive;
  if (cpos == 0) return SplitResult::Negative;

  // Line 25: L cap p+ and L cap p-; vertices on the plane go to both, edges crossing
  // strictly get one vertex, interpolated in double and rounded once, shared by both
  // pieces. With kSide the chord's vertices (those both pieces get) are kept aside, at
  // most 4 (more: a fragment with vertices along the plane, not put off).
  Vec3d ch[4];
  int p = 0, q = 0, c = 0;
  for (int k = 0; k < n; ++k) {
    int k1 = (k + 1 == n) ? 0 : k + 1;
    double s0 = val[k], s1 = val[k1];
    if (s0 >= 0.0) pos[p++] = poly[k];
    if (s0 <= 0.0) neg[q++] = poly[k];
    if (kSide && s0 == 0.0) ch[c & 3] = poly[k], ++c;
    if ((s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0)) {
      Vec3d x = edge_crossing(poly[k], poly[k1], s0, s1);
      pos[p++] = x;
      neg[q++] = x;
      if (kSide) ch[c & 3] = x, ++c;
    }
  }
  npos = p >= 3 ? p : 0;
  nneg = q >= 3 ? q : 0;
  if (kSide && c >= 1 && c <= 4 && npos != 0 && nneg != 0 && !side->on_line) {
    const PlaneValue sv(*side);
    bool beyond = true;
    for (int i = 0; i < c && beyond; ++i) beyond = sv(ch[i]) < -side->bound;
    if (beyond) {
      off = true;
      npos = nneg = 0;
    }
  }
  return SplitResult::Both;
}
}  // namespace

VG_SCALAR_LOOPS SplitResult split_fragment(const NodePlane& pl, const Vec3d* poly, int n, Vec3d* pos, int& npos,
                                           Vec3d* neg, int& nneg) {
  bool off = false;
  return split_pieces<false>(pl, nullptr, poly, n, pos, npos, neg, nneg, off);
}

VG_SCALAR_LOOPS SplitResult split_fragment(const NodePlane& pl, const NodePlane& side, const Vec3d* poly, int n,
                                           Vec3d* pos, int& npos, Vec3d* neg, int& nneg, bool& off) {
  off = false;
  return split_pieces<true>(pl, &side, poly, n, pos, npos, neg, nneg, off);
}

namespace {
// The clip's walk: emit(point, on the plane) for each output vertex in order (each input
// vertex and each edge's crossing at most once: at most 2n).
template <class P, class Emit>
void clip_values_walk(const P* poly, const double* values, int n, bool keep_nonneg, Emit&& emit) {
  for (int k = 0; k < n; ++k) {
    int k1 = (k + 1 == n) ? 0 : k + 1;
    double s0 = keep_nonneg ? values[k] : -values[k];
    double s1 = keep_nonneg ? values[k1] : -values[k1];
    if (s0 >= 0.0) emit(poly[k], s0 == 0.0);
    if ((s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0)) emit(P(edge_crossing(poly[k], poly[k1], s0, s1)), true);
  }
}

template <class P>
void clip_values_impl(const P* poly, const double* values, int n, bool keep_nonneg, std::vector<P>& out,
                      std::vector<uint8_t>* on_plane) {
  out.clear();
  if (on_plane) on_plane->clear();
  clip_values_walk(poly, values, n, keep_nonneg, [&](const P& x, bool on) {
    out.push_back(x);
    if (on_plane) on_plane->push_back(on);
  });
  if (out.size() < 3) {
    out.clear();
    if (on_plane) on_plane->clear();
  }
}
}  // namespace

int clip_by_values(const Vec3d* poly, const double* values, int n, bool keep_nonneg, Vec3d* out, uint8_t* on_plane) {
  int m = 0;
  clip_values_walk(poly, values, n, keep_nonneg, [&](const Vec3d& x, bool on) {
    if (on_plane) on_plane[m] = on;
    out[m++] = x;
  });
  return m >= 3 ? m : 0;
}

void clip_by_values(const Vec3d* poly, const double* values, int n, bool keep_nonneg, std::vector<Vec3d>& out,
                    std::vector<uint8_t>* on_plane) {
  clip_values_impl(poly, values, n, keep_nonneg, out, on_plane);
}

void clip_by_values(const Vec3f* poly, const double* values, int n, bool keep_nonneg, std::vector<Vec3f>& out,
                    std::vector<uint8_t>* on_plane) {
  clip_values_impl(poly, values, n, keep_nonneg, out, on_plane);
}

double polygon_area(const Vec3d* poly, int n) {
  if (n < 3) return 0.0;
  Vec3d o = poly[0], acc(0, 0, 0);
  for (int k = 1; k + 1 < n; ++k) acc += cross(poly[k] - o, poly[k + 1] - o);
  return 0.5 * length(acc);
}

UVAxes UVAxes::from_normal(const Vec3f& n) {
  UVAxes f;
  int w = max_axis(vabs(n));
  f.u = (w + 1) % 3;
  f.v = (w + 2) % 3;
  // (e_u x e_v) = e_w for the cyclic order, so a polygon counter-clockwise about n is
  // counter-clockwise in (u, v) iff n_w > 0.
  f.flip = n[w] < 0.0f;
  return f;
}

UVBox UVBox::of(const UVAxes& f, const Vec3d* poly, int n) {
  UVBox b;
  if (n <= 0) return b;
  const auto mu = axis_member(f.u), mv = axis_member(f.v);
#if defined(__SSE2__)
  // (u, v) in the two lanes of one register: _mm_min_pd(x, lo) is x < lo ? x : lo and
  // _mm_max_pd(x, hi) is hi < x ? x : hi per lane, the comparisons of std::min(lo, x) and
  // std::max(hi, x) (NaNs and signed zeros included), so the box has the scalar form's
  // bits with half its operations (about 5 fragments' boxes a receiver and BSP visit).
  __m128d lo = _mm_set_pd(poly[0].*mv, poly[0].*mu), hi = lo;
  for (int k = 1; k < n; ++k) {
    const __m128d x = _mm_set_pd(poly[k].*mv, poly[k].*mu);
    lo = _mm_min_pd(x, lo);
    hi = _mm_max_pd(x, hi);
  }
  alignas(16) double l[2], h[2];
  _mm_store_pd(l, lo);
  _mm_store_pd(h, hi);
  b.ulo = l[0], b.vlo = l[1], b.uhi = h[0], b.vhi = h[1];
  return b;
#else
  b.ulo = b.uhi = poly[0].*mu;
  b.vlo = b.vhi = poly[0].*mv;
  for (int k = 1; k < n; ++k) {
    b.ulo = std::min(b.ulo, poly[k].*mu);
    b.uhi = std::max(b.uhi, poly[k].*mu);
    b.vlo = std::min(b.vlo, poly[k].*mv);
    b.vhi = std::max(b.vhi, poly[k].*mv);
  }
  return b;
#endif
}

UVBox UVBox::everything() {
  constexpr double inf = std::numeric_limits<double>::infinity();
  return UVBox{-inf, inf, -inf, inf};
}

UVBox shadow_box(const LightPlane& lp, const Vec3d& rd, const Vec3d* q, size_t n) {
  const ShadowFrame f = ShadowFrame::of(lp, rd);
  if (!f.bounded) return UVBox::everything();
  ShadowFrame::Extent e;
  for (size_t k = 0; k < n; ++k) {
    const ShadowFrame::Vertex x = f.project(lp, q[k]);
    if (!x.bounded) return UVBox::everything();
    e.add(x);
  }
  return f.box(lp, e);
}

UVBox shadow_box_of_box(const LightPlane& lp, const Vec3d& rd, const Vec3d& lo, const Vec3d& hi) {
  const ShadowFrame f = ShadowFrame::of(lp, rd);
  if (!f.bounded) return UVBox::everything();
  const Vec3d& nd = f.nd;
  const double hr = f.hr;
  // up: the corner of the largest hp / hr (so of the largest t: both quotients are
  // monotone in it), each coordinate picked by nd's sign; dn: the opposite corner. A
  // corner's height is dot(nd, c) - h0 as shadow_box computes it, from the products
  // n_i c_i of its coordinates (pu for up's, pd for dn's).
  double up[3], dn[3], pu[3], pd[3];
  const double n3[3] = {nd.x, nd.y, nd.z}, lo3[3] = {lo.x, lo.y, lo.z}, hi3[3] = {hi.x, hi.y, hi.z};
  for (int i = 0; i < 3; ++i) {
    const bool raise = (n3[i] >= 0.0) == (hr > 0.0);
    up[i] = raise ? hi3[i] : lo3[i];
    dn[i] = raise ? lo3[i] : hi3[i];
    pu[i] = n3[i] * up[i];
    pd[i] = n3[i] * dn[i];
  }
  const double hup = pu[0] + pu[1] + pu[2] - lp.h0, hdn = pd[0] + pd[1] + pd[2] - lp.h0;
  // up holds the largest quotient; dn's test catches a NaN in the other coordinates.
  if (!(hup / hr <= 1.0 - 0x1p-10) || !(hdn / hr <= 1.0 - 0x1p-10)) return UVBox::everything();
  const int iu = lp.axes.u, iv = lp.axes.v;
  // t at up with dn's coordinate on axis a, and at dn with up's.
  const auto t_up_but = [&](int a) {
    double q[3] = {pu[0], pu[1], pu[2]};
    q[a] = pd[a];
    return hr / (hr - (q[0] + q[1] + q[2] - lp.h0));
  };
  const auto t_dn_but = [&](int a) {
    double q[3] = {pd[0], pd[1], pd[2]};
    q[a] = pu[a];
    return hr / (hr - (q[0] + q[1] + q[2] - lp.h0));
  };
  const double tup = hr / (hr - hup), tdn = hr / (hr - hdn);
  // The extremes of coordinate a (u or v): among the four corners sharing up's a, the
  // product (a - r_a) t is monotone in t, so extreme at their largest and least t: at up
  // and at dn with up's a; among those with dn's a, at up with dn's a and at dn.
  const auto range = [&](int a, double& mn, double& mx) {
    const double ra = rd[a], x = up[a] - ra, y = dn[a] - ra;
    const double c0 = ra + x * tup, c1 = ra + x * t_dn_but(a), c2 = ra + y * tdn, c3 = ra + y * t_up_but(a);
    mn = std::min(std::min(c0, c1), std::min(c2, c3));
    mx = std::max(std::max(c0, c1), std::max(c2, c3));
  };
  ShadowFrame::Extent e;
  range(iu, e.ulo, e.uhi);
  range(iv, e.vlo, e.vhi);
  // The spread's bound: every corner's |u - r_u| and |v - r_v| are at most these.
  e.spread = std::max(std::abs(e.ulo - rd[iu]), std::abs(e.uhi - rd[iu])) +
             std::max(std::abs(e.vlo - rd[iv]), std::abs(e.vhi - rd[iv]));
  return f.box(lp, e);
}

bool point_in_fragment(const UVAxes& f, const Vec3d* poly, int n, const Vec3d& p, double slack) {
  // 2D orientation (b - a) x (p - a) in double: 2 differences per factor, 2 products,
  // 1 subtraction, < 5.01 u_d of the permanent |bu - au||pv - av| + |bv - av||pu - au|;
  // 8 u_d accepts points on the boundary (shared edges of neighbouring fragments are the
  // same segment, so no sample falls between them).
  const double bound_k = 8.0 * kUnitRoundoffD;
  const auto mu = axis_member(f.u), mv = axis_member(f.v);
  for (int k = 0; k < n; ++k) {
    const Vec3d& a = poly[k];
    const Vec3d& b = poly[(k + 1 == n) ? 0 : k + 1];
    double eu = b.*mu - a.*mu, ev = b.*mv - a.*mv;
    double pu = p.*mu - a.*mu, pv = p.*mv - a.*mv;
    double o = eu * pv - ev * pu;
    if (f.flip) o = -o;
    if (o >= 0.0) continue;  // inside this edge whatever the bound (it is >= 0)
    double bound = bound_k * (std::abs(eu * pv) + std::abs(ev * pu)) +
                   slack * (2.0 * (std::abs(pu) + std::abs(pv)) + std::abs(eu) + std::abs(ev));
    if (o < -bound) return false;
  }
  return true;
}

// atan2(y, x) for y >= 0 (fragment.h). The quotient t = min(y, |x|) / max(y, |x|) in
// [0, 1] is reduced about the nearest c = i / 16 (atan t = atan c + atan u, u = (t - c) /
// (1 + t c), |u| <= 1/32; t - c is exact by Sterbenz for i >= 1) and atan u is its series
// to u^11 (the next term, u^13 / 13 < 2^-68, is far below an ulp of the result); the
// octant's constant (atan c, pi/2 - atan c, pi - atan c or pi/2 + atan c, each rounded
// once from a 200-bit value) is added last. NaN or two infinite inputs take std::atan2.
namespace {
// edge_angle's body, inlined into lambert_irradiance's edge loop.
[[gnu::always_inline]] inline double edge_angle_inline(double y, double x) {
  static constexpr double kBase[4][17] = {{
      // atan c
      0x0.0p+0, 0x1.ff55bb72cfdeap-5, 0x1.fd5ba9aac2f6ep-4, 0x1.7b97b4bce5b02p-3,
      0x1.f5b75f92c80ddp-3, 0x1.362773707ebccp-2, 0x1.6f61941e4def1p-2, 0x1.a64eec3cc23fdp-2,
      0x1.dac670561bb4fp-2, 0x1.0657e94db30d0p-1, 0x1.1e00babdefeb4p-1, 0x1.345f01cce37bbp-1,
      0x1.4978fa3269ee1p-1, 0x1.5d58987169b18p-1, 0x1.700a7c5784634p-1, 0x1.819d0b7158a4dp-1,
      0x1.921fb54442d18p-1}, {
      // pi/2 - atan c
      0x1.921fb54442d18p+0, 0x1.82250768ac529p+0, 0x1.7249faa996a21p+0, 0x1.62acbeaca61b8p+0,
      0x1.5368c951e9cfdp+0, 0x1.4495d86823225p+0, 0x1.3647503caf55cp+0, 0x1.288bfa3512419p+0,
      0x1.1b6e192ebbe44p+0, 0x1.0ef3c09d694b0p+0, 0x1.031f57e54adbep+0, 0x1.efe068bba2275p-1,
      0x1.dac670561bb4fp-1, 0x1.c6e6d2171bf18p-1, 0x1.b434ee31013fdp-1, 0x1.a2a25f172cfe4p-1,
      0x1.921fb54442d18p-1}, {
      // pi - atan c
      0x1.921fb54442d18p+1, 0x1.8a225e5677921p+1, 0x1.8234d7f6ecb9dp+1, 0x1.7a6639f874768p+1,
      0x1.72c43f4b1650ap+1, 0x1.6b5ac6d632f9fp+1, 0x1.643382c07913ap+1, 0x1.5d55d7bcaa899p+1,
      0x1.56c6e7397f5aep+1, 0x1.5089baf0d60e4p+1, 0x1.4a9f8694c6d6bp+1, 0x1.4507f4d109f29p+1,
      0x1.3fc176b7a8560p+1, 0x1.3ac98f27e8652p+1, 0x1.361d162e61b8bp+1, 0x1.31b87267eca85p+1,
      0x1.2d97c7f3321d2p+1}, {
      // pi/2 + atan c
      0x1.921fb54442d18p+0, 0x1.a21a631fd9508p+0, 0x1.b1f56fdeef00fp+0, 0x1.c192abdbdf879p+0,
      0x1.d0d6a1369bd34p+0, 0x1.dfa992206280bp+0, 0x1.edf81a4bd64d4p+0, 0x1.fbb3705373617p+0,
      0x1.0468a8ace4df6p+1, 0x1.0aa5d4f58e2c0p+1, 0x1.109009519d639p+1, 0x1.16279b155a47bp+1,
      0x1.1b6e192ebbe44p+1, 0x1.206600be7bd52p+1, 0x1.251279b802819p+1, 0x1.29771d7e7791fp+1,
      0x1.2d97c7f3321d2p+1}};
  const double ax = std::abs(x);
  const bool steep = y > ax;  // within pi/4 of pi/2: the quotient the other way up
  const double t = steep ? ax / y : y / ax;
  if (!(t >= 0.0 && t <= 1.0)) return std::atan2(y, x);
  const int i = int(t * 16.0 + 0.5);
  const double c = double(i) * 0.0625;
  const double u = (t - c) / (1.0 + t * c);
  const double u2 = u * u;
  const double p =
      u + u * u2 * (-1.0 / 3.0 + u2 * (1.0 / 5.0 + u2 * (-1.0 / 7.0 + u2 * (1.0 / 9.0 + u2 * (-1.0 / 11.0)))));
  // x >= 0: atan c + p, or pi/2 - (atan c + p) when steep; x < 0: pi - (atan c + p), or
  // pi/2 + atan c + p when steep.
  const int o = x < 0.0 ? (steep ? 3 : 2) : (steep ? 1 : 0);
  return (o == 0 || o == 3) ? kBase[o][i] + p : kBase[o][i] - p;
}
}  // namespace

double edge_angle(double y, double x) { return edge_angle_inline(y, x); }

double lambert_irradiance(const Vec3d& rd, const Vec3f& nr, const Vec3d* poly, int n) {
  // Clip to the receiver's upper half-space, in double relative to r, and sum the edge
  // terms of the clipped polygon as its vertices come out (no buffer: a stack array of
  // Vec3d is zero-initialised on every call, 0.7% of a columns solve).
  // E = 1/2 sum_k theta_k (nr . gamma_k), gamma_k the unit normal of (q_k, q_k+1) seen
  // from r; the sign makes a polygon counter-clockwise about its emitting normal (facing
  // r) positive, and the absolute value makes the result independent of the winding.
  // Each vertex's offset from r, its height over r's plane and its squared length are
  // computed once and carried to the next edge (the same values as computing them per
  // edge end).
  const Vec3d nd = to_double(nr);
  double sum = 0.0;
  auto term = [&](const Vec3d& a, double aa, const Vec3d& b, double bb) {
    if (aa == 0.0 || bb == 0.0) return;  // length() == 0 exactly then, without the roots
    Vec3d c = cross(a, b);
    double lc = length(c);
    if (lc == 0.0) return;
    double theta = edge_angle_inline(lc, dot(a, b));
    sum += theta * dot(nd, c) / lc;
  };
  int qn = 0;
  Vec3d first, prev;
  double first_sq = 0.0, prev_sq = 0.0;
  auto emit = [&](const Vec3d& v) {
    const double vv = dot(v, v);
    if (qn == 0) first = v, first_sq = vv;
    else term(prev, prev_sq, v, vv);
    prev = v;
    prev_sq = vv;
    ++qn;
  };
  if (n <= 0) return 0.0;
  const Vec3d p_first = poly[0] - rd;
  const double s_first = dot(nd, p_first);
  Vec3d p0 = p_first;
  double s0 = s_first;
  for (int k = 0; k < n; ++k) {
    const bool last = k + 1 == n;
    const Vec3d p1 = last ? p_first : poly[k + 1] - rd;
    const double s1 = last ? s_first : dot(nd, p1);
    if (s0 >= 0.0) emit(p0);
    if ((s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0)) emit(p0 + (p1 - p0) * (s0 / (s0 - s1)));
    p0 = p1;
    s0 = s1;
  }
  if (qn < 3) return 0.0;
  term(prev, prev_sq, first, first_sq);
  return 0.5 * std::abs(sum);
}

}  // namespace visgate::plucker
