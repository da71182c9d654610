// Scene families for `visgate gen`, the harness and the fuzzers (DESIGN section 7).
// Every family is deterministic in (name, params): the same seed gives a bit-identical
// scene on every machine.
#pragma once

#include <string>
#include <vector>

#include "lib/scene/scene.h"

namespace visgate {

struct FamilyParams {
  uint64_t seed = 1;
  long triangles = -1;   // target blocker triangle count; -1: the family's default
  long receivers = -1;   // receiver count (a square grid where the family uses one); -1: default
  long samples = -1;     // samples per light; -1: default
  double light_scale = 1.0;  // scales every light polygon about its centre
  // The generated scene multiplied by 2^scale_exponent, clamped to the exponents for
  // which that copy is exact (lib/scene/exact_transform.h); a copy's name ends in
  // "@2^k" with the k applied.
  int scale_exponent = 0;
};

std::vector<std::string> family_names();
bool is_family(const std::string& name);
// Generates a scene; errors for unknown families or parameters out of range.
Result<Scene> generate_family(const std::string& name, const FamilyParams& p);

// Helpers shared by families: a square light of half-size `half` centred at `c` in the
// plane z = c.z emitting towards -z, and a receiver grid over [x0,x1] x [y0,y1] at height z.
Light make_square_light_down(const Vec3d& c, double half, int samples, uint64_t seed);
ReceiverGrid make_floor_grid(double x0, double x1, double y0, double y1, double z, int nu, int nv, float offset);
// Finishes a scene: prepares lights (sampling) and fills grid receivers.
Status finish_scene(Scene& s);

}  // namespace visgate
