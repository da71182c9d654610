// Scene families (lib/scene/families.h, DESIGN section 7): determinism, sizes, the
// topological promises of each family checked with lib/mesh/prepare, and the geometric
// promises (aimed segments through shared edges, receivers on faces, grid snapping).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <numbers>

#include "lib/mesh/prepare.h"
#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "tests/support/family_scene.h"

namespace visgate {
namespace {

Scene gen(const std::string& f, uint64_t seed, long tris = -1, long recv = -1, long samples = -1, double ls = 1.0) {
  return test_support::family(f, seed, tris, recv, samples, ls);
}

// Distance from p to segment ab, in double.
double point_segment_distance(const Vec3d& p, const Vec3d& a, const Vec3d& b) {
  Vec3d ab = b - a;
  double t = std::clamp(dot(p - a, ab) / dot(ab, ab), 0.0, 1.0);
  return length(p - (a + ab * t));
}

// Distance from p to triangle abc, in double (plane distance inside, else edges).
double point_triangle_distance(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  Vec3d n = cross(b - a, c - a);
  double nn = length(n);
  if (nn > 0) {
    n = n / nn;
    Vec3d q = p - n * dot(p - a, n);
    bool in = dot(cross(b - a, q - a), n) >= 0 && dot(cross(c - b, q - b), n) >= 0 && dot(cross(a - c, q - c), n) >= 0;
    if (in) return std::abs(dot(p - a, n));
  }
  return std::min({point_segment_distance(p, a, b), point_segment_distance(p, b, c), point_segment_distance(p, c, a)});
}

double signed_volume(const TriangleSoup& m) {
  double v = 0;
  for (size_t t = 0; t < m.size(); ++t)
    v += dot(to_double(m.corner(t, 0)), cross(to_double(m.corner(t, 1)), to_double(m.corner(t, 2)))) / 6.0;
  return v;
}

TEST(Families, EveryFamilyIsDeterministicBySeed) {
  for (const auto& f : family_names()) {
    long tris = f == "rooms" ? 3000 : -1;
    std::string a = write_scene_json(gen(f, 7, tris)), b = write_scene_json(gen(f, 7, tris)),
                c = write_scene_json(gen(f, 8, tris));
    EXPECT_EQ(a, b) << f;
    EXPECT_NE(a, c) << f;
  }
}

TEST(Families, EveryFamilyHasValidLightsAndFiniteInput) {
  for (const auto& f : family_names()) {
    Scene s = gen(f, 3, f == "rooms" ? 3000 : -1);
    ASSERT_FALSE(s.lights.empty()) << f;
    for (const auto& l : s.lights) {
      EXPECT_GT(l.area, 0.0) << f;
      EXPECT_EQ(l.jitter_points.size(), size_t(l.samples) * size_t(l.jitter)) << f;
    }
    EXPECT_GT(s.mesh.size(), 0u) << f;
    EXPECT_GT(s.receivers.size(), 0u) << f;
    for (const auto& v : s.mesh.vertices) ASSERT_TRUE(is_finite(v)) << f;
    for (const auto& r : s.receivers) ASSERT_TRUE(is_finite(r.p)) << f;
    // A written scene reads back to the same scene (bit-exact coordinates).
    std::string text = write_scene_json(s);
    auto back = read_scene_json(text, f, ".");
    ASSERT_TRUE(back.ok()) << f << ": " << back.error().message;
    EXPECT_EQ(write_scene_json(*back), text) << f;
  }
}

TEST(Families, SizesFollowTheParameters) {
  for (const auto& f : family_names()) {
    if (f == "columns" || f == "rooms") continue;  // checked below with their own sizes
    for (long target : {300L, 1500L}) {
      Scene s = gen(f, 5, target, 100, 8);
      double n = double(s.mesh.size());
      EXPECT_GE(n, 0.8 * double(target)) << f << " target " << target;
      EXPECT_LE(n, 1.25 * double(target)) << f << " target " << target;
      EXPECT_EQ(s.receivers.size(), 100u) << f;  // grids are 10 x 10
      for (const auto& l : s.lights) EXPECT_EQ(l.samples, 8) << f;
    }
  }
  Scene c = gen("columns", 1);
  EXPECT_NEAR(double(c.mesh.size()), 2500.0, 250.0);
  EXPECT_EQ(c.lights[0].samples, 256);
}

TEST(Families, NamesAndDefaultsAreTheDocumentedOnes) {
  // docs/harness.md's family table: triangles (0: not exact there), receivers and samples
  // per light without parameters; every scene named "<family>-<seed>".
  struct Want {
    const char* family;
    size_t triangles, receivers;
    int samples;
  };
  for (const Want& w : {Want{"random-soup", 200, 256, 16}, Want{"columns", 0, 4096, 256},
                        Want{"grid-snapped", 200, 64, 16}, Want{"shared-edge-fan", 0, 64, 16},
                        Want{"sliver-soup", 200, 64, 16}, Want{"on-surface", 0, 64, 16}, Want{"foliage", 0, 1024, 64}}) {
    Scene s = gen(w.family, 11);
    EXPECT_EQ(s.name, std::string(w.family) + "-11");
    if (w.triangles > 0) {
      EXPECT_EQ(s.mesh.size(), w.triangles) << w.family;
    }
    EXPECT_EQ(s.receivers.size(), w.receivers) << w.family;
    for (const auto& l : s.lights) EXPECT_EQ(l.samples, w.samples) << w.family;
  }
  for (const auto& f : family_names()) {
    if (f != "far-origin" && f != "rooms") {
      EXPECT_EQ(gen(f, 4).name, f + "-4");
    }
  }
  EXPECT_EQ(gen("rooms", 4, 3000).name, "rooms-4");
}

TEST(Families, RoomsScaleToMillionsOfTriangles) {
  Scene s = gen("rooms", 1, 1'000'000, 16, 4);
  EXPECT_GE(double(s.mesh.size()), 0.85e6);
  EXPECT_LE(double(s.mesh.size()), 1.15e6);
  EXPECT_GT(s.lights.size(), 27u);  // more rooms than the default building
}

TEST(Families, LightScaleScalesTheLightArea) {
  for (const char* f : {"random-soup", "torus", "shared-edge-fan", "foliage"}) {
    Scene a = gen(f, 2), b = gen(f, 2, -1, -1, -1, 0.5);
    EXPECT_NEAR(b.lights[0].area / a.lights[0].area, 0.25, 1e-6) << f;
  }
}

TEST(Families, TorusIsClosedAndConsistentlyOutward) {
  for (uint64_t seed : {1, 2, 3}) {
    Scene s = gen("torus", seed);
    test_support::expect_closed_manifold(s);
    EXPECT_GT(signed_volume(s.mesh), 0.0);  // outward: positive enclosed volume
    // A shaft through the hole: the receiver under the torus centre sees the light.
    AABB b = s.mesh.bounds();
    EXPECT_GT(b.lo.z, 0.0f);
    EXPECT_LT(b.hi.z, 2.0f);
  }
}

// Boundary edges (single edges) of a prepared mesh must form exactly one closed loop.
void expect_one_boundary_loop(const TriangleSoup& soup, size_t expected_edges, double expected_winding,
                              const Vec3d& axis_point) {
  mesh::PrepareCounts c;
  mesh::PreparedMesh m = mesh::prepare_mesh(soup, &c);
  EXPECT_EQ(mesh::validate(m), "");
  EXPECT_EQ(c.inconsistent_joins, 0u);
  EXPECT_EQ(c.nonmanifold_edges, 0u);
  EXPECT_EQ(c.single_edges, expected_edges);
  std::map<uint32_t, uint32_t> next;
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      if (t.neighbors[k] < 0) {
        EXPECT_EQ(next.count(t.v[k]), 0u) << "boundary vertex with two outgoing edges";
        next[t.v[k]] = t.v[(k + 1) % 3];
      }
  ASSERT_EQ(next.size(), expected_edges);
  uint32_t start = next.begin()->first, v = start;
  size_t steps = 0;
  double winding = 0;
  do {
    Vec3d a = to_double(m.vertex_pos[v]) - axis_point, b = to_double(m.vertex_pos[next[v]]) - axis_point;
    winding += std::atan2(a.x * b.y - a.y * b.x, a.x * b.x + a.y * b.y);
    v = next[v];
  } while (v != start && ++steps <= expected_edges);
  EXPECT_EQ(steps + 1, expected_edges) << "boundary is not one loop";
  EXPECT_NEAR(std::abs(winding) / (2 * std::numbers::pi), expected_winding, 1e-6);
}

TEST(Families, DoubleSurfaceHasOneBoundaryLoopWindingTwice) {
  for (uint64_t seed : {1, 2}) {
    Scene s = gen("double-surface", seed, 400);
    // Boundary: the outer ring, 2 * spokes edges; the centre vertex is the first vertex.
    size_t centre_fan = 0;
    for (const auto& t : s.mesh.triangles) centre_fan += t[0] == 0;
    expect_one_boundary_loop(s.mesh, centre_fan, 2.0, to_double(s.mesh.vertices[0]));
    // Self-intersecting: the two sheets over one (x, y) direction lie on both sides.
    EXPECT_GT(s.mesh.bounds().hi.z - s.mesh.vertices[0].z, 0.0f);
    EXPECT_LT(s.mesh.bounds().lo.z - s.mesh.vertices[0].z, 0.0f);
  }
}

TEST(Families, PouchIsAnOpenSackAroundLightOrReceivers) {
  for (uint64_t seed : {2, 3}) {
    Scene s = gen("pouch", seed, 600);
    mesh::PrepareCounts c;
    mesh::prepare_mesh(s.mesh, &c);
    EXPECT_EQ(c.inconsistent_joins, 0u);
    EXPECT_EQ(c.nonmanifold_edges, 0u);
    EXPECT_GT(c.single_edges, 0u);  // the opening
    AABB b = s.mesh.bounds();
    // The sack's bounding box holds the light (even seeds) or the receivers (odd seeds).
    const AABB target = [&] {
      AABB t;
      if (seed % 2 == 0)
        for (const auto& p : s.lights[0].polygon) t.extend(p);
      else
        for (const auto& r : s.receivers) t.extend(r.p);
      return t;
    }();
    EXPECT_TRUE(b.contains(target.lo) && b.contains(target.hi)) << seed;
  }
}

TEST(Families, GridSnappedCoordinatesAreOnTheGrid) {
  Scene s = gen("grid-snapped", 4);
  auto on_grid = [](const Vec3f& v) {
    for (int k = 0; k < 3; ++k)
      if (double(v[k]) * 4 != std::round(double(v[k]) * 4)) return false;
    return true;
  };
  for (const auto& v : s.mesh.vertices) EXPECT_TRUE(on_grid(v));
  for (const auto& r : s.receivers) EXPECT_TRUE(on_grid(r.p));
  for (const auto& p : s.lights[0].explicit_samples) EXPECT_TRUE(on_grid(p));
  EXPECT_EQ(s.lights[0].jitter, 1);
}

TEST(Families, SharedEdgeFanAimsThroughSharedEdgesAndVertices) {
  Scene s = gen("shared-edge-fan", 9);
  const Light& L = s.lights[0];
  ASSERT_EQ(L.jitter, 1);
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    Vec3d l = to_double(L.explicit_samples[i % L.explicit_samples.size()]);
    Vec3d mid = (to_double(s.receivers[i].p) + l) * 0.5;
    double best = 1e30;
    for (size_t t = 0; t < s.mesh.size(); ++t)
      for (int k = 0; k < 3; ++k)
        best = std::min(best, point_segment_distance(mid, to_double(s.mesh.corner(t, k)), to_double(s.mesh.corner(t, (k + 1) % 3))));
    // One rounding of r = 2q - l moves the midpoint by at most 2^-24 of |r| ~ 2.
    EXPECT_LE(best, 2e-7) << "receiver " << i;
  }
}

TEST(Families, SliverSoupTrianglesAreNearDegenerate) {
  Scene s = gen("sliver-soup", 6);
  for (size_t t = 0; t < s.mesh.size(); ++t) {
    Vec3d a = to_double(s.mesh.corner(t, 0)), b = to_double(s.mesh.corner(t, 1)), c = to_double(s.mesh.corner(t, 2));
    double longest = std::max({length(b - a), length(c - b), length(a - c)});
    double height = length(cross(b - a, c - a)) / longest;  // twice area / base
    EXPECT_LE(height, 1.01e-2 * longest) << t;
  }
}

TEST(Families, OnSurfaceReceiversLieOnBlockerFaces) {
  Scene s = gen("on-surface", 2);
  size_t exactly_on_floor = 0;
  for (const auto& r : s.receivers) {
    double best = 1e30;
    for (size_t t = 0; t < s.mesh.size(); ++t)
      best = std::min(best, point_triangle_distance(to_double(r.p), to_double(s.mesh.corner(t, 0)),
                                                    to_double(s.mesh.corner(t, 1)), to_double(s.mesh.corner(t, 2))));
    EXPECT_LE(best, 1e-6);  // one float rounding of a point of a face
    exactly_on_floor += r.p.z == 0.0f;
  }
  EXPECT_GT(exactly_on_floor, 0u);
}

TEST(Families, FarOriginIsFarFromTheOrigin) {
  for (uint64_t seed : {1, 2, 3, 4, 5}) {
    Scene s = gen("far-origin", seed);
    AABB b = s.bounds();
    for (int k = 0; k < 3; ++k) EXPECT_GE(std::min(std::abs(b.lo[k]), std::abs(b.hi[k])), 9e4f) << seed;
  }
}

TEST(Families, FoliageHasThousandsOfSmallLeaves) {
  Scene s = gen("foliage", 1);
  EXPECT_GE(s.mesh.size(), 3000u);
  size_t small = 0;
  for (size_t t = 0; t < s.mesh.size(); ++t)
    small += length(to_double(s.mesh.corner(t, 1)) - to_double(s.mesh.corner(t, 0))) < 0.2;
  EXPECT_GE(small, s.mesh.size() - 100);
}

TEST(Families, FileFamilyKeepsTheMeshAndPlacesLightAndReceivers) {
  std::string path = testing::TempDir() + "families_test_tet.off";
  {
    std::ofstream f(path);
    f << "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  }
  Scene s = gen("file:" + path, 1);
  ASSERT_EQ(s.mesh.size(), 4u);
  EXPECT_EQ(s.mesh.corner(3, 2), Vec3f(0, 0, 1));
  EXPECT_GT(s.lights[0].polygon[0].z, 1.0f);
  for (const auto& r : s.receivers) EXPECT_LT(r.p.z, 0.0f);
  FamilyParams p;
  EXPECT_FALSE(generate_family("file:/nonexistent/x.off", p).ok());
  EXPECT_FALSE(generate_family("no-such-family", p).ok());
  std::remove(path.c_str());
}

}  // namespace
TEST(Families, DeterministicBySeed) {
  for (const char* f : {"random-soup", "columns", "rooms"}) {
    FamilyParams p;
    p.seed = 3;
    p.receivers = 16;
    p.samples = 4;
    auto a = generate_family(f, p), b = generate_family(f, p);
    ASSERT_TRUE(a.ok() && b.ok()) << f;
    EXPECT_EQ(write_scene_json(*a), write_scene_json(*b)) << f;
  }
}

}  // namespace visgate
