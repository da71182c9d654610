// lib/mesh: mesh preparation of paper 000 section 4.2 (weld, degenerate removal,
// neighbours across consistently facing edges, unique edge labels, double-edge flags).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>

#include "lib/mesh/prepare.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"
#include "tests/support/family_scene.h"

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


// The section 4.2 preparation as it was before the linear-time weld and edge grouping:
// comparator sorts of the welded positions and of the edge incidences. Kept as the
// reference the production code must reproduce field for field.
namespace reference {

struct PosKey {
  uint32_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
  bool operator<(const PosKey& o) const { return x != o.x ? x < o.x : y != o.y ? y < o.y : z < o.z; }
};

size_t weld_vertices(const TriangleSoup& in, std::vector<Vec3f>& pos, std::vector<std::array<uint32_t, 3>>& tris) {
  std::vector<int64_t> remap(in.vertices.size(), -1);
  std::vector<uint32_t> first;
  for (const auto& t : in.triangles)
    for (uint32_t old : t)
      if (remap[old] < 0) {
        remap[old] = int64_t(first.size());
        first.push_back(old);
      }
  const size_t used = first.size();
  std::vector<PosKey> key(used);
  for (size_t r = 0; r < used; ++r) {
    const Vec3f& v = in.vertices[first[r]];
    key[r] = PosKey{canonical_bits(v.x), canonical_bits(v.y), canonical_bits(v.z)};
  }
  std::vector<uint32_t> by_pos(used);
  std::iota(by_pos.begin(), by_pos.end(), 0u);
  std::sort(by_pos.begin(), by_pos.end(), [&](uint32_t a, uint32_t b) { return key[a] < key[b] || (key[a] == key[b] && a < b); });
  std::vector<uint32_t> rep(used), id(used);
  for (size_t k = 0; k < used; ++k)
    rep[by_pos[k]] = k > 0 && key[by_pos[k]] == key[by_pos[k - 1]] ? rep[by_pos[k - 1]] : by_pos[k];
  pos.clear();
  for (size_t r = 0; r < used; ++r) {
    if (rep[r] == r) {
      id[r] = uint32_t(pos.size());
      pos.push_back(in.vertices[first[r]]);
    } else {
      id[r] = id[rep[r]];
    }
  }
  tris.resize(in.triangles.size());
  for (size_t t = 0; t < in.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) tris[t][k] = id[size_t(remap[in.triangles[t][k]])];
  return used - pos.size();
}

void compute_neighbors_and_labels(PreparedMesh& m, PrepareCounts& counts) {
  struct Inc {
    uint64_t key;
    uint32_t tri;
    uint8_t k;
    bool forward;
  };
  std::vector<Inc> inc;
  for (uint32_t t = 0; t < m.triangles.size(); ++t) {
    auto& tri = m.triangles[t];
    tri.neighbors = {-1, -1, -1};
    for (uint8_t k = 0; k < 3; ++k) {
      uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
      uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      inc.push_back({key, t, k, a < b});
    }
  }
  std::sort(inc.begin(), inc.end(), [](const Inc& x, const Inc& y) {
    return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.k < y.k);
  });
  m.is_double_edge.clear();
  for (size_t i = 0; i < inc.size();) {
    size_t j = i;
    while (j < inc.size() && inc[j].key == inc[i].key) ++j;
    size_t n = j - i;
    if (n == 2 && inc[i].forward != inc[i + 1].forward) {
      uint32_t label = uint32_t(m.is_double_edge.size());
      m.is_double_edge.push_back(1);
      auto& ta = m.triangles[inc[i].tri];
      auto& tb = m.triangles[inc[i + 1].tri];
      ta.edge_labels[inc[i].k] = label;
      tb.edge_labels[inc[i + 1].k] = label;
      ta.neighbors[inc[i].k] = int32_t(inc[i + 1].tri);
      tb.neighbors[inc[i + 1].k] = int32_t(inc[i].tri);
      ++counts.double_edges;
    } else {
      if (n == 2) ++counts.inconsistent_joins;
      if (n >= 3) ++counts.nonmanifold_edges;
      for (size_t q = i; q < j; ++q) {
        m.triangles[inc[q].tri].edge_labels[inc[q].k] = uint32_t(m.is_double_edge.size());
        m.is_double_edge.push_back(0);
        ++counts.single_edges;
      }
    }
    i = j;
  }
}

