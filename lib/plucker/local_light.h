// A light in its local frame (plucker_solver.h "Local frame"): the geometry every phase
// of paper 002's soft-shadow framework (section 4.4, Algorithm 2) works on for one
// light: the polygon relative to one of its vertices, its plane with a rounding bound,
// the region oracle's exact plane for the exact paths, and the light's sample points.
// Internal to lib/plucker.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/geom/error_bounds.h"
#include "lib/geom/expansion.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

// Error bound of h(x) = n . (x - p0) in float: 1 rounding in the difference, 1 per
// product, 2 in the sum: (1 + u)^4 - 1 < 4.01 u of |n|_1 |x - p0|_1; doubled.
constexpr float kDotErr = 8.0f * kUnitRoundoffF;

// Every point below is relative to `origin`, a light vertex (a float input, so the
// origin itself is not rounded).
struct LocalLight {
  const Light* light = nullptr;
  Vec3f origin{};          // world position of the local origin (a light vertex)
  std::vector<Vec3d> poly;  // local (double: exact x - origin for float x, see to_local_d)
  Vec3f n{}, p0{};
  LightBounds bounds;       // of poly, centroid included: every fragment is a piece of it (node_plane)
  float plane_tol = 0.0f;  // max |h| of the light's own vertices plus the h error bound
  AABB box;                // local
  float extent = 0.0f;     // largest side of box
  UVAxes axes;
  LightPlane plane;        // n, plane_tol, extent, axes: for shadow boxes (fragment.h)
  // The plane in double (LightPlane::nd, h0): h(x) = nd . x - h0 in the slab tests.
  Vec3d nd{};
  double h0 = 0.0;
  // Exactly planar light (every vertex exactly on the plane of vertices 0, p1, p2, which
  // are not collinear; true of every axis-aligned light): the side of a point is then
  // decided exactly, as the region oracle decides it. emit_sign: the sign of
  // orient3d(v0, v_p1, v_p2, x) for x on the emitting side.
  bool planar = false;
  int p1 = 1, p2 = 2, emit_sign = 1;
  std::vector<Vec3d> samples;     // local jitter points, parallel to light.jitter_points
  std::vector<uint8_t> on_light;  // per jitter point: on the light polygon (fragment test)
  // The region oracle's exact light plane over the frame's (u, v) axes, for the exact path's
  // plane values at fragment vertices (exact_orient.h LiftedLight).
  LiftedLight lift;
};

// The light in the frame of its vertex nearest to `focus` (the centre of the receivers'
// box): fragments are resolved to u times their distance from the origin, so the part of
// the light the receivers look at should be near it.
LocalLight make_local_light(const Light& light, const Vec3d& focus);

inline Vec3f to_local(const Vec3f& x, const Vec3f& origin) { return x - origin; }
// The same in double: exact whenever the exponents of x and origin differ by at most 29
// (the difference of two floats then fits in 53 bits), else rounded once at u_d.
inline Vec3d to_local_d(const Vec3f& x, const Vec3f& origin) { return to_double(x) - to_double(origin); }

// True when to_local_d(x, origin) is exact (Two-Sum's error term is 0 in every
// coordinate). Inline: the occluder selection asks it for every candidate's vertices.
inline bool translates_exactly(const Vec3f& x, const Vec3f& origin) {
  for (int k = 0; k < 3; ++k) {
    double d, e;
    expansion::two_sum(double(x[k]), -double(origin[k]), d, e);
    if (e != 0.0) return false;
  }
  return true;
}

// Index of sample_position(light, j, i) in light.jitter_points (and LocalLight::samples).
inline size_t sample_index(const Light& light, int j, size_t i) {
  return size_t(&sample_position(light, j, i) - light.jitter_points.data());
}

// The open segment r -> s (local) against every triangle of the scene, each translated
// to the local frame as it is tested (lines.h segment_blocked).
bool segment_blocked_by_scene(const Scene& scene, const Vec3f& origin, const Vec3f& r, const Vec3f& s);

}  // namespace visgate::plucker
