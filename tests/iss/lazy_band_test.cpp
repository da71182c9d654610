// The lazy band (lib/iss/traversal.h, Shaft::band; extract_inconsistent in blockers.h):
// the extraction against a brute-force account of the chain it leaves, and solves with
// the band kept lazily (lazy_band=on, with and without the clusters, with and without
// building triangles that turn consistent) against the eager surfaces (lazy_band=off)
// and the exact oracle.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <set>
#include <tuple>

#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "lib/iss/tree.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/families.h"
#include "lib/scene/shapes.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

namespace {

// A directed edge by its end points, and the patch's triangle (-1: merged, consistent).
using DirectedEdge = std::tuple<double, double, double, double, double, double, int32_t>;

// The directed edges of every patch the extraction keeps, as (end points, triangle):
// what the surface's chain is made of, independent of the raw-edge storage.
std::multiset<DirectedEdge> kept_edges(const iss::Surface& s, bool only_consistent) {
  std::multiset<DirectedEdge> out;
  for (const iss::Patch& p : s.patches) {
    if (only_consistent && p.facing == iss::Facing::Inconsistent && p.tri >= 0) continue;
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Vec3d& a = iss::edge_vertex(s, s.edges[k], 0);
      const Vec3d& b = iss::edge_vertex(s, s.edges[k], 1);
      out.insert({a.x, a.y, a.z, b.x, b.y, b.z, p.facing == iss::Facing::Inconsistent ? p.tri : -1});
    }
  }
  return out;
}

}  // namespace

TEST(IssLazyBand, ExtractionKeepsTheConsistentChainAndListsTheBand) {
  // A dense closed surface between a receiver floor and a wide light: the per-triangle
  // surface of the root shaft, refined as CONSTRUCT-INITIAL-SHAFT refines it, holds
  // merged consistent patches and a band of inconsistent triangles. The extraction must
  // keep every consistent patch's edges (same end points, same direction), list exactly
  // the inconsistent triangles, leave a valid surface, and turn the edges between the two
  // into boundary edges that keep their mesh label (COMBINE's loose edges).
  Scene sc = family("scan", 3, 3000, 64, 16);
  mesh::PreparedMesh pm = mesh::prepare_mesh(sc.mesh);
  iss::BlockerContext ctx{&pm, 0};
  AABB rb, lb;
  for (const Receiver& r : sc.receivers) rb.extend(r.p);
  for (const AABB& b : sc.lights[0].jitter_boxes) lb.extend(b);
  const AABB bounds = sc.bounds();
  double scale = 0;
  for (int k = 0; k < 3; ++k) scale = std::max({scale, std::abs(double(bounds.lo[k])), std::abs(double(bounds.hi[k]))});
  ctx.scale = scale;
  iss::ShaftGeometry g(rb, lb, iss::choose_main_axis(rb, lb), scale);
  ASSERT_GE(g.main_axis(), 0);
  iss::TreeNode rn, ln;  // no inside triangles
  iss::Workspace ws;
  std::vector<uint32_t> all(pm.triangles.size());
  for (uint32_t t = 0; t < all.size(); ++t) all[t] = t;
  iss::Surface s = iss::construct_triangle_surface(ctx, all, g, rn, ln, ws);
  iss::classify_edges(s, g);
  iss::update_patch_facings(ctx, s, g);
  iss::merge_patches(s, ws);
  ASSERT_EQ(iss::validate(s, &pm), "");
  std::set<uint32_t> want_band;
  std::set<int32_t> shared_labels;  // mesh edges between a kept and a removed patch
  for (const iss::RawEdge& re : s.raw) {
    if (re.nb[0] == iss::kNoPatch || re.nb[1] == iss::kNoPatch) continue;
    auto removed = [&](int32_t p) {
      return s.patches[size_t(p)].facing == iss::Facing::Inconsistent && s.patches[size_t(p)].tri >= 0;
    };
    if (removed(re.nb[0]) != removed(re.nb[1])) shared_labels.insert(re.mesh_edge);
  }
  for (const iss::Patch& p : s.patches)
    if (p.facing == iss::Facing::Inconsistent && p.tri >= 0) want_band.insert(uint32_t(p.tri));
  ASSERT_GT(want_band.size(), 20u) << "the scene must have a band";
  ASSERT_GT(s.patches.size(), want_band.size()) << "and consistent patches";
  ASSERT_FALSE(shared_labels.empty());
  const std::multiset<DirectedEdge> want_edges = kept_edges(s, true);
  const size_t patches_before = s.patches.size();

  std::vector<uint32_t> band{7};  // appended to, never cleared
  EXPECT_EQ(iss::extract_inconsistent(s, band, ws), want_band.size());
  EXPECT_EQ(iss::validate(s, &pm), "");
  EXPECT_EQ(s.patches.size(), patches_before - want_band.size());
  ASSERT_EQ(band.size(), want_band.size() + 1);
  EXPECT_EQ(band[0], 7u);
  EXPECT_EQ(std::set<uint32_t>(band.begin() + 1, band.end()), want_band);
  EXPECT_EQ(kept_edges(s, false), want_edges);
  for (const iss::Patch& p : s.patches) EXPECT_FALSE(p.facing == iss::Facing::Inconsistent && p.tri >= 0);
  // No raw edge is left without a patch, and each edge the kept and removed patches
  // shared is a boundary edge now, with its label.
  std::set<int32_t> boundary_labels;
  for (const iss::RawEdge& re : s.raw) {
    EXPECT_FALSE(re.nb[0] == iss::kNoPatch && re.nb[1] == iss::kNoPatch);
    if ((re.nb[0] == iss::kNoPatch) != (re.nb[1] == iss::kNoPatch)) boundary_labels.insert(re.mesh_edge);
  }
  for (int32_t label : shared_labels) EXPECT_TRUE(boundary_labels.count(label)) << "label " << label;
  // Nothing left to take: a second extraction changes nothing.
  const size_t n = band.size();
  EXPECT_EQ(iss::extract_inconsistent(s, band, ws), 0u);
  EXPECT_EQ(band.size(), n);
}

