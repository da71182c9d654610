// Tests of lib/plucker/fragment.cpp: light fragments, node planes, shadow boxes and
// point-in-fragment (paper 002 section 4.2).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "lib/geom/predicates.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

namespace {

// The pieces after a split by `pl`: each piece it cuts replaced by its two sides.
std::vector<std::vector<Vec3d>> split_all(const NodePlane& pl, const std::vector<std::vector<Vec3d>>& pieces) {
  std::vector<std::vector<Vec3d>> out;
  std::vector<Vec3d> pos, neg;
  for (const auto& pc : pieces) {
    if (split_fragment(pl, pc.data(), int(pc.size()), pos, neg) != SplitResult::Both) {
      out.push_back(pc);
      continue;
    }
    if (!pos.empty()) out.push_back(pos);
    if (!neg.empty()) out.push_back(neg);
  }
  return out;
}

// A square light at height 2 of random size (1e-3 to 1e3) and offset (0 every third
// trial, else up to 1e3 away), and random points around it between two heights.
struct RandomSquareLight {
  double scale, off;
  std::vector<Vec3d> light;
  LightBounds lb;
  RandomSquareLight(Rng& rng, int trial)
      : scale(std::pow(10.0, rng.uniform(-3, 3))), off(trial % 3 == 0 ? 0.0 : rng.uniform(-1e3, 1e3)),
        light({Vec3d(off, off, 2), Vec3d(off, off + scale, 2), Vec3d(off + scale, off + scale, 2),
               Vec3d(off + scale, off, 2)}),
        lb(LightBounds::of(light.data(), 4)) {}
  Vec3d point(Rng& rng, double zlo, double zhi) const {
    const double x = off + scale * rng.uniform(-0.5, 1.5), y = off + scale * rng.uniform(-0.5, 1.5);
    return Vec3d(x, y, rng.uniform(zlo, zhi));
  }
};

}  // namespace

TEST(PluckerFragment, NodePlaneSignsFromTheLightsBoundsAreExact) {
  // A node plane's one error bound per plane (fragment.h LightBounds, the largest over
  // the light polygon): on pieces of random lights (far from the local origin too), made
  // by random splits so that their vertices are interpolated, every decided side of a
  // vertex is the exact sign of det[x - r, a - r, b - r] (orient3d_exact_value), and a piece a
  // plane split off is never judged to lie on the wrong side by that plane.
  Rng rng(33);
  int decided = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const RandomSquareLight sq(rng, trial);
    const std::vector<Vec3d>& light = sq.light;
    const LightBounds& lb = sq.lb;
    auto random_point = [&](double zlo, double zhi) { return sq.point(rng, zlo, zhi); };
    std::vector<std::vector<Vec3d>> pieces = {light};
    std::vector<Vec3d> pos, neg;
    for (int k = 0; k < 6; ++k) {  // split every piece by a random plane through a random query point
      const NodePlane pl = node_plane(random_point(-2, 0), random_point(0.5, 1.5), random_point(0.5, 1.5), lb);
      std::vector<std::vector<Vec3d>> next;
      for (const auto& pc : pieces) {
        SplitResult sr = split_fragment(pl, pc.data(), int(pc.size()), pos, neg);
        if (sr != SplitResult::Both) {
          next.push_back(pc);
          continue;
        }
        // The pieces are on their sides of the plane that cut them, up to its bound.
        if (!pos.empty()) {
          EXPECT_NE(classify_fragment(pl, pos.data(), int(pos.size())), SplitResult::Negative);
          next.push_back(pos);
        }
        if (!neg.empty()) {
          EXPECT_NE(classify_fragment(pl, neg.data(), int(neg.size())), SplitResult::Positive);
          next.push_back(neg);
        }
      }
      pieces.swap(next);
    }
    const Vec3d r = random_point(-2, 0), a = random_point(0.5, 1.5), b = random_point(0.5, 1.5);
    const NodePlane pl = node_plane(r, a, b, lb);
    if (pl.on_line) continue;
    // Split by this plane too: the crossing points lie on it up to their rounding, where
    // only the bound keeps a decided sign exact.
    const std::vector<std::vector<Vec3d>> last = split_all(pl, pieces);
    for (const auto& pc : last)
      for (const Vec3d& x : pc) {
        const SplitResult sr = classify_fragment(pl, &x, 1);
        const int exact = orient3d_exact_value(SumPoint(Vec3f(), r), SumPoint(Vec3f(), x), SumPoint(Vec3f(), a),
                                               SumPoint(Vec3f(), b)).sign;
        if (sr == SplitResult::ZeroArea) continue;  // within the bound: undecided
        ++decided;
        EXPECT_EQ(sr == SplitResult::Positive ? 1 : -1, exact);
      }
  }
  EXPECT_GT(decided, 5000);
}

