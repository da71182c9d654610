// Silhouette regions (lib/plucker/silhouette_region.h): the exact segment test on a
// hand-worked case, and solves with the regions (silhouette_regions=on, and auto, the
// default) against the triangle path (off) and the region oracle on a sphere, a torus (segments
// crossing it twice: two front faces, c = 2, over part of the light), a box with faces
// edge-on to some receivers and the scan family.
#include "lib/plucker/silhouette_region.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <random>
#include <vector>

#include "lib/plucker/plucker_solver.h"
#include "lib/plucker/shaft.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"
#include "tests/support/plucker_scenes.h"

namespace visgate {
namespace {

using test_support::expect_region_oracle;
using test_support::expect_same_answers;
using test_support::family_scene;
using test_support::light_scene;
using test_support::receiver_square;
using test_support::run;

TEST(PluckerSilhouetteRegion, TriangleMeetsHandWorked) {
  TriangleSoup m;
  m.vertices = {Vec3f(0, 0, 1), Vec3f(1, 0, 1), Vec3f(0, 1, 1)};
  m.triangles = {{0, 1, 2}};
  const Vec3f r(0.25f, 0.25f, 0);
  // Through the interior, beside it, through a vertex and along an edge (touching counts),
  // stopping before its plane, and r in its plane with p too (undecided).
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, r, SumPoint(Vec3f(0.25f, 0.25f, 2))), 1);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, r, SumPoint(Vec3f(3, 3, 2))), 0);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, Vec3f(0, 0, 0), SumPoint(Vec3f(0, 0, 2))), 1);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, Vec3f(0.5f, 0, 0), SumPoint(Vec3f(0.5f, 0, 2))), 1);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, r, SumPoint(Vec3f(0.25f, 0.25f, 0.5f))), 0);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, Vec3f(2, 2, 1), SumPoint(Vec3f(3, 2, 1))), -1);
  // The double part of a sum point counts: p just beyond the plane along the ray.
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, r, SumPoint(Vec3f(0.25f, 0.25f, 1), Vec3d(0, 0, 1e-20))), 1);
  EXPECT_EQ(plucker::SurfaceTrees::triangle_meets(m, 0, r, SumPoint(Vec3f(0.25f, 0.25f, 1), Vec3d(0, 0, -1e-20))), 0);
}

// Normal cones (faces_one_side): over nearly flat patches of random triangles, with r
// above, below or beside them, a true answer means every triangle has r exactly on
// that one strict side (exact_side); some answers are true.
TEST(PluckerSilhouetteRegion, NormalConesOnlyWhereEveryFaceAgrees) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> xy(-1.0f, 1.0f), jitter(-0.05f, 0.05f), far(-4.0f, 4.0f);
  int decided = 0;
  for (int patch = 0; patch < 200; ++patch) {
    std::vector<std::array<Vec3f, 3>> tris;
    AABBd box, normals;
    const float tilt = jitter(rng) * float(patch % 7);  // some patches far from flat
    for (int k = 0; k < 6; ++k) {
      std::array<Vec3f, 3> t;
      for (Vec3f& v : t) v = Vec3f(xy(rng), xy(rng), 0.0f), v.z = jitter(rng) + tilt * v.x;
      const Vec3d a = to_double(t[0]);
      Vec3d n = cross(to_double(t[1]) - a, to_double(t[2]) - a);
      if (!(length(n) > 1e-3)) continue;
      if (n.z < 0.0) std::swap(t[1], t[2]), n = -n;  // one orientation, as a surface's
      tris.push_back(t);
      for (const Vec3f& v : t) box.extend(to_double(v));
      normals.extend(n * (1.0 / length(n)));
    }
    for (int q = 0; q < 20; ++q) {
      const Vec3f r(far(rng), far(rng), far(rng));
      if (!plucker::faces_one_side(box, normals, to_double(r))) continue;
      ++decided;
      int side = 0;
      for (const auto& t : tris) {
        const int sd = plucker::exact_side(t[0], t[1], t[2], SumPoint(r));
        ASSERT_NE(sd, 0);
        if (side != 0) {
          ASSERT_EQ(sd, side);
        }
        side = sd;
      }
    }
  }
  EXPECT_GT(decided, 100);
}

