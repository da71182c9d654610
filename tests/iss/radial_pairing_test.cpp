// lib/iss/radial_pairing.h: radial pairing of non-manifold edges.
#include <gtest/gtest.h>

#include "lib/iss/radial_pairing.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/shapes.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

// ---- radial pairing of non-manifold edges (radial_pairing.h) --------------------------------

TEST(IssPairing, AbuttingBoxesShareTheirOuterFaces) {
  // Boxes [0,1]^3 and [1,2] x [0,1]^2 touch in the square x = 1: each of its four edges
  // carries two faces of each box. Hand-worked union pairing: across the edge
  // (1,0,0)-(1,1,0) A's bottom face continues into B's bottom face (plane z = 0), and
  // the two coincident end faces pair with each other.
  for (double off : {0.0, 1e5}) {
    TriangleSoup soup;
    shapes::add_box(soup, Vec3d(off, 0, 0), Vec3d(off + 1, 1, 1));
    shapes::add_box(soup, Vec3d(off + 1, 0, 0), Vec3d(off + 2, 1, 1));
    mesh::PrepareCounts counts;
    mesh::PreparedMesh m = mesh::prepare_mesh(soup, &counts);
    EXPECT_GE(counts.nonmanifold_edges, 4u);
    size_t pairs = iss::pair_nonmanifold_edges(m);
    EXPECT_EQ(mesh::validate(m), "") << off;
    EXPECT_GE(pairs, 8u) << off;  // two pairs on each of the four edges of the square
    int checked = 0;
    for (size_t t = 0; t < m.triangles.size(); ++t) {
      for (int k = 0; k < 3; ++k) {
        Vec3f a = m.corner(t, k), b = m.corner(t, (k + 1) % 3), c = m.corner(t, (k + 2) % 3);
        // A's bottom triangle on the edge x = 1, z = 0.
        if (!(a.x == float(off + 1) && b.x == float(off + 1) && a.z == 0 && b.z == 0 && c.z == 0 && c.x < float(off + 1)))
          continue;
        int32_t nb = m.triangles[t].neighbors[k];
        ASSERT_GE(nb, 0) << off;
        bool in_b_bottom = true;
        for (int q = 0; q < 3; ++q)
          in_b_bottom = in_b_bottom && m.corner(size_t(nb), q).z == 0 && m.corner(size_t(nb), q).x >= float(off + 1);
        EXPECT_TRUE(in_b_bottom) << off;
        ++checked;
      }
    }
    EXPECT_EQ(checked, 1) << off;
  }
}

TEST(IssPairing, LeavesEdgesThatDoNotAlternateSingle) {
  // Three triangles on one edge (odd), and four whose directions do not alternate
  // (two coincident fans with the same facing): no pairing, labels stay single.
  TriangleSoup soup;
  soup.vertices = {Vec3f(0, 0, 0), Vec3f(0, 0, 1), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(-1, 0, 0)};
  soup.triangles = {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}};
  mesh::PreparedMesh m = mesh::prepare_mesh(soup);
  EXPECT_EQ(iss::pair_nonmanifold_edges(m), 0u);
  EXPECT_EQ(mesh::validate(m), "");
  soup.vertices.push_back(Vec3f(0, -1, 0));
  soup.triangles = {{0, 1, 2}, {0, 1, 3}, {1, 0, 4}, {1, 0, 5}};  // forward, forward, back, back
  m = mesh::prepare_mesh(soup);
  EXPECT_EQ(iss::pair_nonmanifold_edges(m), 0u);
  EXPECT_EQ(mesh::validate(m), "");
  for (const auto& tr : m.triangles)
    for (int k = 0; k < 3; ++k) EXPECT_LT(tr.neighbors[k], 0) << "no edge of this fan is double";
}
