// lib/mesh repair (issue 9, DESIGN section 7): a zoo of broken meshes built here, each with
// its hand-derived expected report; writer round trips that lose nothing; SHA-256 against
// the FIPS 180-4 vectors; and the `visgate repair` CLI on malformed input (exit 2, no
// output file), on a clean and a repaired mesh, and on the refusal to overwrite its input.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <numeric>
#include <cstring>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <numbers>
#include <sstream>

#include "lib/mesh/mesh_write.h"
#include "lib/mesh/repair.h"
#include "lib/mesh/repair_input.h"
#include "lib/mesh/repair_report.h"
#include "lib/mesh/repair_predicates.h"
#include "lib/mesh/sha256.h"
#include "lib/scene/mesh_io.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"
#include "oracle/exact_predicates.h"

using namespace visgate;
using namespace visgate::mesh;

namespace {

const oracle::CgalExactPredicates kEx;

PolygonSoup make_soup(std::vector<Vec3d> v, std::vector<std::vector<uint32_t>> f) {
  PolygonSoup s;
  s.vertices = std::move(v);
  s.faces = std::move(f);
  return s;
}

RepairResult run(const PolygonSoup& s, RepairOptions o = {}) {
  auto r = repair_mesh(s, o, kEx);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return std::move(*r);
}

// Expected defect counts: every field not named is zero.
void expect_defects(const DefectCounts& got, const std::vector<std::pair<std::string, size_t>>& nonzero,
                    const char* when) {
  for (const auto& [name, n] : got.items()) {
    size_t want = 0;
    for (const auto& [k, v] : nonzero)
      if (k == name) want = v;
    EXPECT_EQ(n, want) << when << ": " << name;
  }
}

size_t step_change(const RepairResult& r, const std::string& step, const std::string& key) {
  for (const auto& s : r.steps)
    if (s.name == step)
      for (const auto& [k, v] : s.changes)
        if (k == key) return v;
  ADD_FAILURE() << "no step " << step << " / " << key;
  return 0;
}

// A double `k` ulps from x.
double ulps(double x, int k) {
  for (; k > 0; --k) x = std::nextafter(x, INFINITY);
  for (; k < 0; ++k) x = std::nextafter(x, -INFINITY);
  return x;
}

// Tetrahedron A(0,0,0) B(1,0,0) C(0,1,0) D(0,0,1) with outward faces (normals -z, -y, -x
// and (1,1,1)).
const Vec3d kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0), kD(0, 0, 1);
std::vector<std::vector<uint32_t>> tet_faces() { return {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}; }
PolygonSoup tet() { return make_soup({kA, kB, kC, kD}, tet_faces()); }

// Unit cube, outward, as shapes::add_box builds it (8 corners, 12 triangles).
PolygonSoup cube() {
  TriangleSoup t;
  shapes::add_box(t, Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  PolygonSoup s;
  for (const auto& v : t.vertices) s.vertices.push_back(Vec3d(v));
  for (const auto& f : t.triangles) s.faces.push_back({f[0], f[1], f[2]});
  return s;
}

}  // namespace

// ------------------------------------------------------------------------------------
// Reference: the intact meshes are clean.

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

// ------------------------------------------------------------------------------------
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

// The weld decides |p - q| <= T exactly: a pair at exactly T merges, the next double
// above does not.
TEST(RepairWeld, ToleranceBoundaryIsExact) {
  std::vector<Vec3d> p = {{0, 0, 0}, {0.375, 0, 0}};
  std::vector<uint8_t> used(2, 1);
  EXPECT_EQ(weld_vertices_exact(p, used, 0.375, WeldMode::Chain, kEx).merged, 1u);
  EXPECT_EQ(weld_vertices_exact(p, used, std::nextafter(0.375, 0.0), WeldMode::Chain, kEx).merged, 0u);
  // 3-4-5 triangle far from the origin: distance exactly 5e-3 * 2^-? is not a double, so
  // use a dyadic one: (3, 4) * 2^-10 has length 5 * 2^-10 exactly.
  std::vector<Vec3d> q = {{1e6, -1e6, 7}, {1e6 + 3 * 0x1p-10, -1e6 + 4 * 0x1p-10, 7}};
  EXPECT_EQ(weld_vertices_exact(q, used, 5 * 0x1p-10, WeldMode::Chain, kEx).merged, 1u);
  EXPECT_EQ(weld_vertices_exact(q, used, std::nextafter(5 * 0x1p-10, 0.0), WeldMode::Chain, kEx).merged, 0u);
  // Exact mode: -0 equals +0.
  std::vector<Vec3d> z = {{0.0, 1, 2}, {-0.0, 1, 2}};
  EXPECT_EQ(weld_vertices_exact(z, used, 0.0, WeldMode::Chain, kEx).merged, 1u);
}

