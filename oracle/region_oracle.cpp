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
#include <CGAL/Interval_nt.h>
#include <CGAL/Polygon_with_holes_2.h>
#include <CGAL/convex_hull_2.h>
#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <numbers>
#include <tuple>

#include "lib/geom/expansion.h"
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

// GMP rationals, the exact type behind FT: the frame and the pyramid planes are computed
// on them directly and wrapped in FT once (one constant node each). Built as a lazy DAG
// and squashed, the same values cost one node and one rational per operation, and made
// the frame and the pyramid about 18% of fuzz_plucker's samples (perf, 2026-12-03).
using Q = FT::ET;

// The exact light frame of region_oracle.h.
struct LightFrame {
  V3 n;                    // exact Newell normal (emitting side)
  FT d0;                   // plane: n . x = d0
  int k = 2, i1 = 0, i2 = 1;  // dropped axis and the two kept ones
  std::vector<IK::Point_2> dpolygon;  // light polygon in the frame, counter-clockwise
                                      // (float coordinates: exact doubles)
  bool reversed = false;   // the frame's CCW runs against the light's own order
  std::vector<V3> lifted;  // vertices of the convex hull of `polygon`, lifted to the plane
                           // (constants: their exact() is the rational they were made from)
  double scale = 1.0;      // 3D area = frame area * scale (|n| / |n_k|)

  // dpolygon as an exact polygon and its doubled area, made at first use: only
  // visible_region's Boolean operations and its fraction need them (the certified bound,
  // which answers most pairs, reads dpolygon; building the lazy polygon and its area was
  // a fifth of the frame's allocations under ASan).
  const Poly& polygon() const {
    if (!polygon_made_) {
      std::vector<Pt2> pts;
      for (const IK::Point_2& p : dpolygon) pts.emplace_back(FT(p.x()), FT(p.y()));
      polygon_ = Poly(pts.begin(), pts.end());
      area2_ = polygon_.area();
      polygon_made_ = true;
    }
    return polygon_;
  }
  const FT& area2() const {
    polygon();
    return area2_;
  }

  V3 lift(const Pt2& p) const {
    V3 x;
    x[i1] = p.x();
    x[i2] = p.y();
    x[k] = (d0 - n[i1] * p.x() - n[i2] * p.y()) / n[k];
    return x;
  }
  FT height(const V3& x) const { return dot(n, x) - d0; }

 private:
  mutable Poly polygon_;
  mutable FT area2_;
  mutable bool polygon_made_ = false;
};

// Removes repeated consecutive vertices and vertices collinear with their neighbours
// (exact predicates for either kernel).
template <class P>
void simplify(std::vector<P>& pts) {
  bool changed = true;
  while (changed && pts.size() >= 3) {
    changed = false;
    for (size_t i = 0; i < pts.size() && pts.size() >= 3; ++i) {
      const P& a = pts[(i + pts.size() - 1) % pts.size()];
      const P& b = pts[i];
      const P& c = pts[(i + 1) % pts.size()];
      if (a == b || CGAL::collinear(a, b, c)) {
        pts.erase(pts.begin() + long(i));
        changed = true;
        --i;
      }
    }
  }
}

// The exact value of an expansion (finite doubles) as a rational: the components'
// integer mantissas aligned to the smallest exponent and summed as one integer, then
// scaled by a power of two (one canonicalisation instead of a rational sum per component).
Q rational(const expansion::Small& e) {
  if (e.empty()) return Q(0);
  int lo = INT_MAX;
  for (double c : e) {
    int ex = 0;
    std::frexp(c, &ex);
    lo = std::min(lo, ex - 53);
  }
  mpz_class z(0);
  for (double c : e) {
    int ex = 0;
    const double m = std::ldexp(std::frexp(c, &ex), 53);  // an integer below 2^53
    mpz_class t(m);
    mpz_mul_2exp(t.get_mpz_t(), t.get_mpz_t(), mp_bitcnt_t(ex - 53 - lo));
    z += t;
  }
  Q q(z);
  if (lo < 0) mpq_div_2exp(q.get_mpq_t(), q.get_mpq_t(), mp_bitcnt_t(-lo));
  else mpq_mul_2exp(q.get_mpq_t(), q.get_mpq_t(), mp_bitcnt_t(lo));
  return q;
}

LightFrame make_frame(const Light& light) {
  LightFrame f;
  const auto& v = light.polygon;
  const size_t m = v.size();
  // n = sum of v_j x v_(j+1) (exact expansions, summed as rationals); the plane through
  // the centroid: d0 = n . (sum v_j) / m.
  Q n[3], sum[3];
  for (int a = 0; a < 3; ++a) {
    n[a] = rational(expansion::newell_component<expansion::Small>(v.data(), m, a));
    expansion::Small s;
    for (const Vec3f& p : v) expansion::grow_vector(s, double(p[a]));
    sum[a] = rational(s);
  }
  const Q d0 = (n[0] * sum[0] + n[1] * sum[1] + n[2] * sum[2]) / Q(double(m));
  f.k = 0;
  for (int j = 1; j < 3; ++j)
    if (abs(n[j]) > abs(n[f.k])) f.k = j;
  f.i1 = (f.k + 1) % 3;
  f.i2 = (f.k + 2) % 3;
  VG_CHECK(sgn(n[f.k]) != 0);
  for (int a = 0; a < 3; ++a) f.n[a] = FT(n[a]);
  f.d0 = FT(d0);
  // The frame polygon's coordinates are floats: simplified and hulled on doubles with
  // exact predicates (the same decisions as on the lazy points, without building their
  // exact values to read the coordinates back).
  std::vector<IK::Point_2> dpts;
  for (const Vec3f& p : v) dpts.emplace_back(double(p[f.i1]), double(p[f.i2]));
  simplify(dpts);
  VG_CHECK(dpts.size() >= 3);
  // Exact predicates on the doubles: the same answers as on the exact polygon.
  VG_CHECK(CGAL::is_simple_2(dpts.begin(), dpts.end(), IK()));
  f.dpolygon = dpts;
  if (CGAL::orientation_2(dpts.begin(), dpts.end(), IK()) == CGAL::CLOCKWISE) {
    std::reverse(f.dpolygon.begin() + 1, f.dpolygon.end());  // as Polygon_2::reverse_orientation
    f.reversed = true;
  }
  std::vector<IK::Point_2> hull;
  CGAL::convex_hull_2(dpts.begin(), dpts.end(), std::back_inserter(hull));
  for (const IK::Point_2& p : hull) {
    const double u = p.x(), w = p.y();
    V3 lifted;
    lifted[f.i1] = FT(u);
    lifted[f.i2] = FT(w);
    lifted[f.k] = FT(Q((d0 - n[f.i1] * Q(u) - n[f.i2] * Q(w)) / n[f.k]));
    f.lifted.push_back(lifted);
  }
  Vec3d nd = approx(f.n);
  f.scale = length(nd) / std::abs(nd[f.k]);
  return f;
}

