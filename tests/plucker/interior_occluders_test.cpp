// Interior occluders (lib/plucker/interior_occluders.h): the polygon-triangle test on
// hand-worked cases; the polygons found on scan checked against an independent inside
// test (ray parity in double at points spread over each polygon) and for planarity and
// convexity; and the solves with them against the previous code path (interior=off) and
// the region oracle on scan, concave, interpenetrating and open meshes and receivers
// close to the surface.
#include "lib/plucker/interior_occluders.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <set>

#include "lib/geom/predicates.h"
#include "lib/plucker/plucker_solver.h"
#include "lib/plucker/silhouette_region.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/rng.h"
#include "tests/support/bvh_walk.h"
#include "tests/support/plucker_scenes.h"

namespace visgate {
namespace {

using test_support::family_scene;
using test_support::light_scene;
using test_support::receiver_square;
using test_support::expect_region_oracle;
using test_support::expect_same_answers;
using test_support::run;

TEST(PluckerInteriorOccluders, PolygonMeetsTriangleHandWorked) {
  // The unit square in z = 0.
  const std::vector<Vec3f> q = {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(1, 1, 0), Vec3f(0, 1, 0)};
  // Through its middle, above it, beside it (straddling its plane), touching a corner
  // with a vertex, lying in its plane apart from it (the exact test cannot tell: meets).
  EXPECT_TRUE(plucker::polygon_meets_triangle(q, Vec3f(0.5f, 0.5f, -1), Vec3f(0.6f, 0.5f, 1), Vec3f(0.5f, 0.6f, 1)));
  EXPECT_FALSE(plucker::polygon_meets_triangle(q, Vec3f(0, 0, 1), Vec3f(1, 0, 1), Vec3f(0, 1, 1)));
  EXPECT_FALSE(plucker::polygon_meets_triangle(q, Vec3f(2, 0, -1), Vec3f(3, 0, 1), Vec3f(2, 1, 1)));
  EXPECT_TRUE(plucker::polygon_meets_triangle(q, Vec3f(1, 1, 0), Vec3f(2, 1, 1), Vec3f(1, 2, 1)));
  EXPECT_TRUE(plucker::polygon_meets_triangle(q, Vec3f(2, 0, 0), Vec3f(3, 0, 0), Vec3f(2, 1, 0)));
  // A triangle crossing the square's plane only through an edge of the square from
  // outside: its segment in the plane ends on the square's edge x = 1.
  EXPECT_TRUE(plucker::polygon_meets_triangle(q, Vec3f(1, 0.5f, -1), Vec3f(1, 0.5f, 1), Vec3f(2, 0.5f, 0)));
  // A large triangle the square passes through without touching an edge of it.
  EXPECT_TRUE(plucker::polygon_meets_triangle(q, Vec3f(0.5f, -5, -5), Vec3f(0.5f, 5, -5), Vec3f(0.5f, 0, 5)));
}

// The reference for polygon_meets_triangle: Q as the fan of its first corner, every
// closed segment (a triangle edge against each fan triangle, each Q edge against the
// triangle) tested with exact orientations from scratch.
int exact_o3(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  const Sign s = orient3d_exact(a, b, c, d);
  return s == Sign::Positive ? 1 : (s == Sign::Negative ? -1 : 0);
}
bool fan_segment_meets(const Vec3f& p, const Vec3f& q, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const int sp = exact_o3(a, b, c, p), sq = exact_o3(a, b, c, q);
  if (sp * sq > 0) return false;
  if (sp == 0 && sq == 0) return true;
  const int s1 = exact_o3(p, q, a, b), s2 = exact_o3(p, q, b, c), s3 = exact_o3(p, q, c, a);
  return !((s1 > 0 || s2 > 0 || s3 > 0) && (s1 < 0 || s2 < 0 || s3 < 0));
}
bool fan_polygon_meets(const std::vector<Vec3f>& q, const Vec3f t[3]) {
  for (int e = 0; e < 3; ++e)
    for (size_t k = 1; k + 1 < q.size(); ++k)
      if (fan_segment_meets(t[e], t[(e + 1) % 3], q[0], q[k], q[k + 1])) return true;
  for (size_t k = 0; k < q.size(); ++k)
    if (fan_segment_meets(q[k], q[(k + 1) % q.size()], t[0], t[1], t[2])) return true;
  return false;
}

// Random strictly convex lattice polygons (corners p + i u + j v, exact floats, in order)
// against random triangles whose corners are often on Q's plane, its corners or its
// edges' midpoints (the closed and degenerate cases): both forms of
// polygon_meets_triangle give the fan reference's answer.
TEST(PluckerInteriorOccluders, PolygonMeetsTriangleMatchesTheFanReference) {
  Rng rng(17);
  int met = 0, apart = 0;
  for (int iter = 0; iter < 4000; ++iter) {
    const Vec3d p(double(rng.below(9)) - 4, double(rng.below(9)) - 4, double(rng.below(9)) - 4);
    const Vec3d u(double(rng.below(5)) - 2, double(rng.below(5)) - 2, 2), v(2, double(rng.below(5)) - 2, double(rng.below(5)) - 2);
    if (length(cross(u, v)) == 0.0) continue;
    // The strictly convex hull of random lattice points, counter-clockwise.
    std::vector<std::array<int64_t, 2>> pts;
    for (int k = 0; k < 3 + int(rng.below(8)); ++k) pts.push_back({int64_t(rng.below(9)) - 4, int64_t(rng.below(9)) - 4});
    std::sort(pts.begin(), pts.end());
    pts.erase(std::unique(pts.begin(), pts.end()), pts.end());
    auto cr = [](const std::array<int64_t, 2>& o, const std::array<int64_t, 2>& a, const std::array<int64_t, 2>& b) {
      return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
    };
    std::vector<std::array<int64_t, 2>> h;
    for (int pass = 0; pass < 2; ++pass) {
      const size_t base = h.size();
      for (size_t i = 0; i < pts.size(); ++i) {
        const auto& x = pass == 0 ? pts[i] : pts[pts.size() - 1 - i];
        while (h.size() >= base + 2 && cr(h[h.size() - 2], h.back(), x) <= 0) h.pop_back();
        h.push_back(x);
      }
      h.pop_back();
    }
    if (h.size() < 3) continue;
    std::vector<Vec3f> q;
    for (const auto& ij : h) q.push_back(Vec3f(p + u * double(ij[0]) + v * double(ij[1])));
    // Triangle corners: on Q's plane (lattice points, Q's corners, edge midpoints) or off it.
    auto corner = [&]() {
      switch (rng.below(7)) {
        case 0: return Vec3f(p + u * (double(rng.below(13)) - 6) + v * (double(rng.below(13)) - 6));
        case 1: return q[rng.below(q.size())];
        case 2: {
          const size_t k = rng.below(q.size());
          return Vec3f((to_double(q[k]) + to_double(q[(k + 1) % q.size()])) * 0.5);
        }
        default:
          return Vec3f(float(rng.uniform(-20, 20)), float(rng.uniform(-20, 20)), float(rng.uniform(-20, 20)));
      }
    };
    const Vec3f t[3] = {corner(), corner(), corner()};
    const bool want = fan_polygon_meets(q, t);
    const int sides[3] = {exact_o3(q[0], q[1], q[2], t[0]), exact_o3(q[0], q[1], q[2], t[1]),
                          exact_o3(q[0], q[1], q[2], t[2])};
    EXPECT_EQ(plucker::polygon_meets_triangle(q, t[0], t[1], t[2]), want) << iter;
    EXPECT_EQ(plucker::polygon_meets_triangle(q, t[0], t[1], t[2], sides), want) << iter;
    (want ? met : apart) += 1;
  }
  EXPECT_GT(met, 1000);
  EXPECT_GT(apart, 300);
}

// Ray parity in double from x along a fixed generic direction: odd inside a closed mesh
// without self-intersections (an independent test of the winding check, which is exact
// and signed).
bool inside_by_parity(const TriangleSoup& m, const Vec3d& x) {
  const Vec3d d = normalize(Vec3d(0.5377, 0.8421, 0.0413));
  int hits = 0;
  for (uint32_t t = 0; t < m.size(); ++t) {
    const Vec3d a = to_double(m.corner(t, 0)), b = to_double(m.corner(t, 1)), c = to_double(m.corner(t, 2));
    const Vec3d e1 = b - a, e2 = c - a, p = cross(d, e2);
    const double det = dot(e1, p);
    if (std::abs(det) < 1e-300) continue;
    const Vec3d s = x - a;
    const double u = dot(s, p) / det;
    const Vec3d qv = cross(s, e1);
    const double v = dot(d, qv) / det, tt = dot(e2, qv) / det;
    hits += u > 0 && v > 0 && u + v < 1 && tt > 0;
  }
  return hits % 2 == 1;
}

// Every polygon of io: planar, strictly convex, points spread over it inside the surface
// (ray parity, independent of the builder's exact checks), and apart from every triangle
// of its surface.
void expect_polygons_inside(const Scene& s, const plucker::ClosedSurfaces& cs, const plucker::InteriorOccluders& io) {
  Rng rng(5);
  for (const auto& e : io.entries()) {
    const auto q = io.polygon(e);
    ASSERT_GE(q.size(), 3u);
    ASSERT_LE(q.size(), size_t(plucker::InteriorOccluders::kMaxVertices));
    EXPECT_GE(cs.triangles(e.surface), plucker::InteriorOccluders::kMinTriangles);
    for (size_t k = 0; k < q.size(); ++k) {
      EXPECT_EQ(orient3d_exact(q[0], q[1], q[2], q[k]), Sign::Zero) << k;  // one plane
      // Strictly convex: every corner strictly on the inner side of the plane through
      // the normal and each edge.
      const Vec3d n = cross(to_double(q[1]) - to_double(q[0]), to_double(q[2]) - to_double(q[0]));
      const Vec3d a = to_double(q[k]), b = to_double(q[(k + 1) % q.size()]);
      for (size_t j = 0; j < q.size(); ++j)
        if (j != k && j != (k + 1) % q.size()) {
          EXPECT_GT(dot(cross(b - a, to_double(q[j]) - a), n), 0.0) << k << j;
        }
    }
    // Points spread over the polygon (corners, edge midpoints, random convex combinations)
    // are inside the surface.
    for (int k = 0; k < 40; ++k) {
      Vec3d x(0, 0, 0);
      double wsum = 0;
      for (const Vec3f& c : q) {
        const double w = k < int(q.size()) ? (&c == &q[size_t(k)] ? 1.0 : 1e-3) : rng.uniform(0.0, 1.0);
        x = x + to_double(c) * w;
        wsum += w;
      }
      EXPECT_TRUE(inside_by_parity(s.mesh, x / wsum)) << k;
    }
    for (uint32_t t = 0; t < s.mesh.size(); ++t) {
      if (cs.surface(t) != e.surface) continue;
      EXPECT_FALSE(plucker::polygon_meets_triangle(q, s.mesh.corner(t, 0), s.mesh.corner(t, 1), s.mesh.corner(t, 2)));
    }
  }
}

TEST(PluckerInteriorOccluders, ScanPolygonsArePlanarConvexAndInside) {
  auto s = family_scene("scan", 3, 3000, 16, 4);
  ASSERT_TRUE(s.ok());
  const plucker::ClosedSurfaces cs(s->mesh);
  const plucker::InteriorOccluders one(*s, cs, 0);
  ASSERT_EQ(one.entries().size(), s->lights.size());  // one per light for the ellipsoid
  expect_polygons_inside(*s, cs, one);
  // With further polygons: the first of each light is the same one, the rest pass the
  // same checks.
  const plucker::InteriorOccluders io(*s, cs);
  ASSERT_GE(io.entries().size(), one.entries().size());
  for (size_t li = 0; li < s->lights.size(); ++li) {
    ASSERT_GE(io.of_light(li).size(), 1u);
    const auto a = one.polygon(one.of_light(li)[0]), b = io.polygon(io.of_light(li)[0]);
    ASSERT_EQ(a.size(), b.size());
    for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(to_double(a[k]), to_double(b[k]));
  }
  expect_polygons_inside(*s, cs, io);
}

// The same polygons whether InteriorOccluders builds its own triangle hierarchies or walks
// SurfaceTrees' (the solver's default): scan, and a torus beside a sphere (two surfaces
// with polygons) with further polygons; each also passes the independent inside checks.
TEST(PluckerInteriorOccluders, SurfaceTreesHierarchiesGiveTheSamePolygons) {
  auto scan = family_scene("scan", 3, 3000, 16, 4);
  ASSERT_TRUE(scan.ok());
  Scene two = light_scene(receiver_square(4, -1.3f, 0.5f), 8, Vec3d(0.1, -0.05, 3.0));
  shapes::add_torus(two.mesh, Vec3d(-0.5, 0, 1.2), 0.5, 0.2, 48, 24);
  shapes::add_sphere(two.mesh, Vec3d(0.9, 0.1, 1.0), 0.3, 40, 20);
  ASSERT_TRUE(finish_scene(two).ok());
  for (const Scene* s : {&*scan, &two}) {
    const plucker::ClosedSurfaces cs(s->mesh);
    const plucker::SurfaceTrees trees(s->mesh, cs);
    const plucker::InteriorOccluders own(*s, cs), shared(*s, cs, plucker::InteriorOccluders::kDefaultExtra, &trees);
    ASSERT_GE(own.entries().size(), s->lights.size());
    ASSERT_EQ(own.entries().size(), shared.entries().size());
    std::set<int32_t> surfaces;
    for (const auto& e : own.entries()) surfaces.insert(e.surface);
    EXPECT_EQ(surfaces.size(), s == &two ? 2u : 1u);
    for (size_t i = 0; i < own.entries().size(); ++i) {
      const auto& a = own.entries()[i];
      const auto& b = shared.entries()[i];
      EXPECT_EQ(a.surface, b.surface);
      EXPECT_EQ(a.light, b.light);
      const auto pa = own.polygon(a), pb = shared.polygon(b);
      ASSERT_EQ(pa.size(), pb.size()) << i;
      for (size_t k = 0; k < pa.size(); ++k) EXPECT_EQ(to_double(pa[k]), to_double(pb[k])) << i << " " << k;
    }
    expect_polygons_inside(*s, cs, shared);
  }
}

// Surface k's hierarchy in `trees` against brute force: the shape (test::expect_bvh_shape),
// every triangle of the surface in exactly one leaf and none of another surface (nor any
// other triangle), and every node's box the componentwise min/max of its triangles'
// corners in double (by value). Its rank is its leaf order, surface after surface.
void expect_surface_hierarchy(const TriangleSoup& mesh, const plucker::ClosedSurfaces& cs,
                              const plucker::SurfaceTrees& trees, int32_t k, uint32_t rank0) {
  const accel::Bvh<float>& b = trees.hierarchy(k);
  const std::vector<uint32_t>& tris = trees.triangles(k);
  ASSERT_FALSE(b.empty());
  std::vector<int> seen(mesh.size(), 0);
  test::expect_bvh_shape(b, [&](uint32_t i, uint32_t pos) {
    const auto& nd = b.node(i);
    Vec3d lo(1e300, 1e300, 1e300), hi(-1e300, -1e300, -1e300);
    for (uint32_t p = pos; p < pos + nd.count; ++p) {
      ASSERT_LT(b.item(p), tris.size());
      const uint32_t t = tris[b.item(p)];
      for (int c = 0; c < 3; ++c) {
        const Vec3d v = to_double(mesh.corner(t, c));
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], v[a]), hi[a] = std::max(hi[a], v[a]);
      }
      if (b.is_leaf(nd)) {
        ++seen[t];
        ASSERT_EQ(trees.rank(t), rank0 + p);
      }
    }
    for (int a = 0; a < 3; ++a) {
      ASSERT_EQ(double(nd.box.lo[a]), lo[a]) << "node " << i;
      ASSERT_EQ(double(nd.box.hi[a]), hi[a]) << "node " << i;
    }
  });
  for (uint32_t t = 0; t < mesh.size(); ++t) ASSERT_EQ(seen[t], cs.surface(t) == k ? 1 : 0) << t;
}

