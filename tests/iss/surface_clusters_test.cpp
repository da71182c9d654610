// lib/iss/surface_clusters.h: the clusters' boundaries and facing proofs against brute
// force and exact orientation, and the clustered construction (clusters=on) against the
// per-triangle one (clusters=off) and the exact oracle.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <set>

#include "lib/geom/predicates.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/radial_pairing.h"
#include "lib/iss/surface_clusters.h"
#include "lib/iss/triangle_bvh.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

struct Prepared {
  mesh::PreparedMesh m;
  std::vector<AABB> boxes;
  std::unique_ptr<iss::TriangleBvh> bvh;
  std::unique_ptr<iss::SurfaceClusters> clusters;
};

std::unique_ptr<Prepared> prepare(const Scene& s) {
  auto p = std::make_unique<Prepared>();
  p->m = mesh::prepare_mesh(s.mesh);
  iss::pair_nonmanifold_edges(p->m);
  p->boxes.resize(p->m.triangles.size());
  for (size_t t = 0; t < p->m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) p->boxes[t].extend(p->m.corner(t, k));
  p->bvh = std::make_unique<iss::TriangleBvh>(p->boxes);
  p->clusters = std::make_unique<iss::SurfaceClusters>(p->m, *p->bvh);
  return p;
}

// The triangles below node i (leaf order positions of its subtree).
std::vector<uint32_t> triangles_below(const accel::Bvh<float>& bvh, uint32_t i) {
  std::vector<uint32_t> out;
  std::vector<uint32_t> stack{i};
  while (!stack.empty()) {
    uint32_t j = stack.back();
    stack.pop_back();
    const auto& nd = bvh.node(j);
    if (bvh.is_leaf(nd)) {
      for (uint32_t t : bvh.leaf_items(nd)) out.push_back(t);
    } else {
      stack.push_back(bvh.left(j));
      stack.push_back(bvh.right(j));
    }
  }
  std::sort(out.begin(), out.end());
  return out;
}

// An open hemisphere (a boundary loop), a closed box sharing no vertex with it, and a
// fan of three triangles on one edge (non-manifold): several components, open and
// non-manifold edges in one mesh, between a floor of receivers and a light above.
Scene mixed_scene() {
  Scene s;
  s.lights.push_back(square_light(0, 0, 4, 0.4, 16));
  add_receiver_grid(s, -2, 2, -2, 2, 0.01, 12);
  EXPECT_TRUE(finish_scene(s).ok());
  shapes::add_open_sphere(s.mesh, Vec3d(0, 0, 1.6), 0.9, 24, 12, 1.2, false);
  shapes::add_box(s.mesh, Vec3d(1.2, 1.2, 0.6), Vec3d(1.6, 1.5, 1.0));
  auto tri = [&](Vec3f a, Vec3f b, Vec3f c) {
    uint32_t v = uint32_t(s.mesh.vertices.size());
    s.mesh.vertices.insert(s.mesh.vertices.end(), {a, b, c});
    s.mesh.triangles.push_back({v, v + 1, v + 2});
  };
  tri(Vec3f(-1.5f, 0, 1), Vec3f(-1.0f, 0, 1), Vec3f(-1.25f, 0.3f, 1.2f));
  tri(Vec3f(-1.0f, 0, 1), Vec3f(-1.5f, 0, 1), Vec3f(-1.25f, -0.3f, 1.2f));
  tri(Vec3f(-1.5f, 0, 1), Vec3f(-1.0f, 0, 1), Vec3f(-1.25f, 0.0f, 0.7f));
  return s;
}

}  // namespace

TEST(IssClusters, BoundariesAndConesHoldForEveryNode) {
  // Brute force per node: the boundary is exactly the edges of the node's triangles
  // whose double-edge neighbour is outside the node (the cones are checked through
  // their use, below). Closed, open and non-manifold meshes; some nodes eligible.
  std::vector<Scene> scenes;
  scenes.push_back(family("scan", 3, 3000, 96, 16));
  scenes.push_back(family("torus", 2, -1, 96, 16));
  scenes.push_back(family("shared-edge-fan", 5, -1, 96, 16));
  scenes.push_back(mixed_scene());
  for (const Scene& s : scenes) {
    auto p = prepare(s);
    const auto& bvh = p->clusters->tree();
    size_t eligible = 0;
    for (uint32_t i = 0; i < bvh.node_count(); ++i) {
      std::vector<uint32_t> tris = triangles_below(bvh, i);
      std::set<uint32_t> in(tris.begin(), tris.end());
      std::multiset<uint32_t> want, got;
      for (uint32_t t : tris)
        for (int k = 0; k < 3; ++k) {
          const auto& tri = p->m.triangles[t];
          int32_t nb = tri.neighbors[size_t(k)];
          bool interior = nb >= 0 && p->m.is_double_edge[tri.edge_labels[size_t(k)]] && in.count(uint32_t(nb));
          if (!interior) want.insert(t * 4 + uint32_t(k));
        }
      std::vector<uint32_t> be;
      p->clusters->boundary(i, be);
      got.insert(be.begin(), be.end());
      ASSERT_EQ(got, want) << s.name << " node " << i;
      if (!p->clusters->eligible(i)) continue;
      ++eligible;
    }
    EXPECT_GT(eligible, 0u) << s.name;
  }
}

