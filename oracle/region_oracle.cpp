// The region oracle (DESIGN section 5): exact visible region of a light polygon from a
// receiver with Epeck and CGAL's 2D Boolean set operations. This is the only translation
// unit of visgate that instantiates the Boolean-operation code (DESIGN section 9). The
// exact frame, the blocker cases and the irradiance formula are documented in
// region_oracle.h.
#include "oracle/region_prepare.h"

#include <CGAL/Boolean_set_operations_2.h>
#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>
#include <CGAL/Polygon_set_2.h>
#include <CGAL/Polygon_with_holes_2.h>
#include <CGAL/convex_hull_2.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <numbers>
#include <tuple>

#include "lib/geom/expansion.h"
#include "lib/geom/float_mode.h"

namespace visgate::oracle {

namespace region {

namespace {

using PolyH = CGAL::Polygon_with_holes_2<EK>;
using PolySet = CGAL::Polygon_set_2<EK>;

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

Cull make_cull(const ExactLight& f, const Vec3f& rf, double coord_scale) {
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


}  // namespace

ExactLight make_exact_light(const Light& light) {
  ExactLight f;
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

std::pair<size_t, size_t> crossing_ends(size_t i, size_t j, int tag_i, int tag_j, const Vec3f* tag_points) {
  if (tag_points && tag_i >= 0 && tag_j >= 0) {
    const Vec3f &pi = tag_points[tag_i], &pj = tag_points[tag_j];
    if (std::tie(pj.x, pj.y, pj.z) < std::tie(pi.x, pi.y, pi.z)) return {j, i};
  }
  return {i, j};
}

std::vector<V3> clip(const std::vector<V3>& poly, const V3& m, const FT& e, bool squash_new,
                     std::vector<int>* tags, const Vec3f* tag_points, int new_tag) {
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

bool prepare(const Scene& scene, size_t receiver, size_t light_index, bool fast_paths, Prepared& p,
             const ExactLight* frame) {
  const Light& light = scene.lights[light_index];
  const Receiver& rec = scene.receivers[receiver];
  if (frame == nullptr) {
    p.own_frame = std::make_unique<ExactLight>(make_exact_light(light));
    frame = p.own_frame.get();
  }
  p.frame = frame;
  const ExactLight& f = *frame;
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

}  // namespace region

namespace {

using namespace region;

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

}  // namespace

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
  const ExactLight& f = pre.f();
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

}  // namespace visgate::oracle
