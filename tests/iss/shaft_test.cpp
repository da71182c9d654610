// lib/iss/shaft.h: the shaft hull, its oblique planes and the segment/triangle test (paper 000 section 4.4.1);
// direct_cull (traversal.h) against may_intersect_box.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "lib/geom/haines_shaft.h"
#include "lib/iss/shaft.h"
#include "lib/iss/traversal.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

// Two random boxes near `offset` (iteration `it` of a loop): some share coordinates with
// the other (equal corners give axis-aligned lines and duplicate candidates), and with
// `equal_too` every 7th pair is one box twice.
std::pair<AABB, AABB> shaft_boxes(std::mt19937& rng, double offset, int it, bool equal_too) {
  Vec3f o(float(offset), float(-offset), float(offset));
  AABB r = random_box(rng, o), l = random_box(rng, o);
  if (it % 3 == 1) l.lo.x = r.lo.x;
  if (it % 5 == 2) { l.lo.y = r.lo.y; l.hi.y = r.hi.y; }
  if (equal_too && it % 7 == 3) l = r;
  return {r, l};
}

}  // namespace

// ---- shaft geometry (section 4.4.1) ----------------------------------------------------

TEST(IssShaft, HullContainsEveryBoxToBoxSegment) {
  std::mt19937 rng(7);
  for (double offset : {0.0, 1e5}) {  // near and far from the origin
    for (int it = 0; it < 200; ++it) {
      Vec3f o(float(offset), float(-offset), float(offset));
      AABB r = random_box(rng, o), l = random_box(rng, o);
      iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 2e5);
      for (int k = 0; k < 20; ++k) {
        std::uniform_real_distribution<double> t(0, 1);
        Vec3d p, q;
        for (int a = 0; a < 3; ++a) {
          p[a] = r.lo[a] + (double(r.hi[a]) - r.lo[a]) * t(rng);
          q[a] = l.lo[a] + (double(l.hi[a]) - l.lo[a]) * t(rng);
        }
        Vec3d x = p + (q - p) * t(rng);
        ASSERT_TRUE(g.may_contain_point(x));
        ASSERT_TRUE(g.may_intersect_segment(p, q));
      }
      // A point beyond the common bounding box is outside.
      Vec3d far = to_double(vmax(r.hi, l.hi)) + Vec3d(1, 1, 1);
      EXPECT_FALSE(g.may_contain_point(far));
    }
  }
}

// The oblique planes as the constructor built them through for_each_shaft_corner_line
// (lib/geom/haines_shaft.h), with the full cross-product duplicate test: the reference
// for the constructor's written-out loops.
static std::vector<iss::ConservativePlane> reference_oblique_planes(const AABB& rf, const AABB& lf, double scale) {
  const AABBd r = iss::to_double(rf), l = iss::to_double(lf);
  std::vector<iss::ConservativePlane> out;
  size_t first = 0;
  auto l1 = [](const Vec3d& n) { return std::abs(n.x) + std::abs(n.y) + std::abs(n.z); };
  for_each_shaft_corner_line(r, l, [&](const ShaftCornerLine& line) {
    const int i = line.i, j = line.j;
    if (line.corner == 0) first = out.size();
    const double rx0 = std::min(r.lo[i], r.hi[i]), rx1 = std::max(r.lo[i], r.hi[i]);
    const double ry0 = std::min(r.lo[j], r.hi[j]), ry1 = std::max(r.lo[j], r.hi[j]);
    const double lx0 = std::min(l.lo[i], l.hi[i]), lx1 = std::max(l.lo[i], l.hi[i]);
    const double ly0 = std::min(l.lo[j], l.hi[j]), ly1 = std::max(l.lo[j], l.hi[j]);
    const double px = line.ai, py = line.aj, dx = line.bi - px, dy = line.bj - py;
    if (dx == 0.0 || dy == 0.0) return;
    for (double sg : {1.0, -1.0}) {
      double nx = sg * dy, ny = -sg * dx;
      double d = nx * px + ny * py;
      const bool ux = nx > 0, uy = ny > 0;
      double dmax = std::max({d, nx * (ux ? rx1 : rx0) + ny * (uy ? ry1 : ry0), nx * (ux ? lx1 : lx0) + ny * (uy ? ly1 : ly0)});
      if (dmax - d > 0x1p-40 * (std::abs(nx) + std::abs(ny)) * scale) continue;
      d = dmax;
      Vec3d n(0, 0, 0);
      n[i] = nx;
      n[j] = ny;
      bool dup = false;
      for (size_t k = first; k < out.size(); ++k)
        if (cross(out[k].n, n) == Vec3d(0, 0, 0) && dot(out[k].n, n) > 0 && out[k].d * l1(n) == d * l1(out[k].n))
          dup = true;
      if (!dup && out.size() < 12) {
        iss::ConservativePlane p;
        p.n = n;
        p.d = d;
        p.tol = 0x1p-40 * l1(n) * scale;
        out.push_back(p);
      }
    }
  });
  return out;
}

