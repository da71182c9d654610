// lib/repair/repair_report.cpp: the face accounting of the report.
#include <gtest/gtest.h>

#include "tests/support/repair_fixtures.h"
#include "lib/repair/repair_report.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

// Output triangles are in input face order, and the runs map every one of them back.
TEST(RepairReport, SourceRunsMapEveryOutputTriangle) {
  // Face 0 a quad (2 triangles), face 1 a triangle, face 2 a repeated-vertex triangle
  // (removed), faces 3 and 4 triangles, face 5 a pentagon (3 triangles).
  std::vector<uint32_t> src = {0, 0, 1, 3, 4, 5, 5, 5, kFilledHole, kFilledHole};
  auto runs = source_runs(src);
  EXPECT_EQ(runs, (std::vector<std::array<size_t, 4>>{{0, 0, 1, 2}, {2, 1, 1, 1}, {3, 3, 2, 1}, {5, 5, 1, 3}}));
  // A quad mesh is one run.
  EXPECT_EQ(source_runs({0, 0, 1, 1, 2, 2}), (std::vector<std::array<size_t, 4>>{{0, 0, 3, 2}}));
  // Through repair: the T-junction split appends a triangle, which the output order puts
  // back next to its face; hole filling comes last.
  PolygonSoup s = make_soup({{0, 0, 0}, {2, 0, 0}, {1, 1, 0}, {1, 0, 0}, {1, -1, 0}}, {{0, 1, 2}, {0, 4, 3}, {3, 4, 1}});
  RepairResult r = run(s);
  EXPECT_EQ(r.output_source, (std::vector<uint32_t>{0, 0, 1, 2}));
  EXPECT_EQ(source_runs(r.output_source), (std::vector<std::array<size_t, 4>>{{0, 0, 1, 2}, {2, 1, 2, 1}}));
}
