// lib/ssv/edge_tree.h: candidate edges per receiver against a brute-force scan of every
// edge (exact frustum clipping in double, weights and near-edge-on triangles), the
// receivers' box frustum against points of each receiver's frustum, the light-plane
// crossing candidates against a scan of every triangle, and the solver with the edge
// index against the wedge indexes.
#include "lib/ssv/edge_tree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "lib/solver.h"
#include "lib/ssv/integrate.h"
#include "lib/ssv/occluders.h"
#include "tests/support/family_scene.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

namespace {

// The segment a b (frame coordinates) meets the frustum of r_local over L' (h >= 0 and
// inside every plane through r and an edge of L'), touching counted: Liang-Barsky in
// double, independent of lib/ssv's clipping.
bool meets_frustum(const Vec3d& a, const Vec3d& b, const Vec3d& r, const LightFrame& frame) {
  double t0 = 0.0, t1 = 1.0;
  auto clip = [&](double fa, double fb) {  // keep f >= 0
    if (fa < 0.0 && fb < 0.0) return false;
    if (fa >= 0.0 && fb >= 0.0) return true;
    const double t = fa / (fa - fb);
    if (fa < 0.0) t0 = std::max(t0, t);
    else t1 = std::min(t1, t);
    return t0 <= t1;
  };
  if (!clip(a.z, b.z)) return false;
  const size_t n = frame.poly.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3d p(frame.poly[i].u, frame.poly[i].v, 0.0), q(frame.poly[(i + 1) % n].u, frame.poly[(i + 1) % n].v, 0.0);
    Vec3d nrm = cross(p - r, q - r);
    if (dot(nrm, Vec3d(0, 0, 0) - r) < 0.0) nrm = -nrm;
    if (!clip(dot(nrm, a - r), dot(nrm, b - r))) return false;
  }
  return t0 <= t1;
}

struct TreeSetup {
  mesh::PreparedMesh pm;
  LightFrame frame;
  std::vector<Vec3d> fp;
  std::vector<Edge> edges;
  TrianglePlanes planes;
  double M = 0.0;
  EdgeTree tree;
  TreeSetup(const Scene& s, size_t light) {
    pm = mesh::prepare_mesh(s.mesh);
    frame = make_light_frame(s.lights[light]);
    fp = frame_positions(pm, frame);
    edges = mesh_edges(pm);
    planes = triangle_planes(pm);
    const AABB b = s.bounds();
    M = std::max(max_component(vabs(b.lo)), max_component(vabs(b.hi)));
    tree = EdgeTree(edges, pm, M);
  }
};

// Whether edge e can add a piece or a doubt for receiver r: some incident triangle
// active with r on its front side and another not (weight != 0), or r within twice the
// doubt threshold of an active incident triangle's plane (ReceiverIntegrator::facing).
// The weight sign(facing(T1)) - sign(facing(T2)) of active triangles, and whether r lies
// within twice the doubt threshold of an active triangle's plane.
void weight_and_doubt(const TreeSetup& st, const Edge& e, const Vec3d& r, int& w, bool& near) {
  w = 0;
  near = false;
  for (int k = 0; k < 2; ++k) {
    const int32_t t = k == 0 ? e.t1 : e.t2;
    if (t < 0) continue;
    const auto& v = st.pm.triangles[size_t(t)].v;
    if (!(st.fp[v[0]].z > 0.0 || st.fp[v[1]].z > 0.0 || st.fp[v[2]].z > 0.0)) continue;
    const TrianglePlane& p = st.planes[size_t(t)];
    const double f = dot(p.unit(), r - p.a);
    double reach = 0.0;
    for (int c = 0; c < 3; ++c) reach = std::max(reach, length(r - to_double(st.pm.corner(size_t(t), c))));
    near |= std::abs(f) <= 0x1p-19 * reach;
    const int s = (f > 0.0) - (f < 0.0);
    w += k == 0 ? s : -s;
  }
}
int exact_weight(const TreeSetup& st, const Edge& e, const Vec3d& r) {
  int w = 0;
  bool near = false;
  weight_and_doubt(st, e, r, w, near);
  return w;
}
bool near_edge_on(const TreeSetup& st, const Edge& e, const Vec3d& r) {
  int w = 0;
  bool near = false;
  weight_and_doubt(st, e, r, w, near);
  return near;
}
bool may_count(const TreeSetup& st, const Edge& e, const Vec3d& r) {
  int w = 0;
  bool near = false;
  weight_and_doubt(st, e, r, w, near);
  return w != 0 || near || e.t2 < 0;
}

