// Triangle shapes for the scene families (see shapes.h).
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

void add_patch(TriangleSoup& s, const Vec3d& o, const Vec3d& u, const Vec3d& v, int nu, int nv) {
  uint32_t base = uint32_t(s.vertices.size());
  for (int b = 0; b <= nv; ++b)
    for (int a = 0; a <= nu; ++a) s.vertices.push_back(Vec3f(o + u * (double(a) / nu) + v * (double(b) / nv)));
  auto id = [&](int a, int b) { return base + uint32_t(b * (nu + 1) + a); };
  for (int b = 0; b < nv; ++b)
    for (int a = 0; a < nu; ++a) {
      uint32_t p00 = id(a, b), p10 = id(a + 1, b), p11 = id(a + 1, b + 1), p01 = id(a, b + 1);
      if ((a + b) % 2 == 0) {
        s.triangles.push_back({p00, p10, p11});
        s.triangles.push_back({p00, p11, p01});
      } else {
        s.triangles.push_back({p00, p10, p01});
        s.triangles.push_back({p10, p11, p01});
      }
    }
}

void add_fan(TriangleSoup& s, const Vec3d& center, const std::vector<Vec3d>& rim, bool closed) {
  uint32_t c = vtx(s, center), first = uint32_t(s.vertices.size());
  for (const auto& p : rim) vtx(s, p);
  uint32_t n = uint32_t(rim.size());
  for (uint32_t k = 0; k + 1 < n + (closed ? 1u : 0u); ++k) s.triangles.push_back({c, first + k, first + (k + 1) % n});
}

void add_open_sphere(TriangleSoup& s, const Vec3d& c, double r, int slices, int stacks, double opening, bool open_top) {
  // Polar angle th runs from `opening` to pi measured from the open pole; the closed
  // pole is one vertex.
  uint32_t base = uint32_t(s.vertices.size());
  double sgn = open_top ? 1.0 : -1.0;
  auto point = [&](double th, double ph) {
    return c + Vec3d(std::sin(th) * std::cos(ph), sgn * std::sin(th) * std::sin(ph), sgn * std::cos(th)) * r;
  };
  for (int j = 0; j < stacks; ++j) {
    double th = opening + (std::numbers::pi - opening) * j / stacks;
    for (int i = 0; i < slices; ++i) s.vertices.push_back(Vec3f(point(th, 2 * std::numbers::pi * i / slices)));
  }
  uint32_t pole = vtx(s, point(std::numbers::pi, 0.0));
  auto id = [&](int j, int i) { return base + uint32_t(j * slices + (i % slices)); };
  // With open_top the map (th, ph) is the usual sphere map, outward for (j, i+1, j+1)
  // ordering as in add_sphere; mirroring y and z for the other pole keeps it outward
  // (two reflections are a rotation).
  for (int j = 0; j + 1 < stacks; ++j)
    for (int i = 0; i < slices; ++i) {
      s.triangles.push_back({id(j, i), id(j + 1, i), id(j, i + 1)});
      s.triangles.push_back({id(j, i + 1), id(j + 1, i), id(j + 1, i + 1)});
    }
  for (int i = 0; i < slices; ++i) s.triangles.push_back({id(stacks - 1, i), pole, id(stacks - 1, i + 1)});
}

void add_double_cover_disc(TriangleSoup& s, const Vec3d& c, double R, double h, int rings, int spokes) {
  const int m = 2 * spokes;  // vertices per ring: t covers [0, 4 pi)
  uint32_t center = vtx(s, c), base = uint32_t(s.vertices.size());
  for (int k = 1; k <= rings; ++k) {
    double r = R * k / rings;
    for (int i = 0; i < m; ++i) {
      double t = (i + 0.5) * 2 * std::numbers::pi / spokes;
      s.vertices.push_back(Vec3f(c + Vec3d(r * std::cos(t), r * std::sin(t), h * r * std::sin(t / 2))));
    }
  }
  auto id = [&](int k, int i) { return base + uint32_t((k - 1) * m + (i % m)); };
  // Counter-clockwise seen from +z where the projection is counter-clockwise in t.
  for (int i = 0; i < m; ++i) s.triangles.push_back({center, id(1, i), id(1, i + 1)});
  for (int k = 1; k < rings; ++k)
    for (int i = 0; i < m; ++i) {
      s.triangles.push_back({id(k, i), id(k + 1, i), id(k + 1, i + 1)});
      s.triangles.push_back({id(k, i), id(k + 1, i + 1), id(k, i + 1)});
    }
}

void rotate(TriangleSoup& s, size_t first, const Vec3d& pivot, const Vec3d& axis, double angle) {
  double co = std::cos(angle), si = std::sin(angle);
  for (size_t i = first; i < s.vertices.size(); ++i) {
    Vec3d p = to_double(s.vertices[i]) - pivot;
    Vec3d q = p * co + cross(axis, p) * si + axis * (dot(axis, p) * (1 - co));
    s.vertices[i] = Vec3f(pivot + q);
  }
}

}  // namespace visgate::shapes
