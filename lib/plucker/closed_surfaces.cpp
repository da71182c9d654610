// Closed surfaces of the scene; see closed_surfaces.h.
#include "lib/plucker/closed_surfaces.h"

#include <cmath>

#include "lib/mesh/prepare.h"

namespace visgate::plucker {

ClosedSurfaces::ClosedSurfaces(const TriangleSoup& mesh, const mesh::PreparedMesh& pm) {
  const size_t n = pm.triangles.size();
  // Components by a flood over the neighbours (symmetric, lib/mesh/prepare.h) from each
  // unreached triangle in increasing order: each is first met at its smallest triangle,
  // the order in which the ids below are given. A component is closed when none of its
  // triangles has an edge without a neighbour.
  std::vector<int32_t> comp(n, -1);
  std::vector<uint8_t> comp_open;
  std::vector<uint32_t> stack;
  for (uint32_t t0 = 0; t0 < n; ++t0) {
    if (comp[t0] >= 0) continue;
    const int32_t c = int32_t(comp_open.size());
    uint8_t open = 0;
    comp[t0] = c;
    stack.push_back(t0);
    while (!stack.empty()) {
      const uint32_t t = stack.back();
      stack.pop_back();
      for (const int32_t nb : pm.triangles[t].neighbors) {
        if (nb < 0) {
          open = 1;
        } else if (comp[size_t(nb)] < 0) {
          comp[size_t(nb)] = c;
          stack.push_back(uint32_t(nb));
        }
      }
    }
    comp_open.push_back(open);
  }
  // Surface ids in the order of the closed components' first triangles.
  std::vector<int32_t> id(comp_open.size(), -1);
  int32_t closed = 0;
  for (size_t c = 0; c < comp_open.size(); ++c)
    if (!comp_open[c]) id[c] = closed++;
  if (closed == 0) return;
  boxes_.resize(size_t(closed));
  sizes_.assign(size_t(closed), 0);
  surface_of_.assign(mesh.size(), -1);
  nb_.assign(mesh.size(), {-1, -1, -1});
  // Sources are increasing, so with no triangle dropped every source is its own index.
  const bool same_ids = n == mesh.size();
  // Each welded vertex extends a surface's box once (stamp: the last surface it
  // extended): extend moves lo (hi) only for a point strictly below (above) it, so a
  // point met again leaves the box's bits as they are, whatever the order.
  std::vector<int32_t> stamp(pm.vertex_pos.size(), -1);
  for (uint32_t t = 0; t < n; ++t) {
    const int32_t s = id[size_t(comp[t])];
    if (s < 0) continue;
    const mesh::PreparedTriangle& tri = pm.triangles[t];
    surface_of_[tri.source] = s;
    ++sizes_[size_t(s)];
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = tri.v[size_t(k)];
      if (stamp[v] != s) {
        stamp[v] = s;
        boxes_[size_t(s)].extend(pm.vertex_pos[v]);
      }
      const int32_t nb = tri.neighbors[size_t(k)];  // >= 0: the component is closed
      nb_[tri.source][size_t(k)] = same_ids ? nb : int32_t(pm.triangles[size_t(nb)].source);
    }
  }
  // Signed volumes about each box's centre, in double, with the sum of the terms'
  // magnitudes as the scale below which the sign is not trusted.
  std::vector<double> vol(boxes_.size(), 0.0), mag(boxes_.size(), 0.0);
  std::vector<Vec3d> centre(boxes_.size());
  for (size_t s = 0; s < boxes_.size(); ++s) centre[s] = (to_double(boxes_[s].lo) + to_double(boxes_[s].hi)) * 0.5;
  for (uint32_t t = 0; t < mesh.size(); ++t) {
    const int32_t s = surface_of_[t];
    if (s < 0) continue;
    const Vec3d o = centre[size_t(s)];
    const Vec3d a = to_double(mesh.corner(t, 0)) - o, b = to_double(mesh.corner(t, 1)) - o,
                c = to_double(mesh.corner(t, 2)) - o;
    const double v = dot(a, cross(b, c));
    vol[size_t(s)] += v;
    mag[size_t(s)] += std::abs(v);
  }
  orient_.resize(boxes_.size());
  for (size_t s = 0; s < boxes_.size(); ++s)
    orient_[s] = int8_t(vol[s] > 1e-9 * mag[s] ? 1 : (vol[s] < -1e-9 * mag[s] ? -1 : 0));
}

}  // namespace visgate::plucker
