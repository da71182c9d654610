// Tests of lib/plucker/pyramid_side.h: the near polygons' pyramid test.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "lib/plucker/pyramid_side.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::plucker;

TEST(PluckerPyramidSide, AllOutsideIsTheScalarTestAtEveryVertex) {
  // all_outside (two vertices at a time with SSE2) against outside_side vertex by vertex
  // on random planes and polygons of 1 to 7 vertices, most of them placed so that each
  // vertex's value lies within a few bounds of the margin (either answer, decided by the
  // last bits), some with a vertex inside or on the plane.
  Rng rng(2039);
  int outside = 0, inside = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    PyramidPlane pp;
    pp.n = Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1));
    pp.l = Vec3d(rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(-4, 4));
    const double wscale = std::ldexp(1.0, -int(rng.below(50)));
    pp.w = Vec3d(rng.uniform(0, wscale), rng.uniform(0, wscale), rng.uniform(0, wscale));
    pp.set_lanes();
    const double shift = trial % 5 == 0 ? 0.0 : rng.uniform(0, wscale);
    const uint32_t n = 1 + uint32_t(rng.below(7));
    std::vector<Vec3d> pv(n);
    for (Vec3d& v : pv) {
      const Vec3d d(rng.uniform(-2, 2), rng.uniform(-2, 2), rng.uniform(-2, 2));
      // Moved along n so that dot(n, d) is about -16 e - shift (give or take a few of it).
      const double e = std::abs(d.x) * pp.w.x + std::abs(d.y) * pp.w.y + std::abs(d.z) * pp.w.z;
      const double nn = dot(pp.n, pp.n);
      const double target = (trial % 3 == 0 ? rng.uniform(-1, 1) : -(16.0 * e + shift) * rng.uniform(0.5, 1.5));
      const double t = nn > 0.0 ? (target - dot(pp.n, d)) / nn : 0.0;
      v = pp.l + d + pp.n * t;
    }
    if (trial % 11 == 0) pv[rng.below(n)] = pp.l;  // a vertex on the plane
    bool expect = true;
    for (const Vec3d& v : pv) expect = expect && outside_side(pp, v - pp.l, shift);
    ASSERT_EQ(all_outside(pp, pv.data(), n, shift), expect) << trial;
    (expect ? outside : inside) += 1;
  }
  EXPECT_GT(outside, 20000);
  EXPECT_GT(inside, 20000);
}