PreparedMesh prepare_mesh(const TriangleSoup& soup, PrepareCounts* counts_out) {
  PrepareCounts counts;
  counts.input_vertices = soup.vertices.size();
  counts.input_triangles = soup.triangles.size();
  PreparedMesh m;
  std::vector<std::array<uint32_t, 3>> tris;
  counts.welded_vertices = reference::weld_vertices(soup, m.vertex_pos, tris);
  std::vector<uint32_t> source(tris.size());
  for (uint32_t t = 0; t < source.size(); ++t) source[t] = t;
  counts.degenerate_removed = mesh::remove_degenerate(tris, source);
  m.triangles.resize(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    m.triangles[t].v = tris[t];
    m.triangles[t].source = source[t];
  }
  reference::compute_neighbors_and_labels(m, counts);
  if (counts_out) *counts_out = counts;
  return m;
}

}  // namespace reference

uint32_t float_bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

// Field for field, positions bit for bit (a welded -0 stays -0).
void expect_same(const PreparedMesh& a, const PrepareCounts& ca, const PreparedMesh& b, const PrepareCounts& cb,
                 const std::string& what) {
  SCOPED_TRACE(what);
  ASSERT_EQ(a.vertex_pos.size(), b.vertex_pos.size());
  for (size_t i = 0; i < a.vertex_pos.size(); ++i) {
    ASSERT_EQ(float_bits(a.vertex_pos[i].x), float_bits(b.vertex_pos[i].x)) << "vertex " << i;
    ASSERT_EQ(float_bits(a.vertex_pos[i].y), float_bits(b.vertex_pos[i].y)) << "vertex " << i;
    ASSERT_EQ(float_bits(a.vertex_pos[i].z), float_bits(b.vertex_pos[i].z)) << "vertex " << i;
  }
  ASSERT_EQ(a.triangles.size(), b.triangles.size());
  for (size_t t = 0; t < a.triangles.size(); ++t) {
    ASSERT_EQ(a.triangles[t].v, b.triangles[t].v) << "triangle " << t;
    ASSERT_EQ(a.triangles[t].source, b.triangles[t].source) << "triangle " << t;
    ASSERT_EQ(a.triangles[t].neighbors, b.triangles[t].neighbors) << "triangle " << t;
    ASSERT_EQ(a.triangles[t].edge_labels, b.triangles[t].edge_labels) << "triangle " << t;
  }
  ASSERT_EQ(a.is_double_edge, b.is_double_edge);
  EXPECT_EQ(ca.input_vertices, cb.input_vertices);
  EXPECT_EQ(ca.welded_vertices, cb.welded_vertices);
  EXPECT_EQ(ca.input_triangles, cb.input_triangles);
  EXPECT_EQ(ca.degenerate_removed, cb.degenerate_removed);
  EXPECT_EQ(ca.double_edges, cb.double_edges);
  EXPECT_EQ(ca.single_edges, cb.single_edges);
  EXPECT_EQ(ca.inconsistent_joins, cb.inconsistent_joins);
  EXPECT_EQ(ca.nonmanifold_edges, cb.nonmanifold_edges);
}

void expect_as_reference(const TriangleSoup& s, const std::string& what) {
  PrepareCounts c, rc;
  PreparedMesh m = prepare_mesh(s, &c);
  PreparedMesh r = reference::prepare_mesh(s, &rc);
  expect_same(m, c, r, rc, what);
}