TEST(PluckerFragment, SplitHalvesAndDegenerateCases) {
  std::vector<Vec3d> sq = {Vec3d(-1, -1, 2), Vec3d(-1, 1, 2), Vec3d(1, 1, 2), Vec3d(1, -1, 2)};
  std::vector<Vec3d> pos, neg;
  // Plane through the origin and the line x = 0, z = 1 (along y): splits at x = 0.
  SplitResult s = split_fragment(Vec3d(0, 0, 0), Vec3d(0, -1, 1), Vec3d(0, 1, 1), sq.data(), 4, pos, neg);
  ASSERT_EQ(s, SplitResult::Both);
  EXPECT_DOUBLE_EQ(polygon_area(pos.data(), int(pos.size())), 2.0);
  EXPECT_DOUBLE_EQ(polygon_area(neg.data(), int(neg.size())), 2.0);
  // The query point on the node's line.
  EXPECT_EQ(split_fragment(Vec3d(0, 0, 0), Vec3d(0, 0, 1), Vec3d(0, 0, 3), sq.data(), 4, pos, neg), SplitResult::OnLine);
  // A zero-area fragment (a segment) on the splitting plane.
  std::vector<Vec3d> seg = {Vec3d(0, -1, 2), Vec3d(0, 0, 2), Vec3d(0, 1, 2)};
  EXPECT_EQ(split_fragment(Vec3d(0, 0, 0), Vec3d(0, -1, 1), Vec3d(0, 1, 1), seg.data(), 3, pos, neg),
            SplitResult::ZeroArea);
  // A vertex on the plane goes to both pieces.
  std::vector<Vec3d> tri = {Vec3d(0, -1, 2), Vec3d(1, 1, 2), Vec3d(-1, 1, 2)};
  ASSERT_EQ(split_fragment(Vec3d(0, 0, 0), Vec3d(0, -1, 1), Vec3d(0, 1, 1), tri.data(), 3, pos, neg), SplitResult::Both);
  EXPECT_EQ(pos.size(), 3u);
  EXPECT_EQ(neg.size(), 3u);
}

TEST(PluckerFragment, ShadowBoxHoldsTheCentralProjection) {
  // shadow_box (fragment.h) against points of the polygon projected in double from r onto
  // the light plane z = 2 (local frame: the plane n . x = 0 after moving the origin).
  Rng rng(5);
  LightPlane lp;
  lp.n = Vec3f(0, 0, -1);
  lp.plane_tol = 0;
  lp.extent = 2;
  lp.axes = UVAxes::from_normal(lp.n);
  for (int trial = 0; trial < 300; ++trial) {
    // Local frame: the light plane is z = 0, the receiver below at z = -2.
    Vec3d r(rng.uniform(-1, 1), rng.uniform(-1, 1), -2);
    Vec3d q[3];
    for (auto& v : q) v = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1.9, -0.1));
    UVBox b = shadow_box(lp, r, q, 3);
    for (int k = 0; k < 30; ++k) {
      double u = rng.uniform(), w = rng.uniform() * (1 - u);
      Vec3d x = q[0] + (q[1] - q[0]) * u + (q[2] - q[0]) * w;
      Vec3d rd = r;
      double t = -rd.z / (x.z - rd.z);
      Vec3d y = rd + (x - rd) * t;
      EXPECT_TRUE(b.contains(float(y[lp.axes.u]), float(y[lp.axes.v])));
    }
  }
  // A vertex at the receiver's height (or behind it): no useful bound.
  Vec3d r(0, 0, -2);
  Vec3d q[3] = {Vec3d(0.5, 0, -2), Vec3d(1, 0, -1), Vec3d(0, 1, -1)};
  UVBox b = shadow_box(lp, r, q, 3);
  EXPECT_TRUE(b.contains(1e30f, -1e30f));
}

namespace {
bool same_bits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }
bool same_box(const UVBox& a, const UVBox& b) {
  return same_bits(a.ulo, b.ulo) && same_bits(a.uhi, b.uhi) && same_bits(a.vlo, b.vlo) && same_bits(a.vhi, b.vhi);
}
}  // namespace

TEST(PluckerFragment, UVBoxOfIsTheScalarMinAndMax) {
  // UVBox::of (two lanes at a time where SSE2 is there) gives the bits of std::min and
  // std::max over the vertices in order, for every axis pair, with repeated values,
  // signed zeros and NaNs among the coordinates.
  auto reference = [](const UVAxes& f, const std::vector<Vec3d>& poly) {
    UVBox b;
    if (poly.empty()) return b;
    b.ulo = b.uhi = poly[0][f.u];
    b.vlo = b.vhi = poly[0][f.v];
    for (size_t k = 1; k < poly.size(); ++k) {
      b.ulo = std::min(b.ulo, poly[k][f.u]), b.uhi = std::max(b.uhi, poly[k][f.u]);
      b.vlo = std::min(b.vlo, poly[k][f.v]), b.vhi = std::max(b.vhi, poly[k][f.v]);
    }
    return b;
  };
  const double pick[] = {0.0, -0.0, 1.0, -1.0, 0.5, std::numeric_limits<double>::quiet_NaN()};
  Rng rng(91);
  for (int trial = 0; trial < 3000; ++trial) {
    const UVAxes f = UVAxes::from_normal(trial % 3 == 0 ? Vec3f(1, 0, 0) : (trial % 3 == 1 ? Vec3f(0, -1, 0) : Vec3f(0, 0, 1)));
    std::vector<Vec3d> poly(rng.below(8));
    const bool nan = trial % 5 == 0;
    for (Vec3d& p : poly)
      for (int c = 0; c < 3; ++c) {
        const uint64_t k = rng.below(nan ? 6 : 5);
        p[c] = trial % 2 == 0 ? pick[k] : (k == 5 ? pick[5] : rng.uniform(-1e3, 1e3));
      }
    EXPECT_TRUE(same_box(UVBox::of(f, poly.data(), int(poly.size())), reference(f, poly))) << trial;
  }
}

