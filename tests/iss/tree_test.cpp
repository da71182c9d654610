// lib/iss/tree.h: the lazy receiver and light-sample trees (paper 000 section 4.3).
#include <gtest/gtest.h>

#include <algorithm>

#include "lib/iss/tree.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/shapes.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

// Splits `tree` down to its leaves (SPLIT-NODE on every node) and calls leaf(node) for
// each leaf; returns the number of leaves.
template <class F>
int for_each_leaf(iss::PointTree& tree, F&& leaf) {
  std::vector<int> stack{tree.root()};
  int leaves = 0;
  while (!stack.empty()) {
    int i = stack.back();
    stack.pop_back();
    tree.split(i);
    const iss::TreeNode& n = tree.node(i);
    if (n.split_done()) {
      stack.push_back(n.left);
      stack.push_back(n.right);
      continue;
    }
    ++leaves;
    leaf(n);
  }
  return leaves;
}

}  // namespace

TEST(IssTree, GridLeavesAreCompactNotStrips) {
  // 32 x 32 receivers on a floor, leaves of 64: the N*A split must give square-ish
  // leaves (8 x 8), not strips of collinear points (zero box area, see tree.cpp).
  std::vector<AABB> boxes;
  std::vector<Vec3f> centers;
  for (int b = 0; b < 32; ++b)
    for (int a = 0; a < 32; ++a) {
      Vec3f p(0.1875f * float(a), 0.1875f * float(b), 0.01f);
      boxes.emplace_back(p, p);
      centers.push_back(p);
    }
  mesh::PreparedMesh m;
  std::vector<AABB> tri_boxes;
  iss::PointTree tree(boxes, centers, 64, m, tri_boxes);
  const int leaves = for_each_leaf(tree, [&](const iss::TreeNode& n) {
    EXPECT_LE(n.size(), 64u);
    double ex = double(n.box.extent().x) + 0.1875, ey = double(n.box.extent().y) + 0.1875;
    EXPECT_LE(std::max(ex, ey), 2.0 * std::min(ex, ey)) << "leaf " << ex << " x " << ey;
  });
  EXPECT_EQ(leaves, 16);
}

TEST(IssTree, LeavesDoNotStraddleAWall) {
  // 32 x 8 receivers at z = 0.01 (x = 0.1 + 0.2 a, y = 0.1 + 0.2 b) and a wall box
  // 2.95 <= x <= 3.25 standing on the floor: columns a <= 14 lie left of it, a = 15
  // (x = 3.1) inside it, a >= 16 right of it. Hand-worked: a leaf with points of two of
  // these classes would hold a wall face in its inside list (section 4.4.2: the wall
  // could never block its shafts); the split cost of tree.h keeps the classes apart.
  for (double offset : {0.0, 4096.0}) {  // also far from the origin (float spacing 2^-12)
    std::vector<AABB> boxes;
    std::vector<Vec3f> centers;
    std::vector<int> cls;
    for (int b = 0; b < 8; ++b)
      for (int a = 0; a < 32; ++a) {
        Vec3f p(float(offset + 0.1 + 0.2 * a), float(0.1 + 0.2 * b), 0.01f);
        boxes.emplace_back(p, p);
        centers.push_back(p);
        cls.push_back(a <= 14 ? 0 : a == 15 ? 1 : 2);
      }
    TriangleSoup soup;
    shapes::add_box(soup, Vec3d(offset + 2.95, -1, 0), Vec3d(offset + 3.25, 3, 2));
    mesh::PreparedMesh m = mesh::prepare_mesh(soup);
    std::vector<AABB> tri_boxes;
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      AABB tb;
      for (int k = 0; k < 3; ++k) tb.extend(m.corner(t, k));
      tri_boxes.push_back(tb);
    }
    iss::PointTree tree(boxes, centers, 16, m, tri_boxes);
    ASSERT_FALSE(tree.node(tree.root()).inside.empty());
    const int leaves = for_each_leaf(tree, [&](const iss::TreeNode& n) {
      EXPECT_LE(n.size(), 16u);
      int c0 = cls[tree.order()[n.begin]];
      for (uint32_t k = n.begin; k < n.end; ++k)
        EXPECT_EQ(cls[tree.order()[k]], c0) << "offset " << offset << ": leaf mixes wall sides";
      EXPECT_TRUE(n.inside.empty()) << "offset " << offset;
    });
    EXPECT_GE(leaves, 16);
  }
}