// The spatial hash misses no pair: clusters equal those of union-find over all pairs
// decided exactly, on points where many pairs sit exactly at distance T (a dyadic grid
// of step T on two axes, so neighbours are T apart when T is dyadic), others a few ulps
// beyond it, far from the origin and across cell boundaries.
TEST(RepairWeld, MatchesAllPairsBruteForce) {
  Rng rng(21);
  for (double T : {0.25, 0x1p-20, 3e-7}) {
    std::vector<Vec3d> p;
    const Vec3d o(1e5, -2e5, 7);
    for (int i = 0; i < 700; ++i) {
      Vec3d q = o + Vec3d(double(rng.below(12)) * T, double(rng.below(12)) * T, double(rng.below(3)) * 3 * T);
      if (rng.below(3) == 0) q.x = ulps(q.x, int(rng.below(5)) - 2);
      p.push_back(q);
    }
    std::vector<uint8_t> used(p.size(), 1);
    WeldResult w = weld_vertices_exact(p, used, T, WeldMode::Chain, kEx);
    // Brute force: union-find with the lowest index as root.
    std::vector<uint32_t> root(p.size());
    std::iota(root.begin(), root.end(), 0u);
    std::function<uint32_t(uint32_t)> find = [&](uint32_t x) { return root[x] == x ? x : root[x] = find(root[x]); };
    size_t exact_t = 0;
    for (uint32_t i = 0; i < p.size(); ++i)
      for (uint32_t j = i + 1; j < p.size(); ++j) {
        const int c = kEx.compare_distance(p[i], p[j], T);
        exact_t += c == 0;
        if (c <= 0) {
          uint32_t a = find(i), b = find(j);
          if (a != b) root[std::max(a, b)] = std::min(a, b);
        }
      }
    std::vector<uint32_t> want(p.size());
    for (uint32_t i = 0; i < p.size(); ++i) want[i] = find(i);
    if (T != 3e-7) {
      EXPECT_GT(exact_t, 100u) << "T " << T;  // dyadic T: the boundary case is exercised
    }
    EXPECT_EQ(w.rep, want) << "T " << T;
  }
}

// Chaining: v0, v1, v2 on a line 0.6 T apart. Chain mode merges all three (diameter
// 1.2 T, reported); strict mode refuses, merging {v0, v1} and keeping v2.
TEST(RepairWeld, ChainingIsReportedAndStrictModeRefusesIt) {
  const double T = 1.0;
  std::vector<Vec3d> p = {{0, 0, 0}, {0.625, 0, 0}, {1.25, 0, 0}, {10, 0, 0}};
  std::vector<uint8_t> used(4, 1);
  WeldResult c = weld_vertices_exact(p, used, T, WeldMode::Chain, kEx);
  EXPECT_EQ(c.merged, 2u);
  EXPECT_EQ(c.clusters, 1u);
  ASSERT_EQ(c.chained.size(), 1u);
  EXPECT_EQ(c.chained[0].vertices, (std::vector<uint32_t>{0, 1, 2}));
  EXPECT_DOUBLE_EQ(c.chained[0].diameter, 1.25);
  EXPECT_EQ(c.rep, (std::vector<uint32_t>{0, 0, 0, 3}));
  WeldResult s = weld_vertices_exact(p, used, T, WeldMode::Strict, kEx);
  EXPECT_EQ(s.merged, 1u);
  EXPECT_EQ(s.strict_splits, 1u);
  EXPECT_EQ(s.rep, (std::vector<uint32_t>{0, 0, 2, 3}));

  // Through repair_mesh: three triangles hanging off w0 = 0, w1 = 0.9, w2 = -0.5 (on x).
  // Chain: w2-w0-w1 is one cluster of diameter 1.4 > T. Strict: w2 is 1.4 from w1, so
  // it keeps its own vertex, still 0.5 (<= T) from the merged w0: one near-duplicate
  // vertex remains and is reported.
  PolygonSoup soup = make_soup({{0, 0, 0}, {0.9, 0, 0}, {-0.5, 0, 0}, {0, 5, 0}, {0, 0, 5}, {0, -5, 0}, {0, 0, -5}, {5, 5, 5}, {5, -5, 5}},
                               {{0, 3, 4}, {1, 5, 6}, {2, 7, 8}});
  RepairOptions o;
  o.weld_tolerance = T;
  o.weld_mode = WeldMode::Strict;
  RepairResult r = run(soup, o);
  EXPECT_EQ(r.before.defects.near_duplicate_vertices, 2u);
  EXPECT_EQ(r.after.defects.near_duplicate_vertices, 1u);
}

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
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
  ASSERT_EQ(r.removed.size(), 2u);
  EXPECT_EQ(r.removed[0].face, 4u);
  EXPECT_STREQ(r.removed[0].reason, "repeated_vertex");
  EXPECT_EQ(r.removed[1].face, 5u);
  EXPECT_STREQ(r.removed[1].reason, "zero_area");
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
  ASSERT_EQ(r.removed.size(), 2u);
  EXPECT_EQ(r.removed[0].face, 4u);
  EXPECT_STREQ(r.removed[0].reason, "duplicate");
  EXPECT_EQ(r.removed[1].face, 5u);
  EXPECT_STREQ(r.removed[1].reason, "opposite_duplicate");
}

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
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

// ------------------------------------------------------------------------------------
// The double-precision filters in front of the exact predicates (repair_predicates.h):
// whenever a filter answers, its sign is CGAL's exact sign. The inputs are built to be
// nearly degenerate, so that the plain double evaluation gets the sign wrong in some of
// them (counted and required: the filter must then abstain), and exactly degenerate, so
// that the filter must abstain.

namespace {

// Random point at scale 2^e around `centre`.
Vec3d random_point(Rng& rng, const Vec3d& centre, int e) {
  const double s = std::ldexp(1.0, e);
  return centre + Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * s;
}

// det[b - a, c - a, d - a] in plain double, as a naive caller would compute it.
double naive_orient(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  return dot(cross(b - a, c - a), d - a);
}

}  // namespace