TEST(PluckerFragment, ClassifyAndSplitTakeTheScalarDotsSigns) {
  // classify_fragment and split_fragment (their values two lanes at a time where SSE2 is
  // there) give the answer of the scalar values dot(x - base, n) against the bound, with
  // bounds equal to some vertex's |value| (a tie stays within the bound), vertices on
  // the base, and values of both signs; a split's pieces take each vertex of value >= 0
  // (<= 0) and one crossing per strict sign change.
  Rng rng(93);
  std::vector<Vec3d> pos, neg;
  int both = 0, ties = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    NodePlane pl;
    const double sc = std::pow(10.0, rng.uniform(-3, 3));
    pl.base = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * sc;
    pl.n = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    std::vector<Vec3d> poly(rng.below(9));
    for (Vec3d& p : poly)
      p = rng.below(6) == 0 ? pl.base : pl.base + Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * sc;
    std::vector<double> val(poly.size());
    for (size_t k = 0; k < poly.size(); ++k) val[k] = dot(poly[k] - pl.base, pl.n);
    pl.bound = poly.empty() || trial % 3 == 0 ? sc * rng.uniform(0, 0.3) : std::abs(val[rng.below(poly.size())]);
    int cpos = 0, cneg = 0;
    for (double& v : val) {
      if (v > pl.bound) ++cpos;
      else if (v < -pl.bound) ++cneg;
      else ties += v != 0.0, v = 0.0;
    }
    const SplitResult want = cpos == 0 && cneg == 0 ? SplitResult::ZeroArea
                             : cneg == 0            ? SplitResult::Positive
                             : cpos == 0            ? SplitResult::Negative
                                                    : SplitResult::Both;
    EXPECT_EQ(classify_fragment(pl, poly.data(), int(poly.size())), want) << trial;
    ASSERT_EQ(split_fragment(pl, poly.data(), int(poly.size()), pos, neg), want) << trial;
    if (want != SplitResult::Both) continue;
    ++both;
    int np = 0, nn = 0;
    for (size_t k = 0; k < val.size(); ++k) {
      const double s0 = val[k], s1 = val[(k + 1) % val.size()];
      const int cross = (s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0);
      np += (s0 >= 0.0) + cross;
      nn += (s0 <= 0.0) + cross;
    }
    EXPECT_EQ(pos.size(), size_t(np >= 3 ? np : 0)) << trial;
    EXPECT_EQ(neg.size(), size_t(nn >= 3 ? nn : 0)) << trial;
  }
  EXPECT_GT(both, 500);
  EXPECT_GT(ties, 500);
}

TEST(PluckerFragment, ShadowBoxIsThePerVertexForm) {
  // shadow_box takes only the two coordinates of each projected vertex and divides the
  // largest spread once: the same floats as projecting the whole vertex and dividing
  // each spread (the form it replaced), on random lights (axis-aligned and Newell
  // planes), receivers and polygons, vertices behind r included.
  auto reference = [](const LightPlane& lp, const Vec3d& rd, const Vec3d* q, size_t n) {
    const Vec3d nd = (lp.nd.x != 0.0 || lp.nd.y != 0.0 || lp.nd.z != 0.0) ? lp.nd : to_double(lp.n);
    const double hr = dot(nd, rd) - lp.h0;
    // The whole vertices projected first, then their box and spreads.
    std::vector<Vec3d> x;
    for (size_t k = 0; k < n && std::abs(hr) > 0.0; ++k) {
      const double hp = dot(nd, q[k]) - lp.h0;
      if (!(hp / hr <= 1.0 - 0x1p-10)) return UVBox::everything();
      x.push_back(rd + (q[k] - rd) * (hr / (hr - hp)));
    }
    if (!(std::abs(hr) > 0.0)) return UVBox::everything();
    const int a = lp.axes.u, b = lp.axes.v;
    constexpr double inf = std::numeric_limits<double>::infinity();
    UVBox box{inf, -inf, inf, -inf};
    double spread = 0.0;
    for (const Vec3d& p : x) {
      box.ulo = std::min(box.ulo, p[a]), box.uhi = std::max(box.uhi, p[a]);
      box.vlo = std::min(box.vlo, p[b]), box.vhi = std::max(box.vhi, p[b]);
      spread = std::max(spread, (std::abs(p[a] - rd[a]) + std::abs(p[b] - rd[b])) / std::abs(hr));
    }
    const double m = std::max({std::abs(box.ulo), std::abs(box.uhi), std::abs(box.vlo), std::abs(box.vhi), double(lp.extent)});
    const double g = double(lp.plane_tol) * 4.0 * (1.0 + spread) + m * 0x1p-16;
    return UVBox{float(box.ulo - g), float(box.uhi + g), float(box.vlo - g), float(box.vhi + g)};
  };
  Rng rng(92);
  int bounded = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    LightPlane lp;
    lp.n = Vec3f(float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)));
    lp.plane_tol = float(rng.uniform(0, 1e-3));
    lp.extent = float(rng.uniform(0.1, 10));
    lp.axes = UVAxes::from_normal(lp.n);
    if (trial % 2 == 0) lp.nd = normalize(to_double(lp.n)), lp.h0 = rng.uniform(-1, 1);
    const double scale = std::pow(10.0, rng.uniform(-3, 3));
    const Vec3d r(rng.uniform(-1, 1) * scale, rng.uniform(-1, 1) * scale, rng.uniform(-1, 1) * scale);
    std::vector<Vec3d> q(rng.below(7));
    for (Vec3d& v : q) v = r + (Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * scale);
    const UVBox got = shadow_box(lp, r, q.data(), q.size());
    EXPECT_TRUE(same_box(got, reference(lp, r, q.data(), q.size()))) << trial;
    bounded += got.uhi < std::numeric_limits<double>::infinity();
  }
  EXPECT_GT(bounded, 200);
}

