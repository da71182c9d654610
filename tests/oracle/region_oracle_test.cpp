// Tests of oracle/region_oracle.cpp: hand-computed areas and form factors, point
// sampling, agreement with the relation oracle, and the fast paths.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cfenv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <random>
#include <tuple>

#include "lib/scene/families.h"
#include "lib/scene/scene_json.h"
#include "oracle/comparator.h"
#include "oracle/oracle_json.h"
#include "oracle/region_oracle.h"
#include "oracle/relation_oracle.h"
#include "tests/support/oracle_scenes.h"

namespace visgate::oracle {
namespace {

using namespace test_support;

// Independent double-precision ray/triangle test (Moller-Trumbore, no epsilons) used
// only by the sampling estimate.
bool ray_blocked(const Scene& s, const Vec3d& o, const Vec3d& e) {
  Vec3d d = e - o;
  for (size_t t = 0; t < s.mesh.size(); ++t) {
    Vec3d a = to_double(s.mesh.corner(t, 0)), b = to_double(s.mesh.corner(t, 1)), c = to_double(s.mesh.corner(t, 2));
    Vec3d e1 = b - a, e2 = c - a, pv = cross(d, e2);
    double det = dot(e1, pv);
    if (det == 0) continue;
    Vec3d tv = o - a;
    double u = dot(tv, pv) / det;
    if (u < 0 || u > 1) continue;
    Vec3d qv = cross(tv, e1);
    double v = dot(d, qv) / det;
    if (v < 0 || u + v > 1) continue;
    double tt = dot(e2, qv) / det;
    if (tt > 0 && tt < 1) return true;
  }
  return false;
}

// Random occluders between a receiver and a unit light at z = 2.
Scene random_occluders(uint32_t seed, int n) {
  std::mt19937 g(seed);
  // Vertices stay within z in [0.3, 1.7], strictly between the receiver and the light.
  std::uniform_real_distribution<float> xy(0.0f, 1.0f), z(0.5f, 1.5f), d(-0.2f, 0.2f);
  Scene s;
  for (int t = 0; t < n; ++t) {
    Vec3f a(xy(g), xy(g), z(g));
    Vec3f b = a + Vec3f(d(g), d(g), d(g)), c = a + Vec3f(d(g), d(g), d(g));
    s.mesh.vertices.insert(s.mesh.vertices.end(), {a, b, c});
    uint32_t k = uint32_t(3 * t);
    s.mesh.triangles.push_back({k, k + 1, k + 2});
  }
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.4f, 0.6f, 0}, {0, 0, 1}});
  return s;
}

// Even-odd point-in-region test in the light plane z = 2 over every boundary, and the
// distance from x to the nearest boundary edge (double).
bool in_region(const RegionAnswer& a, double x, double y, double& dmin) {
  bool inside = false;
  dmin = 1e300;
  for (const auto& poly : a.polygons)
    for (size_t i = 0, n = poly.size(); i < n; ++i) {
      double ax = poly[i].x, ay = poly[i].y, bx = poly[(i + 1) % n].x, by = poly[(i + 1) % n].y;
      if ((ay > y) != (by > y) && x < ax + (y - ay) * (bx - ax) / (by - ay)) inside = !inside;
      double ex = bx - ax, ey = by - ay, l2 = ex * ex + ey * ey;
      double t = l2 > 0 ? std::clamp(((x - ax) * ex + (y - ay) * ey) / l2, 0.0, 1.0) : 0.0;
      dmin = std::min(dmin, std::hypot(x - (ax + t * ex), y - (ay + t * ey)));
    }
  return inside;
}

TEST(RegionOracle, UnblockedLightIsFullyVisibleWithHandFormFactor) {
  Scene s;
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_EQ(a.visible_fraction, 1.0);
  EXPECT_DOUBLE_EQ(a.light_area, 1.0);
  ASSERT_EQ(a.polygons.size(), 1u);
  // Differential area to a parallel rectangle with one corner above it (Howell's catalogue
  // B-3): F = (1/2pi) (X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2)));
  // the centred square is four such rectangles with X = Y = 0.5 / 2.
  double X = 0.25, sx = std::sqrt(1 + X * X);
  double F = 4.0 * (2.0 * X / sx * std::atan(X / sx)) / (2.0 * std::numbers::pi);
  EXPECT_NEAR(a.irradiance, F, 1e-12);
}