TEST(RepairPredicates, Orient3dFilterIsExactWhenItAnswers) {
  Rng rng(11);
  size_t answered = 0, abstained = 0, naive_wrong = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d centre = it % 3 == 0 ? Vec3d(0, 0, 0) : random_point(rng, Vec3d(0, 0, 0), int(rng.below(40)) - 10);
    const int e = int(rng.below(30)) - 15;
    const Vec3d a = random_point(rng, centre, e), b = random_point(rng, centre, e), c = random_point(rng, centre, e);
    // d on the plane up to rounding, then moved a few ulps on one axis.
    const double s = rng.uniform(-2, 2), t = rng.uniform(-2, 2);
    Vec3d d = a + (b - a) * s + (c - a) * t;
    const int ax = int(rng.below(3)), k = int(rng.below(7)) - 3;
    d[ax] = ulps(d[ax], k);
    const int exact = kEx.orientation(a, b, c, d);
    const int f = orient3d_filter(a, b, c, d);
    const double naive = naive_orient(a, b, c, d);
    if ((naive > 0 ? 1 : naive < 0 ? -1 : 0) != exact) ++naive_wrong;
    if (f == kUnknown) {
      ++abstained;
      continue;
    }
    ++answered;
    ASSERT_EQ(f, exact) << "iteration " << it;
  }
  EXPECT_GT(naive_wrong, 100u);  // the inputs do defeat plain double evaluation
  EXPECT_GT(answered, 1000u);    // and the filter still decides many of them
  EXPECT_GT(abstained, 100u);
  // Exactly degenerate: coplanar (d = a, d on an edge's line through dyadic steps).
  const Vec3d a(1e7, -3, 0.5), b(1e7 + 1, -3, 0.5), c(1e7, -2, 0.75);
  EXPECT_EQ(orient3d_filter(a, b, c, a), kUnknown);
  EXPECT_EQ(orient3d_filter(a, b, c, a + (b - a) * 0.5 + (c - a) * 0.25), kUnknown);
  // Zero by structure: four points sharing a coordinate exactly (a floor z = 0.3 far from
  // the origin) are certified coplanar; with d one ulp off the floor the filter does not
  // say coplanar, and the filtered predicate gives the exact sign.
  const Vec3d f0(1e6, 2e6, 0.3), f1(1e6 + 3, 2e6 - 1, 0.3), f2(1e6 - 2, 2e6 + 5, 0.3), f3(1e6 + 0.1, 2e6 + 0.7, 0.3);
  EXPECT_EQ(orient3d_filter(f0, f1, f2, f3), 0);
  EXPECT_EQ(kEx.orientation(f0, f1, f2, f3), 0);
  const Vec3d f4(f3.x, f3.y, ulps(0.3, 1));
  EXPECT_NE(orient3d_filter(f0, f1, f2, f4), 0);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(f0, f1, f2, f4), kEx.orientation(f0, f1, f2, f4));
  EXPECT_NE(kEx.orientation(f0, f1, f2, f4), 0);
  // Far from degenerate: answered.
  EXPECT_EQ(orient3d_filter(kA, kB, kC, kD), 1);
  EXPECT_EQ(orient3d_filter(kA, kC, kB, kD), -1);
  // Magnitudes where products would overflow or underflow: the filter abstains and the
  // exact predicate decides.
  EXPECT_EQ(orient3d_filter(kA * 0x1p400, kB * 0x1p400, kC * 0x1p400, kD * 0x1p400), kUnknown);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(kA * 0x1p400, kB * 0x1p400, kC * 0x1p400, kD * 0x1p400), 1);
  EXPECT_EQ(orient3d_filter(kA * 0x1p-300, kB * 0x1p-300, kC * 0x1p-300, kD * 0x1p-300), kUnknown);
  EXPECT_EQ(FilteredPredicates(kEx).orientation(kA * 0x1p-300, kB * 0x1p-300, kC * 0x1p-300, kD * 0x1p-300), 1);
}

TEST(RepairPredicates, CollinearAndLineBoxFiltersAreConservative) {
  Rng rng(12);
  const FilteredPredicates fp(kEx);
  size_t off_line_certified = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d centre = random_point(rng, Vec3d(0, 0, 0), int(rng.below(40)) - 10);
    const int e = int(rng.below(30)) - 15;
    const Vec3d a = random_point(rng, centre, e), b = random_point(rng, centre, e);
    // p on the line up to rounding, moved by up to 2 ulps.
    Vec3d p = a + (b - a) * rng.uniform(-0.5, 1.5);
    const int ax = int(rng.below(3));
    p[ax] = ulps(p[ax], int(rng.below(5)) - 2);
    const bool exact = kEx.collinear(a, b, p);
    ASSERT_EQ(fp.collinear(a, b, p), exact) << "iteration " << it;
    // A point box: the line may meet it iff p is collinear, and the filter must never
    // say "misses" for a collinear p.
    const bool may = line_may_meet_box(a, b, p, p);
    if (exact) {
      ASSERT_TRUE(may) << "iteration " << it;
    } else if (!may) {
      ++off_line_certified;
    }
    // A box around p that contains a point exactly on the line (a itself or b) must
    // never be pruned.
    ASSERT_TRUE(line_may_meet_box(a, b, vmin(p, a), vmax(p, a)));
  }
  EXPECT_GT(off_line_certified, 1000u);
  // Dyadic points exactly on the segment (1, 1, 1) + k/8 (3, -2, 5) far from the origin.
  const Vec3d a(1e6 + 1, 1e6 + 1, -1e6 + 1), d(3, -2, 5);
  for (int k = 0; k <= 8; ++k) {
    const Vec3d p = a + d * (k / 8.0);
    EXPECT_TRUE(line_may_meet_box(a, a + d, p, p));
    EXPECT_TRUE(fp.collinear(a, a + d, p));
    Vec3d q = p;
    q.y = ulps(q.y, 1);
    EXPECT_FALSE(fp.collinear(a, a + d, q));
  }
}