// The surfaces' edge tree (EdgeTree::build_in_order_by over float boxes, as SurfaceTrees
// builds it) against a recursion over the shape the header promises: pre-order nodes,
// the left child of node i at i + 1, the left half floor(m / 2), leaves of 1 to kLeaf
// edges at their positions in order, order the identity (every edge in exactly one leaf,
// in order), every node's box equal (==) to the min and max over its edges' boxes taken
// here; and a walk pruned by box overlap finds exactly the edges whose own box meets the
// query (against a scan of every edge).
// A box at a corner in [-10, 10]^3 with sides in [0, 1].
AABB random_box(std::mt19937& rng) {
  std::uniform_real_distribution<float> xy(-10.0f, 10.0f), len(0.0f, 1.0f);
  const Vec3f a(xy(rng), xy(rng), xy(rng));
  AABB b{a, a};
  b.extend(a + Vec3f(len(rng), len(rng), len(rng)));
  return b;
}

// The double min (max) over boxes[begin, end) of their lo (hi).
AABBd union_of(const std::vector<AABB>& boxes, uint32_t begin, uint32_t end) {
  AABBd u{Vec3d(boxes[begin].lo), Vec3d(boxes[begin].hi)};
  for (uint32_t k = begin; k < end; ++k)
    for (int c = 0; c < 3; ++c) {
      u.lo[c] = std::min(u.lo[c], double(boxes[k].lo[c]));
      u.hi[c] = std::max(u.hi[c], double(boxes[k].hi[c]));
    }
  return u;
}

// Checks node i as the node over edges [begin, end); returns its subtree's node count.
uint32_t expect_edge_subtree(const plucker::EdgeTree& tree, const std::vector<AABB>& boxes, uint32_t i,
                             uint32_t begin, uint32_t end) {
  EXPECT_LT(i, tree.node_count());
  if (i >= tree.node_count()) return 1;
  const auto& nd = tree.node(i);
  EXPECT_EQ(nd.count, end - begin) << i;
  const AABBd want = union_of(boxes, begin, end);
  for (int c = 0; c < 3; ++c) {
    EXPECT_EQ(nd.box.lo[c], want.lo[c]) << i << " " << c;
    EXPECT_EQ(nd.box.hi[c], want.hi[c]) << i << " " << c;
  }
  if (end - begin <= plucker::EdgeTree::kLeaf) {
    EXPECT_TRUE(tree.is_leaf(nd));
    EXPECT_EQ(nd.first, begin) << i;
    return 1;
  }
  EXPECT_FALSE(tree.is_leaf(nd));
  const uint32_t mid = begin + (end - begin) / 2;
  EXPECT_EQ(tree.left(i), i + 1);
  const uint32_t left = expect_edge_subtree(tree, boxes, i + 1, begin, mid);
  EXPECT_EQ(tree.right(i), i + 1 + left) << i;
  return 1 + left + expect_edge_subtree(tree, boxes, i + 1 + left, mid, end);
}

TEST(PluckerSilhouetteRegion, EdgeTreeShapeBoxesAndWalk) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> xy(-10.0, 10.0);
  for (const uint32_t n : {0u, 1u, 4u, 5u, 8u, 9u, 100u, 3001u}) {
    std::vector<AABB> boxes;
    for (uint32_t e = 0; e < n; ++e) boxes.push_back(random_box(rng));
    plucker::EdgeTree tree;
    tree.build_in_order_by(n, [&](uint32_t k) -> const AABB& { return boxes[k]; });
    ASSERT_EQ(tree.empty(), n == 0);
    ASSERT_EQ(tree.order.size(), size_t(n));
    for (uint32_t k = 0; k < n; ++k) ASSERT_EQ(tree.item(k), k);
    if (n == 0) continue;
    ASSERT_EQ(expect_edge_subtree(tree, boxes, 0, 0, n), tree.node_count());
    for (int q = 0; q < 20; ++q) {
      const Vec3d c(xy(rng), xy(rng), xy(rng));
      const AABBd query{c, c + Vec3d(3, 3, 3)};
      auto meets = [&](const AABBd& b) {
        return !(b.hi.x < query.lo.x || b.hi.y < query.lo.y || b.hi.z < query.lo.z || b.lo.x > query.hi.x ||
                 b.lo.y > query.hi.y || b.lo.z > query.hi.z);
      };
      auto edge_meets = [&](uint32_t e) { return meets(AABBd{Vec3d(boxes[e].lo), Vec3d(boxes[e].hi)}); };
      std::vector<uint32_t> found, want;
      std::vector<uint32_t> stack{0};
      while (!stack.empty()) {
        const uint32_t i = stack.back();
        stack.pop_back();
        const auto& nd = tree.node(i);
        if (!meets(nd.box)) continue;
        if (!tree.is_leaf(nd)) {
          stack.push_back(tree.left(i));
          stack.push_back(tree.right(i));
          continue;
        }
        for (uint32_t k = nd.first; k < nd.first + nd.count; ++k)
          if (edge_meets(tree.item(k))) found.push_back(tree.item(k));
      }
      for (uint32_t e = 0; e < n; ++e)
        if (edge_meets(e)) want.push_back(e);
      std::sort(found.begin(), found.end());
      EXPECT_EQ(found, want);
    }
  }
}

