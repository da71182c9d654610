// The region oracle (DESIGN section 5): exact visible region of a light polygon from a
// receiver with Epeck and CGAL's 2D Boolean set operations. This is the only translation
// unit of visgate that instantiates the Boolean-operation code (DESIGN section 9). The
// exact frame, the blocker cases and the irradiance formula are documented in
// region_oracle.h.
#include "oracle/region_oracle.h"

#include <CGAL/Boolean_set_operations_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>
#include <CGAL/Polygon_set_2.h>
#include <CGAL/Polygon_with_holes_2.h>
#include <CGAL/convex_hull_2.h>

#include <cmath>
#include <numbers>

#include "lib/geom/float_mode.h"

namespace visgate::oracle {

namespace {

using EK = CGAL::Epeck;
using FT = EK::FT;
using Pt2 = EK::Point_2;
using Poly = CGAL::Polygon_2<EK>;
using PolyH = CGAL::Polygon_with_holes_2<EK>;
using PolySet = CGAL::Polygon_set_2<EK>;
using V3 = Vec3<FT>;
using IK = CGAL::Epick;

V3 exact3(const Vec3f& v) { return V3(FT(double(v.x)), FT(double(v.y)), FT(double(v.z))); }
IK::Point_3 ipt(const Vec3f& v) { return IK::Point_3(double(v.x), double(v.y), double(v.z)); }
// Double nearest (within one ulp) to an exact value. CGAL::to_double on a lazy number
// may return its interval's midpoint with a relative error up to 1e-5
// (Lazy_exact_nt's default relative precision of to_double), which is far too coarse
// for the culling bounds and the reported fraction: always go through the exact value.
double to_double_exact(const FT& x) { return CGAL::to_double(x.exact()); }
Vec3d approx(const V3& v) { return Vec3d(to_double_exact(v.x), to_double_exact(v.y), to_double_exact(v.z)); }

// Collapses the lazy-evaluation DAG behind a value: computes it exactly once and keeps
// only the result, so the Boolean operations do not re-walk clipping expressions.
FT squash(const FT& x) {
  x.exact();
  return x;
}

// The exact light frame of region_oracle.h.
struct LightFrame {
  V3 n;                    // exact Newell normal (emitting side)
  FT d0;                   // plane: n . x = d0
  int k = 2, i1 = 0, i2 = 1;  // dropped axis and the two kept ones
  Poly polygon;            // light polygon in the frame, counter-clockwise
  bool reversed = false;   // the frame's CCW runs against the light's own order
  std::vector<V3> lifted;  // vertices of the convex hull of `polygon`, lifted to the plane
  double scale = 1.0;      // 3D area = frame area * scale (|n| / |n_k|)

