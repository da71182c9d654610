// The region oracle's certified fraction bound (region_oracle.h visible_fraction_bound):
// an enclosure of the exact visible fraction without Boolean operations. The steps: the
// light in its exact frame (its area and perimeter as intervals), each undecided
// triangle's shadow as a convex double polygon within a known distance delta of the
// exact one (interval projection, interval clip, or the exact clip with lazy numbers),
// snapped onto coincident geometry, and the area of the light minus their union by a
// boundary integral with exact side decisions (region_area), widened by Steiner's
// formula for every delta.
#include <CGAL/Interval_nt.h>
#include <boost/container/small_vector.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

#include "lib/geom/float_mode.h"
#include "oracle/region_prepare.h"

namespace visgate::oracle {

namespace {

using namespace region;


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

// Polygons whose box meets a segment's box: every other polygon is strictly separated
// from the segment, so no point just left or right of it lies in that polygon and it
// adds no cut, no membership change and no span error to the segment (exactly; with it
// the rounded spans of such a polygon could only widen the bound). A uniform grid over
// the light's box, polygons beyond it clamped into the border cells (clamping is
// monotone, so overlapping boxes always share a cell). Dense meshes put thousands of
// small shadows on the light: the all-pairs loop was quadratic in them.
class ShadowGrid {
 public:
  explicit ShadowGrid(const std::vector<CPoly>& polys) : box_(polys.size()), stamp_(polys.size(), 0) {
    for (size_t p = 0; p < polys.size(); ++p) {
      Box& b = box_[p];
      for (const P2d& v : polys[p].v) {
        b.x0 = std::min(b.x0, v.x()), b.x1 = std::max(b.x1, v.x());
        b.y0 = std::min(b.y0, v.y()), b.y1 = std::max(b.y1, v.y());
      }
      if (!(std::isfinite(b.x0) && std::isfinite(b.x1) && std::isfinite(b.y0) && std::isfinite(b.y1))) all_ = true;
    }
    if (all_ || polys.size() < 64) {
      all_ = true;
      return;
    }
    n_ = std::min<size_t>(64, size_t(std::sqrt(double(polys.size()))));
    const Box& l = box_[0];
    ox_ = l.x0, oy_ = l.y0;
    sx_ = double(n_) / std::max(l.x1 - l.x0, 1e-300), sy_ = double(n_) / std::max(l.y1 - l.y0, 1e-300);
    if (!std::isfinite(sx_) || !std::isfinite(sy_)) {
      all_ = true;
      return;
    }
    cells_.assign(n_ * n_, {});
    for (size_t p = 1; p < polys.size(); ++p) {
      const Box& b = box_[p];
      for (size_t j = cy(b.y0); j <= cy(b.y1); ++j)
        for (size_t i = cx(b.x0); i <= cx(b.x1); ++i) cells_[j * n_ + i].push_back(uint32_t(p));
    }
  }

  // The polygons q >= 1, q != skip, whose box meets the box of segment (a, b), in
  // increasing order (every such q when the grid is off).
  void candidates(const P2d& a, const P2d& b, size_t skip, std::vector<uint32_t>& out) {
    out.clear();
    if (all_) {
      for (size_t q = 1; q < box_.size(); ++q)
        if (q != skip) out.push_back(uint32_t(q));
      return;
    }
    const double x0 = std::min(a.x(), b.x()), x1 = std::max(a.x(), b.x());
    const double y0 = std::min(a.y(), b.y()), y1 = std::max(a.y(), b.y());
    ++tick_;
    for (size_t j = cy(y0); j <= cy(y1); ++j)
      for (size_t i = cx(x0); i <= cx(x1); ++i)
        for (uint32_t q : cells_[j * n_ + i]) {
          if (stamp_[q] == tick_ || q == skip) continue;
          stamp_[q] = tick_;
          const Box& c = box_[q];
          if (c.x0 <= x1 && x0 <= c.x1 && c.y0 <= y1 && y0 <= c.y1) out.push_back(q);
        }
    std::sort(out.begin(), out.end());
  }

