// Tests of lib/plucker/subtract.cpp: subtracting shadows from fragments, through whole
// solves.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "lib/plucker/lines.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/plucker/subtract.h"
#include "lib/solver.h"
#include "oracle/region_oracle.h"
#include "tests/support/plucker_scenes.h"

using namespace visgate;
using namespace visgate::plucker;
using namespace visgate::test_support;

// A shadow beside a fragment that still cuts it along the planes through its edges
// leaves the fragment whole: nothing of it is hidden. Splitting it anyway, the exact
// path's fragment list grew 1.8x per triangle to 145,369 fragments of one receiver, none
// hidden (fuzz_plucker 82d969b1..., corpus/fuzz/slow). Seen from receiver 0 at the
// origin (or far below), an occluder's shadow on the light plane z = 2 is its (x, y)
// scaled by 2 / z (or by 2 for one halfway to the far receiver).
TEST(PluckerSolver, ShadowBesideAFragmentLeavesItWhole) {
  // The fragments of receiver 0 must be `expect` (as vertex sets), the fractions exact.
  auto check = [](const Scene& s, const std::vector<std::vector<Vec3f>>& expect, const char* path) {
    const auto exact = oracle::visible_region(s, 0, 0);
    for_each_solve(s, {{"coherence", {"on", "off"}}}, {}, [&](const SolveResult& r, const std::string& what) {
      EXPECT_NEAR(r.receivers[0].visible_fraction[0], exact.visible_fraction, 1e-6) << path;
      const auto& frags = r.receivers[0].fragments[0];
      ASSERT_EQ(frags.size(), expect.size()) << path << " " << what;
      for (size_t k = 0; k < frags.size(); ++k) {
        ASSERT_EQ(frags[k].size(), expect[k].size()) << path;
        for (const Vec3f& v : frags[k]) {
          bool found = false;
          for (const Vec3f& e : expect[k]) found |= max_component(vabs(to_double(v) - to_double(e))) < 1e-6;
          EXPECT_TRUE(found) << path << " " << v.x << " " << v.y << " " << v.z;
        }
      }
    });
  };
  {
    // Exact path: receivers 2^24 below the light are more than 2^20 light widths away
    // (shade_group, extreme), and every candidate triangle is subtracted exactly. The
    // triangle halfway casts (1.2, 0.3), (2, -0.5), (2, 1.1) for receiver 0: right of the
    // light [-1, 1]^2, while its edges x + y = 1.5 and y = x - 0.9 both cross it (three
    // fragments, none hidden, before). Receiver 1 widens the shaft to take the triangle.
    const float rz = -0x1p24f, mid = 0.5f * (2.0f + rz);
    Scene s = light_scene({Vec3f(0, 0, rz), Vec3f(4, 0, rz)});
    s.mesh.vertices = {Vec3f(0.6f, 0.15f, mid), Vec3f(1, -0.25f, mid), Vec3f(1, 0.55f, mid)};
    s.mesh.triangles = {{0, 1, 2}};
    SolveResult r = run(s);
    EXPECT_EQ(r.stats.get("exact_receivers"), 2.0);
    EXPECT_GE(r.stats.get("exact_triangles"), 1.0);
    EXPECT_EQ(oracle::visible_region(s, 0, 0).visible_fraction, 1.0);
    check(s, {s.lights[0].polygon}, "exact");
  }
  {
    // Float path, near polygons: receivers at z = 0 and 1 form one group, and triangles
    // within the group's depth are subtracted per receiver, in order. Triangle A at
    // z = 0.75 hides the corner x + y > 1 of the light from receiver 0, leaving the
    // pentagon below. Triangle B at z = 0.5 casts its shadow near (0.8, 0.8), in that
    // corner, off the pentagon, and two of its edge planes cut the pentagon (two
    // fragments before).
    Scene s = light_scene({Vec3f(0, 0, 0), Vec3f(0.125f, 0, 1)});
    s.mesh.vertices = {Vec3f(1.125f, -0.75f, 0.75f), Vec3f(-0.75f, 1.125f, 0.75f), Vec3f(1.125f, 1.125f, 0.75f),
                       Vec3f(0.175f, 0.175f, 0.5f), Vec3f(0.2375f, 0.2f, 0.5f), Vec3f(0.2f, 0.2375f, 0.5f)};
    s.mesh.triangles = {{0, 1, 2}, {3, 4, 5}};
    SolveResult r = run(s);
    EXPECT_GE(r.stats.get("near_polygons"), 2.0);
    check(s, {{Vec3f(-1, -1, 2), Vec3f(1, -1, 2), Vec3f(1, 0, 2), Vec3f(0, 1, 2), Vec3f(-1, 1, 2)}}, "near");
  }
}

