// Radial pairing of non-manifold edges (see radial_pairing.h).
#include "lib/iss/radial_pairing.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace visgate::iss {

size_t pair_nonmanifold_edges(mesh::PreparedMesh& m) {
  struct Inc {
    uint64_t key;
    uint32_t tri;
    uint8_t k;
    bool forward;  // traverses the edge from the smaller to the larger vertex index
    double angle = 0;
  };
  std::vector<Inc> inc;
  inc.reserve(m.triangles.size() * 3);
  for (uint32_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    for (uint8_t k = 0; k < 3; ++k) {
      if (tri.neighbors[k] >= 0) continue;  // already a double edge
      uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
      inc.push_back({(uint64_t(std::min(a, b)) << 32) | std::max(a, b), t, k, a < b});
    }
  }
  std::sort(inc.begin(), inc.end(), [](const Inc& x, const Inc& y) {
    return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.k < y.k);
  });
  size_t pairs = 0;
  std::vector<Inc> group;
  for (size_t i = 0; i < inc.size();) {
    size_t j = i;
    while (j < inc.size() && inc[j].key == inc[i].key) ++j;
    size_t n = j - i;
    if (n < 4 || n % 2 != 0) {
      i = j;
      continue;
    }
    // Angle of each triangle's third vertex about the edge a -> b (a the smaller
    // index), in a frame e1, e2 = d x e1 perpendicular to d.
    uint32_t va = uint32_t(inc[i].key >> 32), vb = uint32_t(inc[i].key & 0xffffffffu);
    Vec3d pa = to_double(m.vertex_pos[va]), d = to_double(m.vertex_pos[vb]) - pa;
    double dl = length(d);
    Vec3d dn = d / dl;
    Vec3d ad = vabs(dn);
    Vec3d ek(0, 0, 0);
    ek[(ad.x <= ad.y && ad.x <= ad.z) ? 0 : (ad.y <= ad.z ? 1 : 2)] = 1.0;
    Vec3d e1 = normalize(cross(dn, ek)), e2 = cross(dn, e1);
    group.assign(inc.begin() + long(i), inc.begin() + long(j));
    for (Inc& g : group) {
      const auto& tri = m.triangles[g.tri];
      Vec3d w = to_double(m.vertex_pos[tri.v[(g.k + 2) % 3]]) - pa;
      g.angle = std::atan2(dot(w, e2), dot(w, e1));
    }
    // Counter-clockwise order; at equal angles (coincident faces) the forward triangle,
    // whose normal points towards the other, comes first.
    std::sort(group.begin(), group.end(), [](const Inc& x, const Inc& y) {
      return x.angle != y.angle ? x.angle < y.angle : (x.forward && !y.forward);
    });
    bool alternate = true;
    for (size_t q = 0; q < n && alternate; ++q) alternate = group[q].forward != group[(q + 1) % n].forward;
    // Two triangles within rounding of the same angle could be ordered either way; an
    // order that no longer alternates is caught above, one that does is a valid pairing.
    if (alternate) {
      size_t first = group[0].forward ? 0 : 1;
      for (size_t q = first; q < n; q += 2) {
        const Inc& f = group[q];
        const Inc& g = group[(q + 1) % n];
        auto& tf = m.triangles[f.tri];
        auto& tg = m.triangles[g.tri];
        uint32_t label = tf.edge_labels[f.k];
        tg.edge_labels[g.k] = label;  // g's own label is left unused, renumbered below
        m.is_double_edge[label] = 1;
        tf.neighbors[f.k] = int32_t(g.tri);
        tg.neighbors[g.k] = int32_t(f.tri);
        ++pairs;
      }
    }
    i = j;
  }
  if (pairs == 0) return 0;
  // Dense renumbering in order of first use.
  std::vector<int64_t> remap(m.edge_count(), -1);
  std::vector<uint8_t> dbl;
  dbl.reserve(m.edge_count());
  for (auto& tri : m.triangles)
    for (int k = 0; k < 3; ++k) {
      uint32_t& l = tri.edge_labels[k];
      if (remap[l] < 0) {
        remap[l] = int64_t(dbl.size());
        dbl.push_back(m.is_double_edge[l]);
      }
      l = uint32_t(remap[l]);
    }
  m.is_double_edge.swap(dbl);
  return pairs;
}

}  // namespace visgate::iss
