// scan: the analogue of paper 000's BUNNY scene (section 5.1.1: the Stanford bunny, ~70k
// triangles, on a plane, "lit by a number of light sources from different directions":
// 10 rectangular lights of 36 samples each; receivers the image's primary-ray hits).
// What is followed from it: a dense closed smooth object standing on a plane, 10
// rectangular lights around and above it facing it, 36 samples per light by default,
// receivers on the plane around it. The thesis gives no light sizes or positions; here
// each light is a 0.6 x 0.4 rectangle (x light_scale) at distance 4 from an object of
// radius about 1, at elevations 30-65 degrees and evenly spread azimuths, so that the
// object casts overlapping soft shadows on the floor grid (1e-3 above the ground).
//
// The object: an ellipsoid (semi-axes 0.85-1.15) displaced radially by smooth
// low-frequency noise (eight sinusoids of the direction, wave numbers 1.5-4, relative
// amplitude up to 0.09 in total), triangulated as a cube sphere: each cube face an n x n
// grid mapped to the sphere by the equal-angle (tangent) warp, 12 n^2 triangles, the
// shorter diagonal of each displaced cell. The map from direction to point is radial and
// injective, so the surface is a closed 2-manifold without self-intersections, every
// triangle counter-clockwise seen from outside, and shared edges are shared indices (the
// cube's lattice points are indexed once). It stands 0.01 above a closed ground slab
// (12 triangles), so the whole mesh is closed.
#include "lib/scene/family_scan.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <numbers>
#include <unordered_map>

#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"