// The fragment list's run index (FragmentRuns) only passes over runs whose box misses a
// shadow's: subtracting the same polygons with it and without it (runs cleared before
// every call: every box tested) gives the same fragments, bit for bit and in order, while
// the list grows to hundreds of fragments (runs cut anew, emptied, and the replacements'
// stretches moved both ways). And the fragments are the light points no triangle hides:
// seen from r at the origin, a triangle between z = 0.5 and 1.5 casts its vertices scaled
// by 2 / z onto the light z = 2, tested at grid points away from every shadow edge.
TEST(PluckerSubtract, RunIndexVisitsTheFragmentsEveryBoxScanVisits) {
  const Vec3d r(0, 0, 0);
  const std::vector<Vec3d> light = {Vec3d(-1, -1, 2), Vec3d(1, -1, 2), Vec3d(1, 1, 2), Vec3d(-1, 1, 2)};
  const UVAxes axes = UVAxes::from_normal(Vec3f(0, 0, 1));
  const LightBounds lb = LightBounds::of(light.data(), int(light.size()));
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uc(-1.0, 1.0), uz(0.5, 1.5), ud(-0.12, 0.12);
  struct Tri {
    Vec3d v[3];
    Vec3d s[3];  // shadow on the light
  };
  std::vector<Tri> tris;
  for (int k = 0; k < 300; ++k) {
    Tri t;
    const double z = uz(rng), cx = uc(rng) * z / 2, cy = uc(rng) * z / 2;
    for (Vec3d& v : t.v) v = Vec3d(cx + ud(rng) * z / 2, cy + ud(rng) * z / 2, z);
    // r on the negative side of (v1 - v0) x (v2 - v0) (subtract.h)
    if (dot(cross(t.v[1] - t.v[0], t.v[2] - t.v[0]), r - t.v[0]) > 0) std::swap(t.v[1], t.v[2]);
    for (int i = 0; i < 3; ++i) t.s[i] = t.v[i] * (2.0 / z);
    tris.push_back(t);
  }
  FragmentList with, without, pieces;
  std::vector<UVBox> with_boxes, without_boxes, piece_boxes;
  FragmentRuns runs, none;
  std::vector<Vec3d> cur, pos, neg;
  BspCounters c;
  with.add(light.data(), light.size());
  without.add(light.data(), light.size());
  with_boxes.assign(1, UVBox::of(axes, light.data(), int(light.size())));
  without_boxes = with_boxes;
  runs.build(with_boxes);
  size_t longest = 0, most_runs = 0;
  const uint8_t skip[3] = {0, 0, 0};
  for (const Tri& t : tris) {
    UVBox qbox = UVBox::of(axes, t.s, 3);
    qbox = UVBox{qbox.ulo - 1e-9, qbox.uhi + 1e-9, qbox.vlo - 1e-9, qbox.vhi + 1e-9};
    const bool a = subtract_polygon(r, t.v, 3, skip, qbox, axes, lb, with, with_boxes, runs, pieces, piece_boxes, cur,
                                    pos, neg, c);
    none = FragmentRuns{};
    const bool b = subtract_polygon(r, t.v, 3, skip, qbox, axes, lb, without, without_boxes, none, pieces,
                                    piece_boxes, cur, pos, neg, c);
    ASSERT_EQ(a, b);
    ASSERT_EQ(with.size(), without.size());
    ASSERT_EQ(runs.size() == 0 ? with.size() : runs.count(), with.size());
    for (size_t f = 0; f < with.size(); ++f) {
      ASSERT_EQ(with.count(f), without.count(f));
      for (int i = 0; i < with.count(f); ++i) {
        ASSERT_EQ(with.data(f)[i].x, without.data(f)[i].x);
        ASSERT_EQ(with.data(f)[i].y, without.data(f)[i].y);
      }
    }
    longest = std::max(longest, with.size());
    most_runs = std::max(most_runs, runs.size());
  }
  EXPECT_GT(longest, 200u);
  EXPECT_GT(most_runs, 8u);
  EXPECT_EQ(c.on_line, 0u);
  // Grid points: visible when outside every shadow triangle (2D, away from its edges by
  // 1e-6), and then in exactly one fragment; hidden ones in none.
  int visible = 0, hidden = 0;
  for (int i = 0; i < 200; ++i)
    for (int j = 0; j < 200; ++j) {
      const Vec3d x(-0.9975 + 0.01 * i, -0.9975 + 0.01 * j, 2.0);
      bool near_edge = false, in = false;
      for (const Tri& t : tris) {
        int inside = 0;
        for (int e = 0; e < 3; ++e) {
          const Vec3d &p = t.s[e], &q = t.s[(e + 1) % 3];
          const double len = std::hypot(q.x - p.x, q.y - p.y);
          const double d = ((q.x - p.x) * (x.y - p.y) - (q.y - p.y) * (x.x - p.x)) / len;
          near_edge |= std::abs(d) < 1e-6;
          inside += d > 0 ? 1 : -1;
        }
        in |= inside == 3 || inside == -3;
      }
      if (near_edge) continue;
      int holders = 0;
      for (size_t f = 0; f < with.size(); ++f) holders += point_in_fragment(axes, with.data(f), with.count(f), x);
      EXPECT_EQ(holders, in ? 0 : 1) << x.x << " " << x.y;
      ++(in ? hidden : visible);
    }
  EXPECT_GT(visible, 1000);
  EXPECT_GT(hidden, 1000);
}