TEST(IssClusters, FacingProofsAgreeWithExactOrientation) {
  // Property: whenever facing_of proves a facing for a node and two boxes, every
  // triangle of the node has the receiver box strictly on the side Table 4.1 reads
  // (all eight corners, exact orient3d), or else the light box on the matching side.
  // Random boxes near and far, scan and torus meshes.
  std::mt19937 rng(5);
  for (const Scene& s : {family("scan", 1, 3000, 96, 16), family("torus", 4, -1, 96, 16)}) {
    auto p = prepare(s);
    const auto& bvh = p->clusters->tree();
    AABB sb = s.bounds();
    Vec3f c = sb.center(), e = sb.extent();
    std::uniform_real_distribution<float> u(-1.5f, 1.5f), w(0.0f, 0.6f);
    size_t proofs = 0;
    auto side = [&](uint32_t t, const AABB& b) {  // +1 all corners above, -1 below, 0 else
      int pos = 0, neg = 0;
      for (int k = 0; k < 8; ++k) {
        Vec3f x(k & 1 ? b.hi.x : b.lo.x, k & 2 ? b.hi.y : b.lo.y, k & 4 ? b.hi.z : b.lo.z);
        Sign sg = orient3d_exact(p->m.corner(t, 0), p->m.corner(t, 1), p->m.corner(t, 2), x);
        pos += sg == Sign::Positive;
        neg += sg == Sign::Negative;
      }
      return pos == 8 ? 1 : (neg == 8 ? -1 : 0);
    };
    for (int q = 0; q < 60; ++q) {
      auto box = [&]() {
        Vec3f lo(c.x + u(rng) * e.x * 1.5f, c.y + u(rng) * e.y * 1.5f, c.z + u(rng) * e.z * 1.5f);
        return AABB(lo, lo + Vec3f(w(rng) * e.x, w(rng) * e.y, w(rng) * e.z));
      };
      AABB rb = box(), lb = box();
      for (uint32_t i = 0; i < bvh.node_count(); ++i) {
        iss::Facing f = p->clusters->facing_of(i, iss::to_double(rb), iss::to_double(lb));
        if (f == iss::Facing::Inconsistent) continue;
        ++proofs;
        for (uint32_t t : triangles_below(bvh, i)) {
          int rs = side(t, rb), ls = side(t, lb);
          bool ok = f == iss::Facing::TowardsReceiver ? (rs == 1 || ls == -1) : (rs == -1 || ls == 1);
          ASSERT_TRUE(ok) << s.name << " node " << i << " triangle " << t;
        }
      }
    }
    EXPECT_GT(proofs, 100u) << s.name;
  }
}

TEST(IssClusters, ClusteredSolveEqualsPerTriangleSolveAndOracle) {
  // The clustered initial shafts (clusters=on, at every size) against the per-triangle
  // construction (clusters=off): the same bits for every relation that touches no
  // triangle, under every option set; and equal to the exact oracle away from
  // degeneracy. Families with closed,
  // open and non-manifold meshes, several components and receivers on the surface.
  const double tau = 1e-5;
  std::vector<Scene> scenes;
  for (const std::string fam : {"scan", "torus", "pouch", "double-surface", "shared-edge-fan", "on-surface",
                                "random-soup", "columns", "rooms"})
    for (uint64_t seed : {1, 2}) scenes.push_back(family(fam, seed, fam == "rooms" || fam == "columns" || fam == "scan" ? 3000 : -1, 128, 16));
  scenes.push_back(mixed_scene());
  for (const Scene& s : scenes) {
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
    for (auto o : kOptionSets) {
      // The clusters' construction alone: the lazy band (which the clusters switch on,
      // with cost_rays) moves relations between shafts and rays, so that near-degenerate
      // ones may differ; lazy_band_test.cpp compares it with the oracle.
      o["lazy_band"] = "off";
      o["clusters"] = "on";
      SolveResult on = run_iss(s, o);
      o["clusters"] = "off";
      SolveResult off = run_iss(s, o);
      const OracleTally t = tally_against_oracle(s, ex, tau, {&on, &off});
      EXPECT_EQ(t.differ_any, 0u) << s.name << " " << describe(o);
      EXPECT_EQ(off.stats.get("cluster_patches"), 0.0);
      if (s.name.rfind("scan", 0) == 0 || s.name.empty()) {
        EXPECT_GT(on.stats.get("cluster_patches"), 0.0) << s.name;
      }
      EXPECT_EQ(t.wrong, 0u) << s.name << " " << describe(o);
    }
  }
}

