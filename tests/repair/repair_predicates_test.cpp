// lib/repair/repair_predicates.h/.cpp: the double-precision filters in front of the exact
// predicates. Whenever a filter answers, its sign is CGAL's exact sign. The inputs are
// built to be nearly degenerate, so that the plain double evaluation gets the sign wrong
// in some of them (counted and required: the filter must then abstain), and exactly
// degenerate, so that the filter must abstain.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/repair_fixtures.h"
#include "lib/repair/repair_predicates.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

namespace {

Vec3d random_point(Rng& rng, const Vec3d& centre, int e) {
  const double s = std::ldexp(1.0, e);
  return centre + Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * s;
}

double naive_orient(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return dot(cross(b - a, c - a), d - a);
}

}  // namespace

TEST(RepairPredicates, Orient3dFilterIsExactWhenItAnswers) {
  Rng rng(11);
  size_t answered = 0, abstained = 0, naive_wrong = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d centre = it % 3 == 0 ? Vec3d(0, 0, 0) : random_point(rng, Vec3d(0, 0, 0), int(rng.below(40)) - 10);
    const int e = int(rng.below(30)) - 15;
    const Vec3d a = random_point(rng, centre, e), b = random_point(rng, centre, e), c = random_point(rng, centre, e);
    // d on the plane up to rounding, then moved a few ulps on one axis.
    const double s = rng.uniform(-2, 2), t = rng.uniform(-2, 2);
    Vec3d d = a + (b - a) * s + (c - a) * t;
    const int ax = int(rng.below(3)), k = int(rng.below(7)) - 3;
    d[ax] = ulps(d[ax], k);
    const int exact = kEx.orientation(a, b, c, d);
    const Sign f = orient3d_filtered(a, b, c, d);
    const double naive = naive_orient(a, b, c, d);
    if ((naive > 0 ? 1 : naive < 0 ? -1 : 0) != exact) ++naive_wrong;
    if (f == Sign::Uncertain) {
      ++abstained;
      continue;
    }
    ++answered;
    ASSERT_EQ(int(f), exact) << "iteration " << it;
  }
  EXPECT_GT(naive_wrong, 100u);  // the inputs do defeat plain double evaluation
  EXPECT_GT(answered, 1000u);    // and the filter still decides many of them
  EXPECT_GT(abstained, 100u);
  // Exactly degenerate: coplanar (d = a, d on an edge's line through dyadic steps).
  const Vec3d a(1e7, -3, 0.5), b(1e7 + 1, -3, 0.5), c(1e7, -2, 0.75);
  EXPECT_EQ(orient3d_filtered(a, b, c, a), Sign::Uncertain);
  EXPECT_EQ(orient3d_filtered(a, b, c, a + (b - a) * 0.5 + (c - a) * 0.25), Sign::Uncertain);
  // Zero by structure: four points sharing a coordinate exactly (a floor z = 0.3 far from
  // the origin) are certified coplanar; with d one ulp off the floor the filter does not
  // say coplanar, and the filtered predicate gives the exact sign.
  const Vec3d f0(1e6, 2e6, 0.3), f1(1e6 + 3, 2e6 - 1, 0.3), f2(1e6 - 2, 2e6 + 5, 0.3), f3(1e6 + 0.1, 2e6 + 0.7, 0.3);
  EXPECT_EQ(orient3d_filtered(f0, f1, f2, f3), Sign::Zero);
  EXPECT_EQ(kEx.orientation(f0, f1, f2, f3), 0);
  const Vec3d f4(f3.x, f3.y, ulps(0.3, 1));
  EXPECT_NE(orient3d_filtered(f0, f1, f2, f4), Sign::Zero);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(f0, f1, f2, f4), kEx.orientation(f0, f1, f2, f4));
  EXPECT_NE(kEx.orientation(f0, f1, f2, f4), 0);
  // Far from degenerate: answered.
  EXPECT_EQ(orient3d_filtered(kA, kB, kC, kD), Sign::Positive);
  EXPECT_EQ(orient3d_filtered(kA, kC, kB, kD), Sign::Negative);
  // Magnitudes where products would overflow or underflow: the filter abstains and the
  // exact predicate decides.
  EXPECT_EQ(orient3d_filtered(kA * 0x1p400, kB * 0x1p400, kC * 0x1p400, kD * 0x1p400), Sign::Uncertain);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(kA * 0x1p400, kB * 0x1p400, kC * 0x1p400, kD * 0x1p400), 1);
  EXPECT_EQ(orient3d_filtered(kA * 0x1p-300, kB * 0x1p-300, kC * 0x1p-300, kD * 0x1p-300), Sign::Uncertain);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(kA * 0x1p-300, kB * 0x1p-300, kC * 0x1p-300, kD * 0x1p-300), 1);
}

