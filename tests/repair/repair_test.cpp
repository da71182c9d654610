// lib/repair/repair.cpp (repair_mesh, the whole pipeline): a zoo of broken meshes built here, each
// with its hand-derived expected report (defect counts before and after, steps, removal
// records), and the reuse of the input analysis when nothing changed.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "tests/support/repair_fixtures.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

TEST(RepairZoo, CleanTetAndCubeAreUntouched) {
  for (const PolygonSoup& s : {tet(), cube()}) {
    RepairResult r = run(s);
    expect_defects(r.before.defects, {}, "before");
    expect_defects(r.after.defects, {}, "after");
    EXPECT_EQ(r.output.triangles.size(), s.faces.size());
    for (size_t t = 0; t < s.faces.size(); ++t)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(r.output.vertices[r.output.triangles[t][size_t(k)]], s.vertices[s.faces[t][size_t(k)]]);
    EXPECT_EQ(r.before.closed_components, 1u);
    ASSERT_EQ(r.after.components.size(), 1u);
    EXPECT_EQ(r.after.components[0].genus, 0);
    EXPECT_EQ(r.after.components[0].volume_sign, 1);
  }
}

// Near-duplicate vertices on both sides of a rounding boundary: B is stored twice, at
// x = 1 + 0.49e-6 (faces ACB, ABD) and x = 1 + 0.51e-6 (face BCD). Rounding to multiples
// of T = 1e-6 (welding by rounding) sends them to 1.000000 and 1.000001, never merging
// them; their true distance is 2e-8 <= T.
TEST(RepairZoo, NearDuplicatesAcrossARoundingBoundaryWeld) {
  const double T = 1e-6;
  Vec3d b1(1 + 0.49e-6, 0, 0), b2(1 + 0.51e-6, 0, 0);
  ASSERT_NE(std::round(b1.x / T), std::round(b2.x / T));  // rounding would keep them apart
  PolygonSoup s = make_soup({kA, b1, kC, kD, b2}, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {4, 2, 3}});
  RepairOptions o;
  o.weld_tolerance = T;
  RepairResult r = run(s, o);
  // Before (exact positions): B1 and B2 apart, so edges B1C, B1D, B2C, B2D bound one hole.
  expect_defects(r.before.defects, {{"near_duplicate_vertices", 1}, {"boundary_loops", 1}}, "before");
  ASSERT_EQ(r.before.boundary_loops.size(), 1u);
  EXPECT_EQ(r.before.boundary_loops[0].size(), 4u);
  EXPECT_EQ(r.weld.merged, 1u);
  EXPECT_EQ(r.weld.clusters, 1u);
  EXPECT_TRUE(r.weld.chained.empty());
  expect_defects(r.after.defects, {}, "after");
  // The welded vertex keeps the lowest-index position bit for bit.
  EXPECT_EQ(r.output.vertices.size(), 4u);
  EXPECT_EQ(r.output.vertices[1], b1);

  // A tolerance below the gap merges nothing and leaves the hole.
  o.weld_tolerance = 1e-8;
  RepairResult r2 = run(s, o);
  EXPECT_EQ(r2.weld.merged, 0u);
  expect_defects(r2.after.defects, {{"boundary_loops", 1}}, "after, small T");
}

// T-junction: triangle ABC above edge AB; below it ADM and MDB with M the midpoint of AB.
// Vertex indices A0 B1 C2 M3 D4. Boundary edges AB BC CA AD MA DB BM (DM is shared):
// the walk gives loops A-B-C and A-M-B-D. M lies strictly inside boundary edge AB. ABC
// touches ADM along AM and MDB along MB beyond their shared corner: 2 intersecting pairs.
// A (faces ABC, ADM) and B (ABC, MDB) each join two faces sharing no edge: two fans, so
// both are non-manifold vertices until the split.
// Repair splits ABC into AMC, MBC: one loop B-C-A-D is left, nothing else.
TEST(RepairZoo, TJunctionIsSplit) {
  PolygonSoup s = make_soup({{0, 0, 0}, {2, 0, 0}, {1, 1, 0}, {1, 0, 0}, {1, -1, 0}}, {{0, 1, 2}, {0, 4, 3}, {3, 4, 1}});
  RepairResult r = run(s);
  expect_defects(r.before.defects,
                 {{"t_junctions", 1}, {"boundary_loops", 2}, {"self_intersections", 2}, {"nonmanifold_vertices", 2}},
                 "before");
  EXPECT_EQ(r.before.nonmanifold_vertices, (std::vector<uint32_t>{0, 1}));
  ASSERT_EQ(r.before.t_junctions.size(), 1u);
  EXPECT_EQ(r.before.t_junctions[0], (std::array<uint32_t, 3>{3, 0, 1}));
  EXPECT_EQ(step_change(r, "clean", "t_junctions_split"), 1u);
  EXPECT_EQ(step_change(r, "clean", "triangles_added_by_splits"), 1u);
  expect_defects(r.after.defects, {{"boundary_loops", 1}}, "after");
  EXPECT_EQ(r.after.boundary_loops[0].size(), 4u);
  EXPECT_EQ(r.output.triangles.size(), 4u);
  // Both halves come from input face 0.
  EXPECT_EQ(std::count(r.output_source.begin(), r.output_source.end(), 0u), 2);
}