TEST(IssShaft, ObliquePlanesEqualTheCornerLineReferenceBitForBit) {
  // Random boxes, also sharing coordinates (equal corners give axis-aligned lines and
  // duplicate candidates), near and far from the origin: the constructor's planes after
  // the six box planes are the reference's, in order, bit for bit.
  std::mt19937 rng(11);
  size_t oblique = 0;
  for (double offset : {0.0, 1e5}) {
    for (int it = 0; it < 2000; ++it) {
      auto [r, l] = shaft_boxes(rng, offset, it, true);
      const double scale = 2e5;
      iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), scale);
      std::vector<iss::ConservativePlane> ref = reference_oblique_planes(r, l, scale);
      ASSERT_EQ(g.plane_count(), 6 + int(ref.size()));
      oblique += ref.size();
      for (size_t k = 0; k < ref.size(); ++k) {
        const iss::ConservativePlane& p = g.plane(6 + int(k));
        ASSERT_EQ(p.n, ref[k].n);
        ASSERT_EQ(p.d, ref[k].d);
        ASSERT_EQ(p.tol, ref[k].tol);
      }
    }
  }
  EXPECT_GT(oblique, 4000u);  // most pairs have oblique planes: the comparison is not empty
}

// The scalar loops may_intersect_segment, may_intersect_box and separated_by_shaft_plane
// were before they evaluated four planes per vector, and separated_by_triangle_plane
// before it evaluated only the two corners per box the normal picks: the references,
// which the new versions must answer as on every input (the same plane values bit for
// bit, answers that do not depend on the planes' order, and eval() monotone in each
// coordinate).
static bool reference_segment(const iss::ShaftGeometry& g, const Vec3d& a, const Vec3d& b) {
  double t0 = 0.0, t1 = 1.0;
  for (int i = 0; i < g.plane_count(); ++i) {
    const iss::ConservativePlane& p = g.plane(i);
    const double ea = p.eval(a) - p.tol, eb = p.eval(b) - p.tol;
    if (ea > 0 && eb > 0) return false;
    if (ea <= 0 && eb <= 0) continue;
    const double t = ea / (ea - eb);
    if (ea > 0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
    if (t0 > t1 + 0x1p-40) return false;
  }
  return true;
}
static bool reference_box(const iss::ShaftGeometry& g, const AABBd& b) {
  for (int i = 0; i < g.plane_count(); ++i) {
    const iss::ConservativePlane& p = g.plane(i);
    const Vec3d q(p.n.x > 0 ? b.lo.x : b.hi.x, p.n.y > 0 ? b.lo.y : b.hi.y, p.n.z > 0 ? b.lo.z : b.hi.z);
    if (p.eval(q) > p.tol) return false;
  }
  return true;
}

static bool reference_shaft_plane(const iss::ShaftGeometry& g, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  for (int i = 0; i < g.plane_count(); ++i) {
    const iss::ConservativePlane& p = g.plane(i);
    if (p.eval(a) > p.tol && p.eval(b) > p.tol && p.eval(c) > p.tol) return true;
  }
  return false;
}
static bool reference_triangle_plane(const iss::ShaftGeometry& g, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const iss::ConservativePlane tp = iss::plane_through(a, b, c, g.scale());
  if (tp.n == Vec3d(0, 0, 0)) return false;
  bool all_pos = true, all_neg = true;
  for (int i = 0; i < 16; ++i) {  // all sixteen corners of the two boxes
    const AABBd& box = i < 8 ? g.receiver() : g.light();
    const Vec3d q(i & 1 ? box.hi.x : box.lo.x, i & 2 ? box.hi.y : box.lo.y, i & 4 ? box.hi.z : box.lo.z);
    const double e = tp.eval(q);
    all_pos = all_pos && e > tp.tol;
    all_neg = all_neg && e < -tp.tol;
  }
  return all_pos || all_neg;
}

TEST(IssShaft, VectorAndCornerPickingTestsAnswerAsTheScalarLoops) {
  // Random shafts (also with shared coordinates, so fewer oblique planes and plane counts
  // that are not multiples of four), segments and boxes around them: end points on the
  // shaft's corners, on its planes (exactly, as far as double allows) and random; both
  // answers are seen often, so the comparison covers both branches.
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(-0.5, 1.5);
  size_t seg_in = 0, seg_out = 0, box_in = 0, box_out = 0, tris = 0, tri_shaft = 0, tri_own = 0;
  for (double offset : {0.0, 1e5}) {
    for (int it = 0; it < 400; ++it) {
      auto [r, l] = shaft_boxes(rng, offset, it, false);
      iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 2e5);
      AABBd all = iss::to_double(r);
      all.extend(iss::to_double(l));
      auto point = [&]() {
        Vec3d p;
        for (int a = 0; a < 3; ++a) p[a] = all.lo[a] + (all.hi[a] - all.lo[a]) * u(rng);
        const int kind = int(rng() % 4);
        if (kind == 1) {  // a corner of one of the boxes
          const AABBd& bx = rng() % 2 ? g.receiver() : g.light();
          p = Vec3d(rng() % 2 ? bx.hi.x : bx.lo.x, rng() % 2 ? bx.hi.y : bx.lo.y, rng() % 2 ? bx.hi.z : bx.lo.z);
        } else if (kind == 2) {  // moved onto a random plane along its normal
          const iss::ConservativePlane& pl = g.plane(int(rng() % unsigned(g.plane_count())));
          const double nn = dot(pl.n, pl.n);
          if (nn > 0) p = p - pl.n * ((pl.eval(p)) / nn);
        }
        return p;
      };
      std::vector<AABBd> boxes;
      for (int k = 0; k < 60; ++k) {
        const Vec3d a = point(), b = point();
        const bool ref = reference_segment(g, a, b);
        ASSERT_EQ(g.may_intersect_segment(a, b), ref);
        (ref ? seg_in : seg_out) += 1;
        AABBd bx;
        bx.lo = vmin(a, b);
        bx.hi = vmax(a, b);
        const bool rb = reference_box(g, bx);
        ASSERT_EQ(g.may_intersect_box(bx), rb);
        (rb ? box_in : box_out) += 1;
        boxes.push_back(bx);
      }
      // The same boxes as box arrays through direct_cull (the cull of the direct test's
      // candidate lists and of dense_ray_lights' estimate).
      const size_t kp = (boxes.size() + 3) & ~size_t(3);
      std::vector<double> arrays(6 * kp, 0.0);
      for (size_t k = 0; k < boxes.size(); ++k)
        for (int ax = 0; ax < 3; ++ax) {
          arrays[size_t(ax) * kp + k] = boxes[k].lo[ax];
          arrays[size_t(3 + ax) * kp + k] = boxes[k].hi[ax];
        }
      std::vector<int64_t> keep(kp, -1);
      iss::direct_cull(arrays.data(), kp, g, keep.data());
      for (size_t k = 0; k < boxes.size(); ++k) ASSERT_EQ(keep[k] != 0, g.may_intersect_box(boxes[k]));
      for (int k = 0; k < 60; ++k) {  // triangles: separated by a shaft plane / by their own plane
        Vec3d a = point(), b = point(), c = point();
        if (k % 4 == 0) c = a + (b - a) * 0.5;  // degenerate: zero normal
        const bool rs = reference_shaft_plane(g, a, b, c), rt = reference_triangle_plane(g, a, b, c);
        ASSERT_EQ(g.separated_by_shaft_plane(a, b, c), rs);
        ASSERT_EQ(g.separated_by_triangle_plane(a, b, c), rt);
        tri_shaft += rs;
        tri_own += rt;
        ++tris;
      }
      // The empty box ISS starts its boxes from: outside, as the scalar loop says.
      ASSERT_EQ(g.may_intersect_box(iss::empty_box()), reference_box(g, iss::empty_box()));
    }
  }
  EXPECT_GT(seg_in, 5000u);
  EXPECT_GT(seg_out, 5000u);
  EXPECT_GT(box_in, 5000u);
  EXPECT_GT(box_out, 2000u);
  EXPECT_GT(tri_shaft, tris / 20);  // both answers of both triangle tests are seen
  EXPECT_LT(tri_shaft, tris - tris / 20);
  EXPECT_GT(tri_own, tris / 50);
  EXPECT_LT(tri_own, tris - tris / 20);
}

