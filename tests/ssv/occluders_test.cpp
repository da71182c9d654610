// lib/ssv/occluders.h: umbra culling by planar convex occluders, and the solver's shaft
// culling of edges. The shaft test on hand-worked cases and against sampled segments, the
// occluder list of a box, the receiver tree, the culling against direct counting, and the
// solver with culling on against culling off and against the exact oracle on adversarial
// scenes (occluder edges on shadow boundaries, receivers on occluder planes, samples on
// the light's boundary).
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "lib/mesh/prepare.h"
#include "lib/scene/shapes.h"
#include "lib/solver.h"
#include "lib/ssv/occluders.h"
#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tests/support/ssv_fixtures.h"

using namespace visgate;
using namespace visgate::ssv;
using namespace visgate::test_support;

namespace {

// The quad [x0, x1] x [y0, y1] at height z as an occluder (normal +z).
PlanarOccluder quad_occluder(double x0, double x1, double y0, double y1, double z) {
  TriangleSoup s;
  shapes::add_quad(s, Vec3d(x0, y0, z), Vec3d(x1, y0, z), Vec3d(x1, y1, z), Vec3d(x0, y1, z));
  const mesh::PreparedMesh pm = mesh::prepare_mesh(s);
  auto occ = planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 16);
  EXPECT_FALSE(occ.empty());
  EXPECT_EQ(occ[0].n, 4);  // the quad comes first (largest)
  return occ[0];
}

std::vector<Vec3d> square(double cx, double cy, double z, double half) {
  return {Vec3d(cx - half, cy - half, z), Vec3d(cx + half, cy - half, z), Vec3d(cx + half, cy + half, z),
          Vec3d(cx - half, cy + half, z)};
}

AABBd point_box(const Vec3d& p) { return AABBd(p, p); }

// Culling on: occluders and shafts; off: neither (the previous code path).
// Shaft culling applies to the wedge indexes: these runs use the scattered wedges (the
// edge index, the default, is compared with `edges`).
SolveResult run(const Scene& s, bool culling, const char* index = "receivers") {
  SolveOptions o;
  o.opts["occluder_culling"] = culling ? "on" : "off";
  o.opts["shaft_culling"] = culling ? "on" : "off";
  o.opts["wedge_index"] = index;
  return make_solver("ssv")->solve(s, o);
}

void expect_same_answers(const SolveResult& a, const SolveResult& b, const std::string& what) {
  ASSERT_EQ(a.receivers.size(), b.receivers.size()) << what;
  for (size_t i = 0; i < a.receivers.size(); ++i) {
    EXPECT_EQ(a.receivers[i].visible_bits, b.receivers[i].visible_bits) << what << " receiver " << i;
    EXPECT_EQ(a.receivers[i].visible_fraction, b.receivers[i].visible_fraction) << what << " receiver " << i;
  }
}

}  // namespace

TEST(OccluderShaft, HandWorked) {
  // Quad [-1, 1]^2 at z = 1, light [-0.5, 0.5]^2 at z = 2. A receiver at (x, 0, 0) sends
  // segments that cross z = 1 at x/2 + [-0.25, 0.25]: inside the quad iff x + 0.5 < 2.
  const PlanarOccluder q = quad_occluder(-1, 1, -1, 1, 1);
  const auto light = square(0, 0, 2, 0.5);
  const double m = 1e-5 * 4;
  EXPECT_TRUE(occluder_blocks_shaft(q, point_box(Vec3d(0, 0, 0)), light, m));
  EXPECT_TRUE(occluder_blocks_shaft(q, point_box(Vec3d(1.4, 0, 0)), light, m));
  EXPECT_FALSE(occluder_blocks_shaft(q, point_box(Vec3d(1.5, 0, 0)), light, m));  // grazes the edge x = 1
  EXPECT_FALSE(occluder_blocks_shaft(q, point_box(Vec3d(1.6, 0, 0)), light, m));
  // A box: blocked iff every corner is.
  EXPECT_TRUE(occluder_blocks_shaft(q, AABBd(Vec3d(-1.4, -1.4, 0), Vec3d(1.4, 1.4, 0)), light, m));
  EXPECT_FALSE(occluder_blocks_shaft(q, AABBd(Vec3d(-1.4, -1.4, 0), Vec3d(1.6, 1.4, 0)), light, m));
  // Receivers on the occluder's plane, above it, and a light straddling it: never.
  EXPECT_FALSE(occluder_blocks_shaft(q, point_box(Vec3d(0, 0, 1)), light, m));
  EXPECT_FALSE(occluder_blocks_shaft(q, point_box(Vec3d(0, 0, 1.5)), light, m));
  EXPECT_FALSE(occluder_blocks_shaft(q, AABBd(Vec3d(0, 0, 0), Vec3d(0, 0, 1)), light, m));
  EXPECT_FALSE(occluder_blocks_shaft(q, point_box(Vec3d(0, 0, 0)), square(0, 0, 1, 0.5), m));
  // The same from the other side (light below, receiver above).
  EXPECT_TRUE(occluder_blocks_shaft(q, point_box(Vec3d(0, 0, 2)), square(0, 0, 0, 0.5), m));
}