TEST(IssLazyBand, LazySolveEqualsEagerSolveAndOracle) {
  // lazy_band=on (with the clusters, whose construction puts the band straight into the
  // list, and without, where it is taken out of the built surfaces; and band_build=on,
  // where sub-shafts build the triangles that turn consistent; and cost_rays=on, which
  // sends more shafts to the rays) against lazy_band=off
  // and the exact oracle, under the Embree option sets (the custom caster never keeps a
  // band). A relation may move between the shafts and the rays, never change answer away
  // from degeneracy.
  const double tau = 1e-5;
  std::vector<Scene> scenes;
  for (const std::string fam : {"scan", "torus", "pouch", "double-surface", "shared-edge-fan", "on-surface",
                                "random-soup", "columns", "rooms", "foliage"})
    for (uint64_t seed : {1, 2})
      scenes.push_back(family(fam, seed, fam == "rooms" || fam == "columns" || fam == "scan" ? 3000 : -1, 128, 16));
  for (const Scene& s : scenes) {
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 2);
    for (auto o : kOptionSets) {
      if (o.count("ray_caster")) continue;
      o["lazy_band"] = "off";
      SolveResult eager = run_iss(s, o);
      EXPECT_EQ(eager.stats.get("band_triangles_extracted"), 0.0);
      for (const char* variant : {"clusters=on", "clusters=off", "band_build=on", "cost_rays=on"}) {
        const bool build = std::string(variant) == "band_build=on";
        o["clusters"] = std::string(variant) == "clusters=off" ? "off" : "on";
        o["band_build"] = build ? "on" : "off";
        o["cost_rays"] = std::string(variant) == "cost_rays=on" ? "on" : "off";
        o["lazy_band"] = "on";
        SolveResult lazy = run_iss(s, o);
        const OracleTally t = tally_against_oracle(s, ex, tau, {&lazy, &eager});
        EXPECT_EQ(t.differ, 0u) << s.name << " " << variant << " " << describe(o);
        EXPECT_EQ(t.wrong, 0u) << s.name << " " << variant << " " << describe(o);
        if (s.name.rfind("scan", 0) == 0) {
          EXPECT_GT(lazy.stats.get("band_triangles_extracted"), 0.0) << s.name;
          EXPECT_GT(lazy.stats.get("band_triangles_dropped"), 0.0) << s.name;
        }
        if (!build) {
          EXPECT_EQ(lazy.stats.get("band_triangles_built"), 0.0);
        }
      }
      o.erase("clusters");
      o.erase("band_build");
      o.erase("cost_rays");
    }
  }
}