// The surfaces' edge trees (SurfaceEdges, built once per solve): every half-edge (t, k) of
// every surface triangle is one edge's (t0, k0) or (t1, k1) exactly once, a pair joins
// two neighbours across the same two corners in opposite directions with t0 < t1, the
// leaf order is a permutation of the edges, and every leaf's box and normal box hold
// its edges' corners and their faces' unit normals (a sphere and a tilted torus, two
// surfaces in one mesh).
TEST(PluckerSilhouetteRegion, SurfaceEdgesHoldEveryHalfOnce) {
  TriangleSoup m;
  shapes::add_sphere(m, Vec3d(0.05, 0.02, 1.4), 0.5, 24, 12);
  shapes::add_torus(m, Vec3d(2, 0, 1.4), 0.6, 0.2, 20, 10);
  shapes::rotate(m, 0, Vec3d(2, 0, 1.4), normalize(Vec3d(1, 0.3, 0)), 1.2);
  const plucker::ClosedSurfaces cs(m);
  ASSERT_EQ(cs.count(), 2u);
  const plucker::SurfaceTrees trees(m, cs);
  std::vector<int> seen(m.size() * 3, 0);
  auto holds = [](const AABBd& b, const Vec3d& p) {
    return b.lo.x <= p.x && b.lo.y <= p.y && b.lo.z <= p.z && b.hi.x >= p.x && b.hi.y >= p.y && b.hi.z >= p.z;
  };
  for (int32_t s = 0; s < int32_t(cs.count()); ++s) {
    const plucker::SurfaceEdges& se = trees.edges(s);
    std::vector<uint32_t> order = se.tree.order;
    std::sort(order.begin(), order.end());
    for (uint32_t k = 0; k < order.size(); ++k) ASSERT_EQ(order[k], k);
    ASSERT_EQ(order.size(), se.edges.size());
    for (const plucker::SurfaceEdges::Edge& e : se.edges) {
      ASSERT_EQ(cs.surface(e.t0), s);
      ++seen[3 * e.t0 + e.k0];
      ASSERT_EQ(cs.neighbors(e.t0)[e.k0], int32_t(e.t1));
      ASSERT_LT(e.k1, 3);  // welded closed meshes: every half paired
      ++seen[3 * e.t1 + e.k1];
      EXPECT_LT(e.t0, e.t1);
      EXPECT_EQ(cs.neighbors(e.t1)[e.k1], int32_t(e.t0));
      EXPECT_EQ(m.corner(e.t0, e.k0), m.corner(e.t1, (e.k1 + 1) % 3));
      EXPECT_EQ(m.corner(e.t1, e.k1), m.corner(e.t0, (e.k0 + 1) % 3));
    }
    for (uint32_t i = 0; i < se.tree.node_count(); ++i) {
      const auto& nd = se.tree.node(i);
      if (!se.tree.is_leaf(nd)) continue;
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) {
        const plucker::SurfaceEdges::Edge& e = se.edges[se.tree.item(k)];
        for (const uint32_t t : {e.t0, e.t1}) {
          for (int c = 0; c < 3; ++c) {
            if (m.corner(t, c) == m.corner(e.t0, e.k0) || m.corner(t, c) == m.corner(e.t0, (e.k0 + 1) % 3)) {
              EXPECT_TRUE(holds(nd.box, to_double(m.corner(t, c))));
            }
          }
          const Vec3d a = to_double(m.corner(t, 0));
          const Vec3d n = cross(to_double(m.corner(t, 1)) - a, to_double(m.corner(t, 2)) - a);
          EXPECT_TRUE(holds(se.node_normals[i], n * (1.0 / length(n))));
        }
      }
    }
  }
  for (uint32_t t = 0; t < m.size(); ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(seen[3 * t + k], cs.surface(t) >= 0 ? 1 : 0) << t << " " << k;
}

