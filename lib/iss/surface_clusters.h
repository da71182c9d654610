// Pre-merged triangle clusters for CONSTRUCT-TRIANGLE-SURFACE (paper 000 sections 4.7.1
// and 4.7.3, with the data layout advice of section 4.13: avoid work that repeats).
//
// An initial shaft of a dense smooth surface holds nearly every triangle, and the
// per-triangle construction followed by UPDATE-PATCH-FACINGS and MERGE-PATCHES turns
// them back into a few large consistent patches plus the inconsistent band near the
// silhouette; that was linear work per light. This structure, built once per solve over
// the nodes of the triangle hierarchy (triangle_bvh.h), lets the construction insert a
// whole node as one patch when every triangle of it is provably consistent with the
// same facing: the patch is the node's boundary (the edges whose neighbour
// triangle is outside the node, directed as their triangle traverses them), which is
// what MERGE-PATCHES would have left of the node's triangles.
//
// Guarantee (what construct_clustered_surface relies on): for a node marked eligible,
// every triangle t has a nonzero normal and, with n_t its exact unit normal (sign of
// cross(b - a, c - a), as plane_through), |n_t - axis| <= spread; every vertex lies in
// the node's float box, so within `radius` of its centre. Then for every point x,
// n_t . (x - p_t) lies within axis . (x - centre) +- (spread |x - centre| + radius) for
// every point p_t of t (facing_of evaluates that bound with a margin far above its
// double rounding). The boundary of a node is the node's triangles' chain boundary:
// interior edges are double edges whose two triangles are both in the node (they
// traverse it in opposite directions, mesh::PreparedMesh), so they cancel.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "lib/iss/blockers.h"
#include "lib/iss/triangle_bvh.h"

namespace visgate::iss {

class SurfaceClusters {
 public:
  // One boundary edge: edge k (corner k to corner k + 1) of triangle t, as t * 4 + k.
  using BoundaryEdge = uint32_t;

  SurfaceClusters(const mesh::PreparedMesh& m, const TriangleBvh& bvh);

  const accel::Bvh<float>& tree() const { return bvh_; }
  bool eligible(uint32_t node) const { return nodes_[node].eligible; }
  // Facing shared by every triangle of an eligible node for the shaft's two boxes by
  // Table 4.1, from the cone bound; Inconsistent when the bound does not prove one.
  Facing facing_of(uint32_t node, const AABBd& receiver, const AABBd& light) const;
  // The node's boundary edges, appended to `out` in leaf order (triangle by triangle,
  // edges 0 to 2): the edges whose neighbour across a double edge is outside the node.
  // Computed on demand, in time linear in the node's triangles: a node is taken whole
  // at most once per initial shaft, and most nodes never are.
  void boundary(uint32_t node, std::vector<BoundaryEdge>& out) const;
  // The node's triangles are the hierarchy's order() at positions [first_pos, first_pos + count).
  uint32_t first_pos(uint32_t node) const { return nodes_[node].first_pos; }

  // Table 4.1 by triangle_facing(plane_through(a, b, c, scale), g) for the triangle at
  // leaf position `pos`, inline, with the same operations in the same order (the same
  // bits as the per-triangle construction's UPDATE-PATCH-FACINGS).
  Facing exact_facing(uint32_t pos, const ShaftGeometry& g) const {
    const uint32_t t = bvh_.order()[pos];
    const ConservativePlane pl = plane_through(to_double(m_.corner(t, 0)), to_double(m_.corner(t, 1)),
                                               to_double(m_.corner(t, 2)), g.scale());
    if (pl.n == Vec3d(0, 0, 0)) return Facing::Inconsistent;  // zero-area triangle
    const int rr = box_side(g.receiver(), pl);
    if (rr != 2) return rr == 0 ? Facing::TowardsReceiver : Facing::TowardsLight;
    const int lr = box_side(g.light(), pl);
    return lr == 0 ? Facing::TowardsLight : lr == 1 ? Facing::TowardsReceiver : Facing::Inconsistent;
  }
  // classify_box_plane inline, with the same operations in the same order (so the same
  // bits): 0 box in front, 1 behind, 2 neither.
  static int box_side(const AABBd& b, const ConservativePlane& pl) {
    const Vec3d lo(pl.n.x > 0 ? std::min(b.lo.x, b.hi.x) : std::max(b.lo.x, b.hi.x),
                   pl.n.y > 0 ? std::min(b.lo.y, b.hi.y) : std::max(b.lo.y, b.hi.y),
                   pl.n.z > 0 ? std::min(b.lo.z, b.hi.z) : std::max(b.lo.z, b.hi.z));
    const double mn = pl.eval(lo);
    if (mn > pl.tol) return 0;
    const Vec3d hi(pl.n.x > 0 ? std::max(b.lo.x, b.hi.x) : std::min(b.lo.x, b.hi.x),
                   pl.n.y > 0 ? std::max(b.lo.y, b.hi.y) : std::min(b.lo.y, b.hi.y),
                   pl.n.z > 0 ? std::max(b.lo.z, b.hi.z) : std::min(b.lo.z, b.hi.z));
    const double mx = pl.eval(hi);
    if (mx < -pl.tol) return 1;
    return 2;
  }

  size_t memory_bytes() const { return nodes_.capacity() * sizeof(Node) + pos_.capacity() * sizeof(uint32_t); }

 private:
  struct Node {
    Vec3d axis{0, 0, 0};
    Vec3d centre{0, 0, 0};
    double spread = 0, radius = 0;
    uint32_t first_pos = 0;
    bool eligible = false;
  };
  // -1, 0 or 1: box below every plane of the node, unknown, above every plane.
  int side_of(const Node& n, const AABBd& b) const;

  const mesh::PreparedMesh& m_;
  const accel::Bvh<float>& bvh_;
  std::vector<Node> nodes_;
  std::vector<uint32_t> pos_;  // leaf-order position of each triangle
};

// CONSTRUCT-TRIANGLE-SURFACE for an initial shaft from the clusters: walks the triangle
// hierarchy, skips nodes whose box misses the shaft, inserts an eligible node as one
// consistent patch when its box meets neither node box, lies between the clip planes
// and facing_of proves its facing, and otherwise builds the leaves' triangles one by
// one exactly as construct_triangle_surface does. The result represents a superset of
// the valid blockers that construct_triangle_surface would take from every triangle
// whose box may meet the shaft, as the same oriented chain restricted to the slab
// (triangles outside the shaft but inside a node taken whole are real triangles that
// meet neither node box, which blockers.h allows).
// `whole`, when given, is increased by the number of nodes taken whole. With `band`, a
// leaf triangle that is a valid blocker by add_triangle's tests, is not beyond a clip
// plane by its box and is inconsistent by Table 4.1 (triangle_facing) is appended to
// `band` instead of built (the lazy band, traversal.h: Shaft::band), in the
// hierarchy's leaf order.
// `exact_max` > 0: a node of at most that many triangles whose cone proves no facing is
// still taken whole when every triangle's own facing (exact_facing, the same bits as
// UPDATE-PATCH-FACINGS would give its patch) is the same consistent one; the cone's
// slack (spread times the distance to the boxes) fails near the band long before the
// triangles do.
Surface construct_clustered_surface(const BlockerContext& ctx, const SurfaceClusters& clusters, const ShaftGeometry& g,
                                    const TreeNode& rnode, const TreeNode& lnode, Workspace& ws,
                                    double* whole_nodes = nullptr, std::vector<uint32_t>* band = nullptr,
                                    size_t exact_max = 0);

}  // namespace visgate::iss
