// Pre-merged triangle clusters for CONSTRUCT-TRIANGLE-SURFACE (paper 000 sections 4.7.1
// and 4.7.3, with the data layout advice of section 4.13: avoid work that repeats).
//
// An initial shaft of a dense smooth surface holds nearly every triangle, and the
// per-triangle construction followed by UPDATE-PATCH-FACINGS and MERGE-PATCHES turns
// them back into a few large consistent patches plus the inconsistent band near the
// silhouette; that was linear work per light. This structure, built once per solve over
// the nodes of the triangle hierarchy (triangle_bvh.h), lets the construction insert a
// whole node as one patch when every triangle of it is provably consistent with the
// same facing: the patch is the node's precomputed boundary (the edges whose neighbour
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
  // The node's boundary edges.
  const BoundaryEdge* boundary(uint32_t node) const { return edges_.data() + nodes_[node].first_edge; }
  uint32_t boundary_count(uint32_t node) const { return nodes_[node].edge_count; }

  size_t memory_bytes() const { return nodes_.capacity() * sizeof(Node) + edges_.capacity() * sizeof(BoundaryEdge); }

 private:
  struct Node {
    Vec3d axis{0, 0, 0};
    Vec3d centre{0, 0, 0};
    double spread = 0, radius = 0;
    uint32_t first_edge = 0, edge_count = 0;
    bool eligible = false;
  };
  // -1, 0 or 1: box below every plane of the node, unknown, above every plane.
  int side_of(const Node& n, const AABBd& b) const;

  const accel::Bvh<float>& bvh_;
  std::vector<Node> nodes_;
  std::vector<BoundaryEdge> edges_;
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
Surface construct_clustered_surface(const BlockerContext& ctx, const SurfaceClusters& clusters, const ShaftGeometry& g,
                                    const TreeNode& rnode, const TreeNode& lnode, Workspace& ws,
                                    double* whole_nodes = nullptr, std::vector<uint32_t>* band = nullptr);

}  // namespace visgate::iss