// `culls`: also expect the tree to leave most (edge, receiver) pairs (dense meshes away
// from the receivers; not loose triangles over them, nor far-origin's loose eps).
void expect_candidates_hold_brute_force(const Scene& s, const char* what, bool culls) {
  size_t must = 0, candidates = 0, pairs = 0, proven = 0;
  for (size_t l = 0; l < s.lights.size() && l < 3; ++l) {
    const TreeSetup st(s, l);
    const float eps = float(4e-6 * st.M);
    // Batches of 8 receivers in index order: the frontier of their box (nodes of at most
    // 64 edges, and 256 as the solver takes on denser meshes), then each query.
    for (const uint32_t frontier_edges : {64u, 256u})
    for (size_t b0 = 0; b0 < s.receivers.size(); b0 += 8) {
      AABBd box;
      std::vector<size_t> batch;
      for (size_t i = b0; i < std::min(b0 + 8, s.receivers.size()); ++i) {
        if (!(st.frame.to_local(s.receivers[i].p).z > 1e-6)) continue;  // the solver casts rays
        box.extend(to_double(s.receivers[i].p));
        batch.push_back(i);
      }
      if (batch.empty()) continue;
      std::vector<uint32_t> starts, got;
      st.tree.frontier(EdgeFrustum(st.frame, box), st.frame, eps, frontier_edges, starts);
      // The batched walk gives each receiver exactly its own query's list.
      std::vector<EdgeFrustum> fs;
      for (size_t i : batch) fs.emplace_back(st.frame, s.receivers[i].p);
      std::vector<std::vector<uint32_t>> lists(fs.size(), std::vector<uint32_t>{7u});
      st.tree.query_batch(fs.data(), fs.size(), st.frame, eps, starts, lists.data());
      for (size_t k = 0; k < batch.size(); ++k) {
        const size_t i = batch[k];
        st.tree.query(EdgeFrustum(st.frame, s.receivers[i].p), st.frame, eps, starts, got);
        EXPECT_EQ(lists[k], got) << what << ": light " << l << " receiver " << i << " batched";
        const Vec3d r = to_double(s.receivers[i].p), rl = st.frame.to_local(s.receivers[i].p);
        // A weight the leaf proved is the exact one, with neither triangle near edge-on.
        for (uint32_t& c : got) {
          const uint32_t e = c & EdgeTree::kEdgeMask;
          if (c != e) {
            ++proven;
            const int w = c & EdgeTree::kWeightPlus2 ? 2 : -2;
            EXPECT_EQ(exact_weight(st, st.edges[e], r), w) << what << ": light " << l << " receiver " << i << " edge " << e;
            EXPECT_FALSE(near_edge_on(st, st.edges[e], r)) << what << ": edge " << e;
          }
          c = e;
        }
        std::sort(got.begin(), got.end());
        EXPECT_TRUE(std::adjacent_find(got.begin(), got.end()) == got.end()) << "an edge returned twice";
        for (size_t e = 0; e < st.edges.size(); ++e) {
          const Edge& ed = st.edges[e];
          if (!meets_frustum(st.fp[ed.a], st.fp[ed.b], rl, st.frame) || !may_count(st, ed, r)) continue;
          ++must;
          EXPECT_TRUE(std::binary_search(got.begin(), got.end(), uint32_t(e)))
              << what << ": light " << l << " receiver " << i << " edge " << e;
        }
        candidates += got.size();
        pairs += st.edges.size();
      }
    }
  }
  EXPECT_GT(must, 20u) << what;
  if (culls) {
    EXPECT_GT(proven, 0u) << what;
  }
  // Batches of more than eight receivers (walked eight at a time) from the root.
  for (size_t l = 0; l < s.lights.size() && l < 2; ++l) {
    const TreeSetup st(s, l);
    const float eps = float(4e-6 * st.M);
    std::vector<EdgeFrustum> fs;
    for (size_t i = 0; i < s.receivers.size() && fs.size() < 21; ++i)
      if (st.frame.to_local(s.receivers[i].p).z > 1e-6) fs.emplace_back(st.frame, s.receivers[i].p);
    const std::vector<uint32_t> root{uint32_t(st.tree.node_count() - 1)};
    std::vector<std::vector<uint32_t>> lists(fs.size());
    std::vector<uint32_t> got;
    st.tree.query_batch(fs.data(), fs.size(), st.frame, eps, root, lists.data());
    for (size_t k = 0; k < fs.size(); ++k) {
      st.tree.query(fs[k], st.frame, eps, root, got);
      EXPECT_EQ(lists[k], got) << what << ": light " << l << " receiver " << k << " of a batch of " << fs.size();
    }
    // With a cap (edge_rays): a list of at most cap is the whole list, a longer one a
    // prefix of it of at most cap + 8 (a leaf's edges), batched or not.
    for (const uint32_t cap : {1u, 5u, 20u}) {
      std::vector<std::vector<uint32_t>> capped(fs.size());
      st.tree.query_batch(fs.data(), fs.size(), st.frame, eps, root, capped.data(), cap);
      for (size_t k = 0; k < fs.size(); ++k) {
        st.tree.query(fs[k], st.frame, eps, root, got, cap);
        EXPECT_EQ(capped[k], got) << what << ": cap " << cap << " receiver " << k;
        if (lists[k].size() <= cap) {
          EXPECT_EQ(got, lists[k]) << what << ": cap " << cap << " receiver " << k;
        } else {
          EXPECT_GT(got.size(), size_t(cap)) << what;
          EXPECT_LE(got.size(), size_t(cap) + 8) << what;
          EXPECT_TRUE(std::equal(got.begin(), got.end(), lists[k].begin())) << what << ": cap " << cap;
        }
      }
    }
  }
  if (culls) {
    EXPECT_LT(candidates * 4, pairs) << what << ": the tree culls nothing";
  }
}