TEST(PluckerFragment, ShadowBoxOfBoxHoldsTheCornersShadowBox) {
  // shadow_box_of_box against shadow_box of the box's eight corners on random lights
  // (axis-aligned and Newell planes, some axis-aligned normals), receivers and boxes,
  // corners behind r or on r's side of the plane included: the same everything()
  // cases, a box holding the corners' box, and the same box when plane_tol is 0 (the
  // extremes are the same floats; only the spread's bound may be larger).
  Rng rng(93);
  int bounded = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    LightPlane lp;
    lp.n = Vec3f(float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)), float(rng.uniform(-1, 1)));
    if (trial % 5 == 0) lp.n.x = 0.0f;
    if (trial % 7 == 0) lp.n.y = 0.0f;
    lp.plane_tol = trial % 3 == 0 ? 0.0f : float(rng.uniform(0, 1e-3));
    lp.extent = float(rng.uniform(0.1, 10));
    lp.axes = UVAxes::from_normal(lp.n);
    if (trial % 2 == 0) lp.nd = normalize(to_double(lp.n)), lp.h0 = rng.uniform(-1, 1);
    const double scale = std::pow(10.0, rng.uniform(-3, 3));
    const Vec3d r(rng.uniform(-1, 1) * scale, rng.uniform(-1, 1) * scale, rng.uniform(-1, 1) * scale);
    const Vec3d a = r + Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * scale;
    const Vec3d b = a + Vec3d(rng.uniform(0, 1), rng.uniform(0, 1), rng.uniform(0, 1)) * (scale * rng.uniform(0, 1));
    Vec3d q[8];
    for (int k = 0; k < 8; ++k) q[k] = Vec3d((k & 1) ? b.x : a.x, (k & 2) ? b.y : a.y, (k & 4) ? b.z : a.z);
    const UVBox want = shadow_box(lp, r, q, 8), got = shadow_box_of_box(lp, r, a, b);
    const bool everything = want.uhi == std::numeric_limits<double>::infinity();
    ASSERT_EQ(everything, got.uhi == std::numeric_limits<double>::infinity()) << trial;
    if (everything) continue;
    ++bounded;
    EXPECT_TRUE(got.ulo <= want.ulo && got.uhi >= want.uhi && got.vlo <= want.vlo && got.vhi >= want.vhi) << trial;
    if (lp.plane_tol == 0.0f) {
      EXPECT_TRUE(same_box(got, want)) << trial;
    }
  }
  EXPECT_GT(bounded, 300);
}

TEST(PluckerFragment, PointInFragmentToleratesANoiseEdge) {
  // A fragment of columns seed 2 (receiver 2330): two computed vertices 1.6e-6 apart make
  // a "noise" edge whose line has a random direction; the sample 1e-3 inside the
  // fragment is on the wrong side of that line. With the vertex slack (fragment.h) it is
  // inside; a point outside the fragment by 1e-3 stays outside.
  const Vec3d poly[4] = {to_double(Vec3f(-1.16099763f, -0.739767432f, 6.03390026f)),
                         to_double(Vec3f(-0.859376073f, 0.703119755f, 6.0640626f)),
                         to_double(Vec3f(-0.859375f, 0.703125f, 6.0640626f)),
                         to_double(Vec3f(-0.63122803f, 0.532933354f, 6.08687735f))};
  UVAxes f = UVAxes::from_normal(Vec3f(0.0995037f, 0, -0.995037f));
  const Vec3d inside = to_double(Vec3f(-1.09503269f, -0.433688283f, 6.04049683f));
  EXPECT_FALSE(point_in_fragment(f, poly, 4, inside));
  const double slack = 3.0 * 0x1p-20;  // as plucker_solver.cpp had for float fragments
  EXPECT_TRUE(point_in_fragment(f, poly, 4, inside, slack));
  const Vec3d outside = to_double(Vec3f(-1.09503269f - 0.01f, -0.433688283f, 6.04049683f));
  EXPECT_FALSE(point_in_fragment(f, poly, 4, outside, slack));
}

TEST(PluckerFragment, ClippedCrossingIsInterpolatedFromTheNearEnd) {
  // fuzz_plucker crash-8f6fea11... (columns with a vertex moved to z = 7e22): clipping a
  // triangle at the light plane, the crossing on the edge walked from the far vertex was
  // p_far + (p_near - p_far) t with t rounded to 1: 0.34 below the plane. The crossing is
  // now interpolated from the end nearer the plane, in either walking direction.
  const Vec3d near(1.5, 0.0, -0.9), far(1.5, 1.0, 0x1p73);
  auto h = [](const Vec3d& p) { return 0.1 * p.x - p.z; };  // a tilted plane, h > 0 below it
  for (int dir = 0; dir < 2; ++dir) {
    std::vector<Vec3d> tri = {Vec3d(1.5, -1.0, -0.9), dir ? far : near, dir ? near : far};
    double vals[3] = {h(tri[0]), h(tri[1]), h(tri[2])};
    std::vector<Vec3d> out;
    clip_by_values(tri.data(), vals, 3, true, out);
    ASSERT_EQ(out.size(), 4u) << dir;
    int crossings = 0;
    for (const Vec3d& p : out) {
      if (p == tri[0] || p == near) continue;
      ++crossings;
      EXPECT_NEAR(p.z, 0.15, 1e-12) << dir;  // on the plane z = 0.1 x
      EXPECT_NEAR(p.x, 1.5, 1e-12) << dir;
    }
    EXPECT_EQ(crossings, 2) << dir;
  }
}