// The fragment list subtract_polygon keeps (spans moved, vertices and boxes left where
// they are, appended, and compacted now and then) against the plain way: a new list
// copied from the old one with each met fragment replaced by its pieces, its boxes made
// in order. Random sequences of operations: triangles of every size subtracted (from
// receivers that move, so a list is cut by many planes), and now and then the caller's
// way of starting over (the list copied with add(), its boxes made in order, the runs
// built). After each, the same fragments bit for bit and in order, the same return
// value, and boxes[polys[k].box] is exactly fragment k's box (UVBox::of).
TEST(PluckerSubtract, FragmentStorageMatchesCopyingTheList) {
  const std::vector<Vec3d> light = {Vec3d(-1, -1, 2), Vec3d(1, -1, 2), Vec3d(1, 1, 2), Vec3d(-1, 1, 2)};
  const UVAxes axes = UVAxes::from_normal(Vec3f(0, 0, 1));
  const LightBounds lb = LightBounds::of(light.data(), int(light.size()));
  // The plain subtraction (subtract.h's contract): a fragment whose box misses the
  // shadow's, or which lies on the negative side of an edge plane (or r on the edge's
  // line), is kept whole; else it is walked through the edges in order, its negative
  // pieces kept, and replaced by them (what is left after the last edge is hidden), or
  // kept whole when a later edge finds what is left outside.
  auto plain = [&](const Vec3d& r, const Vec3d* q, int nq, const UVBox& qbox, FragmentList& frags, bool& met) {
    FragmentList out;
    std::vector<Vec3d> pos(64), neg(64);
    met = false;
    for (size_t f = 0; f < frags.size(); ++f) {
      const Vec3d* fp = frags.data(f);
      const int fn = frags.count(f);
      std::vector<NodePlane> planes;
      for (int m = 0; m < nq; ++m) planes.push_back(node_plane(r, q[m], q[(m + 1) % nq], lb));
      bool keep = !qbox.overlaps(UVBox::of(axes, fp, fn));
      for (int m = 0; m < nq && !keep; ++m) {
        const SplitResult s = classify_fragment(planes[size_t(m)], fp, fn);
        keep = s == SplitResult::Negative || s == SplitResult::OnLine;
      }
      if (keep) {
        out.add(fp, size_t(fn));
        continue;
      }
      met = true;
      FragmentList mine;
      std::vector<Vec3d> cur(fp, fp + fn);
      bool whole = false;
      for (int m = 0; m < nq; ++m) {
        int np = 0, nn = 0;
        const SplitResult s = split_fragment(planes[size_t(m)], cur.data(), int(cur.size()), pos.data(), np,
                                             neg.data(), nn);
        if (s == SplitResult::Positive) continue;
        if (s == SplitResult::Negative || s == SplitResult::OnLine) whole = true;
        if (s != SplitResult::Both) break;
        if (nn != 0) mine.add(neg.data(), size_t(nn));
        cur.assign(pos.data(), pos.data() + np);
        if (np == 0) break;
      }
      if (whole) {
        out.add(fp, size_t(fn));
      } else {
        for (size_t k = 0; k < mine.size(); ++k) out.add(mine.data(k), size_t(mine.count(k)));
      }
    }
    frags = out;
  };
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> uc(-1.0, 1.0), uz(0.3, 1.7), u01(0.0, 1.0);
  FragmentList kept, copied, pieces;
  std::vector<UVBox> boxes, piece_boxes;
  FragmentRuns runs;
  std::vector<Vec3d> cur, pos, neg;
  BspCounters c;
  auto restart = [&](const FragmentList& from) {  // the caller's way (shade_receiver.cpp)
    FragmentList fresh;
    for (size_t f = 0; f < from.size(); ++f) fresh.add(from.data(f), size_t(from.count(f)));
    kept = fresh;
    boxes.clear();
    for (size_t f = 0; f < kept.size(); ++f) boxes.push_back(UVBox::of(axes, kept.data(f), kept.count(f)));
    runs.build(boxes);
  };
  copied.add(light.data(), light.size());
  restart(copied);
  size_t longest = 0, box_compactions = 0, vert_compactions = 0, met_calls = 0;
  const uint8_t skip[3] = {0, 0, 0};
  for (int op = 0; op < 6000; ++op) {
    if (copied.size() == 0 || op % 2000 == 1999) {  // the whole light again, or a fresh copy
      if (copied.size() == 0) copied.add(light.data(), light.size());
      restart(copied);
      continue;
    }
    if (u01(rng) < 0.002) {
      restart(copied);
      continue;
    }
    // A triangle between r and the light: mostly small ones (many fragments), a few large.
    const Vec3d r(uc(rng) * 0.2, uc(rng) * 0.2, 0.0);
    const double z = uz(rng), size = u01(rng) < 0.1 ? 0.6 : 0.08;
    const double cx = r.x + uc(rng) * z / 2, cy = r.y + uc(rng) * z / 2;
    Vec3d t[3];
    for (Vec3d& v : t) v = Vec3d(cx + uc(rng) * size * z, cy + uc(rng) * size * z, z);
    if (dot(cross(t[1] - t[0], t[2] - t[0]), r - t[0]) > 0) std::swap(t[1], t[2]);  // r on the negative side
    Vec3d s[3];
    for (int i = 0; i < 3; ++i) s[i] = r + (t[i] - r) * (2.0 / z);
    UVBox qbox = UVBox::of(axes, s, 3);
    qbox = UVBox{qbox.ulo - 1e-9, qbox.uhi + 1e-9, qbox.vlo - 1e-9, qbox.vhi + 1e-9};
    const size_t nb = boxes.size(), nv = kept.verts.size();
    const bool a = subtract_polygon(r, t, 3, skip, qbox, axes, lb, kept, boxes, runs, pieces, piece_boxes, cur, pos,
                                    neg, c, /*defer_cuts=*/false);
    box_compactions += boxes.size() < nb;
    vert_compactions += kept.verts.size() < nv;
    bool b = false;
    plain(r, t, 3, qbox, copied, b);
    met_calls += b;
    ASSERT_EQ(a, b) << "op " << op;
    ASSERT_EQ(kept.size(), copied.size()) << "op " << op;
    ASSERT_EQ(runs.size() == 0 ? kept.size() : runs.count(), kept.size());
    for (size_t f = 0; f < kept.size(); ++f) {
      ASSERT_EQ(kept.count(f), copied.count(f)) << "op " << op << " fragment " << f;
      for (int i = 0; i < kept.count(f); ++i) {
        ASSERT_EQ(kept.data(f)[i].x, copied.data(f)[i].x);
        ASSERT_EQ(kept.data(f)[i].y, copied.data(f)[i].y);
        ASSERT_EQ(kept.data(f)[i].z, copied.data(f)[i].z);
      }
      ASSERT_LT(kept.polys[f].box, boxes.size());
      const UVBox& got = boxes[kept.polys[f].box];
      const UVBox want = UVBox::of(axes, kept.data(f), kept.count(f));
      ASSERT_TRUE(got.ulo == want.ulo && got.uhi == want.uhi && got.vlo == want.vlo && got.vhi == want.vhi)
          << "op " << op << " fragment " << f;
    }
    longest = std::max(longest, kept.size());
  }
  // The sequences reach what the storage has to get right: long lists (runs), and both
  // compactions.
  EXPECT_GT(longest, 300u);
  EXPECT_GT(met_calls, 1000u);
  EXPECT_GT(box_compactions, 0u);
  EXPECT_GT(vert_compactions, 0u);
}