// A flipped face: BCD reversed. Its three edges are traversed twice in one direction.
TEST(RepairZoo, FlippedFaceIsTurnedBack) {
  PolygonSoup s = tet();
  s.faces[3] = {1, 3, 2};
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"inconsistent_edges", 3}}, "before");
  EXPECT_EQ(step_change(r, "orient", "faces_flipped_for_consistency"), 1u);
  EXPECT_EQ(step_change(r, "orient", "components_turned_outward"), 0u);
  expect_defects(r.after.defects, {}, "after");
  EXPECT_EQ(r.output.triangles[3], (std::array<uint32_t, 3>{1, 2, 3}));
}

// Inside-out tetrahedron: consistent, exact volume negative; all four faces turn.
TEST(RepairZoo, InsideOutClosedComponentTurnsOutward) {
  PolygonSoup s = tet();
  for (auto& f : s.faces) std::swap(f[1], f[2]);
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"inward_components", 1}}, "before");
  EXPECT_EQ(r.before.components[0].volume_sign, -1);
  EXPECT_EQ(step_change(r, "orient", "faces_flipped_outward"), 4u);
  expect_defects(r.after.defects, {}, "after");
  EXPECT_EQ(r.after.components[0].volume_sign, 1);
}

// Möbius strip of 8 quads (16 triangles, 16 vertices): every diagonal and every edge
// between quads is consistent except the seam edge t0-b0, traversed t0 -> b0 by both of
// its faces. One boundary curve of 16 edges. Non-orientable: repair must leave it alone.
TEST(RepairZoo, MobiusStripIsReportedNotForced) {
  const int n = 8;
  std::vector<Vec3d> v;
  for (int i = 0; i < n; ++i) {
    double th = 2 * std::numbers::pi * i / n, ph = th / 2;
    Vec3d radial(std::cos(th), std::sin(th), 0), c = radial * 2.0;
    Vec3d off = (radial * std::cos(ph) + Vec3d(0, 0, 1) * std::sin(ph)) * 0.5;
    v.push_back(c + off);  // t_i = 2i
    v.push_back(c - off);  // b_i = 2i + 1
  }
  auto t = [&](int i) { return i == n ? 1u : uint32_t(2 * i); };      // t_n = b_0
  auto b = [&](int i) { return i == n ? 0u : uint32_t(2 * i + 1); };  // b_n = t_0
  std::vector<std::vector<uint32_t>> f;
  for (int i = 0; i < n; ++i) {
    f.push_back({t(i), b(i), t(i + 1)});
    f.push_back({b(i), b(i + 1), t(i + 1)});
  }
  PolygonSoup s = make_soup(v, f);
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"inconsistent_edges", 1}, {"nonorientable_components", 1}, {"boundary_loops", 1}},
                 "before");
  EXPECT_EQ(r.before.boundary_loops[0].size(), 16u);
  EXPECT_EQ(r.before.components[0].genus, -1);
  EXPECT_EQ(step_change(r, "orient", "faces_flipped_for_consistency"), 0u);
  EXPECT_EQ(step_change(r, "orient", "nonorientable_patches_left"), 1u);
  expect_defects(r.after.defects, {{"inconsistent_edges", 1}, {"nonorientable_components", 1}, {"boundary_loops", 1}},
                 "after");
  for (size_t i = 0; i < f.size(); ++i)
    EXPECT_EQ(r.output.triangles[i], (std::array<uint32_t, 3>{f[i][0], f[i][1], f[i][2]}));
}