TEST(OccluderShaft, EverySampledSegmentOfABlockedShaftCrossesTheOccluder) {
  // Random tilted convex quads and triangles, boxes and lights: whenever the test says
  // blocked, segments from random box points to random points of the light's hull cross
  // the occluder inside (direct double test); many configurations must be blocked and many
  // not, so the property is not vacuous.
  std::mt19937_64 g(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  int blocked = 0, open = 0;
  for (int it = 0; it < 3000; ++it) {
    // A convex quad around (0, 0, 1), or one of its triangles, tilted (a tilted quad
    // rounded to float is not exactly planar: its larger triangle is the occluder).
    const double tilt = it % 3 == 1 ? 0.0 : 0.6 * (u(g) - 0.5), sx = 0.5 + u(g), sy = 0.5 + u(g);
    auto P = [&](double x, double y) { return Vec3d(x * sx, y * sy, 1 + tilt * x + 0.3 * tilt * y); };
    TriangleSoup s;
    const Vec3d a = P(-1, -1), b = P(1, -1.2), c = P(1.1, 1), d = P(-1, 0.9);
    if (it % 3 == 0) {
      s.vertices = {Vec3f(a), Vec3f(b), Vec3f(c)};
      s.triangles = {{0, 1, 2}};
    } else {
      shapes::add_quad(s, a, b, c, d);
    }
    const mesh::PreparedMesh pm = mesh::prepare_mesh(s);
    auto occ = planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 8);
    ASSERT_FALSE(occ.empty());
    const PlanarOccluder& o = occ[0];
    const Vec3d lc = rand_point(g, Vec3d(-0.6, -0.6, 1.8), Vec3d(0.6, 0.6, 2.4));
    std::vector<Vec3d> light = square(lc.x, lc.y, lc.z, 0.05 + 0.4 * u(g));
    light[2].z += 0.1 * (u(g) - 0.5);  // not necessarily planar: the hull counts
    const Vec3d bc = rand_point(g, Vec3d(-1.2, -1.2, -0.2), Vec3d(1.2, 1.2, 0.4));
    const Vec3d half = rand_point(g, Vec3d(0, 0, 0), Vec3d(0.4, 0.4, 0.1));
    const AABBd box(bc - half, bc + half);
    if (!occluder_blocks_shaft(o, box, light, 1e-5 * 4)) {
      ++open;
      continue;
    }
    ++blocked;
    for (int k = 0; k < 50; ++k) {
      const Vec3d r = rand_point(g, box.lo, box.hi);
      double w[4], sum = 0;
      for (double& x : w) sum += (x = u(g));
      Vec3d l(0, 0, 0);
      for (int j = 0; j < 4; ++j) l = l + light[size_t(j)] * (w[j] / sum);
      int hit = 0;
      for (size_t t = 0; t < s.triangles.size(); ++t)
        hit = std::max(hit, segment_vs_triangle(r, l, to_double(s.corner(t, 0)), to_double(s.corner(t, 1)),
                                                to_double(s.corner(t, 2)), 1e-9));
      // A crossing on the quad's diagonal is too close to call for either triangle; it
      // still crosses the quad.
      EXPECT_NE(hit, 0) << "iteration " << it;
    }
  }
  EXPECT_GT(blocked, 300);
  EXPECT_GT(open, 300);
}