namespace {
// Area of the convex polygon p (x, y) and its clip by the half-plane left of a -> b,
// in long double: the reference below, independent of node_plane and split_fragment.
using P2 = std::pair<long double, long double>;
long double area2(const std::vector<P2>& p) {
  long double s = 0;
  for (size_t i = 0; i < p.size(); ++i) {
    const P2 &a = p[i], &b = p[(i + 1) % p.size()];
    s += a.first * b.second - a.second * b.first;
  }
  return std::abs(s) / 2;
}
std::vector<P2> clip_left(const std::vector<P2>& p, const P2& a, const P2& b) {
  auto side = [&](const P2& x) {
    return (b.first - a.first) * (x.second - a.second) - (b.second - a.second) * (x.first - a.first);
  };
  std::vector<P2> out;
  for (size_t i = 0; i < p.size(); ++i) {
    const P2 &x = p[i], &y = p[(i + 1) % p.size()];
    const long double sx = side(x), sy = side(y);
    if (sx >= 0) out.push_back(x);
    if ((sx > 0 && sy < 0) || (sx < 0 && sy > 0)) {
      const long double t = sx / (sx - sy);
      out.push_back({x.first + (y.first - x.first) * t, x.second + (y.second - x.second) * t});
    }
  }
  return out;
}
}  // namespace