// An edge with three faces: fins (A,B,C1) (B,A,C2) (A,B,C3) around AB in three planes.
// Boundary edges AC1 AC2 AC3 BC1 BC2 BC3; A and B have odd boundary degree, so the walk
// gives the loop A-C1-B-C2 and the chain A-C3-B. Ends of the non-manifold edge are not
// counted again as non-manifold vertices. --split-nonmanifold gives each fin its own A
// and B (4 copies): three separate triangles, three loops.
TEST(RepairZoo, EdgeWithThreeFaces) {
  PolygonSoup s = make_soup({{0, 0, 0}, {0, 0, 1}, {1, 0, 0}, {0, 1, 0}, {-1, -1, 0}}, {{0, 1, 2}, {1, 0, 3}, {0, 1, 4}});
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"nonmanifold_edges", 1}, {"boundary_loops", 2}}, "before");
  EXPECT_EQ(r.before.nonmanifold_edges[0], (std::array<uint32_t, 2>{0, 1}));
  expect_defects(r.after.defects, {{"nonmanifold_edges", 1}, {"boundary_loops", 2}}, "after");
  RepairOptions o;
  o.split_nonmanifold = true;
  RepairResult rs = run(s, o);
  EXPECT_EQ(step_change(rs, "split_nonmanifold", "vertex_copies_added"), 4u);
  expect_defects(rs.after.defects, {{"boundary_loops", 3}}, "after split");
  EXPECT_EQ(rs.after.components.size(), 3u);
  EXPECT_EQ(rs.output.vertices.size(), 9u);
  // Copies sit exactly on their originals.
  for (size_t i = 0; i < rs.output.vertices.size(); ++i)
    EXPECT_EQ(rs.output.vertices[i], rs.output.vertices[rs.output_vertex_class[i]]);
}

// A bowtie vertex: two closed tetrahedra touching at A (the second is the first mirrored
// through A, faces reversed to stay outward). Coplanar faces at A lie in opposite
// quadrants: no intersection. Splitting A makes it clean.
TEST(RepairZoo, BowtieVertex) {
  std::vector<Vec3d> v = {kA, kB, kC, kD, -kB, -kC, -kD};
  auto f = tet_faces();
  for (const auto& g : tet_faces()) {
    auto m = [](uint32_t x) { return x == 0 ? 0u : x + 3; };
    f.push_back({m(g[0]), m(g[2]), m(g[1])});
  }
  PolygonSoup s = make_soup(v, f);
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"nonmanifold_vertices", 1}}, "before");
  EXPECT_EQ(r.before.nonmanifold_vertices, (std::vector<uint32_t>{0}));
  EXPECT_EQ(r.before.closed_components, 2u);
  expect_defects(r.after.defects, {{"nonmanifold_vertices", 1}}, "after");
  RepairOptions o;
  o.split_nonmanifold = true;
  RepairResult rs = run(s, o);
  EXPECT_EQ(step_change(rs, "split_nonmanifold", "vertex_copies_added"), 1u);
  expect_defects(rs.after.defects, {}, "after split");
  for (const auto& c : rs.after.components) {
    EXPECT_EQ(c.genus, 0);
    EXPECT_EQ(c.volume_sign, 1);
  }
}

// Zero-area and repeated-vertex faces: the tetrahedron plus (A, A', B) with A' an exact
// copy of A (a repeated vertex once A and A' weld) and a collinear sliver E F G away from
// it (F strictly inside EG: its own T-junction; its three edges: its own loop).
TEST(RepairZoo, ZeroAreaAndRepeatedVertexFaces) {
  PolygonSoup s = tet();
  s.vertices.push_back(kA);  // 4: A'
  s.vertices.push_back({5, 5, 5});
  s.vertices.push_back({6, 6, 6});
  s.vertices.push_back({7, 7, 7});
  s.faces.push_back({0, 4, 1});
  s.faces.push_back({5, 6, 7});
  RepairResult r = run(s);
  expect_defects(r.before.defects,
                 {{"near_duplicate_vertices", 1}, {"repeated_vertex_faces", 1}, {"zero_area_faces", 1},
                  {"t_junctions", 1}, {"boundary_loops", 1}},
                 "before");
  EXPECT_EQ(step_change(r, "clean", "repeated_vertex_faces_removed"), 1u);
  EXPECT_EQ(step_change(r, "clean", "zero_area_faces_removed"), 1u);
  expect_defects(r.after.defects, {}, "after");
  EXPECT_EQ(r.faces_in_output, 4u);
  EXPECT_EQ(r.faces_removed, 2u);
  expect_removed(r, {{4, "repeated_vertex"}, {5, "zero_area"}});
}

