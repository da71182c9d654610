// lib/repair/fill_holes.cpp: hole filling is checked exactly (no fill duplicates a face, cuts
// nearby geometry or makes an edge non-manifold), and orientation runs after it.
#include <gtest/gtest.h>

#include <cmath>

#include "tests/support/repair_fixtures.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

namespace {

// Repair options that fill holes of at most `n` edges.
RepairOptions filling(size_t n) {
  RepairOptions o;
  o.fill_holes = n;
  return o;
}

// The one hole record of `r` (a default one, and a failure, when there is not exactly one).
HoleRecord only_hole(const RepairResult& r) {
  EXPECT_EQ(r.holes.size(), 1u);
  return r.holes.size() == 1 ? r.holes[0] : HoleRecord{};
}

PolygonSoup tube(uint32_t n, bool cap) {
  PolygonSoup s;
  for (uint32_t i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    s.vertices.push_back({std::cos(a), std::sin(a), 0});
    s.vertices.push_back({std::cos(a), std::sin(a), 1});
  }
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t j = (i + 1) % n;
    s.faces.push_back({2 * i, 2 * j, 2 * j + 1});
    s.faces.push_back({2 * i, 2 * j + 1, 2 * i + 1});
  }
  if (cap) {
    s.vertices.push_back({0, 0, 0});
    const uint32_t c = 2 * n;
    for (uint32_t i = 0; i < n; ++i) s.faces.push_back({c, 2 * ((i + 1) % n), 2 * i});
  }
  return s;
}

}  // namespace

TEST(RepairFill, SingleTriangleIsNotClosedByItsOwnCopy) {
  PolygonSoup s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  s.faces = {{0, 1, 2}};
  const RepairOptions o = filling(10);
  RepairResult r = run(s, o);
  const HoleRecord h = only_hole(r);
  EXPECT_FALSE(h.filled);
  EXPECT_STREQ(h.reason, "opposite_duplicate_face");
  EXPECT_EQ(r.output.triangles.size(), 1u);
  EXPECT_EQ(r.after.defects.boundary_loops, 1u);
  EXPECT_EQ(r.after.defects.opposite_duplicate_faces, 0u);
  expect_idempotent(s, o, "single triangle");
}

// A flat 4 x 4 sheet: any fill of its 16-edge rim lies on the sheet.
TEST(RepairFill, FlatSheetIsNotCoveredByASecondLayer) {
  PolygonSoup s;
  for (int y = 0; y <= 4; ++y)
    for (int x = 0; x <= 4; ++x) s.vertices.push_back({double(x), double(y), 0});
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) {
      const uint32_t a = 5 * y + x;
      s.faces.push_back({a, a + 1, a + 6});
      s.faces.push_back({a, a + 6, a + 5});
    }
  const RepairOptions o = filling(100);
  RepairResult r = run(s, o);
  const HoleRecord h = only_hole(r);
  EXPECT_EQ(h.edges, 16u);
  EXPECT_FALSE(h.filled);
  EXPECT_EQ(r.output.triangles.size(), 32u);
  EXPECT_EQ(r.after.defects.self_intersections, 0u);
  expect_idempotent(s, o, "flat sheet");
}

// A cylinder with one 136-edge rim: the minimum-area fill is a valid cap; the closed
// result faces outward, with the volume of the prism over the 136-gon.
TEST(RepairFill, LongRimOfACylinderIsCappedCleanly) {
  const uint32_t n = 136;
  PolygonSoup s = tube(n, true);
  const RepairOptions o = filling(200);
  RepairResult r = run(s, o);
  const HoleRecord h = only_hole(r);
  EXPECT_TRUE(h.filled) << (h.reason ? h.reason : "");
  EXPECT_EQ(h.triangles, n - 2);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_NEAR(volume(r.output), 0.5 * n * std::sin(2 * M_PI / n), 1e-9);
  expect_idempotent(s, o, "capped cylinder");
}

// A hole next to other geometry: a tetrahedron pokes out of the cube through the hole,
// so a cap would cut it. The loop stays open and no intersection is created.
TEST(RepairFill, FillThatWouldCutNearbyGeometryIsRefused) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  s.faces.erase(s.faces.end() - 2, s.faces.end());  // the +z side
  const uint32_t b = uint32_t(s.vertices.size());
  s.vertices.insert(s.vertices.end(), {{1, 1, 2}, {3, 1, 2}, {2, 3, 2}, {2, 2, 5}});
  const uint32_t f[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  for (const auto& t : f) s.faces.push_back({b + t[0], b + t[1], b + t[2]});
  const RepairOptions o = filling(4);
  RepairResult r = run(s, o);
  const HoleRecord h = only_hole(r);
  EXPECT_FALSE(h.filled);
  EXPECT_STREQ(h.reason, "self_intersection");
  EXPECT_EQ(r.after.defects.self_intersections, 0u);
  EXPECT_EQ(r.after.defects.boundary_loops, 1u);
  expect_idempotent(s, o, "hole next to a tetrahedron");
}

// Two holes that meet at a vertex form one boundary walk through it twice: they are
// filled as two holes. (The cube loses triangle (0, 4, 6) of its -x side and (4, 5, 7)
// of its +z side; the boundary walk runs 0 4 5 7 4 6.)
TEST(RepairFill, HolesMeetingAtAVertexAreFilledApart) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {1, 1, 1});
  s.faces.erase(s.faces.begin() + 10);
  s.faces.erase(s.faces.begin());
  EXPECT_EQ(run(s).before.boundary_loops.size(), 1u);
  const RepairOptions o = filling(8);
  RepairResult r = run(s, o);
  EXPECT_EQ(r.holes.size(), 2u);
  for (const HoleRecord& h : r.holes) EXPECT_TRUE(h.filled) << (h.reason ? h.reason : "");
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 1.0);
  expect_idempotent(s, o, "holes meeting at a vertex");
}

// An inside-out open box is closed by filling and must then face outward.
TEST(RepairFill, ComponentsClosedByFillingAreOrientedAfterwards) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {1, 1, 1}, /*inward=*/true);
  s.faces.erase(s.faces.end() - 2, s.faces.end());
  const RepairOptions o = filling(4);
  RepairResult r = run(s, o);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 1.0);
  // And a hollow one: the cavity's open box is filled, then turned inward.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4});
  add_box(t, {1, 1, 1}, {3, 3, 3});
  t.faces.erase(t.faces.end() - 2, t.faces.end());
  RepairResult u = run(t, o);
  EXPECT_EQ(u.after.defects.total(), 0u);
  EXPECT_EQ(volume(u.output), 56.0);
  expect_idempotent(t, o, "hollow box filled");
}