  V3 lift(const Pt2& p) const {
    V3 x;
    x[i1] = p.x();
    x[i2] = p.y();
    x[k] = (d0 - n[i1] * p.x() - n[i2] * p.y()) / n[k];
    return x;
  }
  FT height(const V3& x) const { return dot(n, x) - d0; }
};

// Removes repeated consecutive vertices and vertices collinear with their neighbours.
void simplify(std::vector<Pt2>& pts) {
  bool changed = true;
  while (changed && pts.size() >= 3) {
    changed = false;
    for (size_t i = 0; i < pts.size() && pts.size() >= 3; ++i) {
      const Pt2& a = pts[(i + pts.size() - 1) % pts.size()];
      const Pt2& b = pts[i];
      const Pt2& c = pts[(i + 1) % pts.size()];
      if (a == b || CGAL::collinear(a, b, c)) {
        pts.erase(pts.begin() + long(i));
        changed = true;
        --i;
      }
    }
  }
}

LightFrame make_frame(const Light& light) {
  LightFrame f;
  const auto& v = light.polygon;
  size_t m = v.size();
  V3 c;
  for (size_t j = 0; j < m; ++j) {
    V3 a = exact3(v[j]), b = exact3(v[(j + 1) % m]);
    f.n += cross(a, b);
    c += a;
  }
  c = c / FT(double(m));
  for (int j = 0; j < 3; ++j) f.n[j] = squash(f.n[j]);
  f.d0 = squash(dot(f.n, c));
  f.k = 0;
  for (int j = 1; j < 3; ++j)
    if (CGAL::abs(f.n[j]) > CGAL::abs(f.n[f.k])) f.k = j;
  f.i1 = (f.k + 1) % 3;
  f.i2 = (f.k + 2) % 3;
  VG_CHECK(!CGAL::is_zero(f.n[f.k]));
  std::vector<Pt2> pts;
  for (const Vec3f& p : v) pts.emplace_back(FT(double(p[f.i1])), FT(double(p[f.i2])));
  simplify(pts);
  VG_CHECK(pts.size() >= 3);
  f.polygon = Poly(pts.begin(), pts.end());
  VG_CHECK(f.polygon.is_simple());
  if (f.polygon.orientation() == CGAL::CLOCKWISE) {
    f.polygon.reverse_orientation();
    f.reversed = true;
  }
  std::vector<Pt2> hull;
  CGAL::convex_hull_2(pts.begin(), pts.end(), std::back_inserter(hull));
  for (const Pt2& p : hull) {
    V3 x = f.lift(p);
    x[f.k] = squash(x[f.k]);
    f.lifted.push_back(x);
  }
  Vec3d nd = approx(f.n);
  f.scale = length(nd) / std::abs(nd[f.k]);
  return f;
}

// Sutherland-Hodgman step, exact: keeps the part of the convex polygon with
// dot(m, x) - e >= 0.
std::vector<V3> clip(const std::vector<V3>& poly, const V3& m, const FT& e) {
  std::vector<V3> out;
  size_t n = poly.size();
  if (n == 0) return out;
  std::vector<FT> val(n);
  std::vector<CGAL::Sign> sg(n);
  for (size_t i = 0; i < n; ++i) {
    val[i] = dot(m, poly[i]) - e;
    sg[i] = CGAL::sign(val[i]);
  }
  for (size_t i = 0; i < n; ++i) {
    size_t j = (i + 1) % n;
    if (sg[i] != CGAL::NEGATIVE) out.push_back(poly[i]);
    if ((sg[i] == CGAL::POSITIVE && sg[j] == CGAL::NEGATIVE) || (sg[i] == CGAL::NEGATIVE && sg[j] == CGAL::POSITIVE)) {
      FT t = val[i] / (val[i] - val[j]);
      V3 x = poly[i] + (poly[j] - poly[i]) * t;
      for (int a = 0; a < 3; ++a) x[a] = squash(x[a]);
      out.push_back(x);
    }
  }
  return out;
}

// Double-precision culling data for one receiver and light: the pyramid's box and side
// planes (outward normals). Inputs are exact doubles (floats) or within one ulp of the
// exact lifted light vertices. With M the largest coordinate magnitude, |x - r| <= 2
// sqrt(3) M < 4 M, so for a side normal m = a x b (a, b the edge's hull vertices minus r)
// the rounding of dot(m, x - r) is below ~8e-16 |a| |b| 4M; a triangle is culled only when
// all its vertices are outside one side by more than eps = 1e-9 |a| |b| 4M, or outside the
// box by more than 1e-9 M: six orders of magnitude above the rounding, so no triangle
// meeting the exact pyramid is ever culled (whatever the pyramid's shape).
struct Cull {
  Vec3d r, lo, hi;
  std::vector<Vec3d> normals;
  std::vector<double> eps;