TEST(RepairPredicates, TriangleAndSegmentTestsMatchCgal) {
  // Coordinates on a small integer grid make coplanar, touching and collinear pairs
  // common; every answer is compared with CGAL's do_intersect.
  Rng rng(13);
  const FilteredPredicates fp(kEx);
  size_t hits = 0, seg_hits = 0;
  auto grid_point = [&](double scale, const Vec3d& off) {
    return off + Vec3d(double(rng.below(4)), double(rng.below(4)), double(rng.below(4))) * scale;
  };
  for (int it = 0; it < 30000; ++it) {
    const double scale = it % 2 ? 1.0 : 0x1p-20;
    const Vec3d off = it % 3 ? Vec3d(0, 0, 0) : Vec3d(1e6, -1e6, 3e5);
    Vec3d t[6];
    for (auto& p : t) p = grid_point(scale, off);
    if (kEx.collinear(t[0], t[1], t[2]) || kEx.collinear(t[3], t[4], t[5])) continue;
    const bool want = kEx.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]);
    ASSERT_EQ(fp.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]), want) << "iteration " << it;
    hits += want;
    if (t[3] != t[4]) {
      const bool ws = kEx.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]);
      ASSERT_EQ(fp.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]), ws) << "iteration " << it;
      seg_hits += ws;
    }
  }
  EXPECT_GT(hits, 1000u);
  EXPECT_GT(seg_hits, 1000u);
  // All six points in one tilted plane z = x + 2y (exact on the grid), far from the
  // origin: every pair goes through the coplanar 2D tests; coplanar_side too.
  size_t coplanar_hits = 0;
  for (int it = 0; it < 20000; ++it) {
    const Vec3d off = it % 2 ? Vec3d(0, 0, 0) : Vec3d(4096, -8192, 4096 - 16384);
    Vec3d t[6];
    for (auto& p : t) {
      const double x = double(rng.below(5)), y = double(rng.below(5));
      p = off + Vec3d(x, y, x + 2 * y);
    }
    if (kEx.collinear(t[0], t[1], t[2]) || kEx.collinear(t[3], t[4], t[5])) continue;
    const bool want = kEx.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]);
    ASSERT_EQ(fp.triangles_intersect(t[0], t[1], t[2], t[3], t[4], t[5]), want) << "coplanar iteration " << it;
    coplanar_hits += want;
    if (t[3] != t[4]) {
      ASSERT_EQ(fp.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]),
                kEx.segment_triangle_intersect(t[3], t[4], t[0], t[1], t[2]))
          << "coplanar iteration " << it;
    }
    ASSERT_EQ(fp.coplanar_side(t[0], t[1], t[2], t[3]), kEx.coplanar_side(t[0], t[1], t[2], t[3]))
        << "coplanar iteration " << it;
  }
  EXPECT_GT(coplanar_hits, 1000u);
}

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

// ------------------------------------------------------------------------------------
// Round trips: write each format, read back with the importer, compare bit for bit.

