// Umbra culling for SSV: receivers proven fully blocked from a light by one planar convex
// occluder skip the wedge query, the integration and the reference ray for that light
// ("model no more than a scene needs": a receiver never integrates edges of geometry it
// cannot see through a wall or a floor slab). A light hidden from every receiver is not
// set up at all (no wedges, no BSP), and the wedge BSP of a partly hidden light is rooted
// at the bounds of the receivers left.
//
// Occluders are the mesh's triangles and the convex quads formed by two exactly coplanar
// triangles sharing a double edge (box faces, walls, slabs), the largest `max_count` of
// them by area, none smaller than a quarter of the smallest light (a smaller one blocks
// a shaft only close to its receiver, and trying the many small ones cost more on columns
// than it culled: a speed choice, not a correctness one). A receiver tree (median splits, leaves of a few receivers) is walked per
// light; a node is blocked when some occluder blocks its shaft (below), and its subtree
// is then skipped.
//
// Guarantee (exact up to the stated margin, never an approximation): occluder_blocks_shaft
// is true only when the occluder's plane has every corner of the box on one side and every
// light point on the other, each at least `margin` away, and every segment from a box
// corner to a light point crosses the plane at least `margin` inside every edge of the
// occluder. The intersection of hull(box u light points) with a plane strictly separating
// them is the convex hull of those crossing points, so every segment from a point of the
// box to a point of the light points' hull then meets the occluder's interior at least
// `margin` from its boundary and from both ends: it is blocked, for the exact oracle and
// for a watertight ray test alike (a crossing on the diagonal of a quad meets both closed
// triangles). The light points passed by the solver are L' displaced by the largest jitter
// height on both sides of the light plane, whose hull holds every sample
// (light_frame.h). With margin = 1e-5 of the scene's largest coordinate (about 40 float
// ulps at the unit copy's scale), the culled relations are decided far from degeneracy,
// where the integration and its reference ray give the same answer: the answers do not
// change (ssv_solver_test compares culled against unculled solves and the oracle).
// Evaluation in double on float inputs errs by about 1e-15 of the coordinates.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/mesh/prepare.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

struct PlanarOccluder {
  int n = 3;                       // vertices: 3 (triangle) or 4 (convex quad)
  std::array<Vec3d, 4> v{};
  Vec3d normal{};                  // unit
  double offset = 0.0;             // plane: dot(normal, x) = offset
  std::array<Vec3d, 4> edge_n{};   // unit in-plane normals of the edges, pointing inside
  std::array<double, 4> edge_d{};  // inside edge k: dot(edge_n[k], x) - edge_d[k] >= 0
  AABBd box;
  double area = 0.0;
  // Signed distance of x from the plane.
  double eval(const Vec3d& x) const { return dot(normal, x) - offset; }
  // Smallest signed distance of an in-plane point from the edges (positive inside).
  double inside(const Vec3d& x) const;
};

// The occluders of the prepared mesh (its triangles and coplanar convex quads) of area at
// least min_area, largest first, at most max_count. `edges` and `planes` as built by
// mesh_edges and triangle_planes. `large` (optional): indices into `edges` that include
// every edge of each triangle t with |b - a|^2 |c - a|^2 >= min_area^2 (corners a, b, c;
// EdgeTree::large_triangle_edges); only their triangles and pairs are read, with the
// same result.
std::vector<PlanarOccluder> planar_occluders(const mesh::PreparedMesh& m, const std::vector<Edge>& edges,
                                             PlaneSource planes, size_t max_count, double min_area = 0.0,
                                             const std::vector<uint32_t>* large = nullptr);
inline std::vector<PlanarOccluder> planar_occluders(const mesh::PreparedMesh& m, const std::vector<Edge>& edges,
                                                    const TrianglePlanes& planes, size_t max_count,
                                                    double min_area = 0.0) {
  return planar_occluders(m, edges, PlaneSource{&m, &planes}, max_count, min_area);
}

// True when every segment from a point of `box` to a point of the hull of `light` meets
// the occluder's interior (see the file comment for the exact condition).
bool occluder_blocks_shaft(const PlanarOccluder& o, const AABBd& box, const std::vector<Vec3d>& light,
                           double margin);

// Receivers in a tree of median splits: node boxes are the exact bounds of their receivers.
class ReceiverTree {
 public:
  struct Node {
    AABBd box;
    uint32_t begin = 0, end = 0;  // range of order()
    int32_t left = -1, right = -1;  // children; -1 for a leaf
  };
  ReceiverTree() = default;
  ReceiverTree(const std::vector<Vec3d>& points, uint32_t leaf_size);
  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<uint32_t>& order() const { return order_; }
  size_t memory_bytes() const { return nodes_.size() * sizeof(Node) + order_.size() * sizeof(uint32_t); }

 private:
  int32_t build(const std::vector<Vec3d>& points, uint32_t begin, uint32_t end, uint32_t leaf_size);
  std::vector<Node> nodes_;
  std::vector<uint32_t> order_;
};

// Sets blocked[i] = 1 for every receiver i inside a tree node whose shaft to `light` some
// occluder blocks; returns how many were set. Only occluders with every light point at
// least `margin` on one side of their plane are tried; a node's children try only those
// that may still block a box inside the node's (occluders.cpp, classify).
size_t cull_occluded_receivers(const ReceiverTree& tree, const std::vector<PlanarOccluder>& occluders,
                               const std::vector<Vec3d>& light, double margin, std::vector<uint8_t>& blocked);

}  // namespace visgate::ssv
