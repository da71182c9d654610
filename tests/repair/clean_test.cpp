// lib/repair/clean.cpp: T-junction splits that would recreate a face leave no duplicate.
#include <gtest/gtest.h>

#include "tests/support/repair_fixtures.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

// The split of (a, b, c) at p on ab yields (a, p, c), a copy (in the
// opposite sense) of a face already there; the copy goes and a second run changes
// nothing.
TEST(RepairTJunction, SplitDoesNotLeaveADuplicateFace) {
  PolygonSoup s;
  s.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1, 0, 0}};  // a, b, c, p (p inside ab)
  s.faces = {{0, 1, 2}, {0, 2, 3}};
  RepairResult r = run(s);
  EXPECT_EQ(r.before.defects.t_junctions, 1u);
  EXPECT_EQ(r.after.defects.duplicate_faces + r.after.defects.opposite_duplicate_faces, 0u);
  EXPECT_EQ(r.after.defects.t_junctions, 0u);
  expect_idempotent(s, {}, "t-junction duplicate");
  // The same inside a closed mesh: a tetrahedron whose base is split at a point of an
  // edge only on one side, with an extra copy of one half.
  PolygonSoup t;
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {1, 0, 0}};
  t.faces = {{0, 2, 1}, {0, 4, 3}, {4, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 2, 4}};
  RepairResult u = run(t);
  EXPECT_EQ(u.after.defects.duplicate_faces + u.after.defects.opposite_duplicate_faces, 0u);
  expect_idempotent(t, {}, "closed t-junction duplicate");
}