// Duplicate faces: a copy of BCD (same orientation) and ABC (ACB reversed). Edges AB,
// AC, BC, BD, CD then carry 3 or 4 faces: five non-manifold edges; every vertex is an end
// of one, so no non-manifold vertex is counted.
TEST(RepairZoo, DuplicateFacesBothOrientations) {
  PolygonSoup s = tet();
  s.faces.push_back({2, 3, 1});  // BCD rotated: same orientation
  s.faces.push_back({0, 1, 2});  // ACB reversed
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"duplicate_faces", 1}, {"opposite_duplicate_faces", 1}, {"nonmanifold_edges", 5}},
                 "before");
  expect_defects(r.after.defects, {}, "after");
  expect_removed(r, {{4, "duplicate"}, {5, "opposite_duplicate"}});
}

// An intersecting pair: a vertical triangle pierces a horizontal one. Reported with face
// indices, never "fixed". A control pair folded over a shared edge (coplanar, apexes on
// the same side) intersects too; the same pair unfolded does not.
TEST(RepairZoo, IntersectingPairIsReportedNotFixed) {
  PolygonSoup s = make_soup({{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0.5, 0.5, -1}, {0.5, 0.5, 1}, {3, 3, 0}},
                            {{0, 1, 2}, {3, 4, 5}});
  RepairResult r = run(s);
  expect_defects(r.before.defects, {{"self_intersections", 1}, {"boundary_loops", 2}}, "before");
  expect_defects(r.after.defects, {{"self_intersections", 1}, {"boundary_loops", 2}}, "after");
  EXPECT_EQ(r.after.self_intersections[0], (std::array<uint32_t, 2>{0, 1}));
  EXPECT_EQ(r.output.triangles.size(), 2u);

  // Folded over edge AB: apexes (0,1,0) and (0.5,0.5,0) both above AB, coplanar.
  PolygonSoup fold = make_soup({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, 0.5, 0}}, {{0, 1, 2}, {1, 0, 3}});
  EXPECT_EQ(run(fold).before.defects.self_intersections, 1u);
  PolygonSoup flat = make_soup({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0.5, -0.5, 0}}, {{0, 1, 2}, {1, 0, 3}});
  EXPECT_EQ(run(flat).before.defects.self_intersections, 0u);
  // Sharing one vertex, the second lying along the first's edge (coplanar): intersect.
  PolygonSoup along = make_soup({{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1, 0, 0}, {1, -1, 0}}, {{0, 1, 2}, {0, 4, 3}});
  EXPECT_EQ(run(along).before.defects.self_intersections, 1u);
  // Sharing one vertex, crossing through the other's opposite edge.
  PolygonSoup cross = make_soup({{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1, 1, -1}, {1, 1, 1}}, {{0, 1, 2}, {0, 3, 4}});
  EXPECT_EQ(run(cross).before.defects.self_intersections, 1u);
}