TEST(PluckerFragment, NodePlaneBaseAndBoundAreNearestBasesAndTheDocumentedBound) {
  // node_plane picks its base with the sums of lines.h nearest_base (computed once for
  // the bound too): the same base, and the bound of fragment.cpp from |centroid - base|_1.
  Rng rng(71);
  for (int trial = 0; trial < 2000; ++trial) {
    const double off = trial % 2 ? rng.uniform(-1e4, 1e4) : 0.0;
    std::vector<Vec3d> light = {Vec3d(off, off, 2), Vec3d(off, off + 1, 2), Vec3d(off + 1.5, off + 1, 2.25)};
    const LightBounds lb = LightBounds::of(light.data(), 3);
    auto pt = [&](double s) { return Vec3d(off + s * rng.uniform(-3, 3), off + s * rng.uniform(-3, 3), rng.uniform(-2, 4)); };
    // Ties too: r, a or b at the same 1-norm distance from the centroid.
    const Vec3d r = pt(1), a = trial % 7 == 0 ? r : pt(1), b = trial % 11 == 0 ? a : pt(2);
    const NodePlane pl = node_plane(r, a, b, lb);
    const Vec3d& want = nearest_base(r, a, b, lb.centroid);
    EXPECT_EQ(pl.base.x, want.x);
    EXPECT_EQ(pl.base.y, want.y);
    EXPECT_EQ(pl.base.z, want.z);
    const Vec3d dc = lb.centroid - want;
    const double d1 = (std::abs(dc.x) + std::abs(dc.y) + std::abs(dc.z)) * (1.0 + 0x1p-50) + lb.radius1;
    const double bound = 8.0 * kUnitRoundoffD * max_component(vabs(pl.n)) * d1 +
                         2.0 * kUnitRoundoffD * (std::abs(pl.n.x) + std::abs(pl.n.y) + std::abs(pl.n.z)) * lb.mag;
    EXPECT_EQ(pl.bound, bound);
  }
}

TEST(PluckerFragment, SplitIntoBuffersStaysWithinTwiceTheVertexCount) {
  // The buffer form writes at most 2n vertices per piece (fragment.h): sentinels right
  // after 2n slots stay untouched, also when vertices lie on the plane (they go to both
  // pieces), and the pieces are the vector form's.
  Rng rng(72);
  const Vec3d sentinel(1e300, -1e300, 7);
  for (int trial = 0; trial < 2000; ++trial) {
    const int n = 3 + int(rng.below(6));
    std::vector<Vec3d> poly;
    for (int k = 0; k < n; ++k) {  // convex: a regular polygon, some vertices snapped onto x = 0
      const double t = 2.0 * M_PI * k / n;
      Vec3d v(std::cos(t), std::sin(t), 1.0);
      if (trial % 3 == 0 && std::abs(v.x) < 0.6) v.x = 0.0;
      poly.push_back(v);
    }
    const LightBounds lb = LightBounds::of(poly.data(), n);
    // Planes through the origin's vertical line x = 0 (on some vertices) or random ones.
    const Vec3d r(trial % 3 == 0 ? 0.0 : rng.uniform(-1, 1), rng.uniform(-1, 1), -1.0);
    const Vec3d a(r.x, r.y + 1.0, 0.5), b(trial % 3 == 0 ? 0.0 : rng.uniform(-1, 1), r.y, 0.5);
    const NodePlane pl = node_plane(r, a, b, lb);
    std::vector<Vec3d> pos(size_t(2 * n) + 1, sentinel), neg(size_t(2 * n) + 1, sentinel);
    int np = -1, nn = -1;
    const SplitResult s = split_fragment(pl, poly.data(), n, pos.data(), np, neg.data(), nn);
    EXPECT_EQ(pos[size_t(2 * n)].x, sentinel.x);
    EXPECT_EQ(neg[size_t(2 * n)].x, sentinel.x);
    std::vector<Vec3d> vp, vn;
    EXPECT_EQ(split_fragment(pl, poly.data(), n, vp, vn), s);
    if (s != SplitResult::Both) continue;
    ASSERT_EQ(size_t(np), vp.size());
    ASSERT_EQ(size_t(nn), vn.size());
    for (int k = 0; k < np; ++k) EXPECT_EQ(pos[size_t(k)].x, vp[size_t(k)].x);
    for (int k = 0; k < nn; ++k) EXPECT_EQ(neg[size_t(k)].y, vn[size_t(k)].y);
  }
}