TEST(RegionOracle, SingleOccluderHandArea) {
  // Occluder [0.25, 0.5]^2 at z = 1, halfway: it projects from (0.5, 0.5, 0) onto z = 2
  // as [0, 0.5]^2, a quarter of the light.
  Scene s;
  add_quad(s, {0.25f, 0.25f, 1}, {0.5f, 0.25f, 1}, {0.5f, 0.5f, 1}, {0.25f, 0.5f, 1});
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_EQ(a.visible_fraction, 0.75);
  EXPECT_EQ(a.blockers_projected, 2u);
  EXPECT_DOUBLE_EQ(a.visible_area, 0.75);
  // The visible L-shape has 6 corners.
  ASSERT_EQ(a.polygons.size(), 1u);
  EXPECT_EQ(a.polygons[0].size(), 6u);
  // By symmetry the blocked quarter carries a quarter of the irradiance.
  Scene free = s;
  free.mesh = {};
  EXPECT_NEAR(a.irradiance, 0.75 * visible_region(free, 0, 0).irradiance, 1e-12);
}

TEST(RegionOracle, OccluderCrossingBothSlabPlanes) {
  // A wall x = 0.75 from z = -1 (behind the receiver's level) to z = 3 (beyond the
  // light): light points with x >= 0.75 are blocked (the crossing height
  // 0.5 / (x - 0.5) is in [0.5, 2] for x in [0.75, 1]); fraction 0.75.
  Scene s;
  add_quad(s, {0.75f, -5, -1}, {0.75f, 5, -1}, {0.75f, 5, 3}, {0.75f, -5, 3});
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  EXPECT_EQ(visible_region(s, 0, 0).visible_fraction, 0.75);
  // A hole: a small square occluder in the middle of the light's shadow pyramid.
  Scene h;
  add_quad(h, {0.375f, 0.375f, 1}, {0.625f, 0.375f, 1}, {0.625f, 0.625f, 1}, {0.375f, 0.625f, 1});
  h.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  h.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RegionAnswer a = visible_region(h, 0, 0);
  EXPECT_EQ(a.visible_fraction, 0.75);  // projects to [0.25, 0.75]^2
  ASSERT_EQ(a.polygons.size(), 2u);
  EXPECT_EQ(std::count(a.hole.begin(), a.hole.end(), true), 1);
}

TEST(RegionOracle, ReceiverOnAFaceAndBlockersInTheLightPlaneDoNotBlock) {
  Scene s;
  // The floor contains the receiver; a triangle lies in the light plane over the light.
  add_quad(s, {-5, -5, 0}, {5, -5, 0}, {5, 5, 0}, {-5, 5, 0});
  s.mesh.vertices.insert(s.mesh.vertices.end(), {{-1, -1, 2}, {3, -1, 2}, {-1, 3, 2}});
  s.mesh.triangles.push_back({4, 5, 6});
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_EQ(a.visible_fraction, 1.0);
  EXPECT_EQ(a.blockers_projected, 0u);
  // The relation oracle agrees at the light's centre sample.
  EXPECT_EQ(cls(s, s.receivers[0].p, s.lights[0].jitter_point(0, 0)), RC::Visible);
}

TEST(RegionOracle, ReceiverOnTheLightPlaneIsEdgeOn) {
  Scene s;
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{3, 0.5f, 2}, {0, 0, 1}});
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_TRUE(a.edge_on);
  EXPECT_TRUE(a.polygons.empty());
}

TEST(RegionOracle, FarFromOriginHandArea) {
  // The single-occluder case translated by (2^20, -2^20, 2^18): float spacing there is
  // 2^-3 and 2^-5, so every coordinate (multiples of 0.25) stays exact.
  const float ox = std::ldexp(1.0f, 20), oz = std::ldexp(1.0f, 18);
  Scene s;
  add_quad(s, {ox + 0.25f, -ox + 0.25f, oz + 1}, {ox + 0.5f, -ox + 0.25f, oz + 1}, {ox + 0.5f, -ox + 0.5f, oz + 1},
           {ox + 0.25f, -ox + 0.5f, oz + 1});
  s.lights.push_back(square_light_down(ox, ox + 1, -ox, -ox + 1, oz + 2));
  s.receivers.push_back({{ox + 0.5f, -ox + 0.5f, oz}, {0, 0, 1}});
  EXPECT_EQ(visible_region(s, 0, 0).visible_fraction, 0.75);
}

