// lib/iss/blockers.cpp: blocker storage and validate() (paper 000 sections 4.4.2, 4.13).
#include <gtest/gtest.h>

#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

// ---- blocker representation and validate() (sections 4.4.2, 4.13) -----------------------

TEST(IssBlockers, ValidateAcceptsATriangleAndRejectsBrokenLinks) {
  iss::Surface s = one_triangle_surface(Vec3d(0, 0, 1), Vec3d(1, 0, 1), Vec3d(0, 1, 1), iss::Facing::TowardsReceiver);
  EXPECT_EQ(iss::validate(s, nullptr), "");
  iss::Surface broken = s;
  broken.hull = iss::empty_box();  // patches stand for triangles somewhere
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.hull.hi.z = 0.5;  // the hull holds every edge
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.raw[1].v[1] = Vec3d(5, 5, 5);  // the loop no longer closes
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.raw[2].nb[0] = 0;  // claims a neighbour that does not reference it
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.patches[0].facing = iss::Facing::Inconsistent;  // inconsistent needs its triangle
  EXPECT_NE(iss::validate(broken, nullptr), "");
}
