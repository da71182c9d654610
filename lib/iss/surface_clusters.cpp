// Pre-merged triangle clusters (see surface_clusters.h): cones, spheres and boundaries
// of the triangle hierarchy's nodes: cones bottom-up in linear time, boundaries on demand.
#include "lib/iss/surface_clusters.h"

#include <algorithm>
#include <cmath>
#include <span>

#include "lib/base/check.h"

namespace visgate::iss {

namespace {

// Cone spreads above this prove nothing useful (the bound's slack grows with it) and
// keep the node ineligible, so its children are tried instead.
constexpr double kMaxSpread = 1.0;
// Added to every computed spread: the computed unit normals differ from the exact ones
// by a few ulps, far below this.
constexpr double kSpreadSlack = 1e-9;

}  // namespace

SurfaceClusters::SurfaceClusters(const mesh::PreparedMesh& m, const TriangleBvh& bvh) : m_(m), bvh_(bvh.tree()) {
  const size_t nn = bvh_.node_count();
  nodes_.resize(nn);
  if (nn == 0 || m.triangles.size() >= (size_t(1) << 30)) {  // 4t + k must fit; else no clusters
    for (Node& n : nodes_) n.eligible = false;
    return;
  }
  // Position of each triangle in leaf order, and each node's first position: a node
  // covers the positions [begin, begin + count) (pre-order: the left child is i + 1).
  pos_.assign(m.triangles.size(), 0);
  std::span<const uint32_t> order = bvh_.order();
  for (uint32_t p = 0; p < order.size(); ++p) pos_[order[p]] = p;
  for (uint32_t i = 0; i < nn; ++i) {
    const auto& nd = bvh_.node(i);
    if (bvh_.is_leaf(nd)) {
      VG_CHECK(nodes_[i].first_pos == nd.first);  // leaves are numbered in pre-order
    } else {
      nodes_[i + 1].first_pos = nodes_[i].first_pos;
      nodes_[nd.first].first_pos = nodes_[i].first_pos + bvh_.node(i + 1).count;
    }
  }
  // Unit normals (zero for a triangle without a usable one), in leaf order.
  std::vector<Vec3d> normal(order.size());
  std::vector<uint8_t> degenerate(order.size(), 0);
  for (uint32_t p = 0; p < order.size(); ++p) {
    const uint32_t t = order[p];
    Vec3d a = to_double(m.corner(t, 0)), b = to_double(m.corner(t, 1)), c = to_double(m.corner(t, 2));
    Vec3d n = cross(b - a, c - a);
    double len = length(n);
    // A normal shorter than 1e-6 of its edges' product is a sliver whose direction the
    // double cross product may not resolve well: such a triangle's node stays per triangle.
    if (!(len > 1e-6 * length(b - a) * length(c - a)) || !std::isfinite(len)) {
      degenerate[p] = 1;
      continue;
    }
    normal[p] = n / len;
  }
  // Bottom-up (children have larger indices): cones.
  std::vector<Vec3d> sum(nn, Vec3d(0, 0, 0));
  std::vector<uint8_t> bad(nn, 0);  // a degenerate triangle below, or a cone undefined
  for (size_t ii = nn; ii-- > 0;) {
    const uint32_t i = uint32_t(ii);
    const auto& nd = bvh_.node(i);
    Node& n = nodes_[i];
    const uint32_t lo = n.first_pos, hi = n.first_pos + nd.count;
    AABBd box = to_double(nd.box);
    n.centre = (box.lo + box.hi) * 0.5;
    // Every vertex is in the box: within half its diagonal of the centre (grown by a
    // relative 1e-12 for the rounding of the centre and the length).
    n.radius = 0.5 * length(box.hi - box.lo) * (1 + 1e-12);
    if (bvh_.is_leaf(nd)) {
      for (uint32_t p = lo; p < hi; ++p) {
        bad[i] |= degenerate[p];
        sum[i] += normal[p];
      }
    } else {
      const uint32_t l = i + 1, r = nd.first;
      bad[i] = bad[l] | bad[r];
      sum[i] = sum[l] + sum[r];
    }
    double sl = length(sum[i]);
    if (bad[i] || !(sl > 0)) {
      bad[i] = 1;
      continue;
    }
    n.axis = sum[i] / sl;
    // Spread: max |n_t - axis|, from the triangles at a leaf, from the children's cones
    // above (triangle inequality).
    double spread = 0;
    if (bvh_.is_leaf(nd)) {
      for (uint32_t p = lo; p < hi; ++p) spread = std::max(spread, length(normal[p] - n.axis));
      spread += kSpreadSlack;
    } else {
      const Node& L = nodes_[i + 1];
      const Node& R = nodes_[nd.first];
      // Both children's cones are defined here (bad[] would be set otherwise).
      spread = std::max(L.spread + length(L.axis - n.axis), R.spread + length(R.axis - n.axis)) * (1 + 1e-12);
    }
    n.spread = spread;
    n.eligible = spread <= kMaxSpread;
  }
}

void SurfaceClusters::boundary(uint32_t node, std::vector<BoundaryEdge>& out) const {
  const uint32_t lo = nodes_[node].first_pos, hi = lo + bvh_.node(node).count;
  std::span<const uint32_t> order = bvh_.order();
  for (uint32_t p = lo; p < hi; ++p) {
    const uint32_t t = order[p];
    const auto& tri = m_.triangles[t];
    for (int k = 0; k < 3; ++k) {
      // Interior: a double edge whose other triangle is in the node; the two traverse
      // it in opposite directions, so they cancel in the node's chain.
      const int32_t nb = tri.neighbors[size_t(k)];
      const bool interior = nb >= 0 && m_.is_double_edge[tri.edge_labels[size_t(k)]] && pos_[size_t(nb)] >= lo &&
                            pos_[size_t(nb)] < hi;
      if (!interior) out.push_back(t * 4 + uint32_t(k));
    }
  }
}

int SurfaceClusters::side_of(const Node& n, const AABBd& b) const {
  // axis . (x - centre) over the box: extremes at the corners the axis's signs pick;
  // |x - centre| at most D over the box.
  double mn = 0, mx = 0, d2 = 0;
  for (int k = 0; k < 3; ++k) {
    double u = b.lo[k] - n.centre[k], v = b.hi[k] - n.centre[k];
    double pu = n.axis[k] * u, pv = n.axis[k] * v;
    mn += std::min(pu, pv);
    mx += std::max(pu, pv);
    d2 += std::max(u * u, v * v);
  }
  double d = std::sqrt(d2);
  // The slack of surface_clusters.h plus a margin of 1e-9 of the magnitudes involved,
  // far above the double rounding of these few operations.
  double slack = n.spread * d + n.radius + 1e-9 * (d + n.radius);
  if (mn - slack > 0) return 1;
  if (mx + slack < 0) return -1;
  return 0;
}

Facing SurfaceClusters::facing_of(uint32_t node, const AABBd& receiver, const AABBd& light) const {
  const Node& n = nodes_[node];
  if (!n.eligible) return Facing::Inconsistent;
  // Table 4.1, as update_patch_facings: receiver in front -> towards the receiver, behind
  // -> towards the light; else light in front -> towards the light, behind -> receiver.
  int rs = side_of(n, receiver);
  if (rs > 0) return Facing::TowardsReceiver;
  if (rs < 0) return Facing::TowardsLight;
  int ls = side_of(n, light);
  if (ls > 0) return Facing::TowardsLight;
  if (ls < 0) return Facing::TowardsReceiver;
  return Facing::Inconsistent;
}

}  // namespace visgate::iss