// The ends (from, to) a clip forms the crossing on edge (i, j) from: i first, unless both
// ends are tagged triangle vertices (an index into `tag_points`, >= 0) and j's float point
// is lexicographically smaller. Two triangles sharing an edge then form its crossing from
// the same vertex, whichever way they walk it (clip below and the certified bound's
// interval clip use this one rule, so their points agree).
std::pair<size_t, size_t> crossing_ends(size_t i, size_t j, int tag_i, int tag_j, const Vec3f* tag_points) {
  if (tag_points && tag_i >= 0 && tag_j >= 0) {
    const Vec3f &pi = tag_points[tag_i], &pj = tag_points[tag_j];
    if (std::tie(pj.x, pj.y, pj.z) < std::tie(pi.x, pi.y, pi.z)) return {j, i};
  }
  return {i, j};
}

// Sutherland-Hodgman step, exact: keeps the part of the convex polygon with
// dot(m, x) - e >= 0. New points are squashed (their lazy DAGs collapsed to exact values)
// unless `squash_new` is false: the certified bound needs their intervals (and exact
// signs where the intervals do not decide), not their exact values.
// `tags` (optional, parallel to poly, updated): kept vertices keep their tag (an index
// into `tag_points`, the triangle's float vertices), new ones get `new_tag` (negative). A new point on an
// edge between two tagged vertices is formed from the lexicographically smaller one, so
// two triangles sharing that edge form the same lazy expression for it (the same
// interval, hence the same double point in the certified bound).
std::vector<V3> clip(const std::vector<V3>& poly, const V3& m, const FT& e, bool squash_new = true,
                     std::vector<int>* tags = nullptr, const Vec3f* tag_points = nullptr, int new_tag = -1) {
  std::vector<V3> out;
  std::vector<int> out_tags;
  size_t n = poly.size();
  if (n == 0) {
    if (tags) tags->clear();
    return out;
  }
  std::vector<FT> val(n);
  std::vector<CGAL::Sign> sg(n);
  for (size_t i = 0; i < n; ++i) {
    val[i] = dot(m, poly[i]) - e;
    sg[i] = CGAL::sign(val[i]);
  }
  for (size_t i = 0; i < n; ++i) {
    size_t j = (i + 1) % n;
    if (sg[i] != CGAL::NEGATIVE) {
      out.push_back(poly[i]);
      if (tags) out_tags.push_back((*tags)[i]);
    }
    if ((sg[i] == CGAL::POSITIVE && sg[j] == CGAL::NEGATIVE) || (sg[i] == CGAL::NEGATIVE && sg[j] == CGAL::POSITIVE)) {
      const auto [from, to] = tags ? crossing_ends(i, j, (*tags)[i], (*tags)[j], tag_points) : std::pair{i, j};
      FT t = val[from] / (val[from] - val[to]);
      V3 x = poly[from] + (poly[to] - poly[from]) * t;
      if (squash_new)
        for (int a = 0; a < 3; ++a) x[a] = squash(x[a]);
      out.push_back(x);
      if (tags) out_tags.push_back(new_tag);
    }
  }
  if (tags) *tags = std::move(out_tags);
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
  // The light's frame: the cache's (RegionCache) or own_frame, never copied (a frame
  // holds lazy exact numbers and vectors; copying it per pair was an allocation each).
  const LightFrame* frame = nullptr;
  std::unique_ptr<LightFrame> own_frame;
  V3 r;
  FT h_r, g_r;
  CGAL::Sign side = CGAL::ZERO;
  V3 gn;                                 // the light plane as the half-space g >= 0
  FT ge;
  FastPass fp;
  std::vector<uint32_t> unknown;  // culled triangles the fast paths left undecided
  bool covered = false;           // a Cover triangle: fraction 0

  const LightFrame& f() const { return *frame; }
  FT g_of(const V3& x) const { return side == CGAL::POSITIVE ? f().height(x) : -f().height(x); }

  // The pyramid's side planes through r and consecutive hull vertices, inwards (m . x >= e
  // inside), made at first use: only triangles reaching the receiver's level and far
  // shadows of the certified bound are clipped to them.
  const std::vector<std::pair<V3, FT>>& sides() const {
    if (!sides_made) {
      const Q rq[3] = {r[0].exact(), r[1].exact(), r[2].exact()};
      auto minus_r = [&](const V3& x) {
        return std::array<Q, 3>{x[0].exact() - rq[0], x[1].exact() - rq[1], x[2].exact() - rq[2]};
      };
      const std::vector<V3>& lifted = f().lifted;
      const size_t hn = lifted.size();
      for (size_t j = 0; j < hn; ++j) {
        const std::array<Q, 3> a = minus_r(lifted[j]), b = minus_r(lifted[(j + 1) % hn]),
                               c = minus_r(lifted[(j + 2) % hn]);
        Q m[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        if (sgn(m[0] * c[0] + m[1] * c[1] + m[2] * c[2]) < 0)
          for (Q& x : m) x = -x;
        sides_.emplace_back(V3(FT(m[0]), FT(m[1]), FT(m[2])), FT(Q(m[0] * rq[0] + m[1] * rq[1] + m[2] * rq[2])));
      }
      sides_made = true;
    }
    return sides_;
  }

 private:
  mutable std::vector<std::pair<V3, FT>> sides_;
  mutable bool sides_made = false;
};

// Fills `p` up to the fast-path classification; false when the receiver is on the light
// plane (edge_on: nothing else is filled).
bool prepare(const Scene& scene, size_t receiver, size_t light_index, bool fast_paths, Prepared& p,
             const LightFrame* frame = nullptr) {
  const Light& light = scene.lights[light_index];
  const Receiver& rec = scene.receivers[receiver];
  if (frame == nullptr) {
    p.own_frame = std::make_unique<LightFrame>(make_frame(light));
    frame = p.own_frame.get();
  }
  p.frame = frame;
  const LightFrame& f = *frame;
  p.r = exact3(rec.p);
  const V3& r = p.r;
  p.h_r = f.height(r);
  p.side = CGAL::sign(p.h_r);
  if (p.side == CGAL::ZERO) return false;
  // g = side * height: positive on the receiver's side; g_r = |h_r|.
  p.g_r = CGAL::abs(p.h_r);

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

struct RegionCache::Impl {
  const Scene* scene = nullptr;
  std::vector<std::unique_ptr<LightFrame>> frames;  // per light, made at first use
  // The last pair prepared with fast paths (visible_fraction_bound's), for the
  // visible_region of the same pair that may follow.
  Prepared last;
  size_t last_receiver = SIZE_MAX, last_light = SIZE_MAX;
  bool last_off_plane = false;

  const LightFrame& frame(size_t l) {
    if (frames[l] == nullptr) frames[l] = std::make_unique<LightFrame>(make_frame(scene->lights[l]));
    return *frames[l];
  }
  // prepare() for (receiver, light), through the cache; the result stays in `last`.
  bool prepare_last(size_t receiver, size_t light) {
    if (receiver != last_receiver || light != last_light) {
      last = Prepared{};
      last_receiver = SIZE_MAX;  // until filled
      last_off_plane = prepare(*scene, receiver, light, true, last, &frame(light));
      last_receiver = receiver;
      last_light = light;
    }
    return last_off_plane;
  }
};

RegionCache::RegionCache(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  impl_->scene = &scene;
  impl_->frames.resize(scene.lights.size());
}
RegionCache::~RegionCache() = default;

RegionAnswer visible_region(const Scene& scene, size_t receiver, size_t light_index, const RegionOptions& opt,
                            RegionCache* cache) {
  const IeeeFloatMode ieee;  // Embree leaves FTZ/DAZ on in TBB workers (lib/geom/float_mode.h)
  VG_CHECK(receiver < scene.receivers.size() && light_index < scene.lights.size());
  VG_CHECK(cache == nullptr || cache->impl().scene == &scene);
  const Receiver& rec = scene.receivers[receiver];
  RegionAnswer ans;
  Prepared local;
  const bool cached = cache != nullptr && opt.fast_paths;
  const bool off_plane = cached ? cache->impl().prepare_last(receiver, light_index)
                                : prepare(scene, receiver, light_index, opt.fast_paths, local,
                                          cache ? &cache->impl().frame(light_index) : nullptr);
  const Prepared& pre = cached ? cache->impl().last : local;
  const LightFrame& f = pre.f();
  const FT& light_area2 = f.area2();
  ans.light_area = to_double_exact(light_area2) * f.scale;
  if (!off_plane) {
    ans.edge_on = true;
    return ans;
  }
  const V3& r = pre.r;
  const FT& g_r = pre.g_r;
  const CGAL::Sign side = pre.side;
  auto g_of = [&](const V3& x) { return pre.g_of(x); };
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
    bool all_beyond = true, all_behind = true, reaches_receiver = false, all_positive = true;
    for (const FT& gi : g) {
      if (CGAL::is_positive(gi)) all_beyond = false;
      else all_positive = false;
      if (gi < g_r) all_behind = false;
      if (gi >= g_r) reaches_receiver = true;
    }
    if (all_beyond || all_behind) continue;
    if (reaches_receiver)
      for (const auto& [m, e] : pre.sides()) poly = clip(poly, m, e);
    // g > 0 at every vertex: g > 0 on the whole triangle, so on every point the pyramid
    // clip made; the clip to g >= 0 would return the polygon unchanged.
    if (!all_positive) poly = clip(poly, gn, ge);
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
    if (CGAL::do_overlap(sp.bbox(), f.polygon().bbox()) == false) continue;
    shadows.push_back(std::move(sp));
  }
  ans.blockers_projected = shadows.size();

  // Visible region = light minus the union of the shadows.
  std::vector<PolyH> parts;
  if (shadows.empty()) {
    parts.emplace_back(f.polygon());  // nothing to subtract: no arrangement needed
  } else {
    PolySet vis(f.polygon());
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
  if (!opt.outputs) return ans;

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

namespace {

// Interval_nt<false> needs the rounding mode set upwards around every operation: each
// block of interval arithmetic below runs under a Protect_FPU_rounding guard, which
// restores the caller's mode (the exact predicates and the double error bounds of the
// fast paths assume round-to-nearest and stay outside those blocks).
using I = CGAL::Interval_nt<false>;
using Upward = CGAL::Protect_FPU_rounding<true>;
using P2d = IK::Point_2;

// One polygon of the certified check: a convex CCW polygon with double vertices.
struct CPoly {
  std::vector<P2d> v;
};

CGAL::Sign orient2(const P2d& a, const P2d& b, const P2d& c) { return CGAL::orientation(a, b, c); }

// Containers of one triangle's clip and projection (a triangle clipped by the pyramid's
// sides and the light plane: a dozen vertices at most in practice), kept inline: as
// std::vector they were a quarter of the certified bound's allocations under ASan.
template <class T>
using Small = boost::container::small_vector<T, 12>;

// The convex hull of a few double points, counter-clockwise from the smallest point in
// (x, y) order, extreme points only (exact orientations): Andrew's monotone chain, the
// same vertices in the same order as CGAL::convex_hull_2 (Akl-Toussaint starts there
// too), without its allocations. One point (all equal) or two (all collinear) for
// degenerate input.
void convex_hull_small(Small<P2d> pts, std::vector<P2d>& out) {
  std::sort(pts.begin(), pts.end(), [](const P2d& a, const P2d& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  });
  pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
  out.clear();
  if (pts.size() <= 2) {
    out.assign(pts.begin(), pts.end());
    return;
  }
  Small<P2d> h;
  for (int pass = 0; pass < 2; ++pass) {  // lower chain left to right, then upper right to left
    const size_t base = h.size();
    for (size_t k = 0; k < pts.size(); ++k) {
      const P2d& p = pass == 0 ? pts[k] : pts[pts.size() - 1 - k];
      while (h.size() >= base + 2 && orient2(h[h.size() - 2], h.back(), p) != CGAL::LEFT_TURN) h.pop_back();
      h.push_back(p);
    }
    h.pop_back();  // the last point starts the other chain
  }
  out.assign(h.begin(), h.end());
}
// det[b - a, c - a] enclosed (a, b, c exact doubles).
I det2(const P2d& a, const P2d& b, const P2d& c) {
  return (I(b.x()) - a.x()) * (I(c.y()) - a.y()) - (I(b.y()) - a.y()) * (I(c.x()) - a.x());
}
// Exact sign of the dot product of two collinear vectors b - a and d - c (both non-zero).
bool same_direction(const P2d& a, const P2d& b, const P2d& c, const P2d& d) {
  if (a.x() != b.x()) return (b.x() > a.x()) == (d.x() > c.x());
  return (b.y() > a.y()) == (d.y() > c.y());
}

// The part of edge (a, b) next to convex polygon q, as parameters t in [0, 1]: points
// just left of the edge are in q for t in [lo_l, hi_l], points just right for
// [lo_r, hi_r] (up to finitely many t; they differ only on an edge of q collinear with
// (a, b)). `err` bounds the distance of every computed end to its exact value.
struct Span {
  double lo_l = 0, hi_l = 1, lo_r = 0, hi_r = 1, err = 0;
  bool r_out = false;  // exact: no point just right of the edge is in q
};

Span edge_span(const P2d& a, const P2d& b, const CPoly& q) {
  Span s;
  double err_lo = 0, err_hi = 0;
  size_t n = q.v.size();
  for (size_t k = 0; k < n; ++k) {
    const P2d &c = q.v[k], &d = q.v[(k + 1) % n];
    CGAL::Sign sa = orient2(c, d, a), sb = orient2(c, d, b);
    if (sa == CGAL::ZERO && sb == CGAL::ZERO) {  // (a, b) on the line of edge (c, d)
      if (same_direction(a, b, c, d)) {  // q's interior on the left only
        s.hi_r = -1;
        s.r_out = true;
      } else {
        s.hi_l = -1;
      }
      continue;
    }
    if (sa != CGAL::NEGATIVE && sb != CGAL::NEGATIVE) continue;  // whole edge inside
    if (sa != CGAL::POSITIVE && sb != CGAL::POSITIVE) {          // outside
      s.hi_l = s.hi_r = -1;
      s.r_out = true;
      continue;
    }
    double tm, w;
    {
      Upward up;
      I ha = det2(c, d, a), hb = det2(c, d, b);
      I t = ha / (ha - hb);
      tm = 0.5 * (t.inf() + t.sup());
      w = t.sup() - t.inf();
    }
    if (!(w >= 0) || !std::isfinite(w)) w = 2.0;  // useless enclosure: the bound fails later
    if (sa == CGAL::POSITIVE) {  // inside for t < t*
      if (tm < s.hi_l) s.hi_l = tm;
      if (tm < s.hi_r) s.hi_r = tm;
      err_hi = std::max(err_hi, w);
    } else {
      if (tm > s.lo_l) s.lo_l = tm;
      if (tm > s.lo_r) s.lo_r = tm;
      err_lo = std::max(err_lo, w);
    }
  }
  s.err = err_lo + err_hi;
  return s;
}

// Area of L \ (S_1 u ... u S_m) for the convex polygons polys[0] = L, polys[1..m] = S_j,
// by the boundary integral: a point x of an edge of polygon p is on the region's
// boundary, region on the left (right), when the point just left (right) of x is in
// the region and the one just right (left) is not; a boundary piece carried by edges of
// several polygons is counted on the one of lowest index. Every side decision is exact
// (CGAL's exact orientation on the doubles); only the cut parameters are rounded, and
// moving a cut by e moves the measure of the counted set by at most 2e. The result
// encloses the exact area of the region of these double polygons.
I region_area(const std::vector<CPoly>& polys, const P2d& o) {
  I area(0);
  std::vector<Span> spans(polys.size());
  std::vector<double> cuts;
  for (size_t p = 0; p < polys.size(); ++p) {
    const CPoly& P = polys[p];
    for (size_t k = 0; k < P.v.size(); ++k) {
      const P2d &a = P.v[k], &b = P.v[(k + 1) % P.v.size()];
      // A shadow edge counts only where the point just right of it is in L: within L's
      // span on it, widened by that span's error (exactly nothing when an exact side
      // decision puts the whole edge outside L). Span errors matter only there: the
      // counted set changes on at most min(2 err_q, |window|) for span q. (A far shadow's
      // long edges have large cross products; without the window their cut errors far
      // from L made the bound useless.)
      double window = 1.0;
      if (p != 0) {
        spans[0] = edge_span(a, b, polys[0]);
        const Span& sl = spans[0];
        if (sl.r_out) continue;  // exactly outside L (or on L's edge with L on the left)
        window = std::max(0.0, std::min(1.0, sl.hi_r + sl.err) - std::max(0.0, sl.lo_r - sl.err));
      }
      double err = 0;
      cuts.assign({0.0, 1.0});
      for (size_t q = 0; q < polys.size(); ++q) {
        if (q == p) continue;
        if (q != 0 || p == 0) spans[q] = edge_span(a, b, polys[q]);
        const Span& s = spans[q];
        for (double x : {s.lo_l, s.hi_l, s.lo_r, s.hi_r})
          if (x > 0 && x < 1) cuts.push_back(x);
        err += std::min(2.0 * s.err, window);
      }
      std::sort(cuts.begin(), cuts.end());
      double m = 0;  // signed measure of the counted part of [0, 1]
      for (size_t c = 0; c + 1 < cuts.size(); ++c) {
        double t0 = cuts[c], t1 = cuts[c + 1];
        if (!(t1 > t0)) continue;
        double t = 0.5 * (t0 + t1);
        // Membership of the points just left / right of x(t).
        // Polygon p: the point just left of x(t) is in p, the one just right is not. The
        // region's membership: L's edges have the region (if anywhere) on their left,
        // shadow edges on their right (their left is in the shadow).
        bool in_l = p == 0, in_r = false, tie = false;  // in L, in no shadow
        for (size_t q = 0; q < polys.size(); ++q) {
          if (q == p) continue;
          const Span& s = spans[q];
          bool ql = s.lo_l < t && t < s.hi_l, qr = s.lo_r < t && t < s.hi_r;
          if (q == 0) {
            in_r = qr;  // shadow edge: the right point must be in L
          } else {
            if (ql) in_l = false;
            if (qr) in_r = false;
          }
          if (q < p && ql != qr) tie = true;  // the piece lies on an edge of q too
        }
        if (tie) continue;
        bool left = in_l, right = in_r;
        if (left && !right) m += t1 - t0;
        else if (right && !left) m -= t1 - t0;
      }
      // Each span end moved by at most its error changes the counted set on at most
      // 2 err_q (left and right spans share their cuts) inside the window, where the
      // signed indicator changes by at most 2 (doubled again for safety); plus the
      // rounding of the sum of lengths.
      double e = 4.0 * err + double(cuts.size()) * 0x1p-50;
      Upward up;
      I c = (I(a.x()) - o.x()) * (I(b.y()) - a.y()) - (I(a.y()) - o.y()) * (I(b.x()) - a.x());
      I mi = I(m) + I(-e, e);
      area += c * mi * I(0.5);
    }
  }
  return area;
}

}  // namespace

FractionBound visible_fraction_bound(const Scene& scene, size_t receiver, size_t light_index, RegionCache* cache) {
  const IeeeFloatMode ieee;  // Embree leaves FTZ/DAZ on in TBB workers (lib/geom/float_mode.h)
  VG_CHECK(receiver < scene.receivers.size() && light_index < scene.lights.size());
  VG_CHECK(cache == nullptr || cache->impl().scene == &scene);
  FractionBound out;
  Prepared local;
  const bool off_plane = cache ? cache->impl().prepare_last(receiver, light_index)
                               : prepare(scene, receiver, light_index, true, local);
  const Prepared& pre = cache ? cache->impl().last : local;
  if (!off_plane) {
    out.edge_on = true;
    return out;
  }
  out.unknown_triangles = pre.unknown.size();
  if (pre.covered || pre.unknown.empty()) {  // the exact path's own fast answers
    out.certified = true;
    out.lo = out.hi = pre.covered ? 0.0 : 1.0;
    return out;
  }
  const LightFrame& f = pre.f();
  // The light in the frame: float coordinates, exact doubles; the certified area needs a
  // convex light (DESIGN: lights are convex; anything else goes to the exact path).
  std::vector<CPoly> polys(1);
  polys[0].v = f.dpolygon;
  const size_t ln = polys[0].v.size();
  for (size_t k = 0; k < ln; ++k)
    if (orient2(polys[0].v[k], polys[0].v[(k + 1) % ln], polys[0].v[(k + 2) % ln]) != CGAL::POSITIVE) {
      out.why = "light not strictly convex";
      return out;
    }

  // Shadows of the undecided triangles. The exact path's exact skips (zero-area
  // projections, triangles outside the open slab) are decided exactly here too; a
  // triangle certainly strictly inside the slab is projected with interval arithmetic:
  // its shadow S is the triangle of the exact projected vertices, the double triangle S'
  // has every vertex within delta of them, so S' lies within delta of S and S within
  // delta of S' (Hausdorff, both convex), and the area of the light minus the union
  // changes by at most sum (delta per + pi delta^2) (Steiner's formula for the
  // delta-neighbourhood of a convex set). Any other triangle (clipped by a slab plane or
  // the pyramid) makes the bound give up.
  double light_per = 0;  // perimeter of L, rounded up
  const P2d o = polys[0].v[0];
  I light2(0);  // area of L
  {
    Upward up;
    for (size_t k = 0; k < ln; ++k) {
      const P2d &p0 = polys[0].v[k], &p1 = polys[0].v[(k + 1) % ln];
      I dx = I(p0.x()) - p1.x(), dy = I(p0.y()) - p1.y();
      light_per += CGAL::sqrt(dx * dx + dy * dy).sup();
    }
    for (size_t k = 1; k + 1 < ln; ++k) light2 += det2(o, polys[0].v[k], polys[0].v[k + 1]) * I(0.5);
  }
  // L's frame box grown by its own extent on every side: a shadow vertex beyond it is
  // "far" (below).
  double near_lo[2], near_hi[2], largest = 0;
  {
    double lo[2] = {polys[0].v[0].x(), polys[0].v[0].y()}, hi[2] = {lo[0], lo[1]};
    for (const P2d& v : polys[0].v) {
      lo[0] = std::min(lo[0], v.x()), hi[0] = std::max(hi[0], v.x());
      lo[1] = std::min(lo[1], v.y()), hi[1] = std::max(hi[1], v.y());
    }
    const double ext = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    for (int a = 0; a < 2; ++a) {
      near_lo[a] = lo[a] - ext, near_hi[a] = hi[a] + ext;
      largest = std::max({largest, std::abs(lo[a]), std::abs(hi[a])});
    }
  }
  // Snapping (below): 2^-30 of the largest coordinate, far above the interval
  // midpoints' rounding (a few ulps of it), and at most 2^-30 of L's width (area over
  // perimeter), so that the moves, which enter the bound as delta times a perimeter,
  // stay far below the fraction tolerance on a sliver light far from the origin too (any
  // tolerance keeps the bound valid; this one keeps it narrow).
  std::vector<P2d> anchors = polys[0].v;
  const double light_width = 2.0 * light2.sup() / std::max(light_per, 1e-300);  // area over half the perimeter
  const double snap_tol = 0x1p-30 * std::min(largest, light_width);
  const TriangleSoup& mesh = scene.mesh;
  const FastPass& fp = pre.fp;
  const IK::Point_3 rp = ipt(scene.receivers[receiver].p);
  const Vec3f& rf = scene.receivers[receiver].p;
  I nI[3] = {pre.f().n[0].approx(), pre.f().n[1].approx(), pre.f().n[2].approx()};
  I d0I = pre.f().d0.approx();
  I sg(fp.sgn);
  I rI[3] = {I(double(rf.x)), I(double(rf.y)), I(double(rf.z))};
  I grI;
  {
    Upward up;
    grI = sg * (nI[0] * rI[0] + nI[1] * rI[1] + nI[2] * rI[2] - d0I);
  }
  // The pyramid's side planes in interval arithmetic for the interval clip (below):
  // M = (a - r) x (b - r) for consecutive lifted hull vertices a, b, turned so that
  // M . (c - r) > 0 for the next one c (inside: M . (x - r) >= 0), from the intervals
  // of the exact vertices; made at first use. Empty when an orientation is not certain
  // (the interval clip then leaves every triangle to the lazy path).
  std::vector<std::array<I, 3>> sides_iv;
  int sides_iv_state = 0;  // 0 not made, 1 made, 2 not usable
  auto interval_sides = [&]() -> bool {
    if (sides_iv_state == 0) {
      Upward up;
      const size_t hn = pre.f().lifted.size();
      auto minus_r = [&](const V3& x) {
        return std::array<I, 3>{x[0].approx() - rI[0], x[1].approx() - rI[1], x[2].approx() - rI[2]};
      };
      sides_iv_state = 1;
      for (size_t j = 0; j < hn && sides_iv_state == 1; ++j) {
        const std::array<I, 3> a = minus_r(pre.f().lifted[j]), b = minus_r(pre.f().lifted[(j + 1) % hn]),
                               c = minus_r(pre.f().lifted[(j + 2) % hn]);
        std::array<I, 3> m = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        const I turn = m[0] * c[0] + m[1] * c[1] + m[2] * c[2];
        if (turn.sup() < 0.0)
          for (I& x : m) x = -x;
        else if (!(turn.inf() > 0.0))
          sides_iv_state = 2;
        sides_iv.push_back(m);
      }
    }
    return sides_iv_state == 1;
  };
  I perturb(0);
  for (uint32_t t : pre.unknown) {
    const Vec3f cf[3] = {mesh.corner(t, 0), mesh.corner(t, 1), mesh.corner(t, 2)};
    IK::Point_3 ai = ipt(cf[0]), bi = ipt(cf[1]), ci = ipt(cf[2]);
    if (CGAL::collinear(ai, bi, ci) || CGAL::orientation(ai, bi, ci, rp) == CGAL::COPLANAR) continue;
    bool inside = true, maybe_beyond = false, maybe_behind = false;
    for (int k = 0; k < 3; ++k) {
      double e = 0, v = fp.g(to_double(cf[k]), e);
      bool pos = v > e, below = fp.gr - v > e + fp.gr_err;
      if (!pos || !below) inside = false;
      if (!pos) maybe_beyond = true;
      if (!below) maybe_behind = true;
    }
    if (!inside) {
      // Outside the open slab, exactly (as the exact path): all g <= 0 or all g >= g_r.
      bool all_beyond = maybe_beyond, all_behind = maybe_behind;
      for (int k = 0; k < 3 && (all_beyond || all_behind); ++k) {
        FT g = pre.g_of(exact3(cf[k]));
        if (CGAL::is_positive(g)) all_beyond = false;
        if (g < pre.g_r) all_behind = false;
      }
      if (all_beyond || all_behind) continue;
    }
    // Shadow vertices as intervals (midpoint, and the sum of the two widths as delta).
    Small<P2d> vs;
    double delta = 0;
    auto add_vertex = [&](const I& u, const I& w) {
      double um = 0.5 * (u.inf() + u.sup()), wm = 0.5 * (w.inf() + w.sup());
      double dk = (u.sup() - u.inf()) + (w.sup() - w.inf());
      if (!std::isfinite(um) || !std::isfinite(wm) || !(dk >= 0) || !std::isfinite(dk)) return false;
      delta = std::max(delta, dk);
      vs.emplace_back(um, wm);
      return true;
    };
    // A shadow reaching far beyond L (a vertex next to the receiver's level projects far
    // out) is replaced by its part inside L, the projection of the triangle clipped to
    // the pyramid: L minus the union is the same set. Far vertices made the bound useless:
    // their errors enter delta (Steiner's term grows with delta^2) and the cut parameters
    // of their long edges cancel catastrophically.
    auto far = [&](const Small<P2d>& pts) {
      for (const P2d& v : pts)
        if (!(v.x() >= near_lo[0] && v.x() <= near_hi[0] && v.y() >= near_lo[1] && v.y() <= near_hi[1])) return true;
      return false;
    };
    // A vertex interval is narrow when it is finite and at most 2^-40 of its magnitude
    // or 2^-37 of L's width wide; any other is not used from the plain interval
    // projection (the triangle then takes the lazy path below) nor from a lazy number's
    // interval (its exact value is computed). Either width keeps the bound narrow: it
    // enters as delta times a perimeter (below; at 2^-37 of the width, about 2^-35 of
    // L's area per shadow), and the midpoints stay within 2^-38 of the width of the
    // exact points, far inside the snapping tolerance (at least 2^-31 of the width:
    // the largest coordinate of L is at least half its extent), so coincident points
    // still snap together. The width clause matters for coordinates near zero, where
    // the relative one asked for exact values of intervals 2^-60 of the width wide
    // (10,111 of the 24,000 exact evaluations over 4,665 decoded fuzz_plucker inputs;
    // those evaluations were 5% of its samples under ASan, 2026-12-03).
    auto narrow = [&](const I& v) {
      if (!std::isfinite(v.inf()) || !std::isfinite(v.sup())) return false;
      const double w = v.sup() - v.inf();
      return w <= 0x1p-40 * std::max(std::abs(v.inf()), std::abs(v.sup())) || w <= 0x1p-37 * light_width;
    };
    // Projection of a triangle vertex (a float point strictly inside the slab) in interval
    // arithmetic; false when the interval is not narrow. Both paths below project the
    // triangle's own vertices with it, so a vertex shared by two triangles gets the same
    // double point in both shadows whichever path each takes, and their shared edges are
    // exactly collinear (edge_span's exact case) instead of nearly so, where the cut
    // parameters are ill-conditioned and the bound came out wide.
    auto project_vertex = [&](const Vec3f& x, I& u, I& w) {
      Upward up;
      I xI[3] = {I(double(x.x)), I(double(x.y)), I(double(x.z))};
      I den = sg * (nI[0] * (rI[0] - xI[0]) + nI[1] * (rI[1] - xI[1]) + nI[2] * (rI[2] - xI[2]));  // g_r - g(x)
      I sc = grI / den;
      u = rI[f.i1] + (xI[f.i1] - rI[f.i1]) * sc;
      w = rI[f.i2] + (xI[f.i2] - rI[f.i2]) * sc;
      return narrow(u) && narrow(w);
    };
    bool projected = false;
    if (inside) {  // no clipping: the three vertices projected in interval arithmetic
      projected = true;
      for (int k = 0; k < 3 && projected; ++k) {
        I u, w;
        projected = project_vertex(cf[k], u, w) && add_vertex(u, w);
      }
      if (projected && far(vs)) projected = false;
      if (!projected) {
        vs.clear();
        delta = 0;
      }
    }
    // Interval clip: the lazy path below in interval arithmetic, without its exact
    // numbers. Every clip decision must be certain from the intervals (a vertex
    // interval on one side of each plane; the light-plane and receiver-level tests of
    // triangle vertices likewise), and every projected vertex narrow; otherwise the
    // triangle takes the lazy path, which decides those cases exactly. Where it
    // succeeds it keeps the lazy path's clipping order, crossing points (computed from
    // the same end of each edge) and tags, so the polygon is the same with every vertex
    // enclosed by its interval: the same S' within delta of S. The lazy path's numbers
    // were most of the bound's allocations (a DAG node per operation) and under ASan
    // about 15% of fuzz_plucker's samples (perf, 2026-12-03).
    if (!projected) {
      using IP = std::array<I, 3>;
      Small<std::pair<I, I>> uw;  // projected vertices, added outside the Upward scope
      auto try_intervals = [&]() -> bool {  // true: vs and delta filled; false: take the lazy path
        auto g_iv = [&](const IP& x) { return sg * (nI[0] * x[0] + nI[1] * x[1] + nI[2] * x[2] - d0I); };
        auto point = [](const Vec3f& x) { return IP{I(double(x.x)), I(double(x.y)), I(double(x.z))}; };
        // Keeps the part with value >= 0 (values certainly nonzero), as clip() does.
        auto clip_iv = [&](Small<IP>& poly, Small<int>& tags, const Small<I>& val, int new_tag) {
          Small<IP> kept;
          Small<int> out_tags;
          const size_t n = poly.size();
          for (size_t i = 0; i < n; ++i) {
            const size_t j = (i + 1) % n;
            const bool pi = val[i].inf() > 0.0, pj = val[j].inf() > 0.0;
            if (pi) {
              kept.push_back(poly[i]);
              out_tags.push_back(tags[i]);
            }
            if (pi != pj) {
              const auto [from, to] = crossing_ends(i, j, tags[i], tags[j], cf);
              const I tt = val[from] / (val[from] - val[to]);
              IP x;
              for (int a = 0; a < 3; ++a) x[a] = poly[from][a] + (poly[to][a] - poly[from][a]) * tt;
              kept.push_back(x);
              out_tags.push_back(new_tag);
            }
          }
          poly = std::move(kept);
          tags = std::move(out_tags);
        };
        auto certain = [](const I& v) { return v.inf() > 0.0 || v.sup() < 0.0; };
        Upward up;
        bool reaches = false;
        if (maybe_behind)
          for (int k = 0; k < 3; ++k) {
            const I d = g_iv(point(cf[k])) - grI;
            if (d.inf() >= 0.0) reaches = true;
            else if (!(d.sup() < 0.0)) return false;
          }
        for (bool to_pyramid : {reaches, true}) {
          Small<IP> poly = {point(cf[0]), point(cf[1]), point(cf[2])};
          Small<int> tags = {0, 1, 2};
          Small<I> val;
          if (to_pyramid) {
            if (!interval_sides()) return false;
            for (const IP& m : sides_iv) {
              val.clear();
              for (const IP& x : poly) {
                const I v = m[0] * (x[0] - rI[0]) + m[1] * (x[1] - rI[1]) + m[2] * (x[2] - rI[2]);
                if (!certain(v)) return false;
                val.push_back(v);
              }
              clip_iv(poly, tags, val, -1);
            }
          }
          if (maybe_beyond) {
            val.clear();
            for (const IP& x : poly) {
              const I v = g_iv(x);
              if (!certain(v)) return false;
              val.push_back(v);
            }
            clip_iv(poly, tags, val, -2);
          }
          uw.clear();
          for (size_t k = 0; k < poly.size() && poly.size() >= 3; ++k) {
            const IP& x = poly[k];
            I ui, wi;
            if (tags[k] == -2) {  // on the light plane: its own coordinates
              ui = x[f.i1];
              wi = x[f.i2];
            } else if (tags[k] >= 0) {
              if (!certain(g_iv(x))) return false;  // maybe on the light plane: the lazy path tells
              if (!project_vertex(cf[tags[k]], ui, wi)) return false;
            } else {
              const I sc = grI / (grI - g_iv(x));
              ui = rI[f.i1] + (x[f.i1] - rI[f.i1]) * sc;
              wi = rI[f.i2] + (x[f.i2] - rI[f.i2]) * sc;
            }
            if (!narrow(ui) || !narrow(wi)) return false;
            uw.emplace_back(ui, wi);
          }
          {
            CGAL::Protect_FPU_rounding<true> nearest(CGAL_FE_TONEAREST);  // add_vertex as on the other paths
            vs.clear();
            delta = 0;
            for (const auto& [ui, wi] : uw)
              if (!add_vertex(ui, wi)) return false;
          }
          if (to_pyramid || !far(vs)) break;
        }
        return true;
      };
      // On false the lazy path starts from an empty vs and delta of its own.
      if (try_intervals()) {
        if (vs.size() < 3) continue;
        projected = true;
      }
    }
    if (!projected) {  // the exact path's clipping with lazy exact numbers: exact signs, interval points
      std::vector<V3> tri = {exact3(cf[0]), exact3(cf[1]), exact3(cf[2])};
      bool reaches_receiver = false;  // (every vertex certainly below g_r: no exact test)
      if (maybe_behind)
        for (const V3& x : tri) reaches_receiver |= pre.g_of(x) >= pre.g_r;
      // A wide lazy interval (a point next to the receiver's level: a small g_r - g) is
      // made tight by computing that coordinate exactly (the exact path computes every
      // one) and taking the exact value's interval.
      auto tight = [&](const FT& v) {
        I a0 = v.approx();
        if (narrow(a0)) return a0;
        return I(CGAL::to_interval(v.exact()));
      };
      // g = 0 exactly at a float point (the double test first, exact where it cannot tell).
      auto on_light_plane = [&](const Vec3f& x) {
        double e = 0, v = fp.g(to_double(x), e);
        return std::abs(v) <= e && CGAL::is_zero(pre.g_of(exact3(x)));
      };
      // Without the pyramid clip first; a far shadow is projected again from the part of
      // the triangle inside the pyramid.
      bool finite = true;
      for (bool to_pyramid : {reaches_receiver, true}) {
        std::vector<V3> poly = tri;
        // Which triangle vertex; -1 for a point of a pyramid clip, -2 for one of the clip
        // to g >= 0 (a point on the light plane).
        std::vector<int> tags = {0, 1, 2};
        if (to_pyramid)
          for (const auto& [m, e] : pre.sides()) poly = clip(poly, m, e, false, &tags, cf);
        // Every vertex certainly at g > 0 (the double test above): the clip to g >= 0 would
        // return the polygon unchanged (g is affine, so positive on its convex hull).
        if (maybe_beyond) poly = clip(poly, pre.gn, pre.ge, false, &tags, cf, -2);
        vs.clear();
        delta = 0;
        for (size_t k = 0; k < poly.size() && finite && poly.size() >= 3; ++k) {
          const V3& x = poly[k];
          I ui, wi;
          // A point on the light plane (g = 0) projects onto itself: its own frame
          // coordinates, not the projection formula, whose rounding moved a blocker vertex
          // sitting on a light vertex or edge off it by an ulp. Such a shadow edge along
          // an edge of L was then nearly, not exactly, collinear with it, and the cut
          // parameters of the boundary integral (ill-conditioned there) made the bound
          // useless: 137 of 2,078 fuzz_plucker pairs went to the Boolean operations,
          // which were then 18% of its samples (2026-12-03).
          if (tags[k] == -2 || (tags[k] >= 0 && on_light_plane(cf[tags[k]]))) {
            finite = tags[k] == -2 ? add_vertex(tight(x[f.i1]), tight(x[f.i2]))
                                   : add_vertex(I(double(cf[tags[k]][f.i1])), I(double(cf[tags[k]][f.i2])));
            continue;
          }
          // A kept triangle vertex has 0 <= g < g_r unless it is the receiver itself, whose
          // projection has no finite enclosure either way.
          if (tags[k] >= 0 && project_vertex(cf[tags[k]], ui, wi)) {
            finite = add_vertex(ui, wi);
            continue;
          }
          FT sc = pre.g_r / (pre.g_r - pre.g_of(x));
          FT u = pre.r[f.i1] + (x[f.i1] - pre.r[f.i1]) * sc, w = pre.r[f.i2] + (x[f.i2] - pre.r[f.i2]) * sc;
          finite = add_vertex(tight(u), tight(w));
        }
        if (to_pyramid || !finite || !far(vs)) break;
      }
      if (!finite) {
        out.why = "clipped projection not finite";
        return out;
      }
      if (vs.size() < 3) continue;
    }
    // Snapping. Exact coincidences of the geometry (a shadow corner on a corner of L, two
    // shadows sharing a projected point reached by different formulas, a blocker edge
    // projecting onto an edge of L) come out of the interval midpoints an ulp apart;
    // edges through them were then nearly, not exactly, collinear with L's or each
    // other's, and the boundary integral's cut parameters on nearly collinear edges are
    // ill-conditioned: 137 of 2,078 fuzz_plucker pairs got a bound wider than the
    // fraction tolerance and went to the Boolean operations, 18% of its samples
    // (2026-12-03; 33 after the snapping below). Two moves, each within about snap_tol:
    // - each coordinate within snap_tol of the same coordinate of a vertex of L or of an
    //   earlier shadow takes that value (a whole vertex snaps onto a vertex; a corner an
    //   ulp off an axis-parallel edge of L goes onto its line);
    // - a vertex within snap_tol of the line of an edge of L, but not on it, is pushed
    //   outwards to about snap_tol beyond it: a shadow edge along an edge of L, between
    //   points inside that edge, is then strictly outside, decided by exact side tests.
    // The moved S' is within delta + (the largest move, its 1-norm) of S, so delta grows
    // by that; the exact side tests then decide the coincident parts without cuts.
    {
      const Small<P2d> before = vs;
      for (P2d& v : vs) {
        double c[2] = {v.x(), v.y()};
        for (int k = 0; k < 2; ++k)
          for (const P2d& a : anchors) {
            const double ak = k == 0 ? a.x() : a.y();
            if (std::abs(c[k] - ak) <= snap_tol) {
              c[k] = ak;
              break;
            }
          }
        v = P2d(c[0], c[1]);
      }
      const CPoly& L = polys[0];
      for (P2d& v : vs)
        for (size_t k = 0; k < L.v.size(); ++k) {
          const P2d &c = L.v[k], &d = L.v[(k + 1) % L.v.size()];
          if (orient2(c, d, v) == CGAL::ZERO) continue;
          const double ex = d.x() - c.x(), ey = d.y() - c.y(), len = std::hypot(ex, ey);
          if (!(len > 0)) continue;
          const double dist = (ex * (v.y() - c.y()) - ey * (v.x() - c.x())) / len;  // > 0 inside
          if (!(std::abs(dist) <= snap_tol)) continue;
          const double step = dist + snap_tol;  // against the inward unit normal (-ey, ex) / len
          const P2d w(v.x() + step * ey / len, v.y() - step * ex / len);
          if (orient2(c, d, w) == CGAL::NEGATIVE) v = w;
        }
      double moved = 0;
      for (size_t k = 0; k < vs.size(); ++k)
        moved = std::max(moved, std::abs(vs[k].x() - before[k].x()) + std::abs(vs[k].y() - before[k].y()));
      delta += moved * (1.0 + 0x1p-50);
    }
    // S' = the convex hull of the double vertices (exact predicates): within delta of S.
    CPoly s;
    convex_hull_small(vs, s.v);
    anchors.insert(anchors.end(), s.v.begin(), s.v.end());
    Upward up;
    double per = 0;
    for (size_t k = 0; k < s.v.size() && s.v.size() >= 2; ++k) {
      const P2d &p0 = s.v[k], &p1 = s.v[(k + 1) % s.v.size()];
      I dx = I(p0.x()) - p1.x(), dy = I(p0.y()) - p1.y();
      per += CGAL::sqrt(dx * dx + dy * dy).sup();
    }
    // (A segment's perimeter is twice its length: both directions are summed above.)
    // area(X + B_delta) - area(X) = delta per(X) + pi delta^2 for convex X, and
    // per(S) <= per(S' + B_delta) = per(S') + 2 pi delta: so delta per(S') + 3 pi delta^2
    // bounds the change for S and S' alike.
    // Only the change inside L counts: a point of L within delta of S but not in S has
    // its nearest point of S in S n (L + B_delta), so the change is at most
    // delta per(S n (L + B_delta)) + pi delta^2 <= delta min(per(S), per(L) + 2 pi delta)
    // + pi delta^2 (perimeters grow with convex sets).
    I dI(delta);
    perturb += dI * I(std::min(per, light_per)) + I(9.4248) * dI * dI;
    if (s.v.size() < 3) continue;  // a segment or point: no area (its perturbation term is kept)
    polys.push_back(std::move(s));
  }
  out.shadows = polys.size() - 1;
  I area = region_area(polys, o);
  double lo, hi;
  {
    Upward up;
    area = area + I(-perturb.sup(), perturb.sup());
    I frac = area / light2;
    lo = std::max(frac.inf(), 0.0);
    hi = std::min(frac.sup(), 1.0);
  }
  if (!(lo <= hi)) {
    out.why = "empty enclosure";
    return out;
  }
  out.certified = true;
  out.lo = lo;
  out.hi = hi;
  return out;
}

}  // namespace visgate::oracle
