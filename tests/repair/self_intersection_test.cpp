// lib/repair/self_intersection.cpp: self-intersections reported by the analysis equal all
// pairs tested one by one with CGAL.
#include <gtest/gtest.h>

#include "tests/support/repair_fixtures.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

// Self-intersections of a soup of many small triangles sharing no vertex (so every pair
// is a plain triangle/triangle test): the set analyze_mesh reports equals all pairs
// tested one by one with CGAL, so the box tree misses no candidate.
TEST(RepairPredicates, SelfIntersectionsMatchAllPairsBruteForce) {
  Rng rng(14);
  IndexedMesh m;
  for (int t = 0; t < 600; ++t) {
    const Vec3d c(double(rng.below(12)), double(rng.below(12)), double(rng.below(4)));
    for (int k = 0; k < 3; ++k)
      m.vertices.push_back(c + Vec3d(double(rng.below(3)), double(rng.below(3)), double(rng.below(2))));
    m.triangles.push_back({uint32_t(3 * t), uint32_t(3 * t + 1), uint32_t(3 * t + 2)});
  }
  std::vector<std::array<uint32_t, 2>> want;
  std::vector<uint8_t> flat(m.triangles.size());
  for (size_t i = 0; i < m.triangles.size(); ++i) {
    const auto& t = m.triangles[i];
    flat[i] = kEx.collinear(m.vertices[t[0]], m.vertices[t[1]], m.vertices[t[2]]);
  }
  for (uint32_t i = 0; i < m.triangles.size(); ++i)
    for (uint32_t j = i + 1; j < m.triangles.size(); ++j) {
      if (flat[i] || flat[j]) continue;
      const auto &a = m.triangles[i], &b = m.triangles[j];
      // Equal positions would make the triangles share a vertex: skip such pairs in
      // both lists (analyze_mesh sees vertices by index, and none is shared here).
      if (kEx.triangles_intersect(m.vertices[a[0]], m.vertices[a[1]], m.vertices[a[2]], m.vertices[b[0]],
                                  m.vertices[b[1]], m.vertices[b[2]]))
        want.push_back({i, j});
    }
  Analysis an = analyze_mesh(m, kEx);
  EXPECT_GT(want.size(), 500u);
  EXPECT_EQ(an.self_intersections, want);
  EXPECT_GE(an.self_intersection_pairs_tested, want.size());
}