TEST(IssShaft, ObliquePlanesCutTheCommonBox) {
  // Unit box at the origin, unit box at (10, 10, 0): the hull excludes (0, 10, 0.5).
  AABB r(Vec3f(0, 0, 0), Vec3f(1, 1, 1)), l(Vec3f(10, 10, 0), Vec3f(11, 11, 1));
  iss::MainAxis ax = iss::choose_main_axis(r, l);
  EXPECT_GE(ax.axis, 0);
  iss::ShaftGeometry g(r, l, ax, 11);
  EXPECT_FALSE(g.may_contain_point(Vec3d(0.5, 10, 0.5)));
  EXPECT_TRUE(g.may_contain_point(Vec3d(5.5, 5.5, 0.5)));
  // Exactly on the hull boundary counts as inside (conservative).
  EXPECT_TRUE(g.may_contain_point(Vec3d(1, 0, 0)));
  EXPECT_GT(g.plane_count(), 6);
}

TEST(IssShaft, ObliquePlanesSurviveRoundingOfTheSupportTest) {
  // Flat receiver node on a floor and flat light node below a ceiling (a rooms leaf
  // shaft). Hand-worked: at z = 0.01 the hull is the receiver rectangle (x >= 4.59375),
  // so the wall-foot segment at x = 3.9, z = 0.01 is outside. The x-z hull edge through
  // (4.59375, 0.01) and (1.70508, 2.78) used to be dropped when n.q rounded above d.
  AABB r(Vec3f(4.59375f, 0.09375f, 0.01f), Vec3f(5.90625f, 1.40625f, 0.01f));
  AABB l(Vec3f(1.70508f, 1.70696f, 2.78f), Vec3f(1.99886f, 1.99628f, 2.78f));
  iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 12.0);
  EXPECT_FALSE(g.may_intersect_segment(Vec3d(3.9, 2.1442, 0.01), Vec3d(3.9, 0.00765784, 0.01)));
  EXPECT_FALSE(g.may_contain_point(Vec3d(3.9, 1.0, 0.01)));
  // Every corner pair's segment is still inside (conservative after raising d).
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) {
      Vec3d p(i & 1 ? r.hi.x : r.lo.x, i & 2 ? r.hi.y : r.lo.y, 0.01f);
      Vec3d q(j & 1 ? l.hi.x : l.lo.x, j & 2 ? l.hi.y : l.lo.y, 2.78f);
      EXPECT_TRUE(g.may_contain_point(p + (q - p) * 0.5));
    }
}