namespace {
std::filesystem::path temp_dir() {
  auto d = std::filesystem::temp_directory_path() / ("visgate_repair_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

IndexedMesh random_float_mesh(uint64_t seed) {
  IndexedMesh m;
  Rng rng(seed);
  for (int i = 0; i < 200; ++i) {
    auto coord = [&]() {
      double scale = std::ldexp(1.0, int(rng.below(80)) - 40);
      float f = float((rng.uniform() - 0.5) * scale);
      return double(f);
    };
    m.vertices.push_back({coord(), coord(), coord()});
  }
  m.vertices[0] = {-0.0, double(1e-38f), double(3.4e38f)};  // negative zero, tiny and huge floats
  m.vertices[1] = {double(0x1p-149f), -double(0x1.fffffep+127f), 0.1f};
  for (uint32_t i = 0; i + 2 < 200; ++i) m.triangles.push_back({i, i + 1, i + 2});
  return m;
}

void expect_same_triangles(const IndexedMesh& m, const PolygonSoup& back, bool by_index) {
  ASSERT_EQ(back.faces.size(), m.triangles.size());
  if (by_index) {
    ASSERT_EQ(back.vertices.size(), m.vertices.size());
  }
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    ASSERT_EQ(back.faces[t].size(), 3u);
    for (int k = 0; k < 3; ++k) {
      const Vec3d& want = m.vertices[m.triangles[t][size_t(k)]];
      const Vec3d& got = back.vertices[back.faces[t][size_t(k)]];
      for (int a = 0; a < 3; ++a) {
        uint64_t wb, gb;
        std::memcpy(&wb, &want[a], 8);
        std::memcpy(&gb, &got[a], 8);
        EXPECT_EQ(wb, gb) << "triangle " << t << " corner " << k << " axis " << a;
      }
      if (by_index) {
        EXPECT_EQ(back.faces[t][size_t(k)], m.triangles[t][size_t(k)]);
      }
    }
  }
}
}  // namespace

TEST(RepairRoundTrip, FloatCoordinatesBitExactInEveryFormat) {
  auto dir = temp_dir();
  IndexedMesh m = random_float_mesh(7);
  struct Case { const char* name; MeshFormat f; bool by_index; };
  for (const Case& c : {Case{"m.obj", MeshFormat::Obj, true}, Case{"m.off", MeshFormat::Off, true},
                        Case{"m.ply", MeshFormat::Ply, true}, Case{"m.stl", MeshFormat::StlBinary, false},
                        Case{"a.stl", MeshFormat::StlAscii, false}}) {
    std::string path = (dir / c.name).string();
    ASSERT_TRUE(write_mesh_file(m, c.f, path).ok()) << c.name;
    auto back = read_polygon_file(path);
    ASSERT_TRUE(back.ok()) << c.name << ": " << back.error().message;
    SCOPED_TRACE(c.name);
    expect_same_triangles(m, *back, c.by_index);
  }
  std::filesystem::remove_all(dir);
}

// Double data is written with 17 digits and a "double" PLY property. The importer
// (OpenMesh's PLY reader) hands PLY coordinates over as float, so this test reads the
// text back with strtod itself.
TEST(RepairRoundTrip, DoubleCoordinatesBitExactInPlyText) {
  auto dir = temp_dir();
  IndexedMesh m = random_float_mesh(9);
  Rng rng(3);
  for (auto& v : m.vertices) v = v + Vec3d(rng.uniform() * 1e-9, 0.1, 1.0 / 3.0);  // not floats any more
  m.double_precision = true;
  std::string path = (dir / "d.ply").string();
  ASSERT_TRUE(write_mesh_file(m, MeshFormat::Ply, path).ok());
  std::ifstream in(path);
  std::string line;
  PolygonSoup back;
  bool header = true;
  while (std::getline(in, line)) {
    if (header) {
      if (line == "property double x") back.double_precision = true;
      header = line != "end_header";
      continue;
    }
    std::istringstream ls(line);
    if (back.vertices.size() < m.vertices.size()) {
      std::string a, b, c;
      ls >> a >> b >> c;
      back.vertices.push_back({std::strtod(a.c_str(), nullptr), std::strtod(b.c_str(), nullptr),
                               std::strtod(c.c_str(), nullptr)});
    } else {
      uint32_t n, x, y, z;
      ls >> n >> x >> y >> z;
      EXPECT_EQ(n, 3u);
      back.faces.push_back({x, y, z});
    }
  }
  EXPECT_TRUE(back.double_precision);
  expect_same_triangles(m, back, true);
  // Binary STL cannot hold them: refused, nothing written.
  std::string stl = (dir / "d.stl").string();
  EXPECT_FALSE(write_mesh_file(m, MeshFormat::StlBinary, stl).ok());
  EXPECT_FALSE(std::filesystem::exists(stl));
  std::filesystem::remove_all(dir);
}

// Repair output written and read back, then repaired again: nothing changes (idempotent).
TEST(RepairRoundTrip, RepairedMeshReadsBackAndIsAFixedPoint) {
  auto dir = temp_dir();
  PolygonSoup s = tet();
  for (auto& f : s.faces) std::swap(f[1], f[2]);
  RepairResult r = run(s);
  std::string path = (dir / "t.obj").string();
  ASSERT_TRUE(write_mesh_file(r.output, MeshFormat::Obj, path).ok());
  auto back = read_polygon_file(path);
  ASSERT_TRUE(back.ok());
  RepairResult again = run(*back);
  expect_defects(again.before.defects, {}, "re-read");
  EXPECT_EQ(again.output.triangles, r.output.triangles);
  EXPECT_EQ(again.output.vertices, r.output.vertices);
  std::filesystem::remove_all(dir);
}

// ------------------------------------------------------------------------------------

// ------------------------------------------------------------------------------------
// The input audit: attributes the reader does not keep are counted by name, and double
// coordinates (which the reader rounds to float32) are restored exactly.

namespace {
std::string write_file(const std::string& name, const std::string& bytes) {
  const std::string path = (temp_dir() / name).string();
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  return path;
}

// Reads `bytes` as file `name` and audits it; the audit's counts as a map.
struct Audited {
  PolygonSoup soup;
  InputAudit audit;
  std::map<std::string, size_t> counts;
};
Audited audit_bytes(const std::string& name, const std::string& bytes) {
  Audited a;
  const std::string path = write_file(name, bytes);
  auto soup = read_polygon_file(path);
  EXPECT_TRUE(soup.ok()) << name << ": " << (soup.ok() ? "" : soup.error().message);
  if (!soup.ok()) return a;
  a.soup = std::move(*soup);
  auto r = audit_input(path, bytes, a.soup);
  EXPECT_TRUE(r.ok()) << name << ": " << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return a;
  a.audit = *r;
  for (const auto& [k, v] : r->not_kept) a.counts[k] = v;
  return a;
}

template <class T>
void put_bin(std::string& out, T v, bool big) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  if (big) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

const char* kTetObjFaces = "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
}  // namespace

TEST(RepairInput, AttributesAreCountedNotDropped) {
  {
    // OBJ: 4 normals, 3 texture coordinates, a material, a group, a polyline, corner
    // references on two faces, and a smoothing statement.
    Audited a = audit_bytes("a.obj",
                            "mtllib m.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                            "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
                            "g side\nusemtl red\ns 1\nf 1/1/1 3/3/3 2/2/2\nf 1//1 2//2 4//4\nf 1 4 3\nf 2 3 4\nl 1 2\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"material_libraries", 1}, {"objects", 1}, {"vertex_normals", 4},
                                                        {"texcoords", 3}, {"groups", 1}, {"materials", 1},
                                                        {"smoothing_groups", 1}, {"face_corner_references", 2},
                                                        {"line_elements", 1}}));
    EXPECT_FALSE(a.audit.double_data);
  }
  {
    // PLY: per-vertex normal (nx ny nz: one attribute) and colour, a per-vertex
    // "quality", a face colour, and an extra element.
    Audited a = audit_bytes("a.ply",
                            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                            "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
                            "property uchar blue\nproperty float quality\nelement face 4\nproperty list uchar int vertex_indices\n"
                            "property uchar red\nproperty uchar green\nproperty uchar blue\nelement edge 1\nproperty int vertex1\n"
                            "property int vertex2\nend_header\n"
                            "0 0 0 0 0 1 1 2 3 0.5\n1 0 0 0 0 1 1 2 3 0.5\n0 1 0 0 0 1 1 2 3 0.5\n0 0 1 0 0 1 1 2 3 0.5\n"
                            "3 0 2 1 9 9 9\n3 0 1 3 9 9 9\n3 0 3 2 9 9 9\n3 1 2 3 9 9 9\n0 1\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"vertex_normals", 4}, {"vertex_colors", 4},
                                                        {"ply_property vertex.quality", 4}, {"face_colors", 4},
                                                        {"ply_element edge", 1}}));
  }
  {
    // OFF with vertex colours (COFF) and a face colour on one face line.
    Audited a = audit_bytes("a.off",
                            "COFF\n4 4 0\n0 0 0 255 0 0 255\n1 0 0 255 0 0 255\n0 1 0 255 0 0 255\n0 0 1 255 0 0 255\n"
                            "3 0 2 1\n3 0 1 3 1 1 1\n3 0 3 2\n3 1 2 3\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"vertex_colors", 4}, {"face_colors", 1}}));
  }
  {
    // Binary STL: two facets with normals, one with a non-zero attribute word (colour
    // in some dialects); ASCII STL: facet normals.
    std::string b(80, ' ');
    put_bin<uint32_t>(b, 2, false);
    const float f[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
    for (int t = 0; t < 2; ++t) {
      for (float x : f[t]) put_bin<float>(b, x, false);
      put_bin<uint16_t>(b, uint16_t(t == 0 ? 0x801f : 0), false);
    }
    Audited a = audit_bytes("a.stl", b);
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"face_normals", 1}, {"facet_attribute_words", 1}}));
    Audited t = audit_bytes("t.stl",
                            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
                            "endfacet\nendsolid t\n");
    EXPECT_EQ(t.counts, (std::map<std::string, size_t>{{"face_normals", 1}}));
  }
  std::filesystem::remove_all(temp_dir());
}