// SurfaceTrees given the triangle tree's hierarchy (the solver's way): a surface holding
// every triangle (a lone torus) takes it, and a surface holding at least 90% of them
// (scan's ellipsoid beside its 12-triangle ground slab; a torus beside a small sphere)
// takes it restricted to its triangles (expect_surface_hierarchy); the others (a torus
// beside a sphere, the slab, the small sphere) build their own, and their hierarchies and
// the lone torus's are those of SurfaceTrees built alone (node by node, leaf order).
TEST(PluckerInteriorOccluders, SurfaceTreesTakeTheTriangleTreeForAWholeMeshSurface) {
  auto scan = family_scene("scan", 3, 3000, 16, 4);
  ASSERT_TRUE(scan.ok());
  Scene one = light_scene(receiver_square(4, -1.3f, 0.5f), 8, Vec3d(0.1, -0.05, 3.0));
  shapes::add_torus(one.mesh, Vec3d(-0.5, 0, 1.2), 0.5, 0.2, 48, 24);
  Scene two = one, small = one;
  shapes::add_sphere(two.mesh, Vec3d(0.9, 0.1, 1.0), 0.3, 40, 20);
  shapes::add_sphere(small.mesh, Vec3d(0.9, 0.1, 1.0), 0.1, 8, 4);
  ASSERT_TRUE(finish_scene(one).ok());
  ASSERT_TRUE(finish_scene(two).ok());
  ASSERT_TRUE(finish_scene(small).ok());
  for (const Scene* s : {&one, &two, &small, &*scan}) {
    const plucker::TriangleTree tt(s->mesh);
    const plucker::ClosedSurfaces cs(s->mesh);
    const plucker::SurfaceTrees alone(s->mesh, cs), given(s->mesh, cs, 0, &tt.bvh());
    ASSERT_EQ(cs.count(), s == &one ? 1u : 2u);
    uint32_t rank0 = 0;
    int derived_count = 0;
    for (int32_t k = 0; k < int32_t(cs.count()); ++k) {
      const accel::Bvh<float>&a = alone.hierarchy(k), &b = given.hierarchy(k);
      const size_t nk = given.triangles(k).size();
      expect_surface_hierarchy(s->mesh, cs, given, k, rank0);
      expect_surface_hierarchy(s->mesh, cs, alone, k, rank0);
      rank0 += uint32_t(nk);
      const bool derived = nk < s->mesh.size() && 10 * nk >= 9 * s->mesh.size();
      derived_count += derived ? 1 : 0;
      if (derived) continue;
      ASSERT_EQ(a.node_count(), b.node_count());
      for (uint32_t i = 0; i < a.node_count(); ++i) {
        ASSERT_EQ(a.node(i).first, b.node(i).first);
        ASSERT_EQ(a.node(i).count, b.node(i).count);
        ASSERT_TRUE(a.node(i).box.lo == b.node(i).box.lo && a.node(i).box.hi == b.node(i).box.hi);
      }
      ASSERT_TRUE(std::equal(a.order().begin(), a.order().end(), b.order().begin(), b.order().end()));
    }
    EXPECT_EQ(derived_count, s == &small || s == &*scan ? 1 : 0);
    if (s == &one || s == &two) {
      for (uint32_t t = 0; t < s->mesh.size(); ++t) ASSERT_EQ(alone.rank(t), given.rank(t)) << t;
    }
  }
}

