// lib/repair/triangulate.cpp: polygons by ear clipping, keeping their orientation.
#include <gtest/gtest.h>

#include "tests/support/repair_fixtures.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

// Polygons are triangulated by ear clipping (an L-shaped, non-convex hexagon: a fan from
// vertex 0 would cover the notch) and keep their orientation.
TEST(RepairTriangulate, NonConvexPolygonByEars) {
  std::vector<Vec3d> p = {{0, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 2, 0}, {0, 2, 0}};
  std::vector<std::array<uint32_t, 3>> tris;
  EXPECT_TRUE(triangulate_polygon(p, {0, 1, 2, 3, 4, 5}, tris));
  ASSERT_EQ(tris.size(), 4u);
  double area = 0;
  for (const auto& t : tris) {
    Vec3d n = cross(p[t[1]] - p[t[0]], p[t[2]] - p[t[0]]);
    EXPECT_GT(n.z, 0);  // counter-clockwise like the polygon
    area += n.z / 2;
  }
  EXPECT_DOUBLE_EQ(area, 3.0);
  // Through repair: a quad face becomes two triangles of face 0; a 2-vertex face is
  // accounted as a short face.
  PolygonSoup s = make_soup({{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, {{0, 1, 2, 3}, {0, 1}});
  RepairResult r = run(s);
  EXPECT_EQ(r.polygons_triangulated, 1u);
  EXPECT_EQ(r.output.triangles.size(), 2u);
  EXPECT_EQ(r.faces_in_output, 1u);
  ASSERT_EQ(r.removed.size(), 1u);
  EXPECT_STREQ(r.removed[0].reason, "short_face");
}