TEST(PluckerFragment, ClipIntoBuffersIsTheVectorFormsClip) {
  // The caller-buffer form (shade_receiver.cpp's near polygons) gives the vector form's
  // vertices and on-plane flags bit for bit, writes at most 2n entries (sentinels after
  // them stay), and returns 0 where the vector form comes out empty; values exactly 0
  // (vertices on the plane) and both kept sides included.
  Rng rng(73);
  const Vec3d sentinel(1e300, -1e300, 7);
  int kept = 0, emptied = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = 3 + int(rng.below(6));
    std::vector<Vec3d> poly;
    std::vector<double> vals;
    const double a = rng.uniform(-1, 1), b = rng.uniform(-1, 1), c = rng.uniform(-0.8, 0.8);
    for (int k = 0; k < n; ++k) {
      const double t = 2.0 * M_PI * (k + rng.uniform(0.0, 0.5)) / n;
      poly.emplace_back(std::cos(t), std::sin(t), rng.uniform(-1, 1));
      const double v = a * poly.back().x + b * poly.back().y + c;
      vals.push_back(trial % 4 == 0 && k % 2 == 0 ? 0.0 : v);
    }
    const bool keep_nonneg = trial % 2 == 0;
    std::vector<Vec3d> want;
    std::vector<uint8_t> want_on;
    clip_by_values(poly.data(), vals.data(), n, keep_nonneg, want, &want_on);
    std::vector<Vec3d> out(size_t(2 * n) + 1, sentinel);
    std::vector<uint8_t> on(size_t(2 * n) + 1, 7);
    const int m = clip_by_values(poly.data(), vals.data(), n, keep_nonneg, out.data(), on.data());
    EXPECT_EQ(out[size_t(2 * n)].x, sentinel.x);
    EXPECT_EQ(on[size_t(2 * n)], 7);
    ASSERT_EQ(size_t(m), want.size()) << trial;
    (m == 0 ? emptied : kept) += 1;
    for (int k = 0; k < m; ++k) {
      EXPECT_EQ(out[size_t(k)].x, want[size_t(k)].x);
      EXPECT_EQ(out[size_t(k)].y, want[size_t(k)].y);
      EXPECT_EQ(out[size_t(k)].z, want[size_t(k)].z);
      EXPECT_EQ(on[size_t(k)], want_on[size_t(k)]);
    }
    // Without flags: the same vertices.
    std::vector<Vec3d> bare(size_t(2 * n));
    EXPECT_EQ(clip_by_values(poly.data(), vals.data(), n, keep_nonneg, bare.data(), nullptr), m);
  }
  EXPECT_GT(kept, 500);
  EXPECT_GT(emptied, 100);
}

TEST(PluckerFragment, NodePlaneNormalAndOnLineAreLinesEdgePlaneNormalErr) {
  // node_plane computes N and the on-line test itself (the error bounds component by
  // component, stopping at the first exceeded): the same N as lines.h
  // edge_plane_normal_err and the same answer as on_line with its bounds, also for r on
  // the line (exactly and within rounding); and the form with the centroid distances
  // given is the same plane bit for bit.
  Rng rng(73);
  int on = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    const double off = trial % 2 ? rng.uniform(-1e4, 1e4) : 0.0;
    std::vector<Vec3d> light = {Vec3d(off, off, 2), Vec3d(off, off + 1, 2), Vec3d(off + 1.5, off + 1, 2.25)};
    const LightBounds lb = LightBounds::of(light.data(), 3);
    auto pt = [&] { return Vec3d(off + rng.uniform(-3, 3), off + rng.uniform(-3, 3), rng.uniform(-2, 4)); };
    const Vec3d a = pt(), b = trial % 13 == 0 ? a : pt();
    Vec3d r = pt();
    if (trial % 5 == 0) r = a + (b - a) * double(trial % 3);  // on the line (exactly or nearly)
    if (trial % 5 == 1) r = a + (b - a) * rng.uniform();      // on the segment, up to rounding
    const NodePlane pl = node_plane(r, a, b, lb);
    Vec3d err;
    const Vec3d n = edge_plane_normal_err(r, a, b, err);
    EXPECT_EQ(pl.n.x, n.x);
    EXPECT_EQ(pl.n.y, n.y);
    EXPECT_EQ(pl.n.z, n.z);
    EXPECT_EQ(pl.on_line, on_line(n, err));
    on += pl.on_line;
    const NodePlane q = node_plane(r, a, b, lb, lb.dist1(r), lb.dist1(a), lb.dist1(b));
    EXPECT_EQ(q.n.x, pl.n.x);
    EXPECT_EQ(q.n.y, pl.n.y);
    EXPECT_EQ(q.n.z, pl.n.z);
    EXPECT_EQ(q.base.x, pl.base.x);
    EXPECT_EQ(q.base.y, pl.base.y);
    EXPECT_EQ(q.base.z, pl.base.z);
    EXPECT_EQ(q.bound, pl.bound);
    EXPECT_EQ(q.on_line, pl.on_line);
  }
  EXPECT_GT(on, 100);  // the on-line answers were exercised
}

