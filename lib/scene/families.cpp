// Scene families (see families.h). Sizes follow paper 000 chapter 5 where a family is
// an analogue of a thesis scene (COLUMNS, TREE, SODA).
#include "lib/scene/families.h"

#include "lib/scene/exact_transform.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>

#include "lib/scene/mesh_io.h"
#include "lib/scene/rng.h"
#include "lib/scene/shapes.h"

namespace visgate {

Light make_square_light_down(const Vec3d& c, double half, int samples, uint64_t seed) {
  Light l;
  // Counter-clockwise seen from below (the emitting side): normal -z.
  l.polygon = {Vec3f(c + Vec3d(-half, -half, 0)), Vec3f(c + Vec3d(-half, half, 0)), Vec3f(c + Vec3d(half, half, 0)),
               Vec3f(c + Vec3d(half, -half, 0))};
  l.samples = samples;
  l.seed = seed;
  return l;
}

ReceiverGrid make_floor_grid(double x0, double x1, double y0, double y1, double z, int nu, int nv, float offset) {
  ReceiverGrid g;
  g.origin = Vec3f(Vec3d(x0, y0, z));
  g.u = Vec3f(Vec3d(x1 - x0, 0, 0));
  g.v = Vec3f(Vec3d(0, y1 - y0, 0));
  g.normal = Vec3f(0, 0, 1);
  g.nu = nu;
  g.nv = nv;
  g.offset = offset;
  return g;
}

Status finish_scene(Scene& s) {
  for (size_t l = 0; l < s.lights.size(); ++l) {
    Status st = prepare_light(s.lights[l], s.name + ": lights[" + std::to_string(l) + "]");
    if (!st) return st;
  }
  if (s.grid) s.receivers = grid_receivers(*s.grid);
  return {};
}

namespace {

int grid_side(long receivers, int fallback) {
  if (receivers <= 0) return fallback;
  return std::max(1, int(std::lround(std::sqrt(double(receivers)))));
}

void scale_lights(Scene& s, double k) {
  if (k == 1.0) return;
  for (auto& l : s.lights) {
    Vec3d c(0, 0, 0);
    for (const auto& p : l.polygon) c += to_double(p);
    c = c / double(l.polygon.size());
    for (auto& p : l.polygon) p = Vec3f(c + (to_double(p) - c) * k);
  }
}

// Determinism across compilers. The order in which a function's (or constructor's)
// arguments are evaluated, and the operands of an overloaded operator, is unspecified:
// g++ evaluates Vec3d(rng.uniform(), rng.uniform(), rng.uniform()) right to left, clang
// left to right, so the same seed gave different scenes in the g++ build and the clang
// fuzz build. Every draw below is therefore its own statement. The order kept is the one
// g++ used (right to left for arguments, right operand first for Vec3d + and *), so the
// scenes of the g++ build are unchanged bit for bit.
Vec3d uniform3(Rng& rng, const Vec3d& lo, const Vec3d& hi) {
  const double z = rng.uniform(lo.z, hi.z);
  const double y = rng.uniform(lo.y, hi.y);
  const double x = rng.uniform(lo.x, hi.x);
  return Vec3d(x, y, z);
}

// The start every family shares: the scene named "<family>-<seed>".
Scene named_scene(const std::string& family, const FamilyParams& p) {
  Scene s;
  s.name = family + "-" + std::to_string(p.seed);
  return s;
}

// The counts asked for (--triangles, --receivers, --samples), or the family's default.
long triangles_or(const FamilyParams& p, long fallback) { return p.triangles > 0 ? p.triangles : fallback; }
long receivers_or(const FamilyParams& p, long fallback) { return p.receivers > 0 ? p.receivers : fallback; }
int samples_or(const FamilyParams& p, int fallback) { return p.samples > 0 ? int(p.samples) : fallback; }

// A receiver grid on the floor z = 0 over [x0, x1] x [y0, y1], grid_side(--receivers,
// side) points per side.
ReceiverGrid floor_grid(const FamilyParams& p, double x0, double x1, double y0, double y1, int side, float offset) {
  const int n = grid_side(p.receivers, side);
  return make_floor_grid(x0, x1, y0, y1, 0.0, n, n, offset);
}

// The frame of most families: a square light of half-size `half` centred at `c`
// emitting down (samples_or(p, samples)), over a floor grid on [-extent, extent]^2.
void add_light_and_floor(Scene& s, const FamilyParams& p, const Vec3d& c, double half, int samples, double extent,
                         int side, float offset) {
  s.lights.push_back(make_square_light_down(c, half, samples_or(p, samples), p.seed));
  s.grid = floor_grid(p, -extent, extent, -extent, extent, side, offset);
}

Result<Scene> finished(Scene& s) {
  Status st = finish_scene(s);
  if (!st) return st.error();
  return std::move(s);
}

// random-soup: random triangles of size ~0.1-0.4 in the slab 0.3 < z < 1.7 between a
// receiver grid on z = 0 and a square light at z = 2.
Result<Scene> gen_random_soup(const FamilyParams& p) {
  Scene s = named_scene("random-soup", p);
  Rng rng(p.seed);
  const long n = triangles_or(p, 200);
  for (long t = 0; t < n; ++t) {
    const Vec3d c = uniform3(rng, Vec3d(-1, -1, 0.3), Vec3d(1, 1, 1.7));
    double size = rng.uniform(0.1, 0.4);
    uint32_t base = uint32_t(s.mesh.vertices.size());
    for (int k = 0; k < 3; ++k)
      s.mesh.vertices.push_back(Vec3f(c + uniform3(rng, Vec3d(-1, -1, -1), Vec3d(1, 1, 1)) * size));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  add_light_and_floor(s, p, Vec3d(0, 0, 2), 0.5, 16, 1.2, 16, 0.0f);
  scale_lights(s, p.light_scale);
  return finished(s);
}

// columns: the COLUMNS scene of paper 000 (section 5.1.1): cylindrical columns standing
// on a floor plane under one rectangular area light; about 2.5k triangles, 256 samples.
Result<Scene> gen_columns(const FamilyParams& p) {
  Scene s = named_scene("columns", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 2500);
  const int segments = 16;            // 16 segments: 32 side + 28 cap triangles
  const long per_column = 4L * segments - 4;
  long columns = std::max(1L, (target - 2) / per_column);
  int side = int(std::ceil(std::sqrt(double(columns))));
  double spacing = 8.0 / side;
  shapes::add_quad(s.mesh, Vec3d(-5, -5, 0), Vec3d(5, -5, 0), Vec3d(5, 5, 0), Vec3d(-5, 5, 0));
  long placed = 0;
  for (int gy = 0; gy < side && placed < columns; ++gy)
    for (int gx = 0; gx < side && placed < columns; ++gx, ++placed) {
      double x = -4 + spacing * (gx + 0.5) + rng.uniform(-0.15, 0.15) * spacing;
      double y = -4 + spacing * (gy + 0.5) + rng.uniform(-0.15, 0.15) * spacing;
      double r = spacing * rng.uniform(0.12, 0.22);
      shapes::add_cylinder(s.mesh, Vec3d(x, y, 0), r, rng.uniform(2.0, 4.0), segments);
    }
  // A rectangular light above the columns, tilted slightly so shadows are oblique.
  Light light;
  double hw = 1.5, hh = 0.75;
  light.polygon = {Vec3f(Vec3d(-hw, -hh, 6.0)), Vec3f(Vec3d(-hw, hh, 6.0)), Vec3f(Vec3d(hw, hh, 6.3)),
                   Vec3f(Vec3d(hw, -hh, 6.3))};
  light.samples = samples_or(p, 256);
  light.seed = p.seed;
  s.lights.push_back(light);
  s.grid = floor_grid(p, -5, 5, -5, 5, 64, 1e-3f);
  scale_lights(s, p.light_scale);
  return finished(s);
}

// rooms: the SODA analogue. A building of `floors` storeys of nx x ny rooms (4 m x 4 m,
// 3 m high) with walls as boxes, a door in every inner wall, floor slabs between storeys,
// furniture (tables with legs, shelves, tessellated lamps and vases) in every room and a
// square ceiling light per room. Receivers cover the ground floor. The triangle target
// scales the tessellation of the decorative objects and the number of storeys and rooms.
Result<Scene> gen_rooms(const FamilyParams& p) {
  Scene s = named_scene("rooms", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 30000);
  // Layout: 3 storeys of 3 x 3 rooms up to 100k triangles, then more rooms per storey.
  int floors = 3, nx = 3, ny = 3;
  if (target > 100000) {
    nx = ny = std::max(3, int(std::ceil(std::sqrt(double(target) / 100000.0 * 9.0))));
  }
  const double W = 4.0, H = 3.0, T = 0.2;  // room size, storey height, wall/slab thickness
  int rooms = floors * nx * ny;
  // Fixed geometry per room: walls (~5 boxes) + table (5 boxes) + shelf (4 boxes) = 14 boxes.
  long fixed = long(rooms) * 14 * 12 + long(floors + 1) * 12;
  long deco_budget = std::max(0L, target - fixed);
  // Decorative spheres per room: 4; their tessellation takes the rest of the budget.
  long per_sphere = std::max(32L, deco_budget / (long(rooms) * 4));
  int slices = std::max(6, int(std::sqrt(double(per_sphere) / 2.0)));
  int stacks = std::max(3, int(per_sphere / (2 * slices)));

  for (int f = 0; f <= floors; ++f)  // slabs: ground, between storeys, roof
    shapes::add_box(s.mesh, Vec3d(0, 0, f * H - T), Vec3d(nx * W, ny * W, f * H));
  for (int f = 0; f < floors; ++f) {
    double z0 = f * H, z1 = z0 + H - T;
    double door_w = 1.0, door_h = 2.1;
    // Walls along x (between rows) and y (between columns), with a door in inner walls.
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i < nx; ++i) {
        double x0 = i * W, x1 = x0 + W, y = j * W;
        bool inner = j > 0 && j < ny;
        if (!inner) { shapes::add_box(s.mesh, Vec3d(x0, y - T / 2, z0), Vec3d(x1, y + T / 2, z1)); continue; }
        double d0 = x0 + W / 2 - door_w / 2, d1 = d0 + door_w;
        shapes::add_box(s.mesh, Vec3d(x0, y - T / 2, z0), Vec3d(d0, y + T / 2, z1));
        shapes::add_box(s.mesh, Vec3d(d1, y - T / 2, z0), Vec3d(x1, y + T / 2, z1));
        shapes::add_box(s.mesh, Vec3d(d0, y - T / 2, z0 + door_h), Vec3d(d1, y + T / 2, z1));
      }
    for (int i = 0; i <= nx; ++i)
      for (int j = 0; j < ny; ++j) {
        double y0 = j * W, y1 = y0 + W, x = i * W;
        bool inner = i > 0 && i < nx;
        if (!inner) { shapes::add_box(s.mesh, Vec3d(x - T / 2, y0, z0), Vec3d(x + T / 2, y1, z1)); continue; }
        double d0 = y0 + W / 2 - door_w / 2 + rng.uniform(-0.8, 0.8), d1 = d0 + door_w;
        shapes::add_box(s.mesh, Vec3d(x - T / 2, y0, z0), Vec3d(x + T / 2, d0, z1));
        shapes::add_box(s.mesh, Vec3d(x - T / 2, d1, z0), Vec3d(x + T / 2, y1, z1));
        shapes::add_box(s.mesh, Vec3d(x - T / 2, d0, z0 + door_h), Vec3d(x + T / 2, d1, z1));
      }
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j) {
        Vec3d o(i * W, j * W, z0);
        // Table: top and four legs.
        double tx = rng.uniform(0.8, 2.2), ty = rng.uniform(0.8, 2.2), tw = 1.2, td = 0.8, th = 0.75;
        shapes::add_box(s.mesh, o + Vec3d(tx, ty, th - 0.05), o + Vec3d(tx + tw, ty + td, th));
        for (int k = 0; k < 4; ++k) {
          double lx = tx + (k & 1 ? tw - 0.08 : 0.02), ly = ty + (k & 2 ? td - 0.08 : 0.02);
          shapes::add_box(s.mesh, o + Vec3d(lx, ly, 0), o + Vec3d(lx + 0.06, ly + 0.06, th - 0.05));
        }
        // Shelf against a wall: sides and two boards.
        double sy = rng.uniform(0.5, 2.5);
        shapes::add_box(s.mesh, o + Vec3d(0.15, sy, 0), o + Vec3d(0.5, sy + 0.04, 1.8));
        shapes::add_box(s.mesh, o + Vec3d(0.15, sy + 0.96, 0), o + Vec3d(0.5, sy + 1.0, 1.8));
        shapes::add_box(s.mesh, o + Vec3d(0.15, sy, 0.6), o + Vec3d(0.5, sy + 1.0, 0.64));
        shapes::add_box(s.mesh, o + Vec3d(0.15, sy, 1.2), o + Vec3d(0.5, sy + 1.0, 1.24));
        // Decorative objects: vases on the table, lamps near the ceiling.
        for (int k = 0; k < 4; ++k) {
          Vec3d c = k < 2 ? o + Vec3d(tx + 0.3 + 0.6 * k, ty + 0.4, th + 0.12)
                          : o + uniform3(rng, Vec3d(0.8, 0.8, 1.6), Vec3d(3.2, 3.2, 2.2));
          shapes::add_sphere(s.mesh, c, k < 2 ? 0.1 : 0.15, slices, stacks);
        }
        // Ceiling light.
        s.lights.push_back(make_square_light_down(o + Vec3d(W / 2, W / 2, H - T - 0.02), 0.3,
                                                  samples_or(p, 64), p.seed * 1000 + s.lights.size()));
      }
  }
  s.grid = floor_grid(p, 0, nx * W, 0, ny * W, 64, 1e-2f);
  scale_lights(s, p.light_scale);
  return finished(s);
}

// ---------------------------------------------------------------------------------------
// Adversarial families. Common frame unless stated: blockers in the slab 0.3 < z < 1.7,
// a square light at z = 2 emitting down, receivers on or near z = 0.

Vec3d random_unit(Rng& rng) {
  for (;;) {
    const Vec3d v = uniform3(rng, Vec3d(-1, -1, -1), Vec3d(1, 1, 1));
    double l = length(v);
    if (l > 0.1 && l <= 1.0) return v / l;
  }
}

// Explicit samples: `n` points on the square light of half-size `half` centred at
// (0, 0, z) on a dyadic grid of step half/32 (exact floats), so aimed segments start
// from exactly known points. The light's polygon is the square itself.
Light explicit_square_light(double z, double half, int n, Rng& rng, uint64_t seed) {
  Light l = make_square_light_down(Vec3d(0, 0, z), half, n, seed);
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  for (int j = 0; j < n; ++j) {
    double x = std::round(rng.uniform(-31, 31)) * half / 32, y = std::round(rng.uniform(-31, 31)) * half / 32;
    l.explicit_samples.push_back(Vec3f(Vec3d(x, y, z)));
  }
  return l;
}

// A receiver on the line from sample `l` through target `q`, mirrored: r = 2q - l in
// double, rounded once; the open segment (r, l) has q as its midpoint up to one rounding
// of r (exactly when 2q - l is a float).
Receiver aimed_receiver(const Vec3d& q, const Vec3f& l) {
  Receiver r;
  r.p = Vec3f(q * 2.0 - to_double(l));
  r.n = Vec3f(0, 0, 1);
  return r;
}

// An explicit square light at z = 2 of half-size 0.5 * --light-scale and receivers_or(p,
// 64) receivers, the i-th aimed through sample i (cyclically) at the point target()
// draws.
template <class Target>
void add_aimed_receivers(Scene& s, const FamilyParams& p, Rng& rng, Target&& target) {
  s.lights.push_back(explicit_square_light(2.0, 0.5 * p.light_scale, samples_or(p, 16), rng, p.seed));
  const Light& L = s.lights[0];
  const long nr = receivers_or(p, 64);
  for (long i = 0; i < nr; ++i) {
    const Vec3f& l = L.explicit_samples[size_t(i) % L.explicit_samples.size()];
    s.receivers.push_back(aimed_receiver(target(), l));
  }
}

// torus: a torus (paper 000 Fig. 4.16) between the light and the receivers, slightly
// tilted, with shafts through its hole onto the receiver grid.
Result<Scene> gen_torus(const FamilyParams& p) {
  Scene s = named_scene("torus", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 1024);
  int nv = std::max(3, int(std::lround(std::sqrt(double(target) / 8.0))));  // minor segments
  int nu = std::max(3, int(target / (2 * nv)));                               // major segments
  double R = rng.uniform(0.45, 0.7), r = R * rng.uniform(0.2, 0.45);
  shapes::add_torus(s.mesh, uniform3(rng, Vec3d(-0.1, -0.1, 0.8), Vec3d(0.1, 0.1, 1.2)), R, r, nu, nv);
  const double tilt = rng.uniform(0.0, 0.4);
  const double axis_y = rng.uniform(-1, 1);
  const double axis_x = rng.uniform(-1, 1);
  shapes::rotate(s.mesh, 0, Vec3d(0, 0, 1), normalize(Vec3d(axis_x, axis_y, 0.0) + Vec3d(1e-3, 0, 0)), tilt);
  add_light_and_floor(s, p, Vec3d(0, 0, 2), 0.4 * p.light_scale, 16, 1.2, 16, 0.0f);
  return finished(s);
}

// pouch: an open sack (paper 000 Fig. 4.15). Even seeds: the body wraps around the light
// and the opening faces the receivers; odd seeds: the reverse, the body wraps around the
// receivers and the opening faces the light. Surfaces bend behind the shaft's nodes.
Result<Scene> gen_pouch(const FamilyParams& p) {
  Scene s = named_scene("pouch", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 1024);
  int slices = std::max(6, int(std::lround(std::sqrt(double(target)))));
  int stacks = std::max(2, int(target / (2 * slices)));
  double opening = rng.uniform(0.5, 1.1);  // radians from the open pole
  const bool around_light = p.seed % 2 == 0;
  const double rad = rng.uniform(0.6, 0.8);
  shapes::add_open_sphere(s.mesh, Vec3d(0, 0, around_light ? 2 : 0.1), rad, slices, stacks, opening,
                          /*open_top=*/!around_light);
  add_light_and_floor(s, p, Vec3d(0, 0, 2), (around_light ? 0.25 : 0.5) * p.light_scale, 16, around_light ? 1.5 : 0.4,
                      16, 0.0f);
  shapes::rotate(s.mesh, 0, around_light ? Vec3d(0, 0, 2) : Vec3d(0, 0, 0.1), Vec3d(1, 0, 0), rng.uniform(-0.3, 0.3));
  return finished(s);
}

// double-surface: the double cover of a disc (paper 000 Fig. 4.17), a self-intersecting
// two-sheeted surface with consistent orientation whose one boundary loop winds twice
// around the shaft from the receivers to the light.
Result<Scene> gen_double_surface(const FamilyParams& p) {
  Scene s = named_scene("double-surface", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 1024);
  // Triangles: 2 spokes (centre fan) + (rings - 1) * 4 spokes.
  int rings = std::max(1, int(std::lround(std::sqrt(double(target) / 8.0))));
  int spokes = std::max(3, int(target / (4 * rings)));
  double R = rng.uniform(0.5, 0.8), h = rng.uniform(0.2, 0.6);
  shapes::add_double_cover_disc(s.mesh, Vec3d(0, 0, rng.uniform(0.8, 1.2)), R, h, rings, spokes);
  shapes::rotate(s.mesh, 0, Vec3d(0, 0, 1), Vec3d(0, 0, 1), rng.uniform(0, 2 * std::numbers::pi));
  add_light_and_floor(s, p, Vec3d(0, 0, 2), 0.3 * p.light_scale, 16, 1.0, 16, 0.0f);
  return finished(s);
}

// grid-snapped: every coordinate on the grid of step 1/4 (receivers at z = 0, samples at
// z = 2, blockers on the planes z = 1/2, 1, 3/2 or spanning them), so the midpoint of a
// receiver and a sample (step 1/8) and the quarter points lie on blocker vertices, edges
// and planes exactly.
Result<Scene> gen_grid_snapped(const FamilyParams& p) {
  Scene s = named_scene("grid-snapped", p);
  Rng rng(p.seed);
  const long n = triangles_or(p, 200);
  const double g = 0.25;
  auto gi = [&](int lo, int hi) { return double(lo + long(rng.below(uint64_t(hi - lo + 1)))) * g; };
  for (long t = 0; t < n; ++t) {
    uint32_t base = uint32_t(s.mesh.vertices.size());
    int kind = int(rng.below(3));
    // Grid points drawn z, y, x (see uniform3).
    auto grid_point = [&](int lo, int hi, int zlo, int zhi) {
      const double z = gi(zlo, zhi);
      const double y = gi(lo, hi);
      const double x = gi(lo, hi);
      return Vec3d(x, y, z);
    };
    const Vec3d a = grid_point(-4, 4, 2, 6);
    Vec3d b, c;
    if (kind == 0) {  // horizontal: in a grid plane z = const
      for (Vec3d* v : {&b, &c}) {
        const double dy = gi(-3, 3);
        const double dx = gi(-3, 3);
        *v = Vec3d(a.x + dx, a.y + dy, a.z);
      }
    } else if (kind == 1) {  // vertical: in a plane x = const, holding vertical segments
      for (Vec3d* v : {&b, &c}) {
        const double dz = gi(-2, 2);
        const double dy = gi(-3, 3);
        *v = Vec3d(a.x, a.y + dy, a.z + dz);
      }
    } else {  // general, every vertex on the grid
      b = grid_point(-4, 4, 2, 6);
      c = grid_point(-4, 4, 2, 6);
    }
    s.mesh.vertices.push_back(Vec3f(a));
    s.mesh.vertices.push_back(Vec3f(b));
    s.mesh.vertices.push_back(Vec3f(c));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  int ns = samples_or(p, 16);
  double half = std::max(g, std::round(0.5 * p.light_scale / g) * g);
  Light l = make_square_light_down(Vec3d(0, 0, 2), half, ns, p.seed);
  l.jitter = 1;
  l.pattern = SamplePattern::Explicit;
  int hk = int(std::lround(half / g));
  for (int j = 0; j < ns; ++j) {
    const double y = gi(-hk, hk);
    const double x = gi(-hk, hk);
    l.explicit_samples.push_back(Vec3f(Vec3d(x, y, 2.0)));
  }
  s.lights.push_back(l);
  const long nr = receivers_or(p, 64);
  for (long i = 0; i < nr; ++i) {
    const double y = gi(-6, 6);
    const double x = gi(-6, 6);
    s.receivers.push_back(Receiver{Vec3f(Vec3d(x, y, 0.0)), Vec3f(0, 0, 1)});
  }
  return finished(s);
}

// shared-edge-fan: tessellated planar patches and closed fans (all tilted, vertices
// rounded to float), and receivers aimed so that the open segment to one sample passes
// through a shared vertex or through a point of a shared interior edge (its midpoint, a
// third, or a random point): exactly where the arithmetic allows, else within one
// rounding. The crack test for ray casters: a segment through a shared edge must not
// slip between the two triangles.
Result<Scene> gen_shared_edge_fan(const FamilyParams& p) {
  Scene s = named_scene("shared-edge-fan", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 400);
  struct Edge { uint32_t a, b; };
  std::vector<uint32_t> shared_vertices;
  std::vector<Edge> shared_edges;
  long made = 0;
  int piece = 0;
  while (made < target) {
    size_t v0 = s.mesh.vertices.size(), t0 = s.mesh.triangles.size();
    const Vec3d c = uniform3(rng, Vec3d(-0.8, -0.8, 0.7), Vec3d(0.8, 0.8, 1.3));
    if (piece++ % 2 == 0) {
      int m = int(std::clamp(target - made, 2L, 32L) / 2);
      int nu = std::max(1, int(std::sqrt(double(m)))), nv = std::max(1, m / nu);
      double size = rng.uniform(0.3, 0.7);
      shapes::add_patch(s.mesh, c - Vec3d(size / 2, size / 2, 0), Vec3d(size, 0, 0), Vec3d(0, size, 0), nu, nv);
      for (int b = 1; b < nv; ++b)
        for (int a = 1; a < nu; ++a) shared_vertices.push_back(uint32_t(v0 + size_t(b * (nu + 1) + a)));
    } else {
      int k = int(std::clamp(target - made, 3L, 24L));
      std::vector<Vec3d> rim;
      double rad = rng.uniform(0.15, 0.35);
      for (int i = 0; i < k; ++i) {
        double a = 2 * std::numbers::pi * (i + rng.uniform(-0.3, 0.3)) / k;
        rim.push_back(c + Vec3d(rad * std::cos(a), rad * std::sin(a), 0));
      }
      shapes::add_fan(s.mesh, c, rim, true);
      shared_vertices.push_back(uint32_t(v0));
    }
    const double angle = rng.uniform(0.1, 0.9);
    shapes::rotate(s.mesh, v0, c, random_unit(rng), angle);
    // Interior edges: edges used by two triangles of this piece.
    std::map<std::pair<uint32_t, uint32_t>, int> uses;
    for (size_t t = t0; t < s.mesh.triangles.size(); ++t)
      for (int e = 0; e < 3; ++e) {
        uint32_t a = s.mesh.triangles[t][e], b = s.mesh.triangles[t][(e + 1) % 3];
        ++uses[{std::min(a, b), std::max(a, b)}];
      }
    for (const auto& [e, cnt] : uses)
      if (cnt == 2) shared_edges.push_back({e.first, e.second});
    made += long(s.mesh.triangles.size() - t0);
  }
  add_aimed_receivers(s, p, rng, [&] {
    if (!shared_vertices.empty() && (shared_edges.empty() || rng.below(3) == 0))
      return to_double(s.mesh.vertices[shared_vertices[rng.below(shared_vertices.size())]]);
    const Edge& e = shared_edges[rng.below(shared_edges.size())];
    uint64_t kind = rng.below(3);
    double t = kind == 0 ? 0.5 : kind == 1 ? 1.0 / 3.0 : rng.uniform(0.05, 0.95);
    return to_double(s.mesh.vertices[e.a]) * (1 - t) + to_double(s.mesh.vertices[e.b]) * t;
  });
  return finished(s);
}

// sliver-soup: long thin near-degenerate triangles (length 0.5-2, width 1e-2 to 1e-7 of
// the length, some exactly collinear after rounding), with receivers aimed at points
// inside the slivers so the segments cross them within a sliver's width of its edges.
Result<Scene> gen_sliver_soup(const FamilyParams& p) {
  Scene s = named_scene("sliver-soup", p);
  Rng rng(p.seed);
  const long n = triangles_or(p, 200);
  for (long t = 0; t < n; ++t) {
    const Vec3d c = uniform3(rng, Vec3d(-0.8, -0.8, 0.5), Vec3d(0.8, 0.8, 1.5));
    const double half_length = rng.uniform(0.5, 2.0) / 2;
    Vec3d d = random_unit(rng) * half_length;
    Vec3d side = normalize(cross(d, random_unit(rng)));
    double width = length(d) * 2 * std::pow(10.0, -rng.uniform(2.0, 7.0));
    uint32_t base = uint32_t(s.mesh.vertices.size());
    s.mesh.vertices.push_back(Vec3f(c - d));
    s.mesh.vertices.push_back(Vec3f(c + d));
    s.mesh.vertices.push_back(Vec3f(c + d * rng.uniform(-0.9, 0.9) + side * width));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  add_aimed_receivers(s, p, rng, [&] {
    size_t t = rng.below(s.mesh.size());
    double a = rng.uniform(0.05, 0.9), b = rng.uniform(0.05, 0.95 - a);
    return to_double(s.mesh.corner(t, 0)) * (1 - a - b) + to_double(s.mesh.corner(t, 1)) * a +
           to_double(s.mesh.corner(t, 2)) * b;
  });
  return finished(s);
}

// on-surface: receivers exactly on blocker faces (offset 0): on a tessellated floor (at
// random points, on its shared vertices and on its shared edges), on the top faces of
// boxes standing on it, and on tilted quads (points rounded onto the face's
// neighbourhood, within one rounding of the plane); a few boxes above cast shadows.
Result<Scene> gen_on_surface(const FamilyParams& p) {
  Scene s = named_scene("on-surface", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 300);
  int cells = std::max(1, int(std::sqrt(double(std::max(2L, target / 2)) / 2.0)));
  const double F = 1.5;
  shapes::add_patch(s.mesh, Vec3d(-F, -F, 0), Vec3d(2 * F, 0, 0), Vec3d(0, 2 * F, 0), cells, cells);
  struct Face { Vec3d o, u, v, n; };
  std::vector<Face> faces;
  faces.push_back({Vec3d(-F, -F, 0), Vec3d(2 * F, 0, 0), Vec3d(0, 2 * F, 0), Vec3d(0, 0, 1)});
  while (long(s.mesh.size()) + 12 <= target) {
    uint64_t kind = rng.below(3);
    const double cy = rng.uniform(-1.2, 1.2);  // y before x (see uniform3)
    const Vec3d c(rng.uniform(-1.2, 1.2), cy, 0);
    double w = rng.uniform(0.05, 0.3);
    if (kind == 0) {  // box on the floor, receivers on its top face
      double h = std::ldexp(std::round(rng.uniform(1, 8)), -3);  // dyadic height: top face exact
      shapes::add_box(s.mesh, c - Vec3d(w, w, 0), c + Vec3d(w, w, h));
      faces.push_back({c + Vec3d(-w, -w, h), Vec3d(2 * w, 0, 0), Vec3d(0, 2 * w, 0), Vec3d(0, 0, 1)});
    } else if (kind == 1) {  // tilted quad
      Vec3d o = c + Vec3d(0, 0, rng.uniform(0.2, 0.8));
      Vec3d u = random_unit(rng) * w * 2, v = normalize(cross(Vec3d(0, 0, 1), u)) * w * 2;
      if (cross(u, v).z < 0) v = -v;
      shapes::add_quad(s.mesh, o, o + u, o + u + v, o + v);
      faces.push_back({o, u, v, normalize(cross(u, v))});
    } else {  // occluder above
      Vec3d lo = c + Vec3d(-w, -w, rng.uniform(1.0, 1.6));
      shapes::add_box(s.mesh, lo, lo + Vec3d(2 * w, 2 * w, 0.1));
    }
  }
  s.lights.push_back(make_square_light_down(Vec3d(0, 0, 2), 0.5 * p.light_scale, samples_or(p, 16), p.seed));
  const long nr = receivers_or(p, 64);
  const double cell = 2 * F / cells;
  for (long i = 0; i < nr; ++i) {
    uint64_t kind = rng.below(4);
    Vec3d q;
    Vec3d n(0, 0, 1);
    if (kind == 0) {  // floor vertex
      const double y = -F + cell * double(rng.below(uint64_t(cells) + 1));
      const double x = -F + cell * double(rng.below(uint64_t(cells) + 1));
      q = Vec3d(x, y, 0);
    } else if (kind == 1) {  // floor edge
      const double y = rng.uniform(-F, F);
      const double x = -F + cell * double(rng.below(uint64_t(cells) + 1));
      q = Vec3d(x, y, 0);
    } else {
      const Face& f = faces[rng.below(faces.size())];
      const double b = rng.uniform(0.02, 0.98);
      const double a = rng.uniform(0.02, 0.98);
      q = f.o + f.u * a + f.v * b;
      n = f.n;
    }
    s.receivers.push_back(Receiver{Vec3f(q), Vec3f(n)});
  }
  return finished(s);
}

// foliage: the TREE analogue of paper 000: thousands of small disjoint leaf triangles in
// a crown above a trunk, under a square light; receivers on the ground.
Result<Scene> gen_foliage(const FamilyParams& p) {
  Scene s = named_scene("foliage", p);
  Rng rng(p.seed);
  const long target = triangles_or(p, 4000);
  shapes::add_cylinder(s.mesh, Vec3d(0, 0, 0), 0.06, 0.9, 12);
  long leaves = std::max(1L, target - long(s.mesh.size()));
  // Leaf size shrinks with the count so the crown's density stays about constant.
  double leaf = 0.06 * std::sqrt(4000.0 / double(std::max(leaves, 100L)));
  for (long t = 0; t < leaves; ++t) {
    const double radius = 0.7 * std::cbrt(rng.uniform());
    Vec3d c = Vec3d(0, 0, 1.3) + random_unit(rng) * radius;
    Vec3d a = random_unit(rng), b = normalize(cross(a, random_unit(rng)));
    double sz = leaf * rng.uniform(0.5, 1.0);
    uint32_t base = uint32_t(s.mesh.vertices.size());
    s.mesh.vertices.push_back(Vec3f(c + a * sz));
    s.mesh.vertices.push_back(Vec3f(c + (b * 0.866 - a * 0.5) * sz));
    s.mesh.vertices.push_back(Vec3f(c - (b * 0.866 + a * 0.5) * sz));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  add_light_and_floor(s, p, Vec3d(0.3, 0.2, 3.0), 0.5 * p.light_scale, 64, 1.5, 32, 1e-3f);
  return finished(s);
}

// file:PATH: the mesh of a file, unchanged (its float coordinates kept exactly), between a
// square light above its bounding box and a receiver grid below it.
Result<Scene> gen_file(const std::string& path, const FamilyParams& p) {
  auto soup = read_polygon_file(path);
  if (!soup) return soup.error();
  auto tris = triangulate(*soup, path);
  if (!tris) return tris.error();
  Scene s;
  s.name = "file-" + path.substr(path.find_last_of('/') + 1);
  s.mesh = std::move(*tris);
  if (s.mesh.size() == 0) return Error{path + ": no triangles"};
  AABB b = s.mesh.bounds();
  Vec3d lo = to_double(b.lo), hi = to_double(b.hi), c = (lo + hi) * 0.5;
  double d = std::max(b.diagonal(), 1e-30);
  s.lights.push_back(make_square_light_down(Vec3d(c.x, c.y, hi.z + 0.5 * d), 0.25 * d * p.light_scale,
                                            samples_or(p, 16), p.seed));
  const int side = grid_side(p.receivers, 16);
  double ex = 0.5 * (hi.x - lo.x) + 0.25 * d, ey = 0.5 * (hi.y - lo.y) + 0.25 * d;
  s.grid = make_floor_grid(c.x - ex, c.x + ex, c.y - ey, c.y + ey, lo.z - 0.25 * d, side, side, 0.0f);
  return finished(s);
}

Result<Scene> gen_far_origin(const FamilyParams& p);

using Generator = std::function<Result<Scene>(const FamilyParams&)>;

const std::map<std::string, Generator>& generators() {
  static const std::map<std::string, Generator> g = {
      {"random-soup", gen_random_soup},
      {"columns", gen_columns},
      {"rooms", gen_rooms},
      {"torus", gen_torus},
      {"pouch", gen_pouch},
      {"double-surface", gen_double_surface},
      {"grid-snapped", gen_grid_snapped},
      {"far-origin", gen_far_origin},
      {"shared-edge-fan", gen_shared_edge_fan},
      {"sliver-soup", gen_sliver_soup},
      {"on-surface", gen_on_surface},
      {"foliage", gen_foliage},
  };
  return g;
}

// far-origin: a base family chosen by seed (one whose lights are axis-aligned squares, so
// they stay planar and convex after rounding) translated by an offset whose components
// have magnitudes from 1e5 to 1e6: float32 spacing there is 1/128 to 1/16, so every
// coordinate is rounded coarsely and near-degenerate configurations abound.
Result<Scene> gen_far_origin(const FamilyParams& p) {
  static const char* bases[] = {"random-soup", "torus", "pouch", "double-surface", "shared-edge-fan",
                                "sliver-soup", "grid-snapped", "on-surface", "foliage"};
  Rng rng(p.seed ^ 0xFA20F1F1ull);
  std::string base = bases[rng.below(std::size(bases))];
  FamilyParams bp = p;
  if (base == "foliage" && bp.triangles <= 0) bp.triangles = 1000;
  auto r = generators().at(base)(bp);
  if (!r) return r;
  Scene s = std::move(*r);
  Vec3d off;
  for (int k = 0; k < 3; ++k) {
    const double magnitude = std::round(std::pow(10.0, rng.uniform(5.0, 6.0)));
    off[k] = magnitude * (rng.below(2) ? 1.0 : -1.0);
  }
  auto move = [&](Vec3f& v) { v = Vec3f(to_double(v) + off); };
  for (auto& v : s.mesh.vertices) move(v);
  for (auto& l : s.lights) {
    for (auto& v : l.polygon) move(v);
    for (auto& v : l.explicit_samples) move(v);
  }
  if (s.grid) move(s.grid->origin);
  else
    for (auto& rc : s.receivers) move(rc.p);
  s.name = "far-origin-" + std::to_string(p.seed) + "-" + base;
  return finished(s);
}

}  // namespace

std::vector<std::string> family_names() {
  std::vector<std::string> out;
  for (const auto& [k, v] : generators()) out.push_back(k);
  return out;
}

bool is_family(const std::string& name) { return generators().count(name) > 0 || name.rfind("file:", 0) == 0; }

Result<Scene> generate_family(const std::string& name, const FamilyParams& p) {
  if (p.triangles > 50'000'000) return Error{"--triangles: " + std::to_string(p.triangles) + " exceeds the limit 50000000"};
  if (p.receivers > 50'000'000) return Error{"--receivers: " + std::to_string(p.receivers) + " exceeds the limit 50000000"};
  if (p.samples > (1 << 20)) return Error{"--samples: " + std::to_string(p.samples) + " exceeds the limit 1048576"};
  if (!(p.light_scale > 0) || !std::isfinite(p.light_scale)) return Error{"--light-scale: must be a positive number"};
  if (p.scale_exponent < -400 || p.scale_exponent > 400)
    return Error{"--scale-exponent: " + std::to_string(p.scale_exponent) + " is outside -400..400"};
  Result<Scene> s = Error{""};
  if (name.rfind("file:", 0) == 0) {
    s = gen_file(name.substr(5), p);
  } else {
    auto it = generators().find(name);
    if (it == generators().end()) {
      std::string known;
      for (const auto& n : family_names()) known += (known.empty() ? "" : ", ") + n;
      return Error{"unknown family '" + name + "' (known: " + known + ")"};
    }
    s = it->second(p);
  }
  if (!s || p.scale_exponent == 0) return s;
  const ScaleRange range = exact_scale_range(*s);
  const int k = std::clamp(p.scale_exponent, range.lo, range.hi);
  if (k == 0 || !range.contains(k)) return s;
  Scene scaled = scaled_scene(*s, k);
  scaled.name += "@2^" + std::to_string(k);
  return scaled;
}

}  // namespace visgate