TEST(RepairPredicates, CollinearAndLineBoxFiltersAreConservative) {
  Rng rng(12);
  const FilteredPredicates fp(kEx);
  size_t off_line_certified = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d centre = random_point(rng, Vec3d(0, 0, 0), int(rng.below(40)) - 10);
    const int e = int(rng.below(30)) - 15;
    const Vec3d a = random_point(rng, centre, e), b = random_point(rng, centre, e);
    // p on the line up to rounding, moved by up to 2 ulps.
    Vec3d p = a + (b - a) * rng.uniform(-0.5, 1.5);
    const int ax = int(rng.below(3));
    p[ax] = ulps(p[ax], int(rng.below(5)) - 2);
    const bool exact = kEx.collinear(a, b, p);
    ASSERT_EQ(fp.collinear(a, b, p), exact) << "iteration " << it;
    // A point box: the line may meet it iff p is collinear, and the filter must never
    // say "misses" for a collinear p.
    const bool may = line_may_meet_box(a, b, p, p);
    if (exact) {
      ASSERT_TRUE(may) << "iteration " << it;
    } else if (!may) {
      ++off_line_certified;
    }
    // A box around p that contains a point exactly on the line (a itself or b) must
    // never be pruned.
    ASSERT_TRUE(line_may_meet_box(a, b, vmin(p, a), vmax(p, a)));
  }
  EXPECT_GT(off_line_certified, 1000u);
  // Dyadic points exactly on the segment (1, 1, 1) + k/8 (3, -2, 5) far from the origin.
  const Vec3d a(1e6 + 1, 1e6 + 1, -1e6 + 1), d(3, -2, 5);
  for (int k = 0; k <= 8; ++k) {
    const Vec3d p = a + d * (k / 8.0);
    EXPECT_TRUE(line_may_meet_box(a, a + d, p, p));
    EXPECT_TRUE(fp.collinear(a, a + d, p));
    Vec3d q = p;
    q.y = ulps(q.y, 1);
    EXPECT_FALSE(fp.collinear(a, a + d, q));
  }
}

TEST(RepairPredicates, TriangleAndSegmentTestsMatchCgal) {
  // Coordinates on a small integer grid make coplanar, touching and collinear pairs
  // common; every answer is compared with CGAL's do_intersect.
  Rng rng(13);
  const FilteredPredicates fp(kEx);
  size_t hits = 0, seg_hits = 0;
  auto grid_point = [&](double scale, const Vec3d& off) {
    return off + Vec3d(double(rng.below(4)), double(rng.below(4)), double(rng.below(4))) * scale;
  };
  for (int it = 0; it < 30000; ++it) {
    const double scale = it % 2 ? 1.0 : 0x1p-20;
    const Vec3d off = it % 3 ? Vec3d(0, 0, 0) : Vec3d(1e6, -1e6, 3e5);
    Vec3d t[6];
    for (auto& p : t) p = grid_point(scale, off);
    if (kEx.collinear(t[0], t[1], t[2]) || kEx.collinear(t[3], t[4], t[5])) continue;
    const bool want = kEx.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]);
    ASSERT_EQ(fp.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]), want) << "iteration " << it;
    hits += want;
    if (t[3] != t[4]) {
      const bool ws = kEx.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]);
      ASSERT_EQ(fp.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]), ws) << "iteration " << it;
      seg_hits += ws;
    }
  }
  EXPECT_GT(hits, 1000u);
  EXPECT_GT(seg_hits, 1000u);
  // All six points in one tilted plane z = x + 2y (exact on the grid), far from the
  // origin: every pair goes through the coplanar 2D tests; coplanar_side too.
  size_t coplanar_hits = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d off = it % 2 ? Vec3d(0, 0, 0) : Vec3d(4096, -8192, 4096 - 16384);
    Vec3d t[6];
    for (auto& p : t) {
      const double x = double(rng.below(5)), y = double(rng.below(5));
      p = off + Vec3d(x, y, x + 2 * y);
    }
    if (kEx.collinear(t[0], t[1], t[2]) || kEx.collinear(t[3], t[4], t[5])) continue;
    const bool want = kEx.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]);
    ASSERT_EQ(fp.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]), want) << "coplanar iteration " << it;
    coplanar_hits += want;
    if (t[3] != t[4]) {
      ASSERT_EQ(fp.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]),
                kEx.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]))
          << "coplanar iteration " << it;
    }
    ASSERT_EQ(fp.coplanar_side(t[0], t[1], t[2], t[3]), kEx.coplanar_side(t[0], t[1], t[2], t[3]))
        << "coplanar iteration " << it;
  }
  EXPECT_GT(coplanar_hits, 1000u);
}