// Put-off cuts (subtract.h defer_cuts), by hand: seen from r at the origin the triangle
// at z = 1 casts C = (-1, 4), A = (0, 0), B = (4, 0) on the light z = 2. Fragment F =
// [0.2, 1] x [-1.5, 0.5]: the line of edge C -> A (4x + y = 0) crosses F's lower left
// corner, but the edge itself (x <= 0) does not; F minus the shadow is the rectangle
// [0.2, 1] x [-1.5, 0]. In edge order (C -> A first) the walk cuts off the corner beyond
// 4x + y = 0 and then the rest below y = 0: two fragments. That cut's chord lies below
// y = 0, beyond the next edge A -> B, so it is put off, and after the cut along y = 0
// what is left is inside 4x + y >= 0: one fragment, the rectangle.
TEST(PluckerSubtract, PutOffCutLeavesOneFragmentWhereTheEdgeOrderLeavesTwo) {
  const Vec3d r(0, 0, 0);
  const std::vector<Vec3d> light = {Vec3d(-2, -2, 2), Vec3d(2, -2, 2), Vec3d(2, 2, 2), Vec3d(-2, 2, 2)};
  const std::vector<Vec3d> frag = {Vec3d(0.2, -1.5, 2), Vec3d(1, -1.5, 2), Vec3d(1, 0.5, 2), Vec3d(0.2, 0.5, 2)};
  const UVAxes axes = UVAxes::from_normal(Vec3f(0, 0, 1));
  const LightBounds lb = LightBounds::of(light.data(), int(light.size()));
  const Vec3d q[3] = {Vec3d(-0.5, 2, 1), Vec3d(0, 0, 1), Vec3d(2, 0, 1)};  // C, A, B at z = 1
  const uint8_t skip[3] = {0, 0, 0};
  const UVBox qbox{-1.01, 4.01, -0.01, 4.01};
  for (const bool defer : {true, false}) {
    FragmentList frags, pieces;
    frags.add(frag.data(), frag.size());
    std::vector<UVBox> boxes{UVBox::of(axes, frag.data(), int(frag.size()))}, piece_boxes;
    FragmentRuns runs;
    std::vector<Vec3d> cur, pos, neg;
    BspCounters c;
    ASSERT_TRUE(subtract_polygon(r, q, 3, skip, qbox, axes, lb, frags, boxes, runs, pieces, piece_boxes, cur, pos, neg,
                                 c, defer));
    double area = 0;
    for (size_t f = 0; f < frags.size(); ++f) area += polygon_area(frags.data(f), frags.count(f));
    EXPECT_NEAR(area, 0.8 * 1.5, 1e-12) << defer;
    EXPECT_EQ(c.deferred_cuts, defer ? 1u : 0u);
    ASSERT_EQ(frags.size(), defer ? 1u : 2u);
    if (defer) {  // the rectangle's corners
      ASSERT_EQ(frags.count(0), 4);
      for (int i = 0; i < 4; ++i) {
        const Vec3d& v = frags.data(0)[i];
        EXPECT_TRUE((std::abs(v.x - 0.2) < 1e-12 || std::abs(v.x - 1) < 1e-12) &&
                    (std::abs(v.y + 1.5) < 1e-12 || std::abs(v.y) < 1e-12))
            << v.x << " " << v.y;
      }
    }
  }
}

