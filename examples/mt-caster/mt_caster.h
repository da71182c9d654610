// A textbook float32 Möller-Trumbore segment caster (Möller and Trumbore 1997), the kind
// of visibility code visgate is for: one test per triangle, no epsilons, no watertight
// edge handling. It is the worked example of docs/external-methods.md, run by visgate
// as an exec: program (mt_exec.cpp) and as a plugin (mt_plugin.cpp).
//
// Guarantee: none beyond float32 arithmetic. A segment through an edge shared by two
// triangles can miss both (the two edge tests round differently), so relations through
// a fan's shared edges come out visible where the exact answer is blocked; this is what
// `visgate check --family shared-edge-fan` finds.
#pragma once

#include <cstddef>
#include <cstdint>

namespace mt_caster {

struct V3 {
  float x, y, z;
};
inline V3 sub(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }
inline float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3 at(const float* xyz, size_t k) { return {xyz[3 * k], xyz[3 * k + 1], xyz[3 * k + 2]}; }

// True when the open segment (from, to) meets triangle (v0, v1, v2): the textbook test
// with the ray parameter restricted to (0, 1).
inline bool segment_hits(V3 from, V3 to, V3 v0, V3 v1, V3 v2) {
  const V3 dir = sub(to, from);
  const V3 e1 = sub(v1, v0), e2 = sub(v2, v0);
  const V3 p = cross(dir, e2);
  const float det = dot(e1, p);
  if (det == 0.0f) return false;  // parallel to the plane
  const float inv = 1.0f / det;
  const V3 s = sub(from, v0);
  const float u = dot(s, p) * inv;
  if (u < 0.0f || u > 1.0f) return false;
  const V3 q = cross(s, e1);
  const float v = dot(dir, q) * inv;
  if (v < 0.0f || u + v > 1.0f) return false;
  const float t = dot(e2, q) * inv;
  return t > 0.0f && t < 1.0f;
}

// Occlusion of the segment against every triangle of a soup (xyz vertices, index triples).
inline bool occluded(const float* vertices, const uint32_t* triangles, size_t triangle_count, V3 from, V3 to) {
  for (size_t t = 0; t < triangle_count; ++t)
    if (segment_hits(from, to, at(vertices, triangles[3 * t]), at(vertices, triangles[3 * t + 1]),
                     at(vertices, triangles[3 * t + 2])))
      return true;
  return false;
}

}  // namespace mt_caster