  bool outside(const Vec3d& a, const Vec3d& b, const Vec3d& c) const {
    Vec3d tlo = vmin(a, vmin(b, c)), thi = vmax(a, vmax(b, c));
    for (int k = 0; k < 3; ++k)
      if (thi[k] < lo[k] || tlo[k] > hi[k]) return true;
    for (size_t f = 0; f < normals.size(); ++f) {
      const Vec3d& m = normals[f];
      if (dot(m, a - r) > eps[f] && dot(m, b - r) > eps[f] && dot(m, c - r) > eps[f]) return true;
    }
    return false;
  }
};

Cull make_cull(const LightFrame& f, const Vec3f& rf, double coord_scale) {
  Cull c;
  c.r = to_double(rf);
  double e = 1e-9 * coord_scale;
  c.lo = c.r;
  c.hi = c.r;
  std::vector<Vec3d> L;
  for (const V3& x : f.lifted) L.push_back(approx(x));
  Vec3d centre{};
  for (const Vec3d& x : L) {
    c.lo = vmin(c.lo, x);
    c.hi = vmax(c.hi, x);
    centre += x;
  }
  centre = centre / double(L.size());
  for (int k = 0; k < 3; ++k) {
    c.lo[k] -= e;
    c.hi[k] += e;
  }
  for (size_t j = 0; j < L.size(); ++j) {
    Vec3d m = cross(L[j] - c.r, L[(j + 1) % L.size()] - c.r);
    if (dot(m, centre - c.r) > 0) m = -m;  // outward
    c.normals.push_back(m);
    c.eps.push_back(length(L[j] - c.r) * length(L[(j + 1) % L.size()] - c.r) * 4.0 * e);
  }
  return c;
}

// The double-precision pre-pass (region_oracle.h "Fast paths"). Every value is a
// polynomial of exactly representable inputs (float coordinates, and the light's exact
// plane and lifted vertices rounded to the nearest double) evaluated in double, and its
// sign is trusted only beyond a forward error bound; anything not certain is Unknown and
// goes to the exact path, so the pre-pass never changes an answer.
//
// Bounds (u = 2^-53): g(x) = n . x - d0 from n and d0 rounded once (relative u each):
// 3 products and 3 sums, |err| < 8u (|n|_1 |x|_inf + |d0|) (rounding of the inputs
// included, generously). orient(p, q, x) = det[p - r, q - r, x - r] from double
// differences: Shewchuk's orient3d errboundA (7 + 56u) u of the permanent
// |p-r|_1-style sum; a light vertex x rounded by at most u |x|_inf moves it by at most
// |(p - r) x (q - r)|_1 u |x|_inf. Both are doubled below.
struct FastPass {
  Vec3d r, n;
  double d0 = 0, sgn = 1, gr = 0, gr_err = 0;
  std::vector<Vec3d> L;  // the exact light's hull vertices, rounded to double
  double lmax = 0;       // largest |coordinate| of L

