// The light frame of the soft shadow volume method (paper 001 section 2.1): an
// orthonormal frame (U, V, N) on the light's plane, N its emitting normal, in which edges
// are projected from a receiver onto the light plane and integrated, plus the expanded
// light polygon L' that the wedges and the integration use.
//
// L' is the light polygon scaled about its vertex average until every jitter point lies
// strictly inside it (by 1e-4 of the light's extent), by at most a factor of 4. Depth complexity is integrated over L'
// instead of L: every sample lies in L', so the counters of the samples are unchanged, and
// samples on (or rounded just outside) the boundary of L stay strictly inside the
// integration domain. The wedges of L' contain those of L (conservative).
#pragma once

#include <vector>

#include "lib/geom/frame.h"
#include "lib/scene/scene.h"

namespace visgate::ssv {

struct Vec2f {
  float u = 0.0f, v = 0.0f;
};

inline float cross2(const Vec2f& a, const Vec2f& b) { return a.u * b.v - a.v * b.u; }

// The light's frame (Frame3d: origin, U, V, N, right-handed, U x V = N; to_local and
// to_local_f give (u, v, h) of a world point in double, or rounded once) with L'.
struct LightFrame : Frame3d {
  double extent = 0.0;            // diagonal of the light polygon's bounding box

  std::vector<Vec2f> poly;         // L' in frame coordinates, counter-clockwise
  std::vector<Vec3d> poly_world;   // L' in world coordinates (double)
  std::vector<uint8_t> right_chain;  // per edge i (poly[i] -> poly[i+1]): v strictly increases
  std::vector<Vec2f> jitter_uv;    // per jitter point of the light, frame (u, v)
  float max_jitter_h = 0.0f;       // largest |h| of a jitter point (samples off the plane)
  bool usable = true;              // false: some jitter point lies far outside L (see make_light_frame)
};

// Builds the frame and L' for a prepared light (prepare_light has run).
LightFrame make_light_frame(const Light& light);

}  // namespace visgate::ssv