// A torus under the light: its centre (the box's) is in the hole, so the first polygon
// fails there, and the further polygons cover the ring; a peanut's cross-section is
// pinched at the centre, so rays from it reach little of the two lobes. The polygons pass the independent
// checks, and the solves match the previous path (no interior occluder) and the oracle.
TEST(PluckerInteriorOccluders, FurtherPolygonsCoverNonConvexSolids) {
  std::vector<Vec3f> rec = receiver_square(6, -1.3f, 0.5f);
  for (int variant = 0; variant < 2; ++variant) {
    Scene s = light_scene(rec, 32, Vec3d(0.1, -0.05, 3.0));
    if (variant == 0) shapes::add_torus(s.mesh, Vec3d(0, 0, 1.2), 0.6, 0.2, 48, 24);
    if (variant == 1) {
      // A peanut: a sphere stretched along x and pinched at its middle (closed, one
      // surface; the same map for every copy of a vertex keeps it welded).
      shapes::add_sphere(s.mesh, Vec3d(0, 0, 0), 0.4, 40, 20);
      for (Vec3f& v : s.mesh.vertices) {
        const double x = v.x, pinch = 0.45 + 0.55 * std::abs(x) / 0.4;
        v = Vec3f(Vec3d(0.03 + 2.0 * x, 0.02 + v.y * pinch, 1.1 + v.z * pinch));
      }
    }
    ASSERT_TRUE(finish_scene(s).ok());
    const plucker::ClosedSurfaces cs(s.mesh);
    const plucker::InteriorOccluders one(s, cs, 0), io(s, cs);
    EXPECT_GT(io.entries().size(), one.entries().size()) << variant;
    expect_polygons_inside(s, cs, io);
    const SolveResult on = run(s), first = run(s, {{"interior_extra", "0"}}), off = run(s, {{"interior", "off"}});
    EXPECT_GT(on.stats.get("interior_occluders"), first.stats.get("interior_occluders")) << variant;
    expect_same_answers(s, on, off);
    expect_same_answers(s, on, first);
    expect_region_oracle(s, on);
  }
}