// Every leaf box of the surfaces' edge trees is, bit for bit, the box of all four corners
// of its edges (both halves, in float, as the edges were first built: t's two corners,
// then u's), widened to double. Two boxes with zero coordinates and a sphere, every
// triangle with corners of its own and each zero's sign drawn at random: the welded
// halves of an edge then differ in zero signs, and extend's first-met zero decides.
TEST(PluckerSilhouetteRegion, EdgeLeafBoxesAreTheirEdgesFourCorners) {
  TriangleSoup w;
  shapes::add_box(w, Vec3d(-1, -1, -1), Vec3d(0, 0, 0));
  shapes::add_box(w, Vec3d(0, 0, 0), Vec3d(1, 2, 1));
  shapes::add_sphere(w, Vec3d(0.05, 0.02, 3), 0.5, 24, 12);
  TriangleSoup m;
  Rng rng(3);
  for (const auto& tri : w.triangles) {
    std::array<uint32_t, 3> t{};
    for (int k = 0; k < 3; ++k) {
      Vec3f p = w.vertices[tri[size_t(k)]];
      for (int c = 0; c < 3; ++c)
        if (p[c] == 0.0f && rng.below(2) == 0) p[c] = -0.0f;
      t[size_t(k)] = uint32_t(m.vertices.size());
      m.vertices.push_back(p);
    }
    m.triangles.push_back(t);
  }
  const plucker::ClosedSurfaces cs(m);
  ASSERT_EQ(cs.count(), 3u);
  const plucker::SurfaceTrees trees(m, cs);
  auto bits = [](double d) { return std::bit_cast<uint64_t>(d); };
  size_t leaves = 0, zeros = 0;
  for (int32_t s = 0; s < int32_t(cs.count()); ++s) {
    const plucker::SurfaceEdges& se = trees.edges(s);
    for (uint32_t i = 0; i < se.tree.node_count(); ++i) {
      const auto& nd = se.tree.node(i);
      if (!se.tree.is_leaf(nd)) continue;
      AABB want;
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) {
        const plucker::SurfaceEdges::Edge& e = se.edges[se.tree.item(k)];
        ASSERT_LT(e.k1, 3);
        AABB b{m.corner(e.t0, e.k0), m.corner(e.t0, e.k0)};
        b.extend(m.corner(e.t0, (e.k0 + 1) % 3));
        b.extend(m.corner(e.t1, e.k1));
        b.extend(m.corner(e.t1, (e.k1 + 1) % 3));
        if (k == nd.first)
          want = b;
        else
          want.extend(b);
      }
      ++leaves;
      for (int c = 0; c < 3; ++c) {
        EXPECT_EQ(bits(nd.box.lo[c]), bits(double(want.lo[c]))) << s << " " << i << " " << c;
        EXPECT_EQ(bits(nd.box.hi[c]), bits(double(want.hi[c]))) << s << " " << i << " " << c;
        zeros += (want.lo[c] == 0.0f) + (want.hi[c] == 0.0f);
      }
    }
  }
  EXPECT_GT(leaves, 20u);
  EXPECT_GT(zeros, 20u);  // zero bounds, where the signs could differ
}

// The regions on, auto (the default) and off: the same bits and fractions (up to the
// rounding of the pieces' areas), and the region oracle; `regions` says whether some
// group took the new path with "on".
void expect_regions_match(const Scene& s, bool regions = true) {
  const SolveResult on = run(s, {{"silhouette_regions", "on"}}), dflt = run(s),
                    off = run(s, {{"silhouette_regions", "off"}});
  EXPECT_EQ(off.stats.get("silhouette_groups"), 0.0);
  EXPECT_EQ(on.stats.get("silhouette_declined"), 0.0);
  if (regions) {
    EXPECT_GT(on.stats.get("silhouette_groups"), 0.0);
    EXPECT_GT(on.stats.get("silhouette_pieces"), 0.0);
  }
  expect_same_answers(s, on, off);
  expect_same_answers(s, dflt, off);
  expect_region_oracle(s, on);
}

TEST(PluckerSilhouetteRegion, SphereAsTheTrianglePath) {
  Scene s = light_scene(receiver_square(8, -1.8f, 0.5f), 32, Vec3d(0.1, -0.05, 3.0));
  shapes::add_sphere(s.mesh, Vec3d(0.05, 0.02, 1.4), 0.5, 32, 16);
  ASSERT_TRUE(finish_scene(s).ok());
  expect_regions_match(s);
}