TEST(IssShaft, ObliquePlaneOffsetIsTheLargestEvaluatedCornerValue) {
  // The constructor raises an oblique plane's d to the largest n.c over the eight
  // rectangle corners of its projection as evaluated in double; it evaluates only the
  // corner the signs of n pick (shaft.cpp). Bit for bit the same as all eight.
  std::mt19937 rng(11);
  for (double offset : {0.0, 1e5, 3e-3}) {
    for (int it = 0; it < 500; ++it) {
      Vec3f o(float(offset), float(-offset), float(offset));
      AABB r = random_box(rng, o), l = random_box(rng, o);
      iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 2e5);
      for (int k = 6; k < g.plane_count(); ++k) {
        const iss::ConservativePlane& p = g.plane(k);
        int i = p.n.x != 0 ? 0 : 1, j = p.n.z != 0 ? 2 : 1;
        ASSERT_LT(i, j);
        double best = -1e300;
        for (const AABB* b : {&r, &l})
          for (int c = 0; c < 4; ++c)
            best = std::max(best, p.n[i] * double(c & 1 ? b->hi[i] : b->lo[i]) +
                                      p.n[j] * double(c & 2 ? b->hi[j] : b->lo[j]));
        ASSERT_EQ(p.d, best) << "plane " << k;
      }
    }
  }
}