TEST(PluckerInteriorOccluders, ScanAnswersMatchThePreviousPathAndTheOracle) {
  auto s = family_scene("scan", 3, 3000, 64, 16);
  ASSERT_TRUE(s.ok());
  // The triangle path throughout (silhouette regions off: they leave the surface out
  // whole, so nothing of it is covered or merged).
  const std::map<std::string, std::string> tri = {{"silhouette_regions", "off"}};
  auto with = [&](std::string k, std::string v) {
    std::map<std::string, std::string> o = tri;
    o[k] = v;
    return o;
  };
  const SolveResult on = run(*s, tri), off = run(*s, with("interior", "off")),
                    every = run(*s, {{"interior", "off"}, {"closed", "off"}});
  EXPECT_GT(on.stats.get("interior_occluders"), 0.0);
  EXPECT_GT(on.stats.get("interior_covered"), 0.0);
  EXPECT_EQ(off.stats.get("interior_occluders"), 0.0);
  EXPECT_LT(on.stats.get("occluders") + on.stats.get("near_polygons"),
            off.stats.get("occluders") + off.stats.get("near_polygons"));
  expect_same_answers(*s, on, off);
  expect_same_answers(*s, on, every);
  expect_region_oracle(*s, on);
  // Whole tree nodes left out as covered (cover_nodes) against the test per candidate.
  const SolveResult per_triangle = run(*s, with("cover_nodes", "off"));
  EXPECT_GT(on.stats.get("interior_skipped"), 0.0);
  EXPECT_EQ(per_triangle.stats.get("interior_skipped"), 0.0);
  EXPECT_LT(on.stats.get("closed_dropped") + on.stats.get("interior_covered"),
            per_triangle.stats.get("closed_dropped") + per_triangle.stats.get("interior_covered"));
  expect_same_answers(*s, on, per_triangle);
  // Glued near triangles subtracted as one convex polygon (near_merge) against one by one.
  const SolveResult single = run(*s, with("near_merge", "off"));
  EXPECT_GT(on.stats.get("near_merged"), 0.0);
  EXPECT_EQ(single.stats.get("near_merged"), 0.0);
  EXPECT_LT(on.stats.get("near_splits"), single.stats.get("near_splits"));
  expect_same_answers(*s, on, single);
}

