// Orientation predicates and the textbook float32 segment/triangle test.
//
// orient3d(a, b, c, d) = det[b - a, c - a, d - a]: positive when d lies on the side of
// the plane (a, b, c) that the normal (b - a) x (c - a) points to. Written once as a
// template; `orient3d_f32` is the plain float evaluation (no error bound: it can return
// the wrong sign near zero, which is exactly the failure the oracle measures), the
// oracle instantiates the same formula with CGAL's exact number type.
#pragma once

#include "lib/geom/vec.h"

namespace visgate {

template <class T>
T orient3d(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c, const Vec3<T>& d) {
  return dot(cross(b - a, c - a), d - a);
}

inline float orient3d_f32(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& d) {
  return orient3d<float>(a, b, c, d);
}

// Textbook Möller-Trumbore ("Fast, Minimum Storage Ray/Triangle Intersection", 1997) in
// float32 for the open segment org + t*dir, 0 < t < 1. No epsilon tricks: a zero
// determinant (segment parallel to the plane) is a miss, the barycentric tests are the
// paper's inclusive ones (u < 0 or u > 1 miss, v < 0 or u + v > 1 miss), and the t test
// excludes both endpoints. Float32 throughout: it can crack between triangles sharing an
// edge and misjudge near-degenerate cases; it is the fragile reference.
inline bool segment_hits_triangle_mt(const Vec3f& org, const Vec3f& dir, const Vec3f& v0,
                                     const Vec3f& v1, const Vec3f& v2) {
  Vec3f e1 = v1 - v0, e2 = v2 - v0;
  Vec3f p = cross(dir, e2);
  float det = dot(e1, p);
  if (det == 0.0f) return false;
  float inv = 1.0f / det;
  Vec3f s = org - v0;
  float u = dot(s, p) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  Vec3f q = cross(s, e1);
  float v = dot(dir, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  float t = dot(e2, q) * inv;
  return t > 0.0f && t < 1.0f;
}

}  // namespace visgate