TEST(PluckerFragment, LambertIrradianceIsThePerEdgeSum) {
  // lambert_irradiance carries each vertex's offset, height and squared length to the
  // next edge: the result is the same double as the textbook form that computes them at
  // both ends of every edge (clip to r's upper half-space, then 1/2 |sum theta_k nr .
  // gamma_k|), on random convex polygons above, below and across r's plane.
  // With std::atan2 for the angles instead of edge_angle, the sum is within the angles'
  // bound, 1/2 sum_k 2^-50 min(1, theta_k) <= 2^-51 (n + 1) over the clipped polygon,
  // plus the sums' rounding (taken as 2^-49 (n + 1) together).
  auto reference = [](const Vec3d& rd, const Vec3f& nr, const std::vector<Vec3d>& poly, bool libm = false) {
    const Vec3d nd = to_double(nr);
    std::vector<Vec3d> q;
    const size_t n = poly.size();
    for (size_t k = 0; k < n; ++k) {
      Vec3d p0 = poly[k] - rd, p1 = poly[(k + 1) % n] - rd;
      double s0 = dot(nd, p0), s1 = dot(nd, p1);
      if (s0 >= 0.0) q.push_back(p0);
      if ((s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0)) q.push_back(p0 + (p1 - p0) * (s0 / (s0 - s1)));
    }
    if (q.size() < 3) return 0.0;
    double sum = 0.0;
    for (size_t k = 0; k < q.size(); ++k) {
      const Vec3d& a = q[k];
      const Vec3d& b = q[(k + 1) % q.size()];
      if (dot(a, a) == 0.0 || dot(b, b) == 0.0) continue;
      Vec3d c = cross(a, b);
      double lc = length(c);
      if (lc == 0.0) continue;
      sum += (libm ? std::atan2(lc, dot(a, b)) : edge_angle(lc, dot(a, b))) * dot(nd, c) / lc;
    }
    return 0.5 * std::abs(sum);
  };
  Rng rng(74);
  int nonzero = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = 3 + int(rng.below(6));
    const double cx = rng.uniform(-2, 2), cy = rng.uniform(-2, 2), h = rng.uniform(-1, 2), rad = rng.uniform(0.1, 3);
    const double tilt = rng.uniform(-1, 1);
    std::vector<Vec3d> poly;
    for (int k = 0; k < n; ++k) {
      const double t = 2.0 * M_PI * k / n;
      const double x = cx + rad * std::cos(t), y = cy + rad * std::sin(t);
      poly.emplace_back(x, y, h + tilt * x);
    }
    // Receivers at a vertex, on an edge and at random points.
    Vec3d r(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-1, 1));
    if (trial % 17 == 0) r = poly[0];
    if (trial % 19 == 0) r = (poly[0] + poly[1]) * 0.5;
    const Vec3f nr = trial % 3 == 0 ? Vec3f(0, 0, 1) : Vec3f(float(rng.uniform(-0.5, 0.5)), 0.0f, 1.0f);
    const double got = lambert_irradiance(r, nr, poly.data(), n);
    EXPECT_EQ(got, reference(r, nr, poly)) << trial;
    EXPECT_NEAR(got, reference(r, nr, poly, true), 0x1p-49 * (n + 1)) << trial;
    nonzero += got > 0.0;
  }
  EXPECT_GT(nonzero, 1000);
}

TEST(PluckerFragment, EdgeAngleIsWithinItsBoundOfAtan2) {
  // edge_angle(y, x) against long double atan2l (64-bit significand: its own error is
  // 2^-11 of the bound) on random inputs over 2^40 of scales, both signs of x, and
  // quotients at and next to the table's points i / 16 and midpoints (i + 1/2) / 16 in
  // all four octants; then the exact cases.
  Rng rng(39);
  long double worst = 0.0L;
  for (int trial = 0; trial < 400000; ++trial) {
    double y = std::abs(rng.uniform(-1, 1)), x = rng.uniform(-1, 1);
    if (trial % 3 == 0) {
      y = std::ldexp(y, int(rng.below(40)) - 20);
      x = std::ldexp(x, int(rng.below(40)) - 20);
    } else if (trial % 3 == 1) {
      const double t = std::clamp(double(rng.below(33)) / 32.0 + rng.uniform(-1, 1) * 1e-9, 0.0, 1.0);
      const double s = rng.below(2) != 0 ? 1.0 : -1.0;
      if (rng.below(2) != 0) y = t, x = s;
      else y = 1.0, x = s * t;
    }
    const long double exact = atan2l((long double)y, (long double)x);
    const long double err = fabsl((long double)edge_angle(y, x) - exact);
    ASSERT_LE(err, 0x1p-50L * std::min(exact, 1.0L)) << std::hexfloat << y << " " << x;
    worst = std::max(worst, err);
  }
  EXPECT_GT(worst, 0.0L);  // the bound was reached for, not met by exact answers alone
  EXPECT_EQ(edge_angle(0.0, 1.0), 0.0);
  EXPECT_EQ(edge_angle(0.0, -1.0), std::atan2(0.0, -1.0));
  EXPECT_EQ(edge_angle(1.0, 0.0), std::atan2(1.0, 0.0));
  EXPECT_EQ(edge_angle(2.0, 2.0), std::atan2(2.0, 2.0));
  EXPECT_EQ(edge_angle(2.0, -2.0), std::atan2(2.0, -2.0));
  EXPECT_EQ(edge_angle(0.0, 0.0), 0.0);
  EXPECT_TRUE(std::isnan(edge_angle(std::nan(""), 1.0)));
}

TEST(PluckerFragment, AxisMemberIsTheIndexedCoordinate) {
  const Vec3d p(1.5, -2.25, 7.0);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(p.*axis_member(i), p[i]);
}