// A dense closed surface's one-sided triangles as near polygons (closed_near, the
// default) against tree occluders (off): the same answers, the region oracle's, with the
// triangle path throughout (silhouette regions off). Fine tori (3,072 and 2,304
// triangles) under the square light, receivers on a grid below; columns' small solids
// (under 1024 triangles each) keep their tree occluders.
TEST(PluckerInteriorOccluders, ClosedNearMatchesTheTreeAndTheOracle) {
  const std::vector<Vec3f> rec = receiver_square(8, -1.4f, 0.4f);
  for (int variant = 0; variant < 2; ++variant) {
    Scene s = light_scene(rec, 32, Vec3d(0.1, -0.05, 3.0));
    if (variant == 0) shapes::add_torus(s.mesh, Vec3d(0.05, 0.02, 1.2), 0.6, 0.2, 64, 24);
    if (variant == 1) shapes::add_torus(s.mesh, Vec3d(0.4, -0.3, 1.0), 0.5, 0.25, 48, 24);
    ASSERT_TRUE(finish_scene(s).ok());
    const SolveResult on = run(s, {{"silhouette_regions", "off"}}),
                      off = run(s, {{"silhouette_regions", "off"}, {"closed_near", "off"}});
    EXPECT_GT(on.stats.get("closed_near_triangles"), 0.0) << variant;
    EXPECT_EQ(off.stats.get("closed_near_triangles"), 0.0) << variant;
    EXPECT_LT(on.stats.get("occluders"), off.stats.get("occluders")) << variant;
    expect_same_answers(s, on, off);
    expect_region_oracle(s, on);
  }
  auto c = family_scene("columns", 3, 2000, 64, 4);
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(run(*c).stats.get("closed_near_triangles"), 0.0);
}