// A torus tilted towards the light: segments through both tubes cross two faces with r
// on the positive side (c = 2), and the silhouettes of the tubes cross each other.
TEST(PluckerSilhouetteRegion, TorusCrossedTwiceAsTheTrianglePath) {
  Scene s = light_scene(receiver_square(8, -1.8f, 0.5f), 32, Vec3d(0.1, -0.05, 3.0));
  shapes::add_torus(s.mesh, Vec3d(0, 0, 1.4), 0.6, 0.2, 40, 16);
  shapes::rotate(s.mesh, 0, Vec3d(0, 0, 1.4), normalize(Vec3d(1, 0.3, 0)), 1.2);
  ASSERT_TRUE(finish_scene(s).ok());
  expect_regions_match(s);
}

// A box whose side faces lie in the planes x = const of two receiver columns of the grid
// and whose front face lies in the plane y = const of a receiver row (those faces are
// edge-on to those receivers: the planes of their edges through r are the face's plane).
TEST(PluckerSilhouetteRegion, EdgeOnFacesAsTheTrianglePath) {
  const std::vector<Vec3f> rec = receiver_square(7, -1.8f, 0.6f);
  Scene s = light_scene(rec, 32, Vec3d(0.1, -0.05, 3.0));
  // Receiver (a, b) is rec[7 a + b]: x from a, y from b.
  shapes::add_box(s.mesh, Vec3d(rec[2 * 7].x, rec[2].y, 1.0), Vec3d(rec[4 * 7].x, 0.5, 1.5));
  ASSERT_TRUE(finish_scene(s).ok());
  expect_regions_match(s);
}

TEST(PluckerSilhouetteRegion, ScanAsTheTrianglePath) {
  for (uint64_t seed : {1, 4}) {
    auto s = family_scene("scan", seed, 4000, 144, 8);
    ASSERT_TRUE(s.ok());
    expect_regions_match(*s);
  }
}

// SilhouetteGroup::candidate decides from a triangle's leaf up what the shaft walk
// decides from the root down: against TriangleTree::candidates with a skip predicate
// (a random cut on the local box and every 11th node, standing for the covered test) on
// spheres and a soup
// around them, every triangle's verdict is its listing (kept, not in a skipped range
// nor under a culled node). And TreeSurfaces names a node's surface exactly when every
// triangle below it is of that surface.
TEST(PluckerSilhouetteRegion, CandidateOnDemandIsTheShaftWalksListing) {
  TriangleSoup m;
  for (int k = 0; k < 4; ++k) shapes::add_sphere(m, Vec3d(0.9 * k, 0.3 * (k % 2), 1.0 + 0.2 * k), 0.35, 24, 12);
  Rng rng(3);
  for (int k = 0; k < 300; ++k) {
    const Vec3d a(rng.uniform(-0.5, 3.2), rng.uniform(-0.5, 0.8), rng.uniform(0.5, 2.0));
    const uint32_t v = uint32_t(m.vertices.size());
    m.vertices.insert(m.vertices.end(), {Vec3f(a), Vec3f(a + Vec3d(0.1, 0.0, 0.02)), Vec3f(a + Vec3d(0.0, 0.1, -0.03))});
    m.triangles.push_back({v, v + 1, v + 2});
  }
  const plucker::ClosedSurfaces cs(m);
  ASSERT_GE(cs.count(), 2u);
  const plucker::TriangleTree tree(m);
  const plucker::TreeSurfaces ts(tree, cs);
  const accel::Bvh<float>& bvh = tree.bvh();
  for (uint32_t i = 0; i < bvh.node_count(); ++i) {
    uint32_t first = i;
    while (!bvh.is_leaf(bvh.node(first))) first = bvh.left(first);
    const auto order = bvh.order();
    const int32_t s0 = cs.surface(order[bvh.node(first).first]);
    bool same = true;
    for (uint32_t p = bvh.node(first).first; p < bvh.node(first).first + bvh.node(i).count; ++p)
      same &= cs.surface(order[p]) == s0;
    EXPECT_EQ(ts.node_surface[i], same ? s0 : -1) << i;
  }
  plucker::SilhouetteGroup g;
  g.tree_surfaces = &ts;
  std::vector<uint32_t> cand;
  std::vector<plucker::TriangleTree::Range> skipped;
  size_t listed = 0, unlisted = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const Vec3f origin = m.vertices[size_t(rng.below(m.vertices.size()))];
    auto local_box = [&](double e) {
      const Vec3d c(rng.uniform(-0.5, 3.2), rng.uniform(-0.5, 0.8), rng.uniform(0.5, 2.0));
      return AABB{Vec3f(c - Vec3d(e, e, e) - to_double(origin)), Vec3f(c + Vec3d(e, e, e) - to_double(origin))};
    };
    const plucker::Shaft shaft(local_box(0.3), local_box(0.6));
    const double cut = rng.uniform(-2.0, 2.0);
    // Not monotone in the box (some nodes skipped whose children would not be): the
    // walk's verdict on a triangle is not its leaf's own.
    auto skip = [&](uint32_t i, const Vec3d& lo) { return lo.x > cut || i % 11 == 5; };
    tree.candidates(shaft, origin, cand, skipped,
                    [&](uint32_t i, const Vec3d& lo, const Vec3d&) { return skip(i, lo); });
    g.node_passes = [&](uint32_t i) {
      const auto& nd = bvh.node(i);
      if (shaft.culls_box(nd.box.lo - origin, nd.box.hi - origin)) return false;
      Vec3d lo, hi;
      tree.local_box(i, to_double(origin), lo, hi);
      return !skip(i, lo);
    };
    g.new_group(m.size(), bvh.node_count(), cs.count());
    // In a random order, so that the cached verdicts are met from every side.
    std::vector<uint32_t> tris(m.size());
    for (uint32_t t = 0; t < tris.size(); ++t) tris[t] = t;
    for (size_t k = tris.size(); k > 1; --k) std::swap(tris[k - 1], tris[size_t(rng.below(k))]);
    for (uint32_t t : tris) {
      const bool in = std::binary_search(cand.begin(), cand.end(), t);
      EXPECT_EQ(g.candidate(t), in) << trial << " " << t;
      (in ? listed : unlisted) += 1;
    }
  }
  EXPECT_GT(listed, 1000u);
  EXPECT_GT(unlisted, 1000u);
}