// A scan whose object's vertices are jittered by about an edge length: silhouettes
// everywhere, like a noisy scanned surface (CGAL's bunny and armadillo); lights
// `light_scale` times larger for wider frusta.
Scene noisy_scan(long triangles, long receivers, double light_scale) {
  Scene noisy = family("scan", 4, triangles, receivers, 8, light_scale);
  std::mt19937_64 g(9);
  std::uniform_real_distribution<float> u(-0.02f, 0.02f);
  for (Vec3f& v : noisy.mesh.vertices)
    if (v.z > 0.05f) v = v + Vec3f(u(g), u(g), u(g));  // the object, not the ground slab
  return noisy;
}

}  // namespace

TEST(SsvEdgeTree, EveryEdgeThatCanCountIsACandidate) {
  // Loose triangles crossing the light plane, closed meshes, single edges of an
  // inconsistently oriented pair and a non-manifold fan.
  expect_candidates_hold_brute_force(random_scene(12, 16, 200), "random", false);
  expect_candidates_hold_brute_force(random_scene(31, 16, 200), "random 31", false);
  for (const char* fam : {"scan", "columns", "torus", "foliage"})
    expect_candidates_hold_brute_force(family(fam, 4, -1, 64, 16), fam, true);
  for (const char* fam : {"grid-snapped", "far-origin", "on-surface", "sliver-soup"})
    expect_candidates_hold_brute_force(family(fam, 4, -1, 64, 16), fam, false);
  // The leaves' per-edge facing test where it removes most candidates.
  expect_candidates_hold_brute_force(noisy_scan(8000, 64, 3.0), "noisy scan", true);
}

