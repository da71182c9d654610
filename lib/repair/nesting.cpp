// Nesting of closed shells (see nesting.h). Inside-ness is ray parity along +x from a
// vertex, made exact by a symbolic perturbation of the ray's start in the (y, z)
// projection, p' = p + e (1, 0) + e^2 (0, 1) for an infinitesimal e: the ray then misses
// every edge and vertex, so each crossing is a strict point-in-triangle test in the
// projection plus the sign of the 3D orientation.
#include "lib/repair/nesting.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "lib/mesh/box_tree.h"

namespace visgate::mesh {

namespace {

// Sign of the (y, z) orientation of a, b and the perturbed q; never 0 when a and b
// project to distinct points.
int perturbed_side(const Vec3d& a, const Vec3d& b, const Vec3d& q, const FilteredPredicates& fp) {
  const int s = fp.orient2d(a, b, q, 0);
  if (s != 0) return s;
  // d/de of (b - a) x (q' - a) in (y, z): -(b_z - a_z), then d/de^2: (b_y - a_y).
  if (a.z != b.z) return a.z > b.z ? 1 : -1;
  if (a.y != b.y) return b.y > a.y ? 1 : -1;
  return 0;
}

// 1: the perturbed +x ray from p crosses triangle t beyond p; 0: it does not; -1: p lies
// on the triangle (its plane, inside the perturbed projection), so parity says nothing.
int ray_crosses(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c, const FilteredPredicates& fp) {
  // Cheap exact rejection: p's (y, z) outside the triangle's projected box (closed).
  if (p.y < std::min({a.y, b.y, c.y}) || p.y > std::max({a.y, b.y, c.y}) || p.z < std::min({a.z, b.z, c.z}) ||
      p.z > std::max({a.z, b.z, c.z}) || p.x > std::max({a.x, b.x, c.x}))
    return 0;
  const int area = fp.orient2d(a, b, c, 0);
  if (area == 0) return 0;  // zero projected area: the perturbed ray misses it
  if (perturbed_side(a, b, p, fp) != area || perturbed_side(b, c, p, fp) != area || perturbed_side(c, a, p, fp) != area)
    return 0;
  const int d = fp.orientation(a, b, c, p);
  if (d == 0) return -1;
  return d != area ? 1 : 0;  // the hit is at t = -det / n_x, ahead of p iff the signs differ
}

// Whether `inner` lies inside the closed shell `outer`: parity at the lowest-index vertex
// of `inner` that is not on `outer`. False when every vertex is on `outer` (coincident
// shells). The vertex order, not the triangle order or orientation, picks the vertex, so
// repair and the analysis of its output agree even on shells that cross.
bool shell_inside(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris, const std::vector<uint32_t>& inner,
                  const std::vector<uint32_t>& outer, const FilteredPredicates& fp) {
  std::vector<uint32_t> verts;
  verts.reserve(inner.size() * 3);
  for (uint32_t t : inner) verts.insert(verts.end(), tris[t].begin(), tris[t].end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  for (uint32_t v : verts) {
    const Vec3d& p = pos[v];
    int crossings = 0;
    bool on = false;
    for (uint32_t u : outer) {
      const int r = ray_crosses(p, pos[tris[u][0]], pos[tris[u][1]], pos[tris[u][2]], fp);
      if (r < 0) { on = true; break; }
      crossings += r;
    }
    if (!on) return crossings % 2 == 1;
  }
  return false;
}

}  // namespace

// depth[i]: how many of the other shells contain shell i (by a vertex of it; shells
// of a valid solid do not cross). Only shells whose box lies in the other's box are
// tested.
std::vector<int> nesting_depths(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris,
                                const std::vector<std::vector<uint32_t>>& shells, const FilteredPredicates& fp) {
  const size_t n = shells.size();
  std::vector<Box3d> box(n);
  for (size_t i = 0; i < n; ++i) {
    box[i] = Box3d{pos[tris[shells[i][0]][0]], pos[tris[shells[i][0]][0]]};
    for (uint32_t t : shells[i])
      for (uint32_t v : tris[t]) box[i].extend(pos[v]);
  }
  auto within = [](const Box3d& a, const Box3d& b) {
    return b.lo.x <= a.lo.x && b.lo.y <= a.lo.y && b.lo.z <= a.lo.z && a.hi.x <= b.hi.x && a.hi.y <= b.hi.y &&
           a.hi.z <= b.hi.z;
  };
  std::vector<int> depth(n, 0);
  if (n < 2) return depth;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i)
      for (size_t j = 0; j < n; ++j)
        if (j != i && within(box[i], box[j]) && shell_inside(pos, tris, shells[i], shells[j], fp)) ++depth[i];
  });
  return depth;
}

}  // namespace visgate::mesh
