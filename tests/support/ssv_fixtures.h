// Test fixtures of the SSV tests (tests/ssv/): the solver, an independent
// double-precision segment test with direct depth counting, random scenes away from
// degeneracy, comparisons with direct counting and with the exact oracle, and the
// wedges of a scene's light.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "lib/mesh/prepare.h"
#include "lib/solver.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/wedge.h"
#include "oracle/relation_oracle.h"
#include "tests/support/scenes.h"

namespace visgate::test_support {

// edge_rays=off: every receiver integrated (tests of the integration's own counts).
inline SolveResult run_ssv(const Scene& s, bool regions, bool edge_rays = true) {
  SolveOptions o;
  o.opts["silhouette_regions"] = regions ? "on" : "off";
  if (!edge_rays) o.opts["edge_rays"] = "off";
  return make_solver("ssv")->solve(s, o);
}


// Independent reference: the open segment (r, s) against one triangle in double with a
// safety margin. Returns +1 for a crossing with the crossing point inside the triangle
// and the segment by more than `m`, 0 for a miss by more than `m`, -1 when too close to
// call. Distances are relative to the triangle's size and the segment's length.
inline int segment_vs_triangle(const Vec3d& r, const Vec3d& s, const Vec3d& a, const Vec3d& b, const Vec3d& c, double m) {
  Vec3d n = cross(b - a, c - a);
  double nl = length(n);
  if (nl == 0.0) return 0;  // zero area: never blocks; the cases here keep away from it
  n = n / nl;
  double dr = dot(n, r - a), ds = dot(n, s - a), len = length(s - r);
  double size = std::max(length(b - a), std::max(length(c - a), length(c - b)));
  if ((dr > m * len && ds > m * len) || (dr < -m * len && ds < -m * len)) return 0;
  if (std::abs(dr) <= m * len || std::abs(ds) <= m * len) return -1;
  double t = dr / (dr - ds);
  Vec3d p = r + (s - r) * t;
  double lam = 1e300;
  const Vec3d v[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    Vec3d e = v[(k + 1) % 3] - v[k];
    double dist = dot(cross(e, p - v[k]), n) / length(e);  // signed distance inside
    lam = std::min(lam, dist);
  }
  if (lam > m * size) return 1;
  if (lam < -m * size) return 0;
  return -1;
}

// Depth complexity of the open segment (r, s) by direct counting, or -1 when some
// triangle is too close to call.
inline int direct_depth(const TriangleSoup& soup, const Vec3f& r, const Vec3f& s, double m = 1e-4) {
  int depth = 0;
  for (size_t t = 0; t < soup.size(); ++t) {
    int c = segment_vs_triangle(to_double(r), to_double(s), to_double(soup.corner(t, 0)), to_double(soup.corner(t, 1)),
                                to_double(soup.corner(t, 2)), m);
    if (c < 0) return -1;
    depth += c;
  }
  return depth;
}

inline Vec3d rand_point(std::mt19937_64& g, const Vec3d& lo, const Vec3d& hi) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return Vec3d(lo.x + (hi.x - lo.x) * u(g), lo.y + (hi.y - lo.y) * u(g), lo.z + (hi.z - lo.z) * u(g));
}