TEST(RegionOracle, MatchesPointSamplingEstimate) {
  for (uint32_t seed = 1; seed <= 4; ++seed) {
    Scene s = random_occluders(seed, 12);
    RegionAnswer a = visible_region(s, 0, 0);
    // Midpoints of a 128 x 128 grid on the light. The estimate errs only in cells cut by
    // a shadow edge: at most (total projected edge length / cell size) cells of area
    // 1/128^2; 12 triangles with projected perimeters below 4 give < 48 * 128 cells,
    // i.e. an error below 48 / 128 ~ 0.375 in the worst case and ~ 1/128 per unit of
    // edge length in practice; 0.02 leaves room for ~2.5 units of shadow boundary.
    const int n = 128;
    int visible = 0;
    Vec3d r = to_double(s.receivers[0].p);
    for (int x = 0; x < n; ++x)
      for (int y = 0; y < n; ++y)
        visible += !ray_blocked(s, r, Vec3d((x + 0.5) / n, (y + 0.5) / n, 2.0));
    EXPECT_NEAR(a.visible_fraction, double(visible) / (n * n), 0.02) << "seed " << seed;
    EXPECT_LT(a.visible_fraction, 1.0) << "seed " << seed;  // the scenes do cast shadows
  }
}

TEST(RegionOracle, SliverOccluderExactArea) {
  // Needle at z = 1 with apex height 2^-20 over a base of 0.5: it projects from
  // (0.5, 0.5, 0) onto z = 2 as (0,0), (1,0), (0.5, 2^-19): area 2^-20 exactly.
  Scene s;
  s.mesh.vertices = {{0.25f, 0.25f, 1}, {0.75f, 0.25f, 1}, {0.5f, 0.25f + std::ldexp(1.0f, -20), 1}};
  s.mesh.triangles = {{0, 1, 2}};
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  EXPECT_EQ(visible_region(s, 0, 0).visible_fraction, 1.0 - std::ldexp(1.0, -20));
}

TEST(RegionOracle, TiltedLightMatchesPointSampling) {
  // Light in the plane z = 2 + x/2 (vertices exact in float, so the exact frame is the
  // float polygon itself); the frame drops z and scales areas by |n| / |n_z|.
  Scene s = random_occluders(31, 12);
  s.lights.clear();
  s.lights.push_back(explicit_light({{0, 0, 2}, {0, 1, 2}, {1, 1, 2.5f}, {1, 0, 2.5f}}, {{0.5f, 0.5f, 2.25f}}));
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_NEAR(a.light_area, std::sqrt(1.25), 1e-12);
  const int n = 128;
  int visible = 0;
  Vec3d r = to_double(s.receivers[0].p);
  for (int x = 0; x < n; ++x)
    for (int y = 0; y < n; ++y) {
      double px = (x + 0.5) / n;
      visible += !ray_blocked(s, r, Vec3d(px, (y + 0.5) / n, 2.0 + px / 2));
    }
  EXPECT_NEAR(a.visible_fraction, double(visible) / (n * n), 0.02);
  EXPECT_LT(a.visible_fraction, 1.0);
}

TEST(RegionOracle, ConsistentWithRelationOracle) {
  size_t checked_visible = 0, checked_blocked = 0;
  for (uint32_t seed = 10; seed <= 13; ++seed) {
    Scene s = random_occluders(seed, 10);
    RegionAnswer a = visible_region(s, 0, 0);
    const Vec3f r = s.receivers[0].p;
    for (int x = 0; x < 40; ++x)
      for (int y = 0; y < 40; ++y) {
        float px = (float(x) + 0.5f) / 40.0f, py = (float(y) + 0.5f) / 40.0f;
        double d;
        bool vis = in_region(a, px, py, d);
        // Strictly inside: 1e-6 away from every boundary (the output polygons are rounded
        // to float, ~6e-8 here).
        if (d < 1e-6) continue;
        RC c = cls(s, r, Vec3f(px, py, 2.0f));
        if (vis) {
          EXPECT_EQ(c, RC::Visible) << seed << " " << px << " " << py;
          ++checked_visible;
        } else {
          EXPECT_EQ(c, RC::Blocked) << seed << " " << px << " " << py;
          ++checked_blocked;
        }
      }
  }
  EXPECT_GT(checked_visible, 100u);
  EXPECT_GT(checked_blocked, 100u);
}