// Put-off cuts on random sequences: after each subtraction the fragments' area is the
// old fragments' area less each old fragment's overlap with the shadow (long double
// clips, not the walk's planes), and at the end a point of the light away from every
// shadow edge lies in a fragment exactly when no shadow holds it. Triangles of several
// sizes from moving receivers (so shadows meet fragments at corners, where cuts are put
// off, and some put-off cuts are still needed at the end).
TEST(PluckerSubtract, PutOffCutsKeepTheAreaAndTheVisibleSet) {
  const std::vector<Vec3d> light = {Vec3d(-1, -1, 2), Vec3d(1, -1, 2), Vec3d(1, 1, 2), Vec3d(-1, 1, 2)};
  const UVAxes axes = UVAxes::from_normal(Vec3f(0, 0, 1));
  const LightBounds lb = LightBounds::of(light.data(), int(light.size()));
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uc(-1.0, 1.0), uz(0.3, 1.7), u01(0.0, 1.0);
  const uint8_t skip[3] = {0, 0, 0};
  uint64_t deferred = 0, with_frags = 0, without_frags = 0;
  for (int seq = 0; seq < 40; ++seq) {
    FragmentList frags, plain, pieces;
    frags.add(light.data(), light.size());
    plain.add(light.data(), light.size());
    std::vector<UVBox> boxes{UVBox::of(axes, light.data(), 4)}, plain_boxes = boxes, piece_boxes;
    FragmentRuns runs, plain_runs;
    std::vector<Vec3d> cur, pos, neg;
    BspCounters c, pc;
    const Vec3d r(uc(rng) * 0.1, uc(rng) * 0.1, 0.0);
    std::vector<std::array<P2, 3>> shadows;
    for (int op = 0; op < 60 && frags.size() != 0; ++op) {
      const double z = uz(rng), size = u01(rng) < 0.2 ? 0.5 : 0.1;
      const double cx = r.x + uc(rng) * z / 2, cy = r.y + uc(rng) * z / 2;
      Vec3d t[3];
      for (Vec3d& v : t) v = Vec3d(cx + uc(rng) * size * z, cy + uc(rng) * size * z, z);
      if (dot(cross(t[1] - t[0], t[2] - t[0]), r - t[0]) > 0) std::swap(t[1], t[2]);
      std::array<P2, 3> s;
      Vec3d sd[3];
      for (int i = 0; i < 3; ++i) {
        sd[i] = r + (t[i] - r) * (2.0 / z);
        s[size_t(i)] = {(long double)r.x + ((long double)t[i].x - r.x) * 2.0L / z,
                        (long double)r.y + ((long double)t[i].y - r.y) * 2.0L / z};
      }
      // Counter-clockwise for clip_left (the shadow of a triangle facing away from r).
      if ((s[1].first - s[0].first) * (s[2].second - s[0].second) -
              (s[1].second - s[0].second) * (s[2].first - s[0].first) < 0)
        std::swap(s[1], s[2]);
      UVBox qbox = UVBox::of(axes, sd, 3);
      qbox = UVBox{qbox.ulo - 1e-9, qbox.uhi + 1e-9, qbox.vlo - 1e-9, qbox.vhi + 1e-9};
      long double want = 0;
      for (size_t f = 0; f < frags.size(); ++f) {
        std::vector<P2> p;
        for (int i = 0; i < frags.count(f); ++i) p.push_back({frags.data(f)[i].x, frags.data(f)[i].y});
        const long double a = area2(p);
        for (int e = 0; e < 3 && !p.empty(); ++e) p = clip_left(p, s[size_t(e)], s[size_t(e + 1) % 3]);
        want += a - (p.size() >= 3 ? area2(p) : 0);
      }
      subtract_polygon(r, t, 3, skip, qbox, axes, lb, frags, boxes, runs, pieces, piece_boxes, cur, pos, neg, c);
      subtract_polygon(r, t, 3, skip, qbox, axes, lb, plain, plain_boxes, plain_runs, pieces, piece_boxes, cur, pos,
                       neg, pc, false);
      long double got = 0;
      for (size_t f = 0; f < frags.size(); ++f) got += polygon_area(frags.data(f), frags.count(f));
      ASSERT_NEAR(double(got), double(want), 1e-10) << "sequence " << seq << " op " << op;
      shadows.push_back(s);
    }
    deferred += c.deferred_cuts;
    with_frags += frags.size();
    without_frags += plain.size();
    // The visible set: grid points 1e-7 or more from every shadow edge's line.
    for (int gy = 0; gy < 41; ++gy)
      for (int gx = 0; gx < 41; ++gx) {
        const long double px = -0.99L + 1.98L * gx / 40, py = -0.99L + 1.98L * gy / 40;
        bool hidden = false, near_edge = false;
        for (const auto& s : shadows) {
          bool inside = true;
          for (int e = 0; e < 3; ++e) {
            const P2 &a = s[size_t(e)], &b = s[size_t(e + 1) % 3];
            const long double len = std::hypot(b.first - a.first, b.second - a.second);
            const long double d = ((b.first - a.first) * (py - a.second) - (b.second - a.second) * (px - a.first)) / len;
            near_edge |= std::abs(d) < 1e-7L;
            inside &= d > 0;
          }
          hidden |= inside;
        }
        if (near_edge) continue;
        bool in_frag = false;
        for (size_t f = 0; f < frags.size() && !in_frag; ++f)
          in_frag = point_in_fragment(axes, frags.data(f), frags.count(f), Vec3d(double(px), double(py), 2.0));
        ASSERT_EQ(in_frag, !hidden) << "sequence " << seq << " point " << double(px) << " " << double(py);
      }
  }
  // Cuts were put off, and the fragments are fewer than the edge order's.
  EXPECT_GT(deferred, 100u);
  EXPECT_LT(with_frags, without_frags);
}