namespace visgate {

namespace {

struct Wave {
  Vec3d k;
  double amplitude, phase;
};

// Radius of the displaced ellipsoid in unit direction d.
double radius_at(const Vec3d& d, const Vec3d& axes, const std::vector<Wave>& waves) {
  const double q = (d.x / axes.x) * (d.x / axes.x) + (d.y / axes.y) * (d.y / axes.y) + (d.z / axes.z) * (d.z / axes.z);
  double r = 1.0 / std::sqrt(q);
  double bump = 0.0;
  for (const Wave& w : waves) bump += w.amplitude * std::sin(dot(w.k, d) + w.phase);
  return r * (1.0 + bump);
}

// A light rectangle of half-sizes (a, b) centred at c, emitting along unit `d` (its
// polygon counter-clockwise seen from the emitting side, as make_square_light_down).
Light facing_light(const Vec3d& c, const Vec3d& d, double a, double b, int samples, uint64_t seed) {
  const Vec3d up = std::abs(d.z) < 0.9 ? Vec3d(0, 0, 1) : Vec3d(1, 0, 0);
  const Vec3d e1 = normalize(cross(up, d));
  const Vec3d e2 = cross(d, e1);  // e1 x e2 = d: the order below turns counter-clockwise about d
  Light l;
  l.polygon = {Vec3f(c - e1 * a - e2 * b), Vec3f(c + e1 * a - e2 * b), Vec3f(c + e1 * a + e2 * b),
               Vec3f(c - e1 * a + e2 * b)};
  l.samples = samples;
  l.seed = seed;
  return l;
}

}  // namespace

Result<Scene> gen_scan(const FamilyParams& p) {
  Scene s;
  s.name = "scan-" + std::to_string(p.seed);
  Rng rng(p.seed);
  const long target = p.triangles > 0 ? p.triangles : 20000;
  const long ground = 12;
  const int n = std::max(2, int(std::lround(std::sqrt(double(std::max(target - ground, 48L)) / 12.0))));

  // Shape parameters; every draw its own statement (families.cpp: argument order).
  Vec3d axes;
  for (int k = 0; k < 3; ++k) axes[k] = rng.uniform(0.85, 1.15);
  std::vector<Wave> waves(8);
  for (size_t w = 0; w < waves.size(); ++w) {
    Vec3d dir;
    for (int k = 0; k < 3; ++k) dir[k] = rng.uniform(-1.0, 1.0);
    if (length(dir) < 1e-3) dir = Vec3d(0, 0, 1);
    const double wave_number = rng.uniform(1.5, 4.0);
    waves[w].k = normalize(dir) * wave_number;
    waves[w].amplitude = rng.uniform(0.004, 0.018);
    waves[w].phase = rng.uniform(0.0, 2 * std::numbers::pi);
  }

  // Cube-sphere vertices, one per lattice point (i, j, k) of the cube's surface.
  const long side = n + 1;
  std::unordered_map<uint64_t, uint32_t> index;
  index.reserve(size_t(6 * side * side));
  std::vector<Vec3d> pos;
  auto warp = [&](long i) { return std::tan((2.0 * double(i) / n - 1.0) * std::numbers::pi / 4); };
  auto vertex = [&](long i, long j, long k) {
    const uint64_t key = uint64_t((i * side + j) * side + k);
    auto it = index.find(key);
    if (it != index.end()) return it->second;
    const Vec3d d = normalize(Vec3d(warp(i), warp(j), warp(k)));
    pos.push_back(d * radius_at(d, axes, waves));
    return index.emplace(key, uint32_t(pos.size() - 1)).first->second;
  };
  std::vector<std::array<uint32_t, 3>> tris;
  tris.reserve(size_t(12 * n) * size_t(n));
  for (int axis = 0; axis < 3; ++axis)
    for (int sign = 0; sign < 2; ++sign) {
      const int u = (axis + 1) % 3, v = (axis + 2) % 3;  // (u, v, axis) right-handed
      for (long a = 0; a < n; ++a)
        for (long b = 0; b < n; ++b) {
          auto at = [&](long du, long dv) {
            long c[3];
            c[axis] = sign ? n : 0;
            c[u] = a + du;
            c[v] = b + dv;
            return vertex(c[0], c[1], c[2]);
          };
          // Counter-clockwise seen from outside: u x v is +axis, so the +axis face keeps
          // the (u, v) order and the -axis face reverses it.
          std::array<uint32_t, 4> q = {at(0, 0), at(1, 0), at(1, 1), at(0, 1)};
          if (!sign) std::swap(q[1], q[3]);
          const bool d02 = length(pos[q[2]] - pos[q[0]]) <= length(pos[q[3]] - pos[q[1]]);
          if (d02) {
            tris.push_back({q[0], q[1], q[2]});
            tris.push_back({q[0], q[2], q[3]});
          } else {
            tris.push_back({q[0], q[1], q[3]});
            tris.push_back({q[1], q[2], q[3]});
          }
        }
    }

  // Standing 0.01 above the ground slab's top face z = 0.
  double zmin = 1e300;
  for (const Vec3d& x : pos) zmin = std::min(zmin, x.z);
  const Vec3d lift(0, 0, 0.01 - zmin);
  shapes::add_box(s.mesh, Vec3d(-3, -3, -0.2), Vec3d(3, 3, 0));
  const uint32_t base = uint32_t(s.mesh.vertices.size());
  for (const Vec3d& x : pos) s.mesh.vertices.push_back(Vec3f(x + lift));
  for (const auto& t : tris) s.mesh.triangles.push_back({base + t[0], base + t[1], base + t[2]});

  // Ten lights around and above the object's centre, facing it.
  const Vec3d centre = lift;
  const int samples = p.samples > 0 ? int(p.samples) : 36;
  for (int l = 0; l < 10; ++l) {
    const double elevation = rng.uniform(30.0, 65.0) * std::numbers::pi / 180;
    const double azimuth = (double(l) + rng.uniform(-0.3, 0.3)) * 2 * std::numbers::pi / 10;
    const Vec3d dir(std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth), std::sin(elevation));
    s.lights.push_back(facing_light(centre + dir * 4.0, -dir, 0.3 * p.light_scale, 0.2 * p.light_scale, samples,
                                    p.seed * 1000 + uint64_t(l)));
  }
  const long g = p.receivers > 0 ? std::max(1L, std::lround(std::sqrt(double(p.receivers)))) : 32;
  s.grid = make_floor_grid(-2.5, 2.5, -2.5, 2.5, 0.0, int(g), int(g), 1e-3f);
  Status st = finish_scene(s);
  if (!st) return st.error();
  return s;
}

}  // namespace visgate