TEST(RegionOracle, ConsistentWithRelationOracleForBlockersCrossingTheSlabPlanes) {
  // Large triangles spanning z in [-1, 3]: they cross the receiver's level (pyramid
  // clipping) and the light plane (slab clipping); some pass right next to the receiver.
  size_t checked_visible = 0, checked_blocked = 0;
  for (uint32_t seed = 40; seed <= 45; ++seed) {
    std::mt19937 g(seed);
    std::uniform_real_distribution<float> xy(-1.0f, 2.0f), z(-1.0f, 3.0f);
    Scene s;
    for (uint32_t t = 0; t < 3; ++t) {
      for (int k = 0; k < 3; ++k) s.mesh.vertices.push_back(Vec3f(xy(g), xy(g), z(g)));
      s.mesh.triangles.push_back({3 * t, 3 * t + 1, 3 * t + 2});
    }
    s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
    s.receivers.push_back({{0.4f, 0.6f, 0}, {0, 0, 1}});
    RegionAnswer a = visible_region(s, 0, 0);
    for (int x = 0; x < 32; ++x)
      for (int y = 0; y < 32; ++y) {
        float px = (float(x) + 0.5f) / 32.0f, py = (float(y) + 0.5f) / 32.0f;
        double d;
        bool vis = in_region(a, px, py, d);
        if (d < 1e-6) continue;
        RC c = cls(s, s.receivers[0].p, Vec3f(px, py, 2.0f));
        EXPECT_EQ(c, vis ? RC::Visible : RC::Blocked) << seed << " " << px << " " << py;
        ++(vis ? checked_visible : checked_blocked);
      }
  }
  EXPECT_GT(checked_visible, 100u);
  EXPECT_GT(checked_blocked, 100u);
}

TEST(RegionOracle, FastPathsAgreeWithTheExactPath) {
  // The double-filtered pre-pass (region_oracle.h "Fast paths") drops certain misses and
  // answers certain covers; with it off every culled triangle goes through the exact
  // projection and the Boolean operations. Both are exact, so the fractions are equal
  // to the last bit, on every family that the harness fuzzes and gates.
  size_t pairs = 0, fast = 0;
  for (const char* fam : kRegionFamilies) {
    for (uint64_t seed = 1; seed <= 2; ++seed) {
      auto scene = small_family_scene(fam, seed, 120);
      ASSERT_TRUE(scene.ok()) << fam;
      for (size_t i = 0; i < scene->receivers.size(); ++i)
        for (size_t l = 0; l < scene->lights.size(); ++l) {
          RegionAnswer a = visible_region(*scene, i, l);
          RegionAnswer b = visible_region(*scene, i, l, RegionOptions{false});
          EXPECT_EQ(a.visible_fraction, b.visible_fraction) << fam << " " << seed << " " << i;
          EXPECT_EQ(a.edge_on, b.edge_on);
          EXPECT_FALSE(b.fast_path);
          ++pairs;
          fast += a.fast_path;
        }
    }
  }
  EXPECT_GT(fast, pairs / 10);
}

