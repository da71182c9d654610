#include "lib/scene/shapes.h"

#include <cmath>
#include <numbers>

namespace visgate::shapes {

namespace {
uint32_t vtx(TriangleSoup& s, const Vec3d& p) {
  s.vertices.push_back(Vec3f(p));
  return uint32_t(s.vertices.size() - 1);
}
}  // namespace

void add_quad(TriangleSoup& s, const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) {
  uint32_t ia = vtx(s, a), ib = vtx(s, b), ic = vtx(s, c), id = vtx(s, d);
  s.triangles.push_back({ia, ib, ic});
  s.triangles.push_back({ia, ic, id});
}

void add_box(TriangleSoup& s, const Vec3d& lo, const Vec3d& hi) {
  uint32_t base = uint32_t(s.vertices.size());
  for (int i = 0; i < 8; ++i)
    s.vertices.push_back(Vec3f(Vec3d(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z)));
  // Faces as CCW quads seen from outside (corner index bits: x=1, y=2, z=4).
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    s.triangles.push_back({base + f[0], base + f[1], base + f[2]});
    s.triangles.push_back({base + f[0], base + f[2], base + f[3]});
  }
}

void add_cylinder(TriangleSoup& s, const Vec3d& b, double r, double h, int n) {
  uint32_t base = uint32_t(s.vertices.size());
  for (int i = 0; i < n; ++i) {
    double a = 2 * std::numbers::pi * i / n;
    s.vertices.push_back(Vec3f(Vec3d(b.x + r * std::cos(a), b.y + r * std::sin(a), b.z)));
    s.vertices.push_back(Vec3f(Vec3d(b.x + r * std::cos(a), b.y + r * std::sin(a), b.z + h)));
  }
  for (int i = 0; i < n; ++i) {
    uint32_t b0 = base + 2 * i, t0 = b0 + 1, b1 = base + 2 * ((i + 1) % n), t1 = b1 + 1;
    s.triangles.push_back({b0, b1, t1});
    s.triangles.push_back({b0, t1, t0});
  }
  for (int i = 1; i + 1 < n; ++i) {
    s.triangles.push_back({base + 1, base + 2 * i + 1, base + 2 * (i + 1) + 1});  // top, CCW from +z
    s.triangles.push_back({base, base + 2 * (i + 1), base + 2 * i});              // bottom, CCW from -z
  }
}

void add_sphere(TriangleSoup& s, const Vec3d& c, double r, int slices, int stacks) {
  uint32_t base = uint32_t(s.vertices.size());
  for (int j = 0; j <= stacks; ++j) {
    double th = std::numbers::pi * j / stacks;
    for (int i = 0; i < slices; ++i) {
      double ph = 2 * std::numbers::pi * i / slices;
      s.vertices.push_back(Vec3f(c + Vec3d(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th)) * r));
    }
  }
  auto id = [&](int j, int i) { return base + uint32_t(j * slices + (i % slices)); };
  for (int j = 0; j < stacks; ++j)
    for (int i = 0; i < slices; ++i) {
      if (j > 0) s.triangles.push_back({id(j, i), id(j + 1, i), id(j, i + 1)});
      if (j + 1 < stacks) s.triangles.push_back({id(j, i + 1), id(j + 1, i), id(j + 1, i + 1)});
    }
}

void add_torus(TriangleSoup& s, const Vec3d& c, double R, double r, int nu, int nv) {
  uint32_t base = uint32_t(s.vertices.size());
  for (int i = 0; i < nu; ++i) {
    double u = 2 * std::numbers::pi * i / nu;
    for (int j = 0; j < nv; ++j) {
      double v = 2 * std::numbers::pi * j / nv;
      double rr = R + r * std::cos(v);
      s.vertices.push_back(Vec3f(c + Vec3d(rr * std::cos(u), rr * std::sin(u), r * std::sin(v))));
    }
  }
  auto id = [&](int i, int j) { return base + uint32_t((i % nu) * nv + (j % nv)); };
  for (int i = 0; i < nu; ++i)
    for (int j = 0; j < nv; ++j) {
      s.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      s.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
}

}  // namespace visgate::shapes