  double g(const Vec3d& x, double& err) const {
    double v = sgn * (dot(n, x) - d0);
    err = 16.0 * 0x1p-53 * ((std::abs(n.x) + std::abs(n.y) + std::abs(n.z)) * max_component(vabs(x)) + std::abs(d0));
    return v;
  }
  // det[p - r, q - r, x - r] and its error bound; `x_rounded` adds the light-vertex term.
  double orient(const Vec3d& p, const Vec3d& q, const Vec3d& x, bool x_rounded, double& err) const {
    Vec3d a = p - r, b = q - r, c = x - r;
    Vec3d ab = cross(a, b);
    double v = dot(ab, c);
    double perm = std::abs(c.x) * (std::abs(a.y * b.z) + std::abs(a.z * b.y)) +
                  std::abs(c.y) * (std::abs(a.z * b.x) + std::abs(a.x * b.z)) +
                  std::abs(c.z) * (std::abs(a.x * b.y) + std::abs(a.y * b.x));
    err = 2.0 * (7.0 + 56.0 * 0x1p-53) * 0x1p-53 * perm;
    if (x_rounded)
      err += 2.0 * (std::abs(ab.x) + std::abs(ab.y) + std::abs(ab.z)) * 0x1p-53 * max_component(vabs(x));
    return v;
  }
};

enum class Fast : uint8_t { Miss, Cover, Unknown };

// One triangle against the light as seen from r: Miss when its shadow certainly has no
// interior point in common with the light, Cover when it certainly hides every light
// point (every segment from r to the light crosses its interior strictly between the
// endpoints), else Unknown. Only triangles certainly strictly inside the open slab
// (0 < g < g_r at every vertex) are decided: their shadow is the central projection of
// the whole triangle, the wedge of the three planes through r and an edge.
Fast fast_classify(const FastPass& fp, const Vec3d tri[3]) {
  for (int k = 0; k < 3; ++k) {
    double e = 0, v = fp.g(tri[k], e);
    if (!(v > e) || !(fp.gr - v > e + fp.gr_err)) return Fast::Unknown;
  }
  bool cover = true;
  for (int k = 0; k < 3; ++k) {
    const Vec3d &p = tri[k], &q = tri[(k + 1) % 3], &w = tri[(k + 2) % 3];
    double ew = 0, sw = fp.orient(p, q, w, false, ew);
    if (!(std::abs(sw) > ew)) return Fast::Unknown;  // r (nearly) in the triangle's plane
    bool all_out = true;
    for (const Vec3d& l : fp.L) {
      double el = 0, sl = fp.orient(p, q, l, true, el);
      bool in = sw > 0 ? sl > el : sl < -el;
      bool out = sw > 0 ? sl < -el : sl > el;
      all_out &= out;
      cover &= in;
    }
    if (all_out) return Fast::Miss;
  }
  return cover ? Fast::Cover : Fast::Unknown;
}

// Lambert's polygon formula (region_oracle.h) for one polygon seen from r with normal nr,
// after clipping to the receiver's upper half-space; double precision.
double polygon_form_factor(std::vector<Vec3d> poly, const Vec3d& r, const Vec3d& nr) {
  std::vector<Vec3d> kept;
  size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3d &a = poly[i], &b = poly[(i + 1) % n];
    double da = dot(nr, a - r), db = dot(nr, b - r);
    if (da >= 0) kept.push_back(a);
    if ((da > 0 && db < 0) || (da < 0 && db > 0)) kept.push_back(a + (b - a) * (da / (da - db)));
  }
  double sum = 0.0;
  for (size_t i = 0; i < kept.size(); ++i) {
    Vec3d u = kept[i] - r, v = kept[(i + 1) % kept.size()] - r;
    Vec3d w = cross(u, v);
    double lw = length(w);
    if (lw == 0.0) continue;
    double theta = std::atan2(lw, dot(u, v));
    sum += theta * dot(nr, w) / lw;
  }
  return -sum / (2.0 * std::numbers::pi);
}

// Everything visible_region and visible_fraction_bound share: the exact frame, the
// receiver's side, the pyramid planes, the double cull and the fast-path classification.
struct Prepared {
  LightFrame f;
  FT light_area2;
  V3 r;
  FT h_r, g_r;
  CGAL::Sign side = CGAL::ZERO;
  std::vector<std::pair<V3, FT>> sides;  // pyramid side planes, inwards
  V3 gn;                                 // the light plane as the half-space g >= 0
  FT ge;
  FastPass fp;
  std::vector<uint32_t> unknown;  // culled triangles the fast paths left undecided
  bool covered = false;           // a Cover triangle: fraction 0