// Under the square light, receivers on a grid below (some right under the surfaces,
// 1e-3 below the lowest point of the sphere): a fine sphere, a torus (its centre is in
// the hole: no first polygon there, further ones on the ring), two interpenetrating spheres (each closed, their union
// not convex), and an open sphere (no closed surface, nothing added).
TEST(PluckerInteriorOccluders, ConcaveInterpenetratingAndOpenMeshesMatchThePreviousPathAndTheOracle) {
  std::vector<Vec3f> rec = receiver_square(8, -1.4f, 0.4f);
  rec.push_back(Vec3f(0.05f, 0.02f, 0.499f));
  for (int variant = 0; variant < 4; ++variant) {
    Scene s = light_scene(rec, 32, Vec3d(0.1, -0.05, 3.0));
    // (Centred off x = 0: add_sphere's lower pole vertices then round to one point.)
    if (variant == 0) shapes::add_sphere(s.mesh, Vec3d(0.05, 0.02, 1.0), 0.5, 32, 16);
    if (variant == 1) shapes::add_torus(s.mesh, Vec3d(0, 0, 1.2), 0.6, 0.2, 32, 16);
    if (variant == 2) {
      shapes::add_sphere(s.mesh, Vec3d(-0.2, 0, 1.0), 0.5, 32, 16);
      shapes::add_sphere(s.mesh, Vec3d(0.25, 0.1, 1.1), 0.45, 32, 16);
    }
    if (variant == 3) shapes::add_open_sphere(s.mesh, Vec3d(0, 0, 1.0), 0.5, 32, 16, 0.5, true);
    ASSERT_TRUE(finish_scene(s).ok());
    const SolveResult on = run(s), off = run(s, {{"interior", "off"}});
    if (variant != 3) {
      EXPECT_GT(on.stats.get("interior_occluders"), 0.0) << variant;
    } else {
      EXPECT_EQ(on.stats.get("interior_occluders"), 0.0) << variant;
    }
    // The torus's first polygon fails (its centre is in the hole); only further ones.
    if (variant == 1) {
      EXPECT_EQ(run(s, {{"interior_extra", "0"}}).stats.get("interior_occluders"), 0.0);
    }
    expect_same_answers(s, on, off);
    expect_same_answers(s, on, run(s, {{"cover_nodes", "off"}}));
    expect_same_answers(s, on, run(s, {{"near_merge", "off"}}));
    expect_region_oracle(s, on);
  }
}

