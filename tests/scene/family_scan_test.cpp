// The scan family (lib/scene/family_scan.cpp): a closed, consistently outward 2-manifold
// after lib/mesh/prepare, triangle counts near the target at scanned-model sizes, ten
// lights around it, bit-identical scenes per seed.
#include <gtest/gtest.h>

#include "lib/mesh/prepare.h"
#include "lib/scene/family_scan.h"
#include "lib/scene/scene_json.h"
#include "tests/support/family_scene.h"

namespace visgate {
namespace {

Scene scan(uint64_t seed, long triangles, long receivers = 16, long samples = 4) {
  return test_support::family("scan", seed, triangles, receivers, samples);
}

// Closed, and prepare keeps every triangle.
void expect_closed_manifold(const Scene& s) {
  test_support::expect_closed_manifold(s);
  EXPECT_EQ(mesh::prepare_mesh(s.mesh).triangles.size(), s.mesh.size());
}

TEST(FamilyScan, ClosedManifoldAfterPrepare) {
  for (uint64_t seed : {1, 2, 3}) expect_closed_manifold(scan(seed, 5000));
  expect_closed_manifold(scan(4, 100));
}

TEST(FamilyScan, TriangleCountsAtScannedModelSizes) {
  for (long target : {70'000L, 300'000L}) {
    Scene s = scan(1, target);
    EXPECT_GE(double(s.mesh.size()), 0.97 * double(target)) << target;
    EXPECT_LE(double(s.mesh.size()), 1.03 * double(target)) << target;
    if (target == 70'000) expect_closed_manifold(s);
  }
}

TEST(FamilyScan, DefaultsFollowBunny) {
  Scene s = scan(1, -1, -1, -1);
  EXPECT_NEAR(double(s.mesh.size()), 20000.0, 600.0);
  ASSERT_EQ(s.lights.size(), 10u);
  for (const auto& l : s.lights) {
    EXPECT_EQ(l.samples, 36);
    EXPECT_EQ(l.polygon.size(), 4u);
    for (const auto& v : l.polygon) EXPECT_GT(v.z, 1.0f);  // above the object's base
  }
  EXPECT_EQ(s.receivers.size(), 32u * 32u);
  // Standing on the ground slab (top face z = 0), not touching it.
  float lowest = 1e30f;
  for (size_t v = 8; v < s.mesh.vertices.size(); ++v) lowest = std::min(lowest, s.mesh.vertices[v].z);
  EXPECT_NEAR(lowest, 0.01f, 1e-6f);
}

TEST(FamilyScan, BitIdenticalPerSeed) {
  const std::string a = write_scene_json(scan(7, 3000)), b = write_scene_json(scan(7, 3000)),
                    c = write_scene_json(scan(8, 3000));
  EXPECT_EQ(a, b);
  EXPECT_NE(a, c);
}

}  // namespace
}  // namespace visgate
