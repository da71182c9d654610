// Candidate silhouette edges per receiver from a hierarchy over the mesh's edges
// (wedge_index=edges): the third way, beside the lazy wedge BSP of paper 001 section 4.1
// and the wedges scattered through the receiver tree (wedge_scatter.h), to give each
// receiver the edges that may be silhouettes from it and project into L'. No wedge is
// built: per light the work follows the queries, not the light's potential silhouette
// edges (a constant fraction of a dense smooth mesh's edges, docs/log/ssv-performance.md
// "Scan: why it grows linearly").
//
// The hierarchy is the edge boxes' BVH of the shaft culling (lib/accel/bvh.h), with per
// node, built once per solve: the box of every triangle incident to an edge below it, the
// per-component range of those triangles' unit normals, and whether some edge below is
// single (one triangle: its weight is never 0 for an active triangle). A query walks
// the tree for one receiver r and one light and leaves a node when
//  - its edges' box lies more than eps outside a plane of the frustum hull(r, L') n {h >= 0}
//    (the pyramid add_edge clips to, integrate.h): no edge below meets it, each would
//    add nothing; or
//  - every incident triangle is active (all its vertices above the light plane) and r
//    lies on the same side of every one of their planes, farther than 2^-19 of its
//    largest distance to their box (plus 1e-9 M): every edge below has weight 0 from r
//    (integrate.h, "Side of a projected edge"), and no triangle below is nearly edge-on
//    (ReceiverIntegrator::facing's doubt needs 2^-20), so validating them would neither
//    add a piece nor mark the receiver doubtful.
// The bound on n.(r - a) is interval arithmetic over the normal ranges and the box,
// evaluated in double; the normal ranges are rounded outwards to float.
//
// Guarantee: every edge of the mesh that meets the frustum (up to eps) and is not proven
// weight 0 from r as above is returned, ascending. The solver then applies build_wedges'
// edge filters (below the light plane, never a silhouette w.r.t. L') and the weight, so a
// receiver integrates exactly the pieces the wedge indexes give it (the wedges contain
// the frustum's edges conservatively too); only which near-degenerate weight tests run
// (facing's doubt, answered by rays) may differ.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

// The frustum of one receiver and light: the light plane (h >= 0) and the planes through
// r and each edge of L', unit normals, inside positive; and its bounding box.
struct EdgeFrustum {
  static constexpr int kMaxPlanes = 17;
  Vec3d n[kMaxPlanes];
  double d[kMaxPlanes];  // inside: dot(n, x) - d >= -eps
  int count = 0;
  Vec3d r{};
  AABBd box;
  // Planes whose normal cannot be formed in double (a receiver so far that two light
  // vertices are in the same direction) are left out: the frustum only grows.
  EdgeFrustum(const LightFrame& frame, const Vec3f& receiver);
};

class EdgeTree {
 public:
  EdgeTree() = default;
  // `bvh` over the edges' boxes (index = edge index) with item boxes kept; `M` bounds
  // every coordinate (the solver's tolerance scale).
  EdgeTree(const accel::Bvh<float>& bvh, const std::vector<Edge>& edges, const mesh::PreparedMesh& m,
           const std::vector<TrianglePlane>& planes, double M);
  bool empty() const { return bvh_ == nullptr || bvh_->empty(); }
  // The candidate edges of receiver f.r for the light of `frame` (see above), ascending,
  // into `out` (cleared first). `eps`: the frustum tolerance (a distance).
  void query(const EdgeFrustum& f, const LightFrame& frame, float eps, std::vector<uint32_t>& out) const;
  size_t memory_bytes() const { return bounds_.capacity() * sizeof(NodeBounds); }

 private:
  struct NodeBounds {
    float tlo[3], thi[3];  // box of the incident triangles' vertices
    float nlo[3], nhi[3];  // ranges of their unit normals' components
    uint32_t single = 0;   // some edge below has one triangle
  };
  const accel::Bvh<float>* bvh_ = nullptr;
  std::vector<NodeBounds> bounds_;
  double abs_margin_ = 0.0;
};

}  // namespace visgate::ssv