// The default group side (plucker_solver.h default_tile): 16 on a scan (a dense closed
// surface with interior polygons) and on a torus made mostly of open strips around a
// small closed one, 8 without interior polygons (columns) or when the closed surface
// with polygons holds under half of the triangles; the answers with the larger groups as
// with tile 8 (the previous default) and the region oracle.
TEST(PluckerInteriorOccluders, DefaultTileFollowsTheInteriorPolygons) {
  auto s = family_scene("scan", 3, 3000, 256, 4);
  ASSERT_TRUE(s.ok());
  const plucker::ClosedSurfaces cs(s->mesh);
  const plucker::InteriorOccluders io(*s, cs);
  ASSERT_GT(io.entries().size(), 0u);
  EXPECT_EQ(plucker::default_tile(*s, &cs, &io), plucker::kConvexSolidTile);
  EXPECT_EQ(plucker::default_tile(*s, &cs, nullptr), plucker::kDefaultTile);
  const SolveResult dflt = run(*s), eight = run(*s, {{"tile", "8"}}), zero = run(*s, {{"tile", "0"}});
  EXPECT_EQ(dflt.stats.get("groups"), 1.0);  // 16 x 16 receivers
  EXPECT_EQ(eight.stats.get("groups"), 4.0);
  EXPECT_EQ(zero.stats.get("groups"), 1.0);
  expect_same_answers(*s, dflt, eight);
  for (size_t i = 0; i < s->receivers.size(); i += 9)  // a spread subset: the oracle is slow
    for (size_t li = 0; li < s->lights.size(); ++li) {
      const oracle::RegionAnswer reg = oracle::visible_region(*s, i, li);
      if (!reg.edge_on) {
        EXPECT_NEAR(dflt.receivers[i].visible_fraction[li], reg.visible_fraction, 1e-4) << i << " " << li;
      }
    }

  std::vector<Vec3f> rec = receiver_square(4, -1.3f, 0.8f);
  Scene torus = light_scene(rec, 8, Vec3d(0.1, -0.05, 3.0));
  shapes::add_torus(torus.mesh, Vec3d(0, 0, 1.2), 0.6, 0.2, 48, 24);
  ASSERT_TRUE(finish_scene(torus).ok());
  const plucker::ClosedSurfaces tcs(torus.mesh);
  const plucker::InteriorOccluders tio(torus, tcs);
  ASSERT_GT(tio.entries().size(), 0u);
  EXPECT_EQ(plucker::default_tile(torus, &tcs, &tio), plucker::kConvexSolidTile);
  // Open triangles (no closed surface) outnumbering the torus's: 8.
  const size_t torus_tris = torus.mesh.size();
  Scene mixed = light_scene(rec, 8, Vec3d(0.1, -0.05, 3.0));
  shapes::add_torus(mixed.mesh, Vec3d(0, 0, 1.2), 0.6, 0.2, 48, 24);
  Rng rng(5);
  for (size_t k = 0; k <= torus_tris; ++k) {
    const Vec3d c(rng.uniform(-2.0, 2.0), rng.uniform(-2.0, 2.0), rng.uniform(2.0, 2.5));
    const uint32_t b = uint32_t(mixed.mesh.vertices.size());
    for (const Vec3d& v : {c, c + Vec3d(0.01, 0, 0), c + Vec3d(0, 0.01, 0)}) mixed.mesh.vertices.push_back(Vec3f(v));
    mixed.mesh.triangles.push_back({b, b + 1, b + 2});
  }
  ASSERT_TRUE(finish_scene(mixed).ok());
  const plucker::ClosedSurfaces mcs(mixed.mesh);
  const plucker::InteriorOccluders mio(mixed, mcs);
  ASSERT_GT(mio.entries().size(), 0u);
  EXPECT_EQ(plucker::default_tile(mixed, &mcs, &mio), plucker::kDefaultTile);

  auto cols = family_scene("columns", 3, 2000, 64, 4);
  ASSERT_TRUE(cols.ok());
  const plucker::ClosedSurfaces ccs(cols->mesh);
  const plucker::InteriorOccluders cio(*cols, ccs);
  EXPECT_EQ(plucker::default_tile(*cols, &ccs, &cio), plucker::kDefaultTile);
}

}  // namespace
}  // namespace visgate