TEST(SsvEdgeTree, UnitNormalsAreTrianglePlanesRoundedToFloat) {
  // The build's two-lane normal against triangle_plane(m, t).unit() in scalar double,
  // bit for bit: random triangles at several scales and offsets, needles, collinear and
  // repeated corners (no plane: 0).
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  size_t planes = 0;
  for (int i = 0; i < 20000; ++i) {
    const float scale = std::ldexp(1.0f, int(rng() % 60) - 30), off = std::ldexp(u(rng), int(rng() % 40) - 10);
    Vec3f c[3];
    for (Vec3f& v : c) v = Vec3f(off + scale * u(rng), off + scale * u(rng), scale * u(rng));
    if (i % 5 == 1) c[2] = c[0] + (c[1] - c[0]) * 0.5f;  // collinear (up to rounding)
    if (i % 5 == 2) c[2] = c[1];                         // repeated corner
    if (i % 5 == 3) c[2] = c[0] + Vec3f(0.0f, 0.0f, std::ldexp(scale, -20));  // needle
    TriangleSoup soup;
    soup.vertices = {c[0], c[1], c[2]};
    soup.triangles = {{0, 1, 2}};
    mesh::PreparedMesh m;
    m.vertex_pos = soup.vertices;
    m.triangles.resize(1);
    m.triangles[0].v = {0, 1, 2};
    const TrianglePlane p = triangle_plane(m, 0);
    const Vec3f want(p.unit());
    bool has_plane = false;
    const Vec3f got = tree_unit_normal(c[0], c[1], c[2], has_plane);
    ASSERT_EQ(has_plane, p.nn > 0.0) << i;
    planes += has_plane ? 1 : 0;
    for (int k = 0; k < 3; ++k) {
      uint32_t a = 0, b = 0;
      std::memcpy(&a, &want[k], 4);
      std::memcpy(&b, &got[k], 4);
      ASSERT_EQ(a, b) << "triangle " << i << " component " << k;
    }
  }
  EXPECT_GT(planes, 10000u);  // most have a plane (not the repeated corners, nor corners a large offset rounds together)
}