TEST(RepairInput, DoubleCoordinatesAreKeptExactly) {
  const Vec3d want[4] = {{0.1, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.0000000000000002}};
  auto expect_exact = [&](const Audited& a, const char* what) {
    ASSERT_EQ(a.soup.vertices.size(), 4u) << what;
    EXPECT_TRUE(a.audit.double_data) << what;
    EXPECT_TRUE(a.soup.double_precision) << what;
    EXPECT_EQ(a.audit.coordinates_restored, 2u) << what;
    for (int i = 0; i < 4; ++i) EXPECT_EQ(a.soup.vertices[size_t(i)], want[i]) << what << " vertex " << i;
  };
  // Text: 1.0000000000000002 has 17 significant digits and is not a float, so the file
  // holds double data, and 0.1 is read as the double 0.1 too.
  expect_exact(audit_bytes("d.obj", std::string("v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.0000000000000002\n") + kTetObjFaces),
               "obj");
  expect_exact(audit_bytes("d.off", "OFF\n4 4 0\n0.1 0 0\n1 0 0\n0 1 0\n# comment\n0 0 1.0000000000000002\n"
                                    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"),
               "off");
  const std::string ply_head = "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
                               "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
  expect_exact(audit_bytes("d.ply", "ply\nformat ascii 1.0\n" + ply_head +
                                        "0.1 0 0\n1 0 0\n0 1 0\n0 0 1.0000000000000002\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"),
               "ply ascii");
  for (bool big : {false, true}) {
    std::string b = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") + " 1.0\n" + ply_head;
    for (const Vec3d& v : want)
      for (int k = 0; k < 3; ++k) put_bin<double>(b, v[k], big);
    const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto& t : f) {
      b.push_back(3);
      for (int k = 0; k < 3; ++k) put_bin<int32_t>(b, t[k], big);
    }
    expect_exact(audit_bytes(big ? "be.ply" : "le.ply", b), big ? "ply big-endian" : "ply little-endian");
  }
  // Float data (at most 9 significant digits) stays float: 0.1 is the float 0.1f.
  Audited fl = audit_bytes("f.obj", std::string("v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.00000012\n") + kTetObjFaces);
  EXPECT_FALSE(fl.audit.double_data);
  EXPECT_EQ(fl.soup.vertices[0].x, double(0.1f));
  // ASCII STL with double data cannot be kept (the reader merges corners by their float
  // positions): refused, naming the file, line and vertex.
  const std::string stl = write_file("d.stl",
                                     "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                     "vertex 0 0.10000000000000001 0\nendloop\nendfacet\nendsolid t\n");
  auto soup = read_polygon_file(stl);
  ASSERT_TRUE(soup.ok());
  auto r = audit_input(stl, "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                            "vertex 0 0.10000000000000001 0\nendloop\nendfacet\nendsolid t\n",
                       *soup);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("d.stl: line 6: vertex 2"), std::string::npos) << r.error().message;
  std::filesystem::remove_all(temp_dir());
}

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

