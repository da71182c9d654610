// Exact transforms of a prepared scene (DESIGN section 2, "Scale"): power-of-two scaling,
// axis permutations with mirrors, and exact translations.
//
// Multiplying every coordinate by 2^k changes no exact class, no relative margin and no
// visible fraction, and float arithmetic commutes with it while every value stays normal.
// The production methods (iss, ssv, plucker-bsp) therefore never see a scene at its own
// scale: Solver::solve hands them its *unit copy*, scaled so that its unit length
// (unit_length: the typical relation length or the typical light size, the larger) lies
// in [2, 4). Every float tolerance inside a method
// is then relative to lengths near 2, as are Embree's (its robust intersector loses hits
// when a scene's triple products of coordinate differences approach float32's
// subnormals, below extents of about 2^-40), and a scene and all its exact 2^k copies reach the
// method as the same bits, so they get the same answers bit for bit. Medians, not the
// bounding box: one outlying point (an explicit sample 2^64 away) must not shrink the
// rest of the scene towards subnormals; and the light's size as well, so that receivers
// sitting on a light (relation lengths near 0) do not blow it up towards overflow.
//
// Permutations, mirrors and translations are exact too but do not commute with float
// rounding: the metamorphic checks (tools/harness/check.h) allow a method to change its
// answer under them only where the exact margin is below tau.
#pragma once

#include <array>

#include "lib/scene/scene.h"

namespace visgate {

// The binade the unit copy's unit length lies in: [2^kUnitExponent,
// 2^(kUnitExponent + 1)) = [2, 4). It holds the built-in adversarial families (light at
// z = 2 over receivers at z = 0), so they reach the methods unscaled.
inline constexpr int kUnitExponent = 1;

// Largest axis extent over every point of the scene (blocker vertices, referenced or
// not, light polygons, light points, explicit samples, receivers), in double. Scales
// exactly with the scene: its rounding in double commutes with 2^k.
double scene_extent(const Scene& scene);

// Exponents k for which scaled_scene(scene, k) is exact: every non-zero coordinate stays
// a normal float32 (no rounding into subnormals, no overflow). A subnormal coordinate
// scales up exactly but not down.
struct ScaleRange {
  int lo = 0, hi = 0;
  bool contains(int k) const { return lo <= k && k <= hi; }
};
ScaleRange exact_scale_range(const Scene& scene);

// The median, over (receiver, light) pairs, of the distance from the receiver to the
// light polygon's vertex average (every k-th receiver, at most about 4096 pairs); 0
// without receivers or lights. Computed in double: scales exactly with the scene.
double typical_relation_length(const Scene& scene);

// The median over lights of the polygon's largest axis extent; 0 without lights.
double typical_light_size(const Scene& scene);
// max(typical_relation_length, typical_light_size), or scene_extent when both are 0.
double unit_length(const Scene& scene);

// k with unit_length(scene) * 2^k in [2, 4), clamped to exact_scale_range(scene) so that
// the unit copy is exact; 0 for a scene without extent. unit_scale_exponent(scaled_scene(s, j)) ==
// unit_scale_exponent(s) - j for every j in exact_scale_range(s).
int unit_scale_exponent(const Scene& scene);

// Every point multiplied by 2^exponent, each product computed in double and rounded
// once to float (exact inside exact_scale_range; outside it, the nearest float to the
// exact product). Light areas scale by 2^(2 exponent), jitter boxes are recomputed,
// normals and everything else are kept. Equal, bit for bit, to preparing the scaled
// input inside the exact range (prepare_light's sampling commutes with 2^k).
Scene scaled_scene(const Scene& scene, int exponent);

// Coordinate i of every point and normal becomes sign[i] * (old coordinate axis[i]);
// `axis` is a permutation of {0, 1, 2}, `sign` entries are +1 or -1. Exact. When the map
// reverses handedness, light polygons and blocker triangles are reversed so that every
// light still emits to the mapped side; the light points are mapped, not resampled, so
// relation (i, j) is the same geometric segment.
struct AxisMap {
  std::array<int, 3> axis{0, 1, 2};
  std::array<int, 3> sign{1, 1, 1};
  bool identity() const { return axis == std::array<int, 3>{0, 1, 2} && sign == std::array<int, 3>{1, 1, 1}; }
  bool reverses_handedness() const;
};
Scene axis_mapped_scene(const Scene& scene, const AxisMap& map);
// The `index`-th of the 48 maps (6 permutations x 8 sign patterns; 0 is the identity).
AxisMap axis_map(unsigned index);

// An exact translation: per axis the largest power-of-two offset (either sign, at most
// the scene's extent, trying 40 binades down) that keeps every coordinate exact in
// float32; 0 on an axis where none does. The offset is returned in `offset`.
Scene translated_scene(const Scene& scene, Vec3d* offset);

}  // namespace visgate
