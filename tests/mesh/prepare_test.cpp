// lib/mesh: mesh preparation of paper 000 section 4.2 (weld, degenerate removal,
// neighbours across consistently facing edges, unique edge labels, double-edge flags).
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>

#include "lib/mesh/prepare.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"

using namespace visgate;
using namespace visgate::mesh;

namespace {

// A unit cube as 8 shared corners and 12 outward triangles.
TriangleSoup cube_soup() {
  TriangleSoup s;
  shapes::add_box(s, Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  return s;
}

// Every triangle gets its own three vertices (a soup as STL files store it), in a
// shuffled vertex order.
TriangleSoup explode_and_shuffle(const TriangleSoup& in, uint64_t seed) {
  TriangleSoup out;
  for (const auto& t : in.triangles) {
    uint32_t b = uint32_t(out.vertices.size());
    for (int k = 0; k < 3; ++k) out.vertices.push_back(in.vertices[t[k]]);
    out.triangles.push_back({b, b + 1, b + 2});
  }
  std::vector<uint32_t> perm(out.vertices.size());
  std::iota(perm.begin(), perm.end(), 0u);
  Rng rng(seed);
  for (size_t i = perm.size(); i > 1; --i) std::swap(perm[i - 1], perm[rng.below(i)]);
  std::vector<Vec3f> v(out.vertices.size());
  for (size_t i = 0; i < perm.size(); ++i) v[perm[i]] = out.vertices[i];
  for (auto& t : out.triangles)
    for (auto& k : t) k = perm[k];
  out.vertices = v;
  return out;
}

}  // namespace

TEST(Weld, ShuffledDuplicateVerticesOfACube) {
  TriangleSoup s = explode_and_shuffle(cube_soup(), 5);
  ASSERT_EQ(s.vertices.size(), 36u);
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  EXPECT_EQ(m.vertex_pos.size(), 8u);
  EXPECT_EQ(c.welded_vertices, 28u);
  EXPECT_EQ(validate(m), "");
}

TEST(Weld, SignedZeroIsOnePositionAndNearbyIsNot) {
  TriangleSoup s;
  s.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(-0.0f, 0, -0.0f), Vec3f(1, 0, 0),
                Vec3f(std::nextafter(0.0f, 1.0f), 1, 0)};
  s.triangles = {{0, 1, 2}, {3, 4, 5}};
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  EXPECT_EQ(m.vertex_pos.size(), 4u);
  EXPECT_EQ(c.welded_vertices, 2u);
}

TEST(Degenerate, TrianglesWithTwoEqualVerticesAreRemovedAfterWelding) {
  TriangleSoup s;
  s.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(1, 0, 0)};
  s.triangles = {{0, 1, 2}, {0, 1, 3}, {2, 2, 0}};
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  EXPECT_EQ(c.degenerate_removed, 2u);
  ASSERT_EQ(m.triangles.size(), 1u);
  EXPECT_EQ(m.triangles[0].source, 0u);
  EXPECT_EQ(validate(m), "");
}

TEST(Labels, ClosedCubeHasOnlyDoubleEdges) {
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(cube_soup(), &c);
  EXPECT_EQ(c.double_edges, 18u);  // V - E + F = 2: 8 - 18 + 12
  EXPECT_EQ(c.single_edges, 0u);
  EXPECT_EQ(m.edge_count(), 18u);
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) EXPECT_GE(t.neighbors[k], 0);
  EXPECT_EQ(validate(m), "");
}

TEST(Labels, OneFlippedFaceLeavesTwoLabelsOnEachOfItsEdges) {
  TriangleSoup s = cube_soup();
  std::swap(s.triangles[4][1], s.triangles[4][2]);  // flip one triangle
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  // The flipped triangle's three edges each join a triangle with the same facing
  // direction: no neighbours there, two labels per edge (paper 000 section 4.2).
  EXPECT_EQ(c.inconsistent_joins, 3u);
  EXPECT_EQ(c.single_edges, 6u);
  EXPECT_EQ(c.double_edges, 15u);
  const auto& ft = m.triangles[4];
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(ft.neighbors[k], -1);
    EXPECT_FALSE(m.is_double_edge[ft.edge_labels[k]]);
  }
  EXPECT_EQ(validate(m), "");
}

TEST(Labels, NonManifoldEdgeIsSingleOnEveryTriangle) {
  TriangleSoup s;
  s.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0), Vec3f(0, -1, 0), Vec3f(0, 0, 1)};
  s.triangles = {{0, 1, 2}, {1, 0, 3}, {1, 0, 4}};
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  EXPECT_EQ(c.nonmanifold_edges, 1u);
  EXPECT_EQ(c.double_edges, 0u);
  EXPECT_EQ(c.single_edges, 9u);
  std::vector<uint32_t> labels;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k) labels.push_back(t.edge_labels[k]);
  std::sort(labels.begin(), labels.end());
  EXPECT_EQ(std::unique(labels.begin(), labels.end()), labels.end());  // all unique
  EXPECT_EQ(validate(m), "");
}

TEST(Labels, TwoConsistentNeighboursShareOneLabel) {
  TriangleSoup s;
  s.vertices = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(1, 1, 0), Vec3f(0, 1, 0)};
  s.triangles = {{0, 1, 2}, {0, 2, 3}};
  PreparedMesh m = prepare_mesh(s);
  EXPECT_EQ(m.triangles[0].neighbors[2], 1);  // edge 2->0
  EXPECT_EQ(m.triangles[1].neighbors[0], 0);  // edge 0->2
  EXPECT_EQ(m.triangles[0].edge_labels[2], m.triangles[1].edge_labels[0]);
  EXPECT_TRUE(m.is_double_edge[m.triangles[0].edge_labels[2]]);
  EXPECT_EQ(validate(m), "");
}

TEST(Validate, DetectsBrokenInvariants) {
  PreparedMesh m = prepare_mesh(cube_soup());
  PreparedMesh a = m;
  a.triangles[0].neighbors[0] = -1;
  EXPECT_NE(validate(a), "");
  PreparedMesh b = m;
  b.vertex_pos[1] = b.vertex_pos[0];
  EXPECT_NE(validate(b), "");
  PreparedMesh c = m;
  c.triangles[0].edge_labels[0] = uint32_t(c.edge_count());
  EXPECT_NE(validate(c), "");
}

TEST(Prepare, FarFromOriginAndSlivers) {
  TriangleSoup s = cube_soup();
  for (auto& v : s.vertices) v = Vec3f(to_double(v) * 0.001 + Vec3d(1e6, -1e6, 1e6));
  // Far out, the float spacing (0.0625 at 1e6) exceeds 0.001: the cube collapses onto
  // one point and every triangle becomes degenerate after exact welding.
  PrepareCounts c;
  PreparedMesh m = prepare_mesh(s, &c);
  EXPECT_EQ(m.vertex_pos.size(), 1u);
  EXPECT_EQ(c.degenerate_removed, 12u);
  EXPECT_EQ(validate(m), "");
  // A sliver (collinear, distinct vertices) is kept: only repeated vertices are removed.
  TriangleSoup t;
  t.vertices = {Vec3f(0, 0, 0), Vec3f(1, 1, 1), Vec3f(2, 2, 2)};
  t.triangles = {{0, 1, 2}};
  EXPECT_EQ(prepare_mesh(t).triangles.size(), 1u);
}