// A region sphere with open plates (not closed: never region surfaces) between it and
// the light and beside it, in the same shafts and tree nodes: the selection leaves the
// sphere's own subtrees out of its walk but lists the plates (mixed nodes are entered).
// Region oracle, and the same answers as the triangle path.
TEST(PluckerSilhouetteRegion, RegionSurfaceBesidePlatesInOneShaft) {
  Scene s = light_scene(receiver_square(8, -1.8f, 0.5f), 32, Vec3d(0.1, -0.05, 3.0));
  shapes::add_sphere(s.mesh, Vec3d(0.05, 0.02, 1.4), 0.5, 48, 24);  // 2,256 triangles: auto takes it
  shapes::add_patch(s.mesh, Vec3d(-0.6, -0.7, 2.1), Vec3d(0.5, 0, 0), Vec3d(0, 0.4, 0.05), 3, 2);
  shapes::add_patch(s.mesh, Vec3d(0.3, 0.1, 0.8), Vec3d(0.3, 0.1, 0), Vec3d(-0.1, 0.6, 0.0), 2, 3);
  shapes::add_quad(s.mesh, Vec3d(0.6, -0.3, 1.3), Vec3d(0.9, -0.3, 1.3), Vec3d(0.9, 0.2, 1.35), Vec3d(0.6, 0.2, 1.35));
  ASSERT_TRUE(finish_scene(s).ok());
  expect_regions_match(s);
  const SolveResult dflt = run(s);
  EXPECT_GT(dflt.stats.get("silhouette_groups"), 0.0);
  expect_region_oracle(s, dflt);
}

// A closed surface reaching behind the light's plane is not a region surface there: the
// triangle path, the same answers.
TEST(PluckerSilhouetteRegion, SurfaceThroughTheLightPlaneStaysOnTheTrianglePath) {
  Scene s = light_scene(receiver_square(6, -1.5f, 0.6f), 16, Vec3d(0.1, -0.05, 2.0));
  shapes::add_sphere(s.mesh, Vec3d(1.2, 0.0, 1.9), 0.3, 16, 8);
  ASSERT_TRUE(finish_scene(s).ok());
  const SolveResult on = run(s, {{"silhouette_regions", "on"}});
  EXPECT_EQ(on.stats.get("silhouette_groups"), 0.0);
  expect_regions_match(s, false);
}

}  // namespace
}  // namespace visgate