TEST(IssShaft, SegmentTriangleTestExcludesEndpoints) {
  Vec3d a(-1, -1, 0), b(1, -1, 0), c(0, 1, 0);
  EXPECT_TRUE(iss::segment_hits_triangle_d(Vec3d(0, 0, -1), Vec3d(0, 0, 1), a, b, c));
  EXPECT_FALSE(iss::segment_hits_triangle_d(Vec3d(0, 0, 0), Vec3d(0, 0, 1), a, b, c));  // endpoint on it
  EXPECT_FALSE(iss::segment_hits_triangle_d(Vec3d(5, 0, -1), Vec3d(5, 0, 1), a, b, c));
  // Through an edge: touching counts as intersecting (DESIGN 3).
  EXPECT_TRUE(iss::segment_hits_triangle_d(Vec3d(0, -1, -1), Vec3d(0, -1, 1), a, b, c));
  // A sliver far smaller than its distance to the segment (fuzz_iss, corpus/iss/sliver):
  // the triangle (0,0,0), (2^-149,0,0), (0,0,1) lies in y = 0 with z in [0, 1]; the
  // segment (-1,-1,1) -> (1,1,2) crosses y = 0 at (0,0,1.5), half a unit above it:
  // a miss. Lowered to cross y = 0 at (0,0,0.5), inside the sliver's x = 0 edge: a
  // touch, which counts.
  Vec3d sa(0, 0, 0), sb(0x1p-149, 0, 0), sc(0, 0, 1);
  EXPECT_FALSE(iss::segment_hits_triangle_d(Vec3d(-1, -1, 1), Vec3d(1, 1, 2), sa, sb, sc));
  EXPECT_TRUE(iss::segment_hits_triangle_d(Vec3d(-1, -1, 0), Vec3d(1, 1, 1), sa, sb, sc));
  // A crossing point on the extension of a sliver's long edges (fuzz_iss 79223f0b...):
  // the sliver (2.5e-32, 0.5, 1), (-0, 0.5, 1), (-0.5, 1, 1) in z = 1; the segment
  // (-0.5, 1.5, 0) -> (-1, 1, 2) crosses z = 1 at (-0.75, 1.25), on the line
  // x + y = 0.5 of the edges b-c and c-a, a quarter unit beyond c: a miss, though two
  // edge products are exactly 0 there and the third has the sign of the others'
  // rounding. The same segment shifted to cross at (-0.25, 0.75), on the sliver: a hit.
  Vec3d la(double(2.46519033e-32f), 0.5, 1), lb(-0.0, 0.5, 1), lc(-0.5, 1, 1);
  EXPECT_FALSE(iss::segment_hits_triangle_d(Vec3d(-0.5, 1.5, 0), Vec3d(-1, 1, 2), la, lb, lc));
  EXPECT_TRUE(iss::segment_hits_triangle_d(Vec3d(0, 1, 0), Vec3d(-0.5, 0.5, 2), la, lb, lc));
}
