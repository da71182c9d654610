// The scene model (../shared/DESIGN.md section 3): one triangle soup of blockers, one or
// more planar convex area lights with seeded sample patterns and K jitter points per
// sample (paper 000 section 4.11), and a set of receivers. Every method, the oracle and
// every tool ask for light points through `sample_position`, so all answer the same
// relations.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/geom/vec.h"
#include "lib/base/result.h"
#include "lib/scene/rng.h"

namespace visgate {

// A triangle soup: indexed, but indices may repeat positions and nothing is welded.
struct TriangleSoup {
  std::vector<Vec3f> vertices;
  std::vector<std::array<uint32_t, 3>> triangles;

  size_t size() const { return triangles.size(); }
  Vec3f corner(size_t t, int k) const { return vertices[triangles[t][k]]; }
  AABB bounds() const;
  // Appends `other`, re-indexing its triangles.
  void append(const TriangleSoup& other);
};

enum class SamplePattern { Stratified, Random, Grid, Explicit };

struct Light {
  // Input.
  std::vector<Vec3f> polygon;  // convex, counter-clockwise seen from the emitting side
  int samples = 16;            // N
  SamplePattern pattern = SamplePattern::Stratified;
  int jitter = 4;              // K jitter points per sample
  uint64_t seed = 1;
  std::vector<Vec3f> explicit_samples;  // with pattern Explicit and jitter 1

  // Derived by `prepare_light` (deterministic from the input).
  Vec3f normal{};                  // unit emitting normal (double-computed, rounded)
  double area = 0.0;               // polygon area
  std::vector<Vec3f> jitter_points;  // samples * jitter, sample-major
  std::vector<AABB> jitter_boxes;    // one per sample: AABB of its K jitter points

  const Vec3f& jitter_point(int sample, int k) const { return jitter_points[size_t(sample) * jitter + k]; }
};

struct Receiver {
  Vec3f p{};
  Vec3f n{0, 0, 1};
};

// Receiver grid (DESIGN section 6): receiver (a, b) with a < nu, b < nv sits at
// origin + u*(a + 0.5)/nu + v*(b + 0.5)/nv + normal*offset, evaluated in double and
// rounded once to float; index b*nu + a.
struct ReceiverGrid {
  Vec3f origin{}, u{}, v{}, normal{0, 0, 1};
  int nu = 0, nv = 0;
  float offset = 0.0f;
};

struct Scene {
  std::string name;
  TriangleSoup mesh;                  // all blockers, every mesh concatenated
  std::vector<Light> lights;
  std::vector<Receiver> receivers;
  std::optional<ReceiverGrid> grid;   // set when receivers came from a grid

  // Relations per receiver: sum of the sample counts of all lights (light-major).
  size_t samples_per_receiver() const;
  // Offset of light l's first sample in a receiver's relation string.
  size_t light_offset(size_t light) const;
  size_t relation_count() const { return receivers.size() * samples_per_receiver(); }
  // Bounds of blockers, light polygons and receivers.
  AABB bounds() const;
  // The same with the blockers' box given (mesh.bounds() or the same floats from elsewhere).
  AABB bounds(const AABB& mesh_box) const;
};

// The fixed hash h(i, j, seed) of DESIGN section 3: splitmix64 finalisers chained over
// the seed, the receiver index and the sample index. Never change it: stored corpus cases
// depend on it.
uint64_t relation_hash(uint64_t receiver, uint64_t sample, uint64_t seed);

// The same hash in two steps, for loops over the samples of one receiver (SSV picks the
// jitter point of every sample of a receiver): relation_hash(i, j, seed) ==
// relation_hash_step(relation_hash_prefix(i, seed), j).
inline uint64_t relation_hash_prefix(uint64_t receiver, uint64_t seed) { return splitmix64(splitmix64(seed) ^ receiver); }
inline uint64_t relation_hash_step(uint64_t prefix, uint64_t sample) {
  return splitmix64(prefix ^ (sample * 0xD1B54A32D192ED03ull));
}

// The light point of relation (receiver i, sample j of `light`): jitter point
// h(i, j, light.seed) mod K of sample j.
inline const Vec3f& sample_position(const Light& light, int j, size_t i) {
  return light.jitter_point(j, int(relation_hash(i, uint64_t(j), light.seed) % uint64_t(light.jitter)));
}

// Validates a light (finite, at least 3 vertices, planar within tolerance, convex,
// non-zero area, consistent counter-clockwise orientation) and computes its derived
// fields. `where` names the element in error messages ("scene.json: lights[0]").
// Planarity tolerance: every vertex within 1e-5 of the polygon's extent (relative) from
// the best plane through the vertices (Newell normal, centroid); float32 vertices of a
// planar polygon are off the exact plane by rounding, about 6e-8 relative, so the
// tolerance is 100x that with room for coordinates stored with fewer digits.
Status prepare_light(Light& light, const std::string& where);

// Generates receivers for a grid.
std::vector<Receiver> grid_receivers(const ReceiverGrid& g);

}  // namespace visgate