TEST(PlanarOccluders, BoxFacesBecomeQuadsAndBentPairsDoNot) {
  TriangleSoup s;
  shapes::add_box(s, Vec3d(0, 0, 0), Vec3d(2, 1, 3));
  // A bent pair: two triangles sharing an edge, not coplanar.
  s.vertices.push_back(Vec3f(5, 0, 0));
  s.vertices.push_back(Vec3f(9, 0, 0));
  s.vertices.push_back(Vec3f(9, 4, 0.5f));
  s.vertices.push_back(Vec3f(5, 4, 0));
  const uint32_t b = uint32_t(s.vertices.size()) - 4;
  s.triangles.push_back({b, b + 1, b + 2});
  s.triangles.push_back({b, b + 2, b + 3});
  const mesh::PreparedMesh pm = mesh::prepare_mesh(s);
  auto occ = planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 100);
  int quads = 0, tris = 0;
  double quad_area = 0;
  for (const auto& o : occ) {
    if (o.n == 4) {
      ++quads;
      quad_area += o.area;
      EXPECT_LT(o.box.hi.x, 2.5) << "the bent pair is no quad";
    } else {
      ++tris;
    }
  }
  EXPECT_EQ(quads, 6);
  EXPECT_EQ(tris, 14);
  EXPECT_NEAR(quad_area, 2 * (2 * 1 + 2 * 3 + 1 * 3), 1e-9);
  for (size_t k = 1; k < occ.size(); ++k) EXPECT_GE(occ[k - 1].area, occ[k].area);
  // The count limit keeps the largest, the area limit drops the small.
  auto few = planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 2);
  ASSERT_EQ(few.size(), 2u);
  EXPECT_NEAR(few[0].area, 0.5 * std::sqrt(260.0), 1e-6);  // a triangle of the bent pair
  EXPECT_TRUE(planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 100, 100.0).empty());
}

TEST(ReceiverTree, PartitionsTheReceiversWithExactBounds) {
  std::mt19937_64 g(5);
  std::vector<Vec3d> pts;
  for (int i = 0; i < 1000; ++i) pts.push_back(rand_point(g, Vec3d(-3, -1, 0), Vec3d(3, 1, 0.5)));
  pts.push_back(pts[7]);  // a duplicate
  ReceiverTree t(pts, 4);
  std::vector<int> seen(pts.size(), 0);
  for (uint32_t i : t.order()) ++seen[i];
  for (int c : seen) EXPECT_EQ(c, 1);
  for (const auto& n : t.nodes()) {
    AABBd b;
    for (uint32_t p = n.begin; p < n.end; ++p) b.extend(pts[t.order()[p]]);
    EXPECT_EQ(b.lo, n.box.lo);
    EXPECT_EQ(b.hi, n.box.hi);
    if (n.left < 0) {
      EXPECT_LE(n.end - n.begin, 4u);
    } else {
      EXPECT_EQ(t.nodes()[size_t(n.left)].begin, n.begin);
      EXPECT_EQ(t.nodes()[size_t(n.left)].end, t.nodes()[size_t(n.right)].begin);
      EXPECT_EQ(t.nodes()[size_t(n.right)].end, n.end);
    }
  }
}

TEST(OccluderCulling, CulledReceiversAreBlockedByDirectCounting) {
  // Walls with a gap between a receiver floor and a light: every culled receiver has
  // every sample blocked by direct counting, and receivers in the gap's light are kept.
  for (uint64_t seed : {1, 2, 3}) {
    Scene s = random_scene(seed, 16, 400);
    // Crossing z = 0.5 at 0.75 x_r + [-0.175, 0.225]: culled for x_r <= -0.3 and x_r >= 0.64.
    shapes::add_quad(s.mesh, Vec3d(-3, -3, 0.5), Vec3d(0, -3, 0.5), Vec3d(0, 3, 0.5), Vec3d(-3, 3, 0.5));
    shapes::add_quad(s.mesh, Vec3d(0.3, -3, 0.5), Vec3d(3, -3, 0.5), Vec3d(3, 3, 0.5), Vec3d(0.3, 3, 0.5));
    ASSERT_TRUE(finish_scene(s).ok());
    const mesh::PreparedMesh pm = mesh::prepare_mesh(s.mesh);
    auto occ = planar_occluders(pm, mesh_edges(pm), triangle_planes(pm), 64);
    std::vector<Vec3d> pts;
    for (const auto& r : s.receivers) pts.push_back(to_double(r.p));
    ReceiverTree tree(pts, 4);
    std::vector<Vec3d> light;
    for (const Vec3f& p : s.lights[0].polygon) light.push_back(to_double(p));
    std::vector<uint8_t> blocked(pts.size(), 0);
    const size_t n = cull_occluded_receivers(tree, occ, light, 1e-5 * 4, blocked);
    EXPECT_GT(n, 50u) << seed;
    EXPECT_LT(n, pts.size()) << seed;
    size_t counted = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      counted += blocked[i];
      if (!blocked[i]) continue;
      for (int j = 0; j < s.lights[0].samples; ++j)
        EXPECT_NE(direct_depth(s.mesh, s.receivers[i].p, sample_position(s.lights[0], j, i)), 0)
            << "seed " << seed << " receiver " << i << " sample " << j;
    }
    EXPECT_EQ(counted, n);
  }
}