// Holes: a cube missing one triangle (a 3-edge loop) and missing a whole square side
// (a 4-edge loop). --fill-holes N fills loops of at most N edges, oriented with their
// neighbours: the cube closes, outward, genus 0.
TEST(RepairZoo, HolesAreFilledUpToN) {
  PolygonSoup one = cube();
  one.faces.erase(one.faces.begin() + 5);
  RepairResult r = run(one);
  expect_defects(r.before.defects, {{"boundary_loops", 1}}, "before");
  EXPECT_EQ(r.before.boundary_loops[0].size(), 3u);
  EXPECT_EQ(r.before.components[0].genus, 0);  // a disc: chi = 8 - 17 + 11 = 2 - 0 - 1
  expect_defects(r.after.defects, {{"boundary_loops", 1}}, "after, no filling");
  RepairOptions o;
  o.fill_holes = 3;
  RepairResult f = run(one, o);
  EXPECT_EQ(step_change(f, "fill_holes", "loops_filled"), 1u);
  EXPECT_EQ(step_change(f, "fill_holes", "triangles_added"), 1u);
  expect_defects(f.after.defects, {}, "after filling");
  EXPECT_EQ(f.after.components[0].volume_sign, 1);
  EXPECT_EQ(f.output_source.back(), kFilledHole);

  // Remove both triangles of the side holding face 5 (shapes::add_box keeps a side's two
  // triangles adjacent: faces 4 and 5).
  PolygonSoup side = cube();
  side.faces.erase(side.faces.begin() + 4, side.faces.begin() + 6);
  o.fill_holes = 3;
  RepairResult s3 = run(side, o);
  EXPECT_EQ(s3.before.boundary_loops[0].size(), 4u);
  EXPECT_EQ(step_change(s3, "fill_holes", "loops_filled"), 0u);
  expect_defects(s3.after.defects, {{"boundary_loops", 1}}, "after, N=3");
  o.fill_holes = 4;
  RepairResult s4 = run(side, o);
  EXPECT_EQ(step_change(s4, "fill_holes", "triangles_added"), 2u);
  expect_defects(s4.after.defects, {}, "after, N=4");
}

// Far from the origin and with slivers: a tetrahedron scaled to a sliver at 1e7; the
// exact predicates still see it closed, outward and non-degenerate.
TEST(RepairZoo, FarFromOriginSliverTet) {
  Vec3d o(1e7, -3e7, 5e6);
  PolygonSoup s = make_soup({o, o + Vec3d(1, 0, 0), o + Vec3d(0, 1e-3, 0), o + Vec3d(0, 0, 1e-3)}, tet_faces());
  RepairResult r = run(s);
  expect_defects(r.before.defects, {}, "before");
  expect_defects(r.after.defects, {}, "after");
}

// NaN / overflow are rejected by the reader; a bad tolerance by repair_mesh.
TEST(RepairZoo, BadToleranceIsAnError) {
  RepairOptions o;
  o.weld_tolerance = -1;
  EXPECT_FALSE(repair_mesh(tet(), o, kEx).ok());
  o.weld_tolerance = std::nan("");
  EXPECT_FALSE(repair_mesh(tet(), o, kEx).ok());
}

// A T-junction on a long diagonal boundary edge far from the origin: the vertex at an
// exactly representable interior point is found; one ulp off the line it is not.
TEST(RepairZoo, TJunctionOnALongDiagonalEdgeFarAway) {
  const Vec3d a(1e6, 2e6, -3e6), d(3, 6, 9);
  for (int off = 0; off < 2; ++off) {
    Vec3d m = a + d * 0.25;
    if (off) m.z = ulps(m.z, 1);
    // Triangle (a, b, apex) and a fan of triangles elsewhere sharing m on its boundary.
    PolygonSoup s = make_soup({a, a + d, a + Vec3d(0, 0, 10), m, m + Vec3d(1, -1, 0), m + Vec3d(1, 1, -5)},
                              {{0, 1, 2}, {3, 4, 5}});
    RepairResult r = run(s, [] { RepairOptions o; o.check_only = true; return o; }());
    EXPECT_EQ(r.before.defects.t_junctions, off ? 0u : 1u) << "off " << off;
  }
}

TEST(RepairSpeed, UnchangedMeshReusesTheInputAnalysis) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  add_box(s, {1, 1, 1}, {3, 3, 3}, true);
  RepairResult r = run(s);
  EXPECT_EQ(step_change(r, "analyze_output", "reused_input_analysis"), 1u);
  EXPECT_EQ(step_change(r, "analyze_output", "self_intersection_pairs_tested"), 0u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(r.after.cavities, 1u);
  // A changed mesh (the cavity listed outward) is analysed again.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4});
  add_box(t, {1, 1, 1}, {3, 3, 3});
  RepairResult u = run(t);
  EXPECT_EQ(step_change(u, "analyze_output", "reused_input_analysis"), 0u);
  EXPECT_EQ(u.after.self_intersection_pairs_tested, u.before.self_intersection_pairs_tested);
  EXPECT_EQ(u.after.defects.total(), 0u);
}