// Random blockers between a floor of receivers (z = 0) and a light at z = 2: loose
// triangles (some crossing the light plane, some below the receivers), spheres and tori
// (closed meshes: double edges), an inconsistently oriented pair and a non-manifold fan
// (single edges of lib/mesh).
inline Scene random_scene(uint64_t seed, int samples, int receivers) {
  std::mt19937_64 g(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Scene s;
  s.name = "ssv-random";
  for (int k = 0; k < 12; ++k) {
    Vec3d c = rand_point(g, Vec3d(-1.2, -1.2, 0.3), Vec3d(1.2, 1.2, 1.7));
    Vec3d a = c + rand_point(g, Vec3d(-0.5, -0.5, -0.3), Vec3d(0.5, 0.5, 0.3));
    Vec3d b = c + rand_point(g, Vec3d(-0.5, -0.5, -0.3), Vec3d(0.5, 0.5, 0.3));
    Vec3d d = c + rand_point(g, Vec3d(-0.5, -0.5, -0.3), Vec3d(0.5, 0.5, 0.3));
    uint32_t base = uint32_t(s.mesh.vertices.size());
    s.mesh.vertices.push_back(Vec3f(a));
    s.mesh.vertices.push_back(Vec3f(b));
    s.mesh.vertices.push_back(Vec3f(d));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  // Triangles crossing the light plane and crossing the receivers' plane.
  for (double zc : {2.0, 0.0}) {
    Vec3d c = rand_point(g, Vec3d(-0.6, -0.6, zc - 0.1), Vec3d(0.6, 0.6, zc + 0.1));
    uint32_t base = uint32_t(s.mesh.vertices.size());
    s.mesh.vertices.push_back(Vec3f(c + Vec3d(-0.4, -0.1, -0.45)));
    s.mesh.vertices.push_back(Vec3f(c + Vec3d(0.4, 0.05, -0.35)));
    s.mesh.vertices.push_back(Vec3f(c + Vec3d(0.1, 0.3, 0.5)));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  shapes::add_sphere(s.mesh, rand_point(g, Vec3d(-0.8, -0.8, 0.8), Vec3d(0.8, 0.8, 1.2)), 0.25 + 0.2 * u(g), 9, 6);
  shapes::add_torus(s.mesh, rand_point(g, Vec3d(-0.8, -0.8, 0.6), Vec3d(0.8, 0.8, 1.4)), 0.35, 0.1, 10, 6);
  {
    // Inconsistently oriented neighbours (same traversal of the shared edge) and a
    // three-triangle fan on one edge.
    Vec3d c = rand_point(g, Vec3d(-0.6, -0.6, 0.9), Vec3d(0.6, 0.6, 1.1));
    uint32_t base = uint32_t(s.mesh.vertices.size());
    for (const Vec3d& p : {c + Vec3d(-0.3, 0, 0), c + Vec3d(0.3, 0, 0.05), c + Vec3d(0, 0.35, 0.1), c + Vec3d(0, -0.3, -0.1),
                           c + Vec3d(0.05, 0.1, 0.4)})
      s.mesh.vertices.push_back(Vec3f(p));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
    s.mesh.triangles.push_back({base, base + 1, base + 3});  // same direction: inconsistent
    s.mesh.triangles.push_back({base + 1, base, base + 4});  // third triangle on the edge
  }
  Light l = make_square_light_down(Vec3d(0.1, -0.05, 2.0), 0.8, samples, seed);
  s.lights.push_back(l);
  for (int i = 0; i < receivers; ++i) s.receivers.push_back({Vec3f(rand_point(g, Vec3d(-1.5, -1.5, 0), Vec3d(1.5, 1.5, 0))), Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

// Compares a result against direct counting (V = depth 0) on every relation that is
// safely away from degeneracy; returns the number of safe relations compared.
inline size_t expect_matches_direct(const Scene& s, const SolveResult& r, const std::string& what) {
  size_t compared = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t l = 0; l < s.lights.size(); ++l)
      for (int j = 0; j < s.lights[l].samples; ++j) {
        int d = direct_depth(s.mesh, s.receivers[i].p, sample_position(s.lights[l], j, i));
        if (d < 0) continue;
        ++compared;
        EXPECT_EQ(r.receivers[i].visible(s.light_offset(l) + size_t(j)), d == 0)
            << what << " receiver " << i << " light " << l << " sample " << j << " depth " << d;
      }
  return compared;
}

// The light [-0.5, 0.5]^2 at z = 2 (emitting down) with explicit samples on its 5 x 5
// grid of step 0.25, boundary included (grid-snapped scenes put samples on light edges).
inline Light grid_sampled_light() {
  Light l = make_square_light_down(Vec3d(0, 0, 2), 0.5, 25, 1);
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  for (int b = 0; b < 5; ++b)
    for (int a = 0; a < 5; ++a) l.explicit_samples.push_back(Vec3f(float(-0.5 + 0.25 * a), float(-0.5 + 0.25 * b), 2.0f));
  return l;
}

// Compares a result against the exact relation oracle: no disagreement where the class
// is not degenerate and the margin is at least tau = 1e-5 (DESIGN section 5). Returns the
// number of relations compared.
inline size_t expect_matches_oracle(const Scene& s, const oracle::RelationOracleResult& ex, const SolveResult& r,
                             const std::string& what) {
  size_t compared = 0, mismatches = 0;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (size_t k = 0; k < ex.classes[i].size(); ++k) {
      char c = ex.classes[i][k];
      if (c == 'd' || ex.margins[i][k] < 1e-5) continue;
      ++compared;
      if (r.receivers[i].visible(k) != (c == 'v') && ++mismatches <= 10)
        ADD_FAILURE() << what << " receiver " << i << " relation " << k << " exact " << c << " margin " << ex.margins[i][k];
    }
  EXPECT_EQ(mismatches, 0u) << what;
  return compared;
}

// The positions of a prepared mesh's vertices in a light's frame (u, v, h).
inline std::vector<Vec3d> frame_positions(const mesh::PreparedMesh& pm, const ssv::LightFrame& frame) {
  std::vector<Vec3d> fp(pm.vertex_pos.size());
  for (size_t v = 0; v < fp.size(); ++v) fp[v] = frame.to_local(pm.vertex_pos[v]);
  return fp;
}

// The wedges of a scene's first light (paper 001 section 2.1) and what they are built from.
struct WedgeSetup {
  mesh::PreparedMesh pm;
  ssv::LightFrame frame;
  std::vector<Vec3d> fp;
  std::vector<ssv::Edge> edges;
  ssv::WedgeBuildCounts counts;
  std::vector<ssv::Wedge> wedges;
};
inline WedgeSetup make_wedges(const Scene& s, double tol = 1e-9 * 4) {
  WedgeSetup w;
  w.pm = mesh::prepare_mesh(s.mesh);
  w.frame = ssv::make_light_frame(s.lights[0]);
  w.fp = frame_positions(w.pm, w.frame);
  w.edges = ssv::mesh_edges(w.pm);
  w.wedges = ssv::build_wedges(w.pm, w.edges, w.fp, w.frame, tol, w.counts);
  return w;
}

}  // namespace visgate::test_support