TEST(IssClusters, ExactFacingIsTriangleFacingBitForBit) {
  // exact_facing (the inline plane and box test by leaf position) against
  // triangle_facing(plane_through(...)) for every triangle and random box pairs: the
  // clustered construction takes a node whole on these facings, so they must be the
  // ones UPDATE-PATCH-FACINGS would compute for the triangles' own patches.
  std::mt19937 rng(11);
  for (const Scene& s : {family("scan", 1, 3000, 96, 16), family("torus", 4, -1, 96, 16), mixed_scene()}) {
    mesh::PreparedMesh m = mesh::prepare_mesh(s.mesh);
    iss::pair_nonmanifold_edges(m);
    std::vector<AABB> boxes(m.triangles.size());
    for (size_t t = 0; t < m.triangles.size(); ++t)
      for (int k = 0; k < 3; ++k) boxes[t].extend(m.corner(t, k));
    iss::TriangleBvh bvh(boxes);
    const double scale = 1.0;
    iss::SurfaceClusters cl(m, bvh);
    const auto order = cl.tree().order();
    AABB sb = s.bounds();
    Vec3f c = sb.center(), e = sb.extent();
    std::uniform_real_distribution<float> u(-1.5f, 1.5f), w(0.0f, 0.6f);
    size_t consistent = 0, inconsistent = 0;
    for (int q = 0; q < 40; ++q) {
      auto box = [&]() {
        Vec3f lo(c.x + u(rng) * e.x * 1.5f, c.y + u(rng) * e.y * 1.5f, c.z + u(rng) * e.z * 1.5f);
        return AABB(lo, lo + Vec3f(w(rng) * e.x, w(rng) * e.y, w(rng) * e.z));
      };
      iss::ShaftGeometry g(box(), box(), iss::MainAxis{}, scale);
      for (uint32_t p = 0; p < order.size(); ++p) {
        const uint32_t t = order[p];
        iss::Facing want = iss::triangle_facing(
            iss::plane_through(iss::corner_d(m, t, 0), iss::corner_d(m, t, 1), iss::corner_d(m, t, 2), scale),
            g);
        ASSERT_EQ(int(cl.exact_facing(p, g)), int(want)) << s.name << " triangle " << t;
        (want == iss::Facing::Inconsistent ? inconsistent : consistent) += 1;
      }
    }
    EXPECT_GT(consistent, 1000u) << s.name;
    EXPECT_GT(inconsistent, 10u) << s.name;
  }
}

TEST(IssClusters, ExactNodeFacingsEqualConeOnlyAndOracle) {
  // Nodes taken whole on their triangles' own facings (cluster_exact) against the cone
  // proofs alone (cluster_exact=0) and against every node size: the same bits for every
  // relation the oracle does not class as touching, with and without the lazy band, and
  // equal to the exact oracle away from degeneracy.
  const double tau = 1e-5;
  std::vector<Scene> scenes;
  for (const std::string fam : {"scan", "torus", "pouch", "double-surface", "shared-edge-fan", "on-surface"})
    for (uint64_t seed : {1, 2}) scenes.push_back(family(fam, seed, fam == "scan" ? 6000 : -1, 128, 16));
  scenes.push_back(mixed_scene());
  for (const Scene& s : scenes) {
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
    for (const char* band : {"off", "on"}) {
      std::map<std::string, std::string> o{{"clusters", "on"}, {"lazy_band", band}, {"cluster_exact", "0"}};
      SolveResult cone = run_iss(s, o);
      for (const char* k : {"64", "1000000"}) {
        o["cluster_exact"] = k;
        SolveResult exact = run_iss(s, o);
        const OracleTally t = tally_against_oracle(s, ex, tau, {&exact, &cone});
        EXPECT_EQ(t.differ_any, 0u) << s.name << " lazy_band=" << band << " cluster_exact=" << k;
        EXPECT_EQ(t.wrong, 0u) << s.name << " lazy_band=" << band << " cluster_exact=" << k;
        if (s.name.rfind("scan", 0) == 0) {
          // Fewer, larger nodes taken whole than with the cone alone.
          EXPECT_LT(exact.stats.get("cluster_patches"), cone.stats.get("cluster_patches")) << s.name << " " << k;
        }
      }
    }
  }
}