TEST(RepairSha256, Fips180Vectors) {
  EXPECT_EQ(sha256_hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(sha256_hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(sha256_hex(std::string(1000000, 'a')), "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
  // Padding boundaries: 55, 56 and 64 bytes (one or two final blocks).
  EXPECT_EQ(sha256_hex(std::string(55, 'a')), "9f4390f8d30c2dd92ec9f095b65e2b9ae9b0a925a5258e241c9f1e910f734318");
  EXPECT_EQ(sha256_hex(std::string(56, 'a')), "b35439a4ac6f0948b6d6f9e3c6af0f5f590ce20f1bde7090ef7970686ec6738a");
  EXPECT_EQ(sha256_hex(std::string(64, 'a')), "ffe054fe7ae0cb6dc65c3af9b61d5209f439851db43d0ba5997337df154668eb");
}

// ------------------------------------------------------------------------------------
// The CLI, run as a process (VISGATE_BIN is the built binary).

#ifdef VISGATE_BIN
namespace {
int run_cli(const std::string& args, std::string* err = nullptr) {
  std::string cmd = std::string(VISGATE_BIN) + " " + args + " 2>" + (temp_dir() / "stderr.txt").string();
  int rc = std::system(cmd.c_str());
  if (err) {
    std::ifstream in(temp_dir() / "stderr.txt");
    std::stringstream ss;
    ss << in.rdbuf();
    *err = ss.str();
  }
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
void write_text(const std::filesystem::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}
std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
}  // namespace

TEST(RepairCli, MalformedInputExitsTwoAndWritesNothing) {
  auto dir = temp_dir();
  struct Bad { const char* name; std::string text; const char* names; };
  std::vector<Bad> bad = {
      {"idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "face 0"},
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1"},
      {"inf.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", "vertex 1"},
      {"short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "short.off"},
      {"trunc.stl", std::string(80, ' ') + std::string("\x05\x00\x00\x00", 4) + std::string(20, '\0'), "trunc.stl"},
      {"mesh.xyz", "1 2 3\n", "xyz"},
  };
  for (const Bad& b : bad) {
    write_text(dir / b.name, b.text);
    auto out = dir / "out.obj";
    std::string err;
    EXPECT_EQ(run_cli("repair " + (dir / b.name).string() + " -o " + out.string(), &err), 2) << b.name << ": " << err;
    EXPECT_FALSE(std::filesystem::exists(out)) << b.name;
    EXPECT_NE(err.find(b.names), std::string::npos) << b.name << ": " << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << b.name << ": one line: " << err;
  }
  std::string err;
  EXPECT_EQ(run_cli("repair " + (dir / "missing.obj").string() + " -o " + (dir / "o.obj").string(), &err), 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "o.obj"));
  std::filesystem::remove_all(dir);
}

TEST(RepairCli, NeverOverwritesTheInputWithoutInPlace) {
  auto dir = temp_dir();
  auto in = dir / "t.obj";
  std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 3 4\n";  // inside out
  write_text(in, text);
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + in.string()), 2);
  EXPECT_EQ(read_all(in), text);
  EXPECT_EQ(run_cli("repair " + in.string()), 2);  // no -o, no --in-place
  EXPECT_EQ(read_all(in), text);
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + (dir / "x.obj").string() + " --weld-mode=loose"), 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.obj"));
  // --check writes nothing and reports the inward component: exit 1.
  EXPECT_EQ(run_cli("repair --check " + in.string()), 1);
  EXPECT_EQ(read_all(in), text);
  // --in-place repairs it: exit 0, and a re-check is clean.
  EXPECT_EQ(run_cli("repair " + in.string() + " --in-place"), 0);
  EXPECT_NE(read_all(in), text);
  EXPECT_EQ(run_cli("repair --check " + in.string()), 0);
  std::filesystem::remove_all(dir);
}

// Double data through the CLI: every coordinate comes back bit for bit (17 digits), the
// attributes the output cannot hold are in the report and on stderr, and a report path
// that is a folder is refused before anything is written.
TEST(RepairCli, DoubleDataAndAttributesSurviveTheRoundTrip) {
  auto dir = temp_dir();
  auto in = dir / "d.obj";
  write_text(in, "v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.0000000000000002\nvn 0 0 1\nvt 0.5 0.5\n"
                 "f 1/1/1 3/1/1 2/1/1\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  for (const char* ext : {".ply", ".obj", ".off"}) {
    auto out = dir / (std::string("o") + ext);
    auto rep = dir / "r.json";
    std::string err;
    ASSERT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + rep.string(), &err), 0) << err;
    EXPECT_NE(err.find("attributes not kept: vertex_normals=1 texcoords=1 face_corner_references=1"), std::string::npos)
        << err;
    auto j = nlohmann::json::parse(read_all(rep));
    EXPECT_EQ(j["input"]["attributes_not_kept"]["vertex_normals"], 1);
    EXPECT_EQ(j["input"]["attributes_not_kept"]["texcoords"], 1);
    EXPECT_EQ(j["input"]["double_coordinates_restored"], 2);
    EXPECT_EQ(j["output"]["coordinate_digits"], 17);
    EXPECT_EQ(j["faces"]["output_source_runs"], nlohmann::json::parse("[[0, 0, 4, 1]]"));
    // Read the vertex lines back with strtod: the doubles, bit for bit. OBJ: "v" lines;
    // OFF: the 4 lines after "OFF" and the counts; PLY: the 4 lines after end_header.
    std::ifstream f(out);
    std::vector<double> xs;
    const std::string e(ext);
    int skip = e == ".off" ? 2 : -1;
    int left = e == ".obj" ? 1 << 30 : 4;
    for (std::string line; std::getline(f, line) && left > 0;) {
      if (e == ".ply" && skip < 0) {
        if (line == "end_header") skip = 0;
        continue;
      }
      if (skip > 0) {
        --skip;
        continue;
      }
      std::istringstream ls(line);
      if (e == ".obj") {
        std::string kw;
        if (!(ls >> kw) || kw != "v") continue;
      }
      std::string x, y, z;
      ASSERT_TRUE(bool(ls >> x >> y >> z)) << ext << ": " << line;
      for (const std::string* t : {&x, &y, &z}) xs.push_back(std::strtod(t->c_str(), nullptr));
      --left;
    }
    ASSERT_EQ(xs.size(), 12u) << ext;
    EXPECT_EQ(xs[0], 0.1) << ext;
    EXPECT_EQ(xs[11], 1.0000000000000002) << ext;
  }
  // A report path that is a folder: exit 2, no mesh, no temporary file left.
  std::filesystem::create_directories(dir / "rep");
  auto out = dir / "never.obj";
  std::string err;
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + (dir / "rep").string(), &err), 2);
  EXPECT_FALSE(std::filesystem::exists(out));
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".visgate-tmp"), std::string::npos) << e.path();
  // ASCII STL double data cannot be kept: exit 2 naming the vertex, nothing written.
  auto stl = dir / "d.stl";
  write_text(stl, "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0.10000000000000001 0\n"
                  "endloop\nendfacet\nendsolid t\n");
  EXPECT_EQ(run_cli("repair " + stl.string() + " -o " + out.string(), &err), 2);
  EXPECT_NE(err.find("vertex 2"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(out));
  std::filesystem::remove_all(dir);
}