TEST(OccluderCulling, SolverAnswersUnchangedOnFamilies) {
  // Culling on and off give the same bits on rooms (walls and slabs cull most relations),
  // columns and foliage (little or nothing to cull), and match the exact oracle.
  for (const char* fam : {"rooms", "columns", "foliage", "grid-snapped", "far-origin"}) {
    Scene s = family(fam, 2, -1, 144, 16);
    const SolveResult on = run(s, true), off = run(s, false);
    expect_same_answers(on, off, fam);
    expect_same_answers(run(s, true, "edges"), off, std::string(fam) + " edge index");
    if (std::string(fam) == "rooms") {
      EXPECT_GT(on.stats.get("occluded_relations"), 0.5 * double(s.relation_count()));
      EXPECT_GT(on.stats.get("edges_outside_shafts"), 0.0);
    }
    EXPECT_EQ(off.stats.get("occluded_relations"), 0.0);
    EXPECT_EQ(off.stats.get("edges_outside_shafts"), 0.0);
  }
  Scene s = family("rooms", 3, 3000, 64, 16);
  oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
  EXPECT_GT(expect_matches_oracle(s, ex, run(s, true), "rooms culled"), 10000u);
}

TEST(OccluderCulling, SolverAnswersUnchangedOnShadowBoundariesAndOccluderPlanes) {
  // A wall quad x <= 1 at z = 1 under a light [-0.5, 0.5]^2 at z = 2 with samples on a
  // grid including the light's boundary: receivers at x = 1.5 send the segment to the
  // samples at x = 0.5 exactly along the wall's edge; receivers around it within 1e-6,
  // receivers on the wall's plane (beside it and on it) and on its edge. Culling on and
  // off must agree, and agree with the oracle where it is not degenerate.
  for (const Vec3d& shift : {Vec3d(0, 0, 0), Vec3d(1024, -512, 256)}) {
    Scene s;
    s.name = "occluder-boundary";
    Light l = grid_sampled_light();
    for (auto& p : l.polygon) p = Vec3f(to_double(p) + shift);
    for (auto& p : l.explicit_samples) p = Vec3f(to_double(p) + shift);
    s.lights.push_back(l);
    shapes::add_quad(s.mesh, Vec3d(-3, -3, 1) + shift, Vec3d(1, -3, 1) + shift, Vec3d(1, 3, 1) + shift,
                     Vec3d(-3, 3, 1) + shift);
    add_receiver_grid(s, -2.5 + shift.x, 0.5 + shift.x, -2 + shift.y, 2 + shift.y, shift.z, 4);
    for (double x : {0.0, 1.0, 1.4, 1.5 - 1e-6, 1.5, 1.5 + 1e-6, 1.6, 3.0})
      for (double z : {0.0, 1.0, 0.5})
        s.receivers.push_back({Vec3f(Vec3d(x, 0.25 * x, z) + shift), Vec3f(0, 0, 1)});
    ASSERT_TRUE(finish_scene(s).ok());
    const SolveResult on = run(s, true), off = run(s, false);
    expect_same_answers(on, off, "occluder boundary");
    expect_same_answers(run(s, true, "edges"), off, "occluder boundary, edge index");
    EXPECT_GT(on.stats.get("occluded_relations"), 0.0);
    oracle::RelationOracleResult ex = oracle::run_relation_oracle(s, 0);
    expect_matches_oracle(s, ex, on, "occluder boundary culled");
  }
}