 private:
  struct Box {
    double x0 = HUGE_VAL, x1 = -HUGE_VAL, y0 = HUGE_VAL, y1 = -HUGE_VAL;
  };
  size_t cell(double v, double o, double s) const {
    const double c = std::floor((v - o) * s);
    return c <= 0 ? 0 : c >= double(n_ - 1) ? n_ - 1 : size_t(c);
  }
  size_t cx(double x) const { return cell(x, ox_, sx_); }
  size_t cy(double y) const { return cell(y, oy_, sy_); }

  std::vector<Box> box_;
  std::vector<uint32_t> stamp_;
  uint32_t tick_ = 0;
  bool all_ = false;
  size_t n_ = 1;
  double ox_ = 0, oy_ = 0, sx_ = 1, sy_ = 1;
  std::vector<std::vector<uint32_t>> cells_;
};

// Area of L \ (S_1 u ... u S_m) for the convex polygons polys[0] = L, polys[1..m] = S_j,
// by the boundary integral: a point x of an edge of polygon p is on the region's
// boundary, region on the left (right), when the point just left (right) of x is in
// the region and the one just right (left) is not; a boundary piece carried by edges of
// several polygons is counted on the one of lowest index. Every side decision is exact
// (CGAL's exact orientation on the doubles); only the cut parameters are rounded, and
// moving a cut by e moves the measure of the counted set by at most 2e. The result
// encloses the exact area of the region of these double polygons. Polygons strictly
// apart from an edge are left out of its loop (ShadowGrid).
I region_area(const std::vector<CPoly>& polys, const P2d& o) {
  I area(0);
  std::vector<Span> spans(polys.size());
  std::vector<double> cuts;
  std::vector<uint32_t> near;  // the shadows whose box meets the edge's, increasing
  ShadowGrid grid(polys);
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
      grid.candidates(a, b, p, near);
      double err = 0;
      cuts.assign({0.0, 1.0});
      auto add_cuts = [&](size_t q) {
        if (q != 0 || p == 0) spans[q] = edge_span(a, b, polys[q]);
        const Span& s = spans[q];
        for (double x : {s.lo_l, s.hi_l, s.lo_r, s.hi_r})
          if (x > 0 && x < 1) cuts.push_back(x);
        err += std::min(2.0 * s.err, window);
      };
      if (p != 0) add_cuts(0);
      for (uint32_t q : near) add_cuts(q);
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
        if (p != 0) {
          const Span& s = spans[0];
          const bool ql = s.lo_l < t && t < s.hi_l, qr = s.lo_r < t && t < s.hi_r;
          in_r = qr;  // shadow edge: the right point must be in L
          if (ql != qr) tie = true;  // the piece lies on an edge of L too
        }
        for (uint32_t q : near) {
          const Span& s = spans[q];
          const bool ql = s.lo_l < t && t < s.hi_l, qr = s.lo_r < t && t < s.hi_r;
          if (ql) in_l = false;
          if (qr) in_r = false;
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

// One pair's bound, step by step (visible_fraction_bound runs them). The state: the light
// polygon L = polys[0] and its measures, the receiver in interval arithmetic, the shadows
// so far (polys[1..]) with their snapping anchors and the perturbation sum, and the
// triangle whose shadow is being made (cf, vs, delta).
class FractionBounder {
 public:
  FractionBounder(const Scene& scene, size_t receiver, const Prepared& pre)
      : scene_(scene), pre_(pre), f_(pre.f()), fp_(pre.fp), rf_(scene.receivers[receiver].p), rp_(ipt(rf_)) {}

  // L in the frame: float coordinates, exact doubles; the certified area needs a convex
  // light (DESIGN: lights are convex; anything else goes to the exact path). False,
  // with `why`, when it is not strictly convex.
  bool light_polygon(const char*& why);
  void receiver_intervals();
  // The shadow of triangle t added to polys (or nothing when it has no area); false,
  // with `why`, when its projection has no finite enclosure.
  bool add_shadow(uint32_t t, const char*& why);
  // The enclosure of the fraction; false when it came out empty.
  bool enclosure(double& lo, double& hi) const;
  size_t shadows() const { return polys_.size() - 1; }

 private:
  enum class Shadow { Made, Skip, NotFinite };
  bool outside_slab(bool& inside, bool& maybe_beyond, bool& maybe_behind) const;
  bool interval_sides();
  bool add_vertex(const I& u, const I& w);
  bool far(const Small<P2d>& pts) const;
  bool narrow(const I& v) const;
  bool project_vertex(const Vec3f& x, I& u, I& w) const;
  bool project_inside();
  bool clip_intervals(bool maybe_beyond, bool maybe_behind);
  Shadow clip_lazy(bool maybe_beyond, bool maybe_behind);
  void snap();
  void hull_and_perturbation();

  const Scene& scene_;
  const Prepared& pre_;
  const ExactLight& f_;
  const FastPass& fp_;
  const Vec3f& rf_;
  const IK::Point_3 rp_;
  // L and its measures.
  std::vector<CPoly> polys_ = std::vector<CPoly>(1);
  P2d o_;
  double light_per_ = 0;  // perimeter of L, rounded up
  I light2_{0};           // area of L
  double near_lo_[2] = {0, 0}, near_hi_[2] = {0, 0};
  std::vector<P2d> anchors_;
  double light_width_ = 0, snap_tol_ = 0;
  // The receiver and the light plane as intervals.
  I nI_[3], d0I_, sg_, rI_[3], grI_;
  std::vector<std::array<I, 3>> sides_iv_;
  int sides_iv_state_ = 0;  // 0 not made, 1 made, 2 not usable
  I perturb_{0};
  // The current triangle and its shadow vertices as intervals (midpoint, and the sum of
  // the two widths as delta).
  Vec3f cf_[3];
  Small<P2d> vs_;
  double delta_ = 0;
};

bool FractionBounder::light_polygon(const char*& why) {
  polys_[0].v = f_.dpolygon;
  const std::vector<P2d>& lv = polys_[0].v;
  const size_t ln = lv.size();
  for (size_t k = 0; k < ln; ++k)
    if (orient2(lv[k], lv[(k + 1) % ln], lv[(k + 2) % ln]) != CGAL::POSITIVE) {
      why = "light not strictly convex";
      return false;
    }
  o_ = lv[0];
  {
    Upward up;
    for (size_t k = 0; k < ln; ++k) {
      const P2d &p0 = lv[k], &p1 = lv[(k + 1) % ln];
      I dx = I(p0.x()) - p1.x(), dy = I(p0.y()) - p1.y();
      light_per_ += CGAL::sqrt(dx * dx + dy * dy).sup();
    }
    for (size_t k = 1; k + 1 < ln; ++k) light2_ += det2(o_, lv[k], lv[k + 1]) * I(0.5);
  }
  // L's frame box grown by its own extent on every side: a shadow vertex beyond it is
  // "far" (far()).
  double largest = 0;
  {
    double lo[2] = {lv[0].x(), lv[0].y()}, hi[2] = {lo[0], lo[1]};
    for (const P2d& v : lv) {
      lo[0] = std::min(lo[0], v.x()), hi[0] = std::max(hi[0], v.x());
      lo[1] = std::min(lo[1], v.y()), hi[1] = std::max(hi[1], v.y());
    }
    const double ext = std::max(hi[0] - lo[0], hi[1] - lo[1]);
    for (int a = 0; a < 2; ++a) {
      near_lo_[a] = lo[a] - ext, near_hi_[a] = hi[a] + ext;
      largest = std::max({largest, std::abs(lo[a]), std::abs(hi[a])});
    }
  }
  // Snapping (snap()): 2^-30 of the largest coordinate, far above the interval
  // midpoints' rounding (a few ulps of it), and at most 2^-30 of L's width (area over
  // perimeter), so that the moves, which enter the bound as delta times a perimeter,
  // stay far below the fraction tolerance on a sliver light far from the origin too (any
  // tolerance keeps the bound valid; this one keeps it narrow).
  anchors_ = lv;
  light_width_ = 2.0 * light2_.sup() / std::max(light_per_, 1e-300);  // area over half the perimeter
  snap_tol_ = 0x1p-30 * std::min(largest, light_width_);
  return true;
}

void FractionBounder::receiver_intervals() {
  for (int a = 0; a < 3; ++a) nI_[a] = f_.n[a].approx();
  d0I_ = f_.d0.approx();
  sg_ = I(fp_.sgn);
  for (int a = 0; a < 3; ++a) rI_[a] = I(double(rf_[a]));
  Upward up;
  grI_ = sg_ * (nI_[0] * rI_[0] + nI_[1] * rI_[1] + nI_[2] * rI_[2] - d0I_);
}

// The pyramid's side planes in interval arithmetic for the interval clip:
// M = (a - r) x (b - r) for consecutive lifted hull vertices a, b, turned so that
// M . (c - r) > 0 for the next one c (inside: M . (x - r) >= 0), from the intervals
// of the exact vertices; made at first use. Not usable when an orientation is not
// certain (the interval clip then leaves every triangle to the lazy path).
bool FractionBounder::interval_sides() {
  if (sides_iv_state_ == 0) {
    Upward up;
    const size_t hn = f_.lifted.size();
    auto minus_r = [&](const V3& x) {
      return std::array<I, 3>{x[0].approx() - rI_[0], x[1].approx() - rI_[1], x[2].approx() - rI_[2]};
    };
    sides_iv_state_ = 1;
    for (size_t j = 0; j < hn && sides_iv_state_ == 1; ++j) {
      const std::array<I, 3> a = minus_r(f_.lifted[j]), b = minus_r(f_.lifted[(j + 1) % hn]),
                             c = minus_r(f_.lifted[(j + 2) % hn]);
      std::array<I, 3> m = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
      const I turn = m[0] * c[0] + m[1] * c[1] + m[2] * c[2];
      if (turn.sup() < 0.0)
        for (I& x : m) x = -x;
      else if (!(turn.inf() > 0.0))
        sides_iv_state_ = 2;
      sides_iv_.push_back(m);
    }
  }
  return sides_iv_state_ == 1;
}

bool FractionBounder::add_vertex(const I& u, const I& w) {
  double um = 0.5 * (u.inf() + u.sup()), wm = 0.5 * (w.inf() + w.sup());
  double dk = (u.sup() - u.inf()) + (w.sup() - w.inf());
  if (!std::isfinite(um) || !std::isfinite(wm) || !(dk >= 0) || !std::isfinite(dk)) return false;
  delta_ = std::max(delta_, dk);
  vs_.emplace_back(um, wm);
  return true;
}

// A shadow reaching far beyond L (a vertex next to the receiver's level projects far
// out) is replaced by its part inside L, the projection of the triangle clipped to the
// pyramid: L minus the union is the same set. Far vertices made the bound useless: their
// errors enter delta (Steiner's term grows with delta^2) and the cut parameters of their
// long edges cancel catastrophically.
bool FractionBounder::far(const Small<P2d>& pts) const {
  for (const P2d& v : pts)
    if (!(v.x() >= near_lo_[0] && v.x() <= near_hi_[0] && v.y() >= near_lo_[1] && v.y() <= near_hi_[1])) return true;
  return false;
}

// A vertex interval is narrow when it is finite and at most 2^-40 of its magnitude or
// 2^-37 of L's width wide; any other is not used from the plain interval projection
// (the triangle then takes the lazy path) nor from a lazy number's interval (its exact
// value is computed). Either width keeps the bound narrow: it enters as delta times a
// perimeter (at 2^-37 of the width, about 2^-35 of L's area per shadow), and the
// midpoints stay within 2^-38 of the width of the exact points, far inside the snapping
// tolerance (at least 2^-31 of the width: the largest coordinate of L is at least half
// its extent), so coincident points still snap together. The width clause matters for
// coordinates near zero, where the relative one alone asks for many exact evaluations.
bool FractionBounder::narrow(const I& v) const {
  if (!std::isfinite(v.inf()) || !std::isfinite(v.sup())) return false;
  const double w = v.sup() - v.inf();
  return w <= 0x1p-40 * std::max(std::abs(v.inf()), std::abs(v.sup())) || w <= 0x1p-37 * light_width_;
}

// Projection of a triangle vertex (a float point strictly inside the slab) in interval
// arithmetic; false when the interval is not narrow. Every path projects the triangle's
// own vertices with it, so a vertex shared by two triangles gets the same double point
// in both shadows whichever path each takes, and their shared edges are exactly
// collinear (edge_span's exact case) instead of nearly so, where the cut parameters are
// ill-conditioned.
bool FractionBounder::project_vertex(const Vec3f& x, I& u, I& w) const {
  Upward up;
  I xI[3] = {I(double(x.x)), I(double(x.y)), I(double(x.z))};
  I den = sg_ * (nI_[0] * (rI_[0] - xI[0]) + nI_[1] * (rI_[1] - xI[1]) + nI_[2] * (rI_[2] - xI[2]));  // g_r - g(x)
  I sc = grI_ / den;
  u = rI_[f_.i1] + (xI[f_.i1] - rI_[f_.i1]) * sc;
  w = rI_[f_.i2] + (xI[f_.i2] - rI_[f_.i2]) * sc;
  return narrow(u) && narrow(w);
}

// The exact path's skips for the current triangle: true when it is outside the open
// slab, exactly (all g <= 0 or all g >= g_r). `inside`: certainly strictly inside the
// slab (double test); maybe_beyond / maybe_behind: some vertex possibly at g <= 0 / at
// g >= g_r.
bool FractionBounder::outside_slab(bool& inside, bool& maybe_beyond, bool& maybe_behind) const {
  inside = true, maybe_beyond = false, maybe_behind = false;
  for (int k = 0; k < 3; ++k) {
    double e = 0, v = fp_.g(to_double(cf_[k]), e);
    bool pos = v > e, below = fp_.gr - v > e + fp_.gr_err;
    if (!pos || !below) inside = false;
    if (!pos) maybe_beyond = true;
    if (!below) maybe_behind = true;
  }
  if (inside) return false;
  bool all_beyond = maybe_beyond, all_behind = maybe_behind;
  for (int k = 0; k < 3 && (all_beyond || all_behind); ++k) {
    FT g = pre_.g_of(exact3(cf_[k]));
    if (CGAL::is_positive(g)) all_beyond = false;
    if (g < pre_.g_r) all_behind = false;
  }
  return all_beyond || all_behind;
}

// A triangle certainly strictly inside the slab, no clipping: its three vertices
// projected in interval arithmetic. False (vs and delta empty) when a projection is not
// narrow or the shadow is far.
bool FractionBounder::project_inside() {
  bool projected = true;
  for (int k = 0; k < 3 && projected; ++k) {
    I u, w;
    projected = project_vertex(cf_[k], u, w) && add_vertex(u, w);
  }
  if (projected && far(vs_)) projected = false;
  if (!projected) {
    vs_.clear();
    delta_ = 0;
  }
  return projected;
}

// Interval clip: the lazy path (clip_lazy) in interval arithmetic, without its exact
// numbers. Every clip decision must be certain from the intervals (a vertex interval on
// one side of each plane; the light-plane and receiver-level tests of triangle vertices
// likewise), and every projected vertex narrow; otherwise the triangle takes the lazy
// path, which decides those cases exactly. Where it succeeds it keeps the lazy path's
// clipping order, crossing points (computed from the same end of each edge) and tags, so
// the polygon is the same with every vertex enclosed by its interval: the same S' within
// delta of S, without the lazy numbers' allocations (a DAG node per operation). True: vs
// and delta filled; false: take the lazy path (which starts from an empty vs and delta).
bool FractionBounder::clip_intervals(bool maybe_beyond, bool maybe_behind) {
  using IP = std::array<I, 3>;
  Small<std::pair<I, I>> uw;  // projected vertices, added outside the Upward scope
  auto g_iv = [&](const IP& x) { return sg_ * (nI_[0] * x[0] + nI_[1] * x[1] + nI_[2] * x[2] - d0I_); };
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
        const auto [from, to] = crossing_ends(i, j, tags[i], tags[j], cf_);
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
      const I d = g_iv(point(cf_[k])) - grI_;
      if (d.inf() >= 0.0) reaches = true;
      else if (!(d.sup() < 0.0)) return false;
    }
  for (bool to_pyramid : {reaches, true}) {
    Small<IP> poly = {point(cf_[0]), point(cf_[1]), point(cf_[2])};
    Small<int> tags = {0, 1, 2};
    Small<I> val;
    if (to_pyramid) {
      if (!interval_sides()) return false;
      for (const IP& m : sides_iv_) {
        val.clear();
        for (const IP& x : poly) {
          const I v = m[0] * (x[0] - rI_[0]) + m[1] * (x[1] - rI_[1]) + m[2] * (x[2] - rI_[2]);
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
        ui = x[f_.i1];
        wi = x[f_.i2];
      } else if (tags[k] >= 0) {
        if (!certain(g_iv(x))) return false;  // maybe on the light plane: the lazy path tells
        if (!project_vertex(cf_[tags[k]], ui, wi)) return false;
      } else {
        const I sc = grI_ / (grI_ - g_iv(x));
        ui = rI_[f_.i1] + (x[f_.i1] - rI_[f_.i1]) * sc;
        wi = rI_[f_.i2] + (x[f_.i2] - rI_[f_.i2]) * sc;
      }
      if (!narrow(ui) || !narrow(wi)) return false;
      uw.emplace_back(ui, wi);
    }
    {
      CGAL::Protect_FPU_rounding<true> nearest(CGAL_FE_TONEAREST);  // add_vertex as on the other paths
      vs_.clear();
      delta_ = 0;
      for (const auto& [ui, wi] : uw)
        if (!add_vertex(ui, wi)) return false;
    }
    if (to_pyramid || !far(vs_)) break;
  }
  return true;
}

// The exact path's clipping with lazy exact numbers: exact signs, interval points.
// Without the pyramid clip first; a far shadow is projected again from the part of the
// triangle inside the pyramid.
FractionBounder::Shadow FractionBounder::clip_lazy(bool maybe_beyond, bool maybe_behind) {
  std::vector<V3> tri = {exact3(cf_[0]), exact3(cf_[1]), exact3(cf_[2])};
  bool reaches_receiver = false;  // (every vertex certainly below g_r: no exact test)
  if (maybe_behind)
    for (const V3& x : tri) reaches_receiver |= pre_.g_of(x) >= pre_.g_r;
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
    double e = 0, v = fp_.g(to_double(x), e);
    return std::abs(v) <= e && CGAL::is_zero(pre_.g_of(exact3(x)));
  };
  bool finite = true;
  for (bool to_pyramid : {reaches_receiver, true}) {
    std::vector<V3> poly = tri;
    // Which triangle vertex; -1 for a point of a pyramid clip, -2 for one of the clip
    // to g >= 0 (a point on the light plane).
    std::vector<int> tags = {0, 1, 2};
    if (to_pyramid)
      for (const auto& [m, e] : pre_.sides()) poly = clip(poly, m, e, false, &tags, cf_);
    // Every vertex certainly at g > 0 (the double test): the clip to g >= 0 would
    // return the polygon unchanged (g is affine, so positive on its convex hull).
    if (maybe_beyond) poly = clip(poly, pre_.gn, pre_.ge, false, &tags, cf_, -2);
    vs_.clear();
    delta_ = 0;
    for (size_t k = 0; k < poly.size() && finite && poly.size() >= 3; ++k) {
      const V3& x = poly[k];
      I ui, wi;
      // A point on the light plane (g = 0) projects onto itself: its own frame
      // coordinates, not the projection formula, whose rounding would move a blocker
      // vertex sitting on a light vertex or edge off it by an ulp (a shadow edge along an
      // edge of L then nearly, not exactly, collinear with it: ill-conditioned cuts).
      if (tags[k] == -2 || (tags[k] >= 0 && on_light_plane(cf_[tags[k]]))) {
        finite = tags[k] == -2 ? add_vertex(tight(x[f_.i1]), tight(x[f_.i2]))
                               : add_vertex(I(double(cf_[tags[k]][f_.i1])), I(double(cf_[tags[k]][f_.i2])));
        continue;
      }
      // A kept triangle vertex has 0 <= g < g_r unless it is the receiver itself, whose
      // projection has no finite enclosure either way.
      if (tags[k] >= 0 && project_vertex(cf_[tags[k]], ui, wi)) {
        finite = add_vertex(ui, wi);
        continue;
      }
      FT sc = pre_.g_r / (pre_.g_r - pre_.g_of(x));
      FT u = pre_.r[f_.i1] + (x[f_.i1] - pre_.r[f_.i1]) * sc, w = pre_.r[f_.i2] + (x[f_.i2] - pre_.r[f_.i2]) * sc;
      finite = add_vertex(tight(u), tight(w));
    }
    if (to_pyramid || !finite || !far(vs_)) break;
  }
  if (!finite) return Shadow::NotFinite;
  return vs_.size() < 3 ? Shadow::Skip : Shadow::Made;
}

// Snapping. Exact coincidences of the geometry (a shadow corner on a corner of L, two
// shadows sharing a projected point reached by different formulas, a blocker edge
// projecting onto an edge of L) come out of the interval midpoints an ulp apart; edges
// through them are then nearly, not exactly, collinear with L's or each other's, and the
// boundary integral's cut parameters on nearly collinear edges are ill-conditioned (a
// bound too wide to decide). Two moves, each within about snap_tol:
// - each coordinate within snap_tol of the same coordinate of a vertex of L or of an
//   earlier shadow takes that value (a whole vertex snaps onto a vertex; a corner an
//   ulp off an axis-parallel edge of L goes onto its line);
// - a vertex within snap_tol of the line of an edge of L, but not on it, is pushed
//   outwards to about snap_tol beyond it: a shadow edge along an edge of L, between
//   points inside that edge, is then strictly outside, decided by exact side tests.
// The moved S' is within delta + (the largest move, its 1-norm) of S, so delta grows
// by that; the exact side tests then decide the coincident parts without cuts.
void FractionBounder::snap() {
  const Small<P2d> before = vs_;
  for (P2d& v : vs_) {
    double c[2] = {v.x(), v.y()};
    for (int k = 0; k < 2; ++k)
      for (const P2d& a : anchors_) {
        const double ak = k == 0 ? a.x() : a.y();
        if (std::abs(c[k] - ak) <= snap_tol_) {
          c[k] = ak;
          break;
        }
      }
    v = P2d(c[0], c[1]);
  }
  const CPoly& L = polys_[0];
  for (P2d& v : vs_)
    for (size_t k = 0; k < L.v.size(); ++k) {
      const P2d &c = L.v[k], &d = L.v[(k + 1) % L.v.size()];
      if (orient2(c, d, v) == CGAL::ZERO) continue;
      const double ex = d.x() - c.x(), ey = d.y() - c.y(), len = std::hypot(ex, ey);
      if (!(len > 0)) continue;
      const double dist = (ex * (v.y() - c.y()) - ey * (v.x() - c.x())) / len;  // > 0 inside
      if (!(std::abs(dist) <= snap_tol_)) continue;
      const double step = dist + snap_tol_;  // against the inward unit normal (-ey, ex) / len
      const P2d w(v.x() + step * ey / len, v.y() - step * ex / len);
      if (orient2(c, d, w) == CGAL::NEGATIVE) v = w;
    }
  double moved = 0;
  for (size_t k = 0; k < vs_.size(); ++k)
    moved = std::max(moved, std::abs(vs_[k].x() - before[k].x()) + std::abs(vs_[k].y() - before[k].y()));
  delta_ += moved * (1.0 + 0x1p-50);
}

// S' = the convex hull of the double vertices (exact predicates): within delta of S.
// area(X + B_delta) - area(X) = delta per(X) + pi delta^2 for convex X, and
// per(S) <= per(S' + B_delta) = per(S') + 2 pi delta: so delta per(S') + 3 pi delta^2
// bounds the change for S and S' alike. Only the change inside L counts: a point of L
// within delta of S but not in S has its nearest point of S in S n (L + B_delta), so the
// change is at most delta per(S n (L + B_delta)) + pi delta^2 <= delta min(per(S),
// per(L) + 2 pi delta) + pi delta^2 (perimeters grow with convex sets).
void FractionBounder::hull_and_perturbation() {
  CPoly s;
  convex_hull_small(vs_, s.v);
  anchors_.insert(anchors_.end(), s.v.begin(), s.v.end());
  Upward up;
  double per = 0;
  // (A segment's perimeter is twice its length: both directions are summed.)
  for (size_t k = 0; k < s.v.size() && s.v.size() >= 2; ++k) {
    const P2d &p0 = s.v[k], &p1 = s.v[(k + 1) % s.v.size()];
    I dx = I(p0.x()) - p1.x(), dy = I(p0.y()) - p1.y();
    per += CGAL::sqrt(dx * dx + dy * dy).sup();
  }
  I dI(delta_);
  perturb_ += dI * I(std::min(per, light_per_)) + I(9.4248) * dI * dI;
  if (s.v.size() < 3) return;  // a segment or point: no area (its perturbation term is kept)
  polys_.push_back(std::move(s));
}

// The exact path's skips (zero-area projections, triangles outside the open slab) are
// decided exactly here too; a triangle certainly strictly inside the slab is projected
// with interval arithmetic: its shadow S is the triangle of the exact projected
// vertices, the double triangle S' has every vertex within delta of them, so S' lies
// within delta of S and S within delta of S' (Hausdorff, both convex), and the area of
// the light minus the union changes by at most sum (delta per + pi delta^2) (Steiner's
// formula for the delta-neighbourhood of a convex set). Any other triangle is clipped
// (clip_intervals, else clip_lazy) and its clipped shadow bounded the same way.
bool FractionBounder::add_shadow(uint32_t t, const char*& why) {
  const TriangleSoup& mesh = scene_.mesh;
  for (int k = 0; k < 3; ++k) cf_[k] = mesh.corner(t, k);
  IK::Point_3 ai = ipt(cf_[0]), bi = ipt(cf_[1]), ci = ipt(cf_[2]);
  if (CGAL::collinear(ai, bi, ci) || CGAL::orientation(ai, bi, ci, rp_) == CGAL::COPLANAR) return true;
  bool inside = true, maybe_beyond = false, maybe_behind = false;
  if (outside_slab(inside, maybe_beyond, maybe_behind)) return true;
  vs_.clear();
  delta_ = 0;
  bool projected = inside && project_inside();
  if (!projected && clip_intervals(maybe_beyond, maybe_behind)) {
    if (vs_.size() < 3) return true;
    projected = true;
  }
  if (!projected) {
    const Shadow s = clip_lazy(maybe_beyond, maybe_behind);
    if (s == Shadow::NotFinite) {
      why = "clipped projection not finite";
      return false;
    }
    if (s == Shadow::Skip) return true;
  }
  snap();
  hull_and_perturbation();
  return true;
}

bool FractionBounder::enclosure(double& lo, double& hi) const {
  I area = region_area(polys_, o_);
  {
    Upward up;
    area = area + I(-perturb_.sup(), perturb_.sup());
    I frac = area / light2_;
    lo = std::max(frac.inf(), 0.0);
    hi = std::min(frac.sup(), 1.0);
  }
  return lo <= hi;
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
  FractionBounder b(scene, receiver, pre);
  if (!b.light_polygon(out.why)) return out;
  b.receiver_intervals();
  for (uint32_t t : pre.unknown)
    if (!b.add_shadow(t, out.why)) return out;
  out.shadows = b.shadows();
  double lo = 0, hi = 1;
  if (!b.enclosure(lo, hi)) {
    out.why = "empty enclosure";
    return out;
  }
  out.certified = true;
  out.lo = lo;
  out.hi = hi;
  return out;
}

}  // namespace visgate::oracle