  FT g_of(const V3& x) const { return side == CGAL::POSITIVE ? f.height(x) : -f.height(x); }
};

// Fills `p` up to the fast-path classification; false when the receiver is on the light
// plane (edge_on: nothing else is filled).
bool prepare(const Scene& scene, size_t receiver, size_t light_index, bool fast_paths, Prepared& p) {
  const Light& light = scene.lights[light_index];
  const Receiver& rec = scene.receivers[receiver];
  p.f = make_frame(light);
  LightFrame& f = p.f;
  p.light_area2 = f.polygon.area();
  p.r = exact3(rec.p);
  const V3& r = p.r;
  p.h_r = f.height(r);
  p.side = CGAL::sign(p.h_r);
  if (p.side == CGAL::ZERO) return false;
  // g = side * height: positive on the receiver's side; g_r = |h_r|.
  p.g_r = CGAL::abs(p.h_r);

  // Pyramid side planes through r and consecutive hull vertices, oriented inwards.
  size_t hn = f.lifted.size();
  for (size_t j = 0; j < hn; ++j) {
    V3 m = cross(f.lifted[j] - r, f.lifted[(j + 1) % hn] - r);
    if (CGAL::sign(dot(m, f.lifted[(j + 2) % hn] - r)) == CGAL::NEGATIVE) m = -m;
    for (int a = 0; a < 3; ++a) m[a] = squash(m[a]);
    p.sides.emplace_back(m, squash(dot(m, r)));
  }
  p.gn = p.side == CGAL::POSITIVE ? f.n : -f.n;
  p.ge = p.side == CGAL::POSITIVE ? f.d0 : -f.d0;

  AABB sb = scene.bounds();
  double coord_scale = std::max(max_component(vabs(to_double(sb.lo))), max_component(vabs(to_double(sb.hi))));
  coord_scale = std::max(coord_scale, max_component(vabs(to_double(rec.p))));
  for (const Vec3f& v : light.polygon) coord_scale = std::max(coord_scale, max_component(vabs(to_double(v))));
  Cull cull = make_cull(f, rec.p, std::max(coord_scale, 1e-30));

  // Fast paths (region_oracle.h): the culled triangles classified in double with
  // error bounds; Miss ones are dropped, one Cover hides the whole light, and only the
  // Unknown ones go to the exact projection and the Boolean operations.
  FastPass& fp = p.fp;
  fp.r = to_double(rec.p);
  fp.n = approx(f.n);
  fp.d0 = to_double_exact(f.d0);
  fp.sgn = p.side == CGAL::POSITIVE ? 1.0 : -1.0;
  fp.gr = fp.g(fp.r, fp.gr_err);
  for (const V3& x : f.lifted) {
    fp.L.push_back(approx(x));
    fp.lmax = std::max(fp.lmax, max_component(vabs(fp.L.back())));
  }
  const TriangleSoup& mesh = scene.mesh;
  for (size_t t = 0; t < mesh.size() && !p.covered; ++t) {
    const Vec3f &af = mesh.corner(t, 0), &bf = mesh.corner(t, 1), &cf = mesh.corner(t, 2);
    const Vec3d tri[3] = {to_double(af), to_double(bf), to_double(cf)};
    // Cull: outside the pyramid (double, conservative).
    if (cull.outside(tri[0], tri[1], tri[2])) continue;
    Fast c = fast_paths ? fast_classify(fp, tri) : Fast::Unknown;
    if (c == Fast::Miss) continue;
    if (c == Fast::Cover) p.covered = true;
    else p.unknown.push_back(uint32_t(t));
  }
  return true;
}

}  // namespace

