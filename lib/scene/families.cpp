// Scene families (see families.h). Sizes follow paper 000 chapter 5 where a family is
// an analogue of a thesis scene (COLUMNS, TREE, SODA).
#include "lib/scene/families.h"

#include <cmath>
#include <functional>
#include <map>

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

// random-soup: random triangles of size ~0.1-0.4 in the slab 0.3 < z < 1.7 between a
// receiver grid on z = 0 and a square light at z = 2.
Result<Scene> gen_random_soup(const FamilyParams& p) {
  Scene s;
  s.name = "random-soup-" + std::to_string(p.seed);
  Rng rng(p.seed);
  long n = p.triangles > 0 ? p.triangles : 200;
  for (long t = 0; t < n; ++t) {
    Vec3d c(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.3, 1.7));
    double size = rng.uniform(0.1, 0.4);
    uint32_t base = uint32_t(s.mesh.vertices.size());
    for (int k = 0; k < 3; ++k)
      s.mesh.vertices.push_back(Vec3f(c + Vec3d(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-1, 1)) * size));
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  s.lights.push_back(make_square_light_down(Vec3d(0, 0, 2), 0.5, p.samples > 0 ? int(p.samples) : 16, p.seed));
  int side = grid_side(p.receivers, 16);
  s.grid = make_floor_grid(-1.2, 1.2, -1.2, 1.2, 0.0, side, side, 0.0f);
  scale_lights(s, p.light_scale);
  Status st = finish_scene(s);
  if (!st) return st.error();
  return s;
}

// columns: the COLUMNS scene of paper 000 (section 5.1.1): cylindrical columns standing
// on a floor plane under one rectangular area light; about 2.5k triangles, 256 samples.
Result<Scene> gen_columns(const FamilyParams& p) {
  Scene s;
  s.name = "columns-" + std::to_string(p.seed);
  Rng rng(p.seed);
  long target = p.triangles > 0 ? p.triangles : 2500;
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
  light.samples = p.samples > 0 ? int(p.samples) : 256;
  light.seed = p.seed;
  s.lights.push_back(light);
  int g = grid_side(p.receivers, 64);
  s.grid = make_floor_grid(-5, 5, -5, 5, 0.0, g, g, 1e-3f);
  scale_lights(s, p.light_scale);
  Status st = finish_scene(s);
  if (!st) return st.error();
  return s;
}

// rooms: the SODA analogue. A building of `floors` storeys of nx x ny rooms (4 m x 4 m,
// 3 m high) with walls as boxes, a door in every inner wall, floor slabs between storeys,
// furniture (tables with legs, shelves, tessellated lamps and vases) in every room and a
// square ceiling light per room. Receivers cover the ground floor. The triangle target
// scales the tessellation of the decorative objects and the number of storeys and rooms.
Result<Scene> gen_rooms(const FamilyParams& p) {
  Scene s;
  s.name = "rooms-" + std::to_string(p.seed);
  Rng rng(p.seed);
  long target = p.triangles > 0 ? p.triangles : 30000;
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
                          : o + Vec3d(rng.uniform(0.8, 3.2), rng.uniform(0.8, 3.2), rng.uniform(1.6, 2.2));
          shapes::add_sphere(s.mesh, c, k < 2 ? 0.1 : 0.15, slices, stacks);
        }
        // Ceiling light.
        s.lights.push_back(make_square_light_down(o + Vec3d(W / 2, W / 2, H - T - 0.02), 0.3,
                                                  p.samples > 0 ? int(p.samples) : 64, p.seed * 1000 + s.lights.size()));
      }
  }
  int g = grid_side(p.receivers, 64);
  s.grid = make_floor_grid(0, nx * W, 0, ny * W, 0.0, g, g, 1e-2f);
  scale_lights(s, p.light_scale);
  Status st = finish_scene(s);
  if (!st) return st.error();
  return s;
}

using Generator = std::function<Result<Scene>(const FamilyParams&)>;

const std::map<std::string, Generator>& generators() {
  static const std::map<std::string, Generator> g = {
      {"random-soup", gen_random_soup},
      {"columns", gen_columns},
      {"rooms", gen_rooms},
  };
  return g;
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
  auto it = generators().find(name);
  if (it == generators().end()) {
    std::string known;
    for (const auto& n : family_names()) known += (known.empty() ? "" : ", ") + n;
    return Error{"unknown family '" + name + "' (known: " + known + ")"};
  }
  return it->second(p);
}

}  // namespace visgate
