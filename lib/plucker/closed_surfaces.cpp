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
  std::vector<int32_t> id(comp_open.size(), -1);
  std::vector<int32_t> of(mesh.size(), -1);
  bool any = false;
  for (uint32_t t = 0; t < n; ++t) {
    const size_t root = size_t(comp[t]);
    if (comp_open[root]) continue;
    if (id[root] < 0) {
      id[root] = int32_t(boxes_.size());
      boxes_.emplace_back();
      sizes_.push_back(0);
    }
    const int32_t s = id[root];
    of[pm.triangles[t].source] = s;
    for (int k = 0; k < 3; ++k) boxes_[size_t(s)].extend(pm.corner(t, k));
    ++sizes_[size_t(s)];
    any = true;
  }
  if (!any) return;
  surface_of_ = std::move(of);
  nb_.assign(mesh.size(), {-1, -1, -1});
  for (uint32_t t = 0; t < n; ++t) {
    const uint32_t src = pm.triangles[t].source;
    if (surface_of_[src] < 0) continue;
    for (int k = 0; k < 3; ++k)
      nb_[src][size_t(k)] = int32_t(pm.triangles[size_t(pm.triangles[t].neighbors[size_t(k)])].source);
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