RegionAnswer visible_region(const Scene& scene, size_t receiver, size_t light_index, const RegionOptions& opt) {
  const IeeeFloatMode ieee;  // Embree leaves FTZ/DAZ on in TBB workers (lib/geom/float_mode.h)
  VG_CHECK(receiver < scene.receivers.size() && light_index < scene.lights.size());
  const Receiver& rec = scene.receivers[receiver];
  RegionAnswer ans;
  Prepared pre;
  bool off_plane = prepare(scene, receiver, light_index, opt.fast_paths, pre);
  const LightFrame& f = pre.f;
  const FT& light_area2 = pre.light_area2;
  ans.light_area = to_double_exact(light_area2) * f.scale;
  if (!off_plane) {
    ans.edge_on = true;
    return ans;
  }
  const V3& r = pre.r;
  const FT& g_r = pre.g_r;
  const CGAL::Sign side = pre.side;
  auto g_of = [&](const V3& x) { return pre.g_of(x); };
  const auto& sides = pre.sides;
  const V3& gn = pre.gn;
  const FT& ge = pre.ge;
  const IK::Point_3 rp = ipt(rec.p);
  const std::vector<uint32_t>& unknown = pre.unknown;
  const TriangleSoup& mesh = scene.mesh;
  if (opt.fast_paths && (pre.covered || unknown.empty())) {
    ans.fast_path = true;
    if (pre.covered) {
      ans.visible_fraction = 0.0;
      ans.visible_area = 0.0;
      return ans;
    }
  }

  std::vector<Poly> shadows;
  for (uint32_t t : unknown) {
    const Vec3f &af = mesh.corner(t, 0), &bf = mesh.corner(t, 1), &cf = mesh.corner(t, 2);
    // Zero-area projections: collinear triangles, planes through the receiver (exact).
    IK::Point_3 ai = ipt(af), bi = ipt(bf), ci = ipt(cf);
    if (CGAL::collinear(ai, bi, ci) || CGAL::orientation(ai, bi, ci, rp) == CGAL::COPLANAR) continue;
    std::vector<V3> poly = {exact3(af), exact3(bf), exact3(cf)};
    FT g[3] = {g_of(poly[0]), g_of(poly[1]), g_of(poly[2])};
    bool all_beyond = true, all_behind = true, reaches_receiver = false;
    for (const FT& gi : g) {
      if (CGAL::is_positive(gi)) all_beyond = false;
      if (gi < g_r) all_behind = false;
      if (gi >= g_r) reaches_receiver = true;
    }
    if (all_beyond || all_behind) continue;
    if (reaches_receiver)
      for (const auto& [m, e] : sides) poly = clip(poly, m, e);
    poly = clip(poly, gn, ge);
    if (poly.size() < 3) continue;
    // Central projection from r onto the light plane: x -> r + (x - r) g_r / (g_r - g(x)).
    std::vector<Pt2> pts;
    pts.reserve(poly.size());
    for (const V3& x : poly) {
      FT gx = g_of(x);
      VG_CHECK(gx < g_r);
      FT s = g_r / (g_r - gx);
      pts.emplace_back(squash(r[f.i1] + (x[f.i1] - r[f.i1]) * s), squash(r[f.i2] + (x[f.i2] - r[f.i2]) * s));
    }
    simplify(pts);
    if (pts.size() < 3) continue;
    Poly sp(pts.begin(), pts.end());
    if (sp.orientation() == CGAL::CLOCKWISE) sp.reverse_orientation();
    // Cheap exact prefilter: skip projections that miss the light's frame box.
    if (CGAL::do_overlap(sp.bbox(), f.polygon.bbox()) == false) continue;
    shadows.push_back(std::move(sp));
  }
  ans.blockers_projected = shadows.size();

  // Visible region = light minus the union of the shadows.
  std::vector<PolyH> parts;
  if (shadows.empty()) {
    parts.emplace_back(f.polygon);  // nothing to subtract: no arrangement needed
  } else {
    PolySet vis(f.polygon);
    PolySet blocked;
    blocked.join(shadows.begin(), shadows.end());
    vis.difference(blocked);
    vis.polygons_with_holes(std::back_inserter(parts));
  }
  FT area2 = 0;
  for (const PolyH& p : parts) {
    area2 += p.outer_boundary().area();
    for (auto h = p.holes_begin(); h != p.holes_end(); ++h) area2 += h->area();
  }
  ans.visible_fraction = to_double_exact(area2 / light_area2);
  ans.visible_area = to_double_exact(area2) * f.scale;

  // Output polygons (floats) and the irradiance (double, from the exact vertices).
  const Vec3d rd = to_double(rec.p), nr = to_double(rec.n);
  double ff = 0.0;
  auto emit = [&](const Poly& p, bool hole) {
    Polygon3f out;
    std::vector<Vec3d> dpoly;
    for (auto v = p.vertices_begin(); v != p.vertices_end(); ++v) {
      Vec3d x = approx(f.lift(*v));
      dpoly.push_back(x);
      out.push_back(Vec3f(x));
    }
    if (f.reversed) {
      std::reverse(out.begin(), out.end());
      std::reverse(dpoly.begin(), dpoly.end());
    }
    ff += polygon_form_factor(std::move(dpoly), rd, nr);
    ans.polygons.push_back(std::move(out));
    ans.hole.push_back(hole);
  };
  for (const PolyH& p : parts) {
    emit(p.outer_boundary(), false);
    for (auto h = p.holes_begin(); h != p.holes_end(); ++h) emit(*h, true);
  }
  // The light emits only to the side its Newell normal points to.
  ans.irradiance = side == CGAL::POSITIVE ? ff : 0.0;
  return ans;
}

}  // namespace visgate::oracle
