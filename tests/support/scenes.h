// Test fixtures: small hand-made scenes shared by the method tests (iss, ssv, raycast,
// external, api): square lights, receiver grids and the light quad of the worked
// TriangleBetweenPointAndLightQuad cases.
#pragma once

#include <gtest/gtest.h>

#include "lib/scene/families.h"
#include "lib/scene/scene.h"
#include "lib/scene/shapes.h"

namespace visgate::test_support {

// A square light of half-size `half` centred at (cx, cy, z), emitting down, `samples`
// samples.
inline Light square_light(double cx, double cy, double z, double half, int samples, uint64_t seed = 3) {
  return make_square_light_down(Vec3d(cx, cy, z), half, samples, seed);
}

// An n x n grid of receivers (facing up) over [x0, x1] x [y0, y1] at height z, cell centres.
inline void add_receiver_grid(Scene& s, double x0, double x1, double y0, double y1, double z, int n) {
  for (int b = 0; b < n; ++b)
    for (int a = 0; a < n; ++a) {
      float x = float(x0 + (x1 - x0) * (a + 0.5) / n), y = float(y0 + (y1 - y0) * (b + 0.5) / n);
      s.receivers.push_back({Vec3f(x, y, float(z)), Vec3f(0, 0, 1)});
    }
}

// A finished scene without mesh: one square light (centre (cx, cy, z), half-size
// `half`, 16 samples, seed 3) over an n x n receiver grid on [x0, x1] x [y0, y1] at z = 0.
inline Scene light_over_grid(double cx, double cy, double z, double half, double x0, double x1, double y0, double y1,
                             int n) {
  Scene s;
  s.lights.push_back(square_light(cx, cy, z, half, 16));
  add_receiver_grid(s, x0, x1, y0, y1, 0, n);
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

// The light quad [-1,1]^2 at z = 2 (emitting down) with explicit samples on a 4 x 4 grid
// (x, y in {-0.75, -0.25, 0.25, 0.75}), one receiver at the origin; everything moved by
// `shift`. Finished, without mesh.
inline Scene quad_scene(const Vec3d& shift = Vec3d(0, 0, 0)) {
  Scene s;
  s.name = "hand";
  Light l = make_square_light_down(Vec3d(0, 0, 2) + shift, 1.0, 16, 1);
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  for (int b = 0; b < 4; ++b)
    for (int a = 0; a < 4; ++a)
      l.explicit_samples.push_back(Vec3f(Vec3d(-0.75 + 0.5 * a, -0.75 + 0.5 * b, 2.0) + shift));
  s.lights.push_back(l);
  s.receivers.push_back({Vec3f(shift), Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

// The blocker of TriangleBetweenPointAndLightQuad: a right triangle at z = 1 with legs 1
// from (0.05, 0.05). The segment from the origin to sample (x, y, 2) crosses z = 1 at
// (x/2, y/2), so it blocks exactly the four samples with x, y in {0.25, 0.75}.
inline void add_quad_blocker(Scene& s) {
  s.mesh.vertices = {Vec3f(0.05f, 0.05f, 1), Vec3f(1.05f, 0.05f, 1), Vec3f(0.05f, 1.05f, 1)};
  s.mesh.triangles = {{0, 1, 2}};
}

}  // namespace visgate::test_support
