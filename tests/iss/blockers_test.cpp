// lib/iss/blockers.cpp: blocker storage and validate() (paper 000 sections 4.4.2, 4.13).
#include <gtest/gtest.h>

#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "lib/scene/shapes.h"
#include "tests/support/iss_fixtures.h"

using namespace visgate;
using namespace visgate::test_support;

// ---- blocker representation and validate() (sections 4.4.2, 4.13) -----------------------

TEST(IssBlockers, ValidateAcceptsATriangleAndRejectsBrokenLinks) {
  iss::Surface s = one_triangle_surface(Vec3d(0, 0, 1), Vec3d(1, 0, 1), Vec3d(0, 1, 1), iss::Facing::TowardsReceiver);
  EXPECT_EQ(iss::validate(s, nullptr), "");
  iss::Surface broken = s;
  broken.hull = iss::empty_box();  // patches stand for triangles somewhere
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.hull.hi.z = 0.5;  // the hull holds every edge
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.raw[1].v[1] = Vec3d(5, 5, 5);  // the loop no longer closes
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.raw[2].nb[0] = 0;  // claims a neighbour that does not reference it
  EXPECT_NE(iss::validate(broken, nullptr), "");
  broken = s;
  broken.patches[0].facing = iss::Facing::Inconsistent;  // inconsistent needs its triangle
  EXPECT_NE(iss::validate(broken, nullptr), "");
}

// ---- the kept large surface of the pool (Workspace::big) ------------------------------

namespace {

bool same_surface(const iss::Surface& a, const iss::Surface& b) {
  if (a.raw.size() != b.raw.size() || a.edges.size() != b.edges.size() || a.patches.size() != b.patches.size())
    return false;
  for (size_t i = 0; i < a.raw.size(); ++i) {
    const iss::RawEdge &x = a.raw[i], &y = b.raw[i];
    if (x.v[0] != y.v[0] || x.v[1] != y.v[1] || x.nb[0] != y.nb[0] || x.nb[1] != y.nb[1] ||
        x.mesh_edge != y.mesh_edge || x.inside != y.inside)
      return false;
  }
  for (size_t i = 0; i < a.edges.size(); ++i)
    if (a.edges[i].raw != b.edges[i].raw || a.edges[i].flipped != b.edges[i].flipped) return false;
  for (size_t i = 0; i < a.patches.size(); ++i)
    if (a.patches[i].first != b.patches[i].first || a.patches[i].count != b.patches[i].count ||
        a.patches[i].tri != b.patches[i].tri)
      return false;
  return a.hull.lo == b.hull.lo && a.hull.hi == b.hull.hi;
}

}  // namespace

TEST(IssBlockers, TheKeptLargeSurfaceBuildsTheSameSurfaceAndIsCharged) {
  // A 48 x 48 patch grid (4,608 triangles, ~7k raw edges: above the pool's limit)
  // between a receiver square and a light square, clipped by nothing.
  Scene sc;
  shapes::add_patch(sc.mesh, Vec3d(-1, -1, 1), Vec3d(2, 0, 0.2), Vec3d(0, 2, 0), 48, 48);
  sc.lights.push_back(square_light(0, 0, 3, 2, 4));
  sc.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
  ASSERT_TRUE(finish_scene(sc).ok());
  mesh::PreparedMesh pm = mesh::prepare_mesh(sc.mesh);
  iss::BlockerContext ctx{&pm, 4.0};
  AABB r(Vec3f(-1, -1, 0), Vec3f(1, 1, 0)), l(Vec3f(-1, -1, 3), Vec3f(1, 1, 3));
  iss::ShaftGeometry g(r, l, iss::choose_main_axis(r, l), 4.0);
  iss::TreeNode rn, ln;
  std::vector<uint32_t> tris(pm.triangles.size());
  for (uint32_t t = 0; t < tris.size(); ++t) tris[t] = t;

  iss::Workspace fresh;
  iss::Surface want = iss::construct_triangle_surface(ctx, tris, g, rn, ln, fresh);
  ASSERT_EQ(iss::validate(want, &pm), "");
  ASSERT_EQ(want.patches.size(), tris.size());
  ASSERT_GT(want.raw.size(), iss::Workspace::kMaxSpareEdges);

  MemoryBudget budget("iss", 1024);
  iss::Workspace ws;
  ws.bind_budget(&budget);
  iss::Surface first = iss::construct_triangle_surface(ctx, tris, g, rn, ln, ws);
  const iss::RawEdge* kept = first.raw.data();
  ws.recycle(std::move(first));
  EXPECT_EQ(ws.big.raw.data(), kept) << "kept, not freed";
  EXPECT_TRUE(ws.big.raw.empty() && ws.big.patches.empty() && ws.big.hull.empty()) << "cleared";
  EXPECT_TRUE(ws.spare.empty()) << "not in the small pool";
  // A construction expecting many edges takes it, and builds what a fresh one builds.
  iss::Surface again = iss::construct_triangle_surface(ctx, tris, g, rn, ln, ws);
  EXPECT_EQ(again.raw.data(), kept);
  EXPECT_EQ(ws.big.raw.capacity(), 0u);
  EXPECT_TRUE(same_surface(again, want));
  // Small constructions do not take it.
  ws.recycle(std::move(again));
  iss::Surface small = iss::construct_triangle_surface(ctx, {0, 1}, g, rn, ln, ws);
  EXPECT_NE(small.raw.data(), kept);
  EXPECT_EQ(ws.big.raw.data(), kept);
  EXPECT_EQ(small.patches.size(), 2u);

  // The kept surface is counted: a budget below its size stops the recycle.
  MemoryBudget tiny("iss", 1);
  iss::Workspace ws2;
  ws2.bind_budget(&tiny);
  iss::Surface big = iss::construct_triangle_surface(ctx, tris, g, rn, ln, ws2);
  ASSERT_GT(big.bytes(), size_t(1) << 20);
  EXPECT_THROW(ws2.recycle(std::move(big)), MemoryBudgetExceeded);
}