TEST(SsvEdgeTree, BoxFrustumHoldsEachReceiversFrustum) {
  // Points r + t (l - r), l in L', t in [0, 1], of every receiver in the box lie inside
  // every plane and the box of the box's frustum.
  Scene s = random_scene(5, 16, 64);
  const LightFrame frame = make_light_frame(s.lights[0]);
  std::mt19937_64 g(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  AABBd box;
  for (const Receiver& rc : s.receivers) box.extend(to_double(rc.p));
  const EdgeFrustum f(frame, box);
  EXPECT_EQ(f.count, 1 + int(frame.poly_world.size()));
  for (const Receiver& rc : s.receivers) {
    const Vec3d r = to_double(rc.p);
    for (int k = 0; k < 50; ++k) {
      // A point of L': a convex combination of two edges' points.
      const size_t n = frame.poly_world.size(), i = size_t(u(g) * double(n)) % n;
      const Vec3d l = frame.poly_world[i] + (frame.origin - frame.poly_world[i]) * u(g);
      const Vec3d x = r + (l - r) * u(g);
      for (int p = 0; p < f.count; ++p) EXPECT_GE(dot(f.n[p], x) - f.d[p], -1e-8);
      for (int c = 0; c < 3; ++c) {
        EXPECT_GE(x[c], f.box.lo[c] - 1e-12);
        EXPECT_LE(x[c], f.box.hi[c] + 1e-12);
      }
    }
  }
}

TEST(SsvEdgeTree, CrossingTrianglesHoldEveryLightPlaneCut) {
  for (uint64_t seed : {12u, 31u, 40u}) {
    Scene s = random_scene(seed, 16, 16);
    const TreeSetup st(s, 0);
    std::vector<uint32_t> crossing;
    st.tree.crossing_triangles(st.edges, st.frame, crossing);
    EXPECT_TRUE(std::is_sorted(crossing.begin(), crossing.end()));
    size_t straddling = 0;
    for (size_t t = 0; t < st.pm.triangles.size(); ++t) {
      bool pos = false, neg = false;
      for (uint32_t v : st.pm.triangles[t].v) {
        pos |= st.fp[v].z > 0.0;
        neg |= st.fp[v].z < 0.0;
      }
      if (!(pos && neg)) continue;
      ++straddling;
      EXPECT_TRUE(std::binary_search(crossing.begin(), crossing.end(), uint32_t(t))) << "triangle " << t;
    }
    EXPECT_GT(straddling, 0u) << "seed " << seed;
    EXPECT_LT(crossing.size(), st.pm.triangles.size()) << "seed " << seed;
    EXPECT_EQ(light_plane_cuts(st.pm, st.fp, st.frame, crossing), light_plane_cuts(st.pm, st.fp, st.frame));
  }
}

TEST(SsvEdgeTree, SolverAnswersEqualTheWedgeIndexes) {
  auto same = [](const Scene& s, const std::string& what) {
    // The indexes' integration (edge_rays would answer some receivers by rays instead).
    SolveOptions a, b, c;
    a.opts["edge_rays"] = b.opts["edge_rays"] = c.opts["edge_rays"] = "off";
    a.opts["wedge_index"] = "edges";
    b.opts["wedge_index"] = "receivers";
    c.opts["wedge_index"] = "bsp";
    const SolveResult ra = make_solver("ssv")->solve(s, a), rb = make_solver("ssv")->solve(s, b),
                      rc = make_solver("ssv")->solve(s, c);
    ASSERT_EQ(ra.receivers.size(), rb.receivers.size());
    for (size_t i = 0; i < ra.receivers.size(); ++i) {
      EXPECT_EQ(ra.receivers[i].visible_bits, rb.receivers[i].visible_bits) << what << " receiver " << i;
      EXPECT_EQ(ra.receivers[i].visible_bits, rc.receivers[i].visible_bits) << what << " receiver " << i;
    }
    EXPECT_EQ(ra.stats.get("wedges"), 0.0) << what;
    EXPECT_EQ(ra.stats.get("edge_index"), 1.0) << what;
    EXPECT_EQ(rb.stats.get("edge_index"), 0.0) << what;
    EXPECT_GT(ra.stats.get("wedges_validated"), 0.0) << what;
  };
  for (const char* fam : {"columns", "torus", "random-soup", "foliage", "sliver-soup", "grid-snapped", "scan",
                          "far-origin", "on-surface", "pouch", "double-surface", "shared-edge-fan"})
    same(family(fam, 4, -1, 144, 16), fam);
  same(family("rooms", 4, 7000, 144, 16), "rooms");
  same(random_scene(12, 16, 200), "random 12");
  same(random_scene(77, 16, 200), "random 77");
}

TEST(SsvEdgeTree, AutoPicksTheEdgesForDenseSmoothMeshes) {
  // scan: far more edges than receivers; columns: fewer. A scan whose vertices are
  // jittered by about an edge length (silhouettes everywhere, like a noisy scanned
  // surface) gives every receiver hundreds of silhouette edges: auto takes the edges
  // there too (the leaves' per-edge facing test keeps the candidates near the validated
  // edges), with the same answers as the wedges.
  const SolveOptions o;
  EXPECT_EQ(make_solver("ssv")->solve(family("scan", 4, 8000, 64, 8), o).stats.get("edge_index"), 1.0);
  EXPECT_EQ(make_solver("ssv")->solve(family("columns", 4, -1, 1024, 8), o).stats.get("edge_index"), 0.0);
  // Its candidates, integrated (edge_rays would cast these receivers: hundreds of edges
  // for 64 samples).
  const Scene noisy = noisy_scan(30000, 64, 3.0);
  SolveOptions n;
  n.opts["edge_rays"] = "off";
  const SolveResult a = make_solver("ssv")->solve(noisy, n);
  SolveOptions e = n;
  e.opts["wedge_index"] = "receivers";
  const SolveResult b = make_solver("ssv")->solve(noisy, e);
  EXPECT_EQ(a.stats.get("edge_index"), 1.0);
  EXPECT_GT(a.stats.get("wedges_validated"), 100.0);
  // Candidates within a few percent of the edges that validate (the wedges' are more).
  EXPECT_LT(a.stats.get("wedges_reported"), 1.05 * a.stats.get("wedges_validated"));
  EXPECT_GT(b.stats.get("wedges_reported"), a.stats.get("wedges_reported"));
  for (size_t i = 0; i < a.receivers.size(); ++i)
    EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << "receiver " << i;
}

// The edge index's on-use sources (wedge.h PlaneSource, ReceiverIntegrator::plane,
// integrate.h FramePositions) against the arrays the wedge indexes build: the same
// doubles, bit for bit, whatever the access order (random, so the direct-mapped caches
// evict and refill: the scan mesh has more triangles and vertices than their slots).
TEST(SsvEdgeTree, OnUsePlanesAndFramePositionsEqualTheArrays) {
  const Scene s = family("scan", 5, 40000, 16, 8);
  const mesh::PreparedMesh pm = mesh::prepare_mesh(s.mesh);
  const TrianglePlanes planes = triangle_planes(pm);
  ASSERT_GT(pm.triangles.size(), 16384u);
  ASSERT_GT(pm.vertex_pos.size(), 16384u);
  const LightFrame frame = make_light_frame(s.lights[0]);
  const std::vector<Vec3d> fp = frame_positions(pm, frame);
  const ReceiverIntegrator on_use(pm, PlaneSource{&pm, nullptr}, FramePositions(pm.vertex_pos, frame), frame);
  const FramePositions from_array(fp);
  auto same = [](const Vec3d& a, const Vec3d& b) { return a.x == b.x && a.y == b.y && a.z == b.z; };
  std::mt19937_64 g(3);
  for (int pass = 0; pass < 3; ++pass) {
    for (int k = 0; k < 20000; ++k) {
      const size_t t = size_t(g() % pm.triangles.size());
      const TrianglePlane a = on_use.plane(t), b = planes[t], c = triangle_plane(pm, t);
      EXPECT_TRUE(same(a.n, b.n) && same(a.a, b.a) && a.nn == b.nn && a.reach2 == b.reach2) << "triangle " << t;
      EXPECT_TRUE(same(c.n, b.n) && same(c.a, b.a) && c.nn == b.nn && c.reach2 == b.reach2) << "triangle " << t;
      const uint32_t v = uint32_t(g() % pm.vertex_pos.size());
      EXPECT_TRUE(same(on_use.positions()[v], fp[v])) << "vertex " << v;
      EXPECT_TRUE(same(from_array[v], fp[v])) << "vertex " << v;
    }
  }
  // Every light-plane cut and edge crossing point: the on-use positions give the array's.
  for (uint64_t seed : {12u, 31u}) {
    Scene r = random_scene(seed, 16, 16);
    const TreeSetup st(r, 0);
    std::vector<uint32_t> all(st.pm.triangles.size());
    for (size_t t = 0; t < all.size(); ++t) all[t] = uint32_t(t);
    const FramePositions on_use_fp(st.pm.vertex_pos, st.frame);
    EXPECT_EQ(light_plane_cuts(st.pm, on_use_fp, st.frame, all), light_plane_cuts(st.pm, st.fp, st.frame));
    size_t crossing_pairs = 0;
    for (const Edge& e : st.edges) {
      if ((st.fp[e.a].z < 0.0) == (st.fp[e.b].z < 0.0)) continue;  // the callers ask crossing pairs only
      EXPECT_TRUE(same(light_plane_point(on_use_fp, e.a, e.b), light_plane_point(st.fp, e.a, e.b)));
      EXPECT_TRUE(same(light_plane_point(on_use_fp, e.b, e.a), light_plane_point(st.fp, e.b, e.a)));
      ++crossing_pairs;
    }
    EXPECT_GT(crossing_pairs, 0u) << "seed " << seed;
  }
  // The occluders from planes computed on use: the same list as from the array.
  for (const char* fam : {"rooms", "columns", "scan"}) {
    const Scene f = family(fam, 2, fam[0] == 's' ? 8000 : -1, 16, 8);
    const mesh::PreparedMesh m = mesh::prepare_mesh(f.mesh);
    const std::vector<Edge> edges = mesh_edges(m);
    const auto a = planar_occluders(m, edges, triangle_planes(m), 1024, 0.01);
    const auto b = planar_occluders(m, edges, PlaneSource{&m, nullptr}, 1024, 0.01);
    ASSERT_EQ(a.size(), b.size()) << fam;
    EXPECT_GT(a.size(), 0u) << fam;
    auto expect_same = [&](const std::vector<PlanarOccluder>& x, const std::vector<PlanarOccluder>& y, const char* what) {
      ASSERT_EQ(x.size(), y.size()) << fam << " " << what;
      for (size_t i = 0; i < x.size(); ++i) {
        EXPECT_EQ(x[i].n, y[i].n) << fam << " " << what;
        EXPECT_TRUE(same(x[i].normal, y[i].normal) && x[i].offset == y[i].offset) << fam << " " << what << " " << i;
        for (int k = 0; k < x[i].n; ++k) EXPECT_TRUE(same(x[i].v[k], y[i].v[k])) << fam << " " << what << " " << i;
      }
    };
    expect_same(a, b, "on use");
    // And from the candidates of the edge tree's large leaves (the solver's path with the
    // edge index): the same list, at thresholds that keep a few, many or every occluder.
    const AABB fb = f.bounds();
    const EdgeTree tree(edges, m, double(std::max(max_component(vabs(fb.lo)), max_component(vabs(fb.hi)))));
    for (double min_area : {1.0, 0.01, 1e-4, 1e-8}) {
      std::vector<uint32_t> large;
      tree.large_triangle_edges(min_area * min_area, large);
      if (min_area == 1.0 && fam[0] == 's') {  // a dense mesh: most leaves are left
        EXPECT_LT(large.size(), edges.size() / 2) << fam;
      }
      expect_same(planar_occluders(m, edges, PlaneSource{&m, nullptr}, 1024, min_area),
                  planar_occluders(m, edges, PlaneSource{&m, nullptr}, 1024, min_area, &large), "large leaves");
    }
  }
}

// lib/ssv/populated.h: vectors on populated mappings (large) and operator new (small)
// hold, grow, move and swap exactly as std::vector does, with value-initialised (zero)
// contents, across the size where the allocation switches.
TEST(SsvPopulated, VectorsBehaveAsStdVector) {
  std::mt19937 rng(5);
  for (size_t n : {size_t(0), size_t(1), size_t(1000), kPopulateBytes / sizeof(uint32_t) - 1,
                   kPopulateBytes / sizeof(uint32_t), size_t(300000)}) {
    PopulatedVector<uint32_t> p(n);
    std::vector<uint32_t> s(n);
    EXPECT_TRUE(std::all_of(p.begin(), p.end(), [](uint32_t v) { return v == 0; }));
    for (size_t k = 0; k < n; ++k) p[k] = s[k] = uint32_t(rng());
    for (int k = 0; k < 70000; ++k) {  // growth through the switch and past it
      const uint32_t v = uint32_t(rng());
      p.push_back(v);
      s.push_back(v);
    }
    PopulatedVector<uint32_t> moved = std::move(p);
    ASSERT_EQ(moved.size(), s.size());
    EXPECT_TRUE(std::equal(moved.begin(), moved.end(), s.begin()));
    PopulatedVector<uint32_t> other(3, 7u);
    other.swap(moved);
    EXPECT_EQ(moved, PopulatedVector<uint32_t>(3, 7u));
    EXPECT_TRUE(std::equal(other.begin(), other.end(), s.begin(), s.end()));
    other.clear();
    other.shrink_to_fit();
    EXPECT_TRUE(other.empty());
  }
}

// PopulatedArray: zero bytes from both allocations (mmap'ed and memset), which for a
// scalar and for an aggregate with zero default member initialisers are the
// value-initialised element; moves hand the block over and leave the source empty.
TEST(SsvPopulated, ArraysStartValueInitialisedAndMove) {
  struct Item {
    float f[3];
    uint32_t a = 0;
    uint8_t b = 0;
  };
  std::mt19937 rng(9);
  for (size_t n : {size_t(0), size_t(1), size_t(1000), kPopulateBytes / sizeof(uint32_t) - 1,
                   kPopulateBytes / sizeof(uint32_t), size_t(300000)}) {
    PopulatedArray<uint32_t> p(n);
    ASSERT_EQ(p.size(), n);
    EXPECT_EQ(p.empty(), n == 0);
    const std::vector<uint32_t> zeros(n);
    EXPECT_TRUE(std::equal(p.data(), p.data() + n, zeros.begin()));
    PopulatedArray<Item> items(n);
    const Item init{};
    EXPECT_TRUE(std::all_of(items.data(), items.data() + n, [&](const Item& it) {
      return it.f[0] == init.f[0] && it.f[1] == init.f[1] && it.f[2] == init.f[2] && it.a == init.a && it.b == init.b &&
             !std::signbit(it.f[0]);
    }));
    std::vector<uint32_t> s(n);
    for (size_t k = 0; k < n; ++k) p[k] = s[k] = uint32_t(rng());
    PopulatedArray<uint32_t> moved(std::move(p));
    EXPECT_EQ(p.size(), 0u);
    EXPECT_EQ(p.data(), nullptr);
    ASSERT_EQ(moved.size(), n);
    EXPECT_TRUE(std::equal(moved.data(), moved.data() + n, s.begin()));
    PopulatedArray<uint32_t> other(5);
    other = std::move(moved);
    EXPECT_TRUE(moved.empty());
    ASSERT_EQ(other.size(), n);
    EXPECT_TRUE(std::equal(other.data(), other.data() + n, s.begin()));
  }
}