TEST(RegionOracle, FastPathsDecideCoveredAndClearLights) {
  // One triangle at z = 1 whose shadow from (0.5, 0.5, 0) on z = 2 is the triangle
  // scaled by 2 about the receiver: x, y >= -4.5 and x + y <= 3 there, which holds the
  // unit light: decided by the pre-pass. A square moved aside misses the pyramid.
  // (Each triangle of a quad hides only part of the light: the pre-pass decides single
  // triangles, the union goes to the exact path.)
  Scene s;
  s.mesh.vertices = {{-2, -2, 1}, {4, -2, 1}, {-2, 4, 1}};
  s.mesh.triangles = {{0, 1, 2}};
  s.lights.push_back(square_light_down(0, 1, 0, 1, 2));
  s.receivers.push_back({{0.5f, 0.5f, 0}, {0, 0, 1}});
  RegionAnswer a = visible_region(s, 0, 0);
  EXPECT_TRUE(a.fast_path);
  EXPECT_EQ(a.visible_fraction, 0.0);
  EXPECT_TRUE(a.polygons.empty());
  EXPECT_EQ(visible_region(s, 0, 0, RegionOptions{false}).visible_fraction, 0.0);
  Scene m;
  add_quad(m, {3, 3, 1}, {4, 3, 1}, {4, 4, 1}, {3, 4, 1});
  m.lights = s.lights;
  m.receivers = s.receivers;
  RegionAnswer b = visible_region(m, 0, 0);
  EXPECT_TRUE(b.fast_path);
  EXPECT_EQ(b.visible_fraction, 1.0);
  ASSERT_EQ(b.polygons.size(), 1u);
  EXPECT_EQ(b.polygons[0].size(), 4u);
  // A square that hides half of the light is decided exactly, not by the pre-pass.
  Scene h;
  add_quad(h, {0.5f, -0.5f, 1}, {1.5f, -0.5f, 1}, {1.5f, 1.5f, 1}, {0.5f, 1.5f, 1});
  h.lights = s.lights;
  h.receivers = s.receivers;
  RegionAnswer c = visible_region(h, 0, 0);
  EXPECT_FALSE(c.fast_path);
  EXPECT_EQ(c.visible_fraction, 0.5);
}

TEST(RegionOracle, RegionCacheChangesNoAnswer) {
  // RegionCache (region_oracle.h) only saves recomputation: bounds and regions with it
  // equal the ones without, bit for bit, whether a region follows its pair's bound (the
  // kept preparation) or another pair's (only the light's frame reused); the fraction-only
  // region (RegionOptions::outputs false) has the same fraction and areas.
  std::vector<Scene> scenes = bound_scenes();
  size_t pairs = 0;
  for (size_t s = 0; s < scenes.size(); s += 6) {
    const Scene& sc = scenes[s];
    RegionCache cache(sc);
    for (size_t i = 0; i < sc.receivers.size(); ++i)
      for (size_t l = 0; l < sc.lights.size(); ++l) {
        FractionBound b0 = visible_fraction_bound(sc, i, l), b1 = visible_fraction_bound(sc, i, l, &cache);
        ASSERT_EQ(b0.edge_on, b1.edge_on);
        ASSERT_EQ(b0.certified, b1.certified);
        EXPECT_EQ(b0.lo, b1.lo) << "scene " << s << " receiver " << i << " light " << l;
        EXPECT_EQ(b0.hi, b1.hi) << "scene " << s << " receiver " << i << " light " << l;
        // After its own bound, then for the first pair again after another pair's bound.
        for (size_t k = 0; k < 2; ++k) {
          const size_t ri = k == 0 ? i : 0, li = k == 0 ? l : 0;
          RegionAnswer a0 = visible_region(sc, ri, li), a1 = visible_region(sc, ri, li, RegionOptions{}, &cache);
          ASSERT_EQ(a0.edge_on, a1.edge_on);
          EXPECT_EQ(a0.visible_fraction, a1.visible_fraction) << "scene " << s << " receiver " << ri << " light " << li;
          EXPECT_EQ(a0.visible_area, a1.visible_area);
          EXPECT_EQ(a0.irradiance, a1.irradiance);
          EXPECT_EQ(a0.polygons, a1.polygons);
          EXPECT_EQ(a0.hole, a1.hole);
          // Without the outputs (the comparator's fallback): the same fraction and areas.
          RegionOptions fraction_only;
          fraction_only.outputs = false;
          RegionAnswer a2 = visible_region(sc, ri, li, fraction_only, &cache);
          ASSERT_EQ(a0.edge_on, a2.edge_on);
          EXPECT_EQ(a0.visible_fraction, a2.visible_fraction);
          EXPECT_EQ(a0.visible_area, a2.visible_area);
          EXPECT_EQ(a0.light_area, a2.light_area);
          EXPECT_EQ(a0.fast_path, a2.fast_path);
          EXPECT_TRUE(a2.polygons.empty());
        }
        ++pairs;
      }
  }
  EXPECT_GT(pairs, 100u);
}

}  // namespace
}  // namespace visgate::oracle