TEST(PluckerFragment, BoxSideAgreesWithSplitFragmentOnEveryPieceInTheBox) {
  // box_side's answer for a box must be split_fragment's for every fragment inside it:
  // pieces of random lights (far from the origin too) made by random splits, so their
  // vertices are interpolated; the boxes are the light's own (widened by 2^-40 mag, as the
  // BSP walk keeps an input piece's box for all its split pieces) and each piece's, as
  // corners and as the walk's CenterBox (CenterBox::of widening by 2^-40 mag and 2^-44 mag).
  Rng rng(91);
  int decided = 0, undecided = 0, decided_center = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const RandomSquareLight sq(rng, trial);
    const std::vector<Vec3d>& light = sq.light;
    const LightBounds& lb = sq.lb;
    auto random_point = [&](double zlo, double zhi) { return sq.point(rng, zlo, zhi); };
    auto box_of = [](const std::vector<Vec3d>& p, double e, Vec3d& lo, Vec3d& hi) {
      lo = hi = p[0];
      for (const Vec3d& x : p) {
        lo = Vec3d(std::min(lo.x, x.x), std::min(lo.y, x.y), std::min(lo.z, x.z));
        hi = Vec3d(std::max(hi.x, x.x), std::max(hi.y, x.y), std::max(hi.z, x.z));
      }
      lo = lo - Vec3d(e, e, e);
      hi = hi + Vec3d(e, e, e);
    };
    std::vector<std::vector<Vec3d>> pieces = {light};
    std::vector<Vec3d> pos, neg;
    for (int k = 0; k < 6; ++k) {
      pieces = split_all(node_plane(random_point(-2, 0), random_point(0.5, 1.5), random_point(0.5, 1.5), lb), pieces);
    }
    Vec3d llo, lhi, tlo, thi;
    box_of(light, 0x1p-40 * lb.mag, llo, lhi);
    box_of(light, 0.0, tlo, thi);
    const CenterBox lcb = CenterBox::of(tlo, thi, 0x1p-39 * lb.mag);
    for (int q = 0; q < 20; ++q) {
      const NodePlane pl = node_plane(random_point(-2, 0), random_point(0.5, 1.5), random_point(0.5, 1.5), lb);
      const int light_side = box_side(pl, llo, lhi);
      const int light_center = box_side(pl, lcb);
      for (const auto& pc : pieces) {
        Vec3d plo, phi;
        box_of(pc, 0.0, plo, phi);
        const SplitResult sr = split_fragment(pl, pc.data(), int(pc.size()), pos, neg);
        const int piece_center = box_side(pl, CenterBox::of(plo, phi, 0x1p-44 * lb.mag));
        for (const int side : {light_side, box_side(pl, plo, phi), light_center, piece_center}) {
          if (side == 0) {
            ++undecided;
            continue;
          }
          ++decided;
          EXPECT_EQ(sr, side > 0 ? SplitResult::Positive : SplitResult::Negative);
        }
        decided_center += (light_center != 0) + (piece_center != 0);
      }
    }
  }
  EXPECT_GT(decided, 5000);
  EXPECT_GT(decided_center, 2500);
  EXPECT_GT(undecided, 1000);
}

TEST(PluckerFragment, BoxSideOfAHandWorkedBox) {
  // The plane through r = 0 and the line (1, 0, 1) -> (1, 1, 1) is x = z; lines.h's
  // orientation makes points with x < z positive or negative, and a box straddling it,
  // or touching it at a corner, is undecided.
  const LightBounds lb = LightBounds::of(std::vector<Vec3d>{{0, 0, 2}, {4, 0, 2}, {4, 4, 2}, {0, 4, 2}}.data(), 4);
  const NodePlane pl = node_plane(Vec3d(0, 0, 0), Vec3d(1, 0, 1), Vec3d(1, 1, 1), lb);
  ASSERT_FALSE(pl.on_line);
  const int left = box_side(pl, Vec3d(0, 0, 2), Vec3d(1, 4, 2));   // x < z = 2
  const int right = box_side(pl, Vec3d(3, 0, 2), Vec3d(4, 4, 2));  // x > z = 2
  EXPECT_NE(left, 0);
  EXPECT_EQ(right, -left);
  const Vec3d l[4] = {{0, 0, 2}, {1, 0, 2}, {1, 4, 2}, {0, 4, 2}};
  EXPECT_EQ(classify_fragment(pl, l, 4), left > 0 ? SplitResult::Positive : SplitResult::Negative);
  EXPECT_EQ(box_side(pl, Vec3d(1, 0, 2), Vec3d(3, 4, 2)), 0);  // straddles x = 2
  EXPECT_EQ(box_side(pl, Vec3d(0, 0, 2), Vec3d(2, 4, 2)), 0);  // touches it
  // The walk's box of an empty piece is NaN (bsp.cpp widened_box): it decides nothing.
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(box_side(pl, Vec3d(nan, nan, nan), Vec3d(nan, nan, nan)), 0);
  // The same boxes as centre and half-widths (the walk's form), widened by 2^-30.
  auto center = [&](const Vec3d& lo, const Vec3d& hi) { return box_side(pl, CenterBox::of(lo, hi, 0x1p-30)); };
  EXPECT_EQ(center(Vec3d(0, 0, 2), Vec3d(1, 4, 2)), left);
  EXPECT_EQ(center(Vec3d(3, 0, 2), Vec3d(4, 4, 2)), right);
  EXPECT_EQ(center(Vec3d(1, 0, 2), Vec3d(3, 4, 2)), 0);
  EXPECT_EQ(center(Vec3d(0, 0, 2), Vec3d(2, 4, 2)), 0);
  EXPECT_EQ(center(Vec3d(nan, nan, nan), Vec3d(nan, nan, nan)), 0);
  const CenterBox cb = CenterBox::of(Vec3d(0, 0, 2), Vec3d(1, 4, 2), 0x1p-30);
  EXPECT_EQ(cb.c.x, 0.5);
  EXPECT_EQ(cb.h.y, 2.0 + 0x1p-30);
}