TEST(RepairCli, ReportHasHashesCountsAndExitCodes) {
  auto dir = temp_dir();
  auto in = dir / "m.obj";
  // Tetrahedron with a flipped face plus a separate pierced pair (cannot be fixed).
  write_text(in,
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
             "v 5 0 0\nv 7 0 0\nv 5 2 0\nv 5.5 0.5 -1\nv 5.5 0.5 1\nv 8 3 0\n"
             "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n"
             "f 5 6 7\nf 8 9 10\n");
  auto out = dir / "r.ply";
  auto rep = dir / "r.json";
  std::string err;
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + rep.string(), &err), 1) << err;
  EXPECT_NE(err.find("self_intersections"), std::string::npos) << err;
  ASSERT_TRUE(std::filesystem::exists(out));
  auto j = nlohmann::json::parse(read_all(rep));
  EXPECT_EQ(j["format"], "visgate-repair-report");
  EXPECT_EQ(j["exit_code"], 1);
  EXPECT_EQ(j["input"]["sha256"], sha256_hex(read_all(in)));
  EXPECT_EQ(j["output"]["sha256"], sha256_hex(read_all(out)));
  // Independent check of the hash where the system has sha256sum.
  std::string cmd = "sha256sum " + in.string() + " > " + (dir / "sum.txt").string() + " 2>/dev/null";
  if (std::system(cmd.c_str()) == 0) {
    EXPECT_EQ(read_all(dir / "sum.txt").substr(0, 64), j["input"]["sha256"]);
  }
  EXPECT_EQ(j["defects"]["before"]["inconsistent_edges"], 3);
  EXPECT_EQ(j["defects"]["after"]["inconsistent_edges"], 0);
  EXPECT_EQ(j["defects"]["before"]["self_intersections"], 1);
  EXPECT_EQ(j["defects"]["after"]["self_intersections"], 1);
  EXPECT_EQ(j["topology"]["after"]["self_intersections"][0]["input_faces"], nlohmann::json({4, 5}));
  EXPECT_EQ(j["remaining"], nlohmann::json({"boundary_loops", "self_intersections"}));
  EXPECT_EQ(j["faces"]["input"], 6);
  EXPECT_EQ(j["faces"]["in_output"], 6);
  EXPECT_EQ(j["options"]["weld_mode"], "chain");
  bool saw_orient = false;
  for (const auto& s : j["steps"])
    if (s["name"] == "orient") {
      saw_orient = true;
      EXPECT_EQ(s["changes"]["faces_flipped_for_consistency"], 1);
      EXPECT_GE(s["seconds"].get<double>(), 0.0);
    }
  EXPECT_TRUE(saw_orient);
  // The output reads back with every coordinate intact.
  auto back = read_polygon_file(out.string());
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->faces.size(), 6u);
  EXPECT_EQ(back->vertices[7], Vec3d(5.5, 0.5, -1));
  std::filesystem::remove_all(dir);
}
#endif