// A soup whose coordinates come from a small pool (so positions repeat at different
// indices): -0 and +0, subnormals, the largest float, neighbours in ulps; triangles over
// a small vertex set (repeated and opposite-facing triangles, non-manifold edges,
// degenerate triangles by index and by welded position) and unused vertices.
TriangleSoup odd_soup(uint64_t seed, size_t vertices, size_t triangles, size_t pool) {
  const float values[] = {0.0f, -0.0f, 1.0f, -1.0f, std::nextafter(1.0f, 2.0f), std::numeric_limits<float>::denorm_min(),
                          -std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::min(),
                          std::numeric_limits<float>::max(), -std::numeric_limits<float>::max(), 0.1f, 1e6f, 0x1p-30f,
                          3.0f, -2.5f, 1e-38f};
  const size_t nvalues = std::min(pool, std::size(values));
  Rng rng(seed);
  TriangleSoup s;
  for (size_t i = 0; i < vertices; ++i)
    s.vertices.push_back(Vec3f(values[rng.below(nvalues)], values[rng.below(nvalues)], values[rng.below(nvalues)]));
  for (size_t t = 0; t < triangles && vertices > 0; ++t) {
    std::array<uint32_t, 3> tri;
    for (auto& k : tri) k = uint32_t(rng.below(vertices));
    if (rng.below(4) == 0 && t > 0) {  // the same edge again, either way round
      const auto& o = s.triangles[rng.below(t)];
      const int k = int(rng.below(3));
      const bool flip = rng.below(2);
      tri = {o[flip ? (k + 1) % 3 : k], o[flip ? k : (k + 1) % 3], tri[2]};
    }
    s.triangles.push_back(tri);
  }
  return s;
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

// The linear-time weld (hash of positions) and edge grouping (buckets by smaller
// vertex) give exactly the reference's numbering, labels, neighbours and counts.
TEST(Prepare, EqualsTheSortingReferenceOnOddSoups) {
  const size_t shapes[][3] = {{0, 0, 16}, {3, 1, 16}, {5, 8, 2}, {8, 40, 3}, {12, 200, 4}, {40, 60, 16},
                              {300, 500, 16}, {2000, 3000, 6}, {3000, 1000, 16}, {6, 600, 16}};
  for (uint64_t seed = 1; seed <= 12; ++seed)
    for (const auto& sh : shapes)
      expect_as_reference(odd_soup(seed, sh[0], sh[1], sh[2]), "odd soup seed " + std::to_string(seed) + " vertices " +
                                                                  std::to_string(sh[0]) + " triangles " + std::to_string(sh[1]));
}

TEST(Prepare, EqualsTheSortingReferenceOnTheFamilies) {
  struct F {
    const char* name;
    long tris;
  };
  for (const F& f : {F{"scan", 20000}, F{"rooms", -1}, F{"foliage", -1}, F{"torus", -1}, F{"shared-edge-fan", -1}}) {
    Scene s = test_support::family(f.name, 1, f.tris);
    ASSERT_FALSE(s.mesh.triangles.empty()) << f.name;
    expect_as_reference(s.mesh, f.name);
    expect_as_reference(explode_and_shuffle(s.mesh, 7), std::string(f.name) + " exploded");
  }
}

// The parts on their own: the weld, and the labels on triangles that still hold
// repeated vertices (degenerate edges are keys of their own).
TEST(Prepare, PartsEqualTheReference) {
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    TriangleSoup s = odd_soup(seed, 50, 300, 16);
    std::vector<Vec3f> pos, rpos;
    std::vector<std::array<uint32_t, 3>> tris, rtris;
    EXPECT_EQ(weld_vertices(s, pos, tris), reference::weld_vertices(s, rpos, rtris));
    EXPECT_EQ(tris, rtris);
    ASSERT_EQ(pos.size(), rpos.size());
    for (size_t i = 0; i < pos.size(); ++i) EXPECT_EQ(float_bits(pos[i].x), float_bits(rpos[i].x));
    PreparedMesh m, r;
    m.vertex_pos = pos;
    for (size_t t = 0; t < s.triangles.size(); ++t) {
      PreparedTriangle pt;
      pt.v = s.triangles[t];  // unwelded, some with repeated indices
      pt.source = uint32_t(t);
      m.triangles.push_back(pt);
    }
    r = m;
    PrepareCounts c, rc;
    compute_neighbors_and_labels(m, c);
    reference::compute_neighbors_and_labels(r, rc);
    expect_same(m, c, r, rc, "labels seed " + std::to_string(seed));
  }
}
