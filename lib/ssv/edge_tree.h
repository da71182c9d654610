// Candidate silhouette edges per receiver from a hierarchy over the mesh's edges
// (wedge_index=edges): the third way, beside the lazy wedge BSP of paper 001 section 4.1
// and the wedges scattered through the receiver tree (wedge_scatter.h), to give each
// receiver the edges that may be silhouettes from it and project into L'. No wedge is
// built: per light the work follows the queries, not the light's potential silhouette
// edges (a constant fraction of a dense smooth mesh's edges, docs/log/ssv-performance.md
// "Scan: why it grows linearly").
//
// The hierarchy, built once per solve in linear time: the edges in the Morton order of
// their midpoints (one radix sort), leaves of four consecutive edges, each level above
// pairing consecutive nodes. Per node: the box of its edges, the box of every triangle
// incident to them, the per-component range of those triangles' unit normals, and
// whether some edge below is single (one triangle: its weight is never 0 for an active
// triangle). A query walks
// the tree for one receiver r and one light and leaves a node when
//  - its edges' box lies more than eps outside a plane of the frustum hull(r, L') n {h >= 0}
//    (the pyramid add_edge clips to, integrate.h) or of its bounding box: no edge below
//    meets it, each would add nothing; or
//  - every incident triangle is active (its box more than 2e-6 M above the light plane)
//    and r lies on the same side of every one of their planes, farther than 2^-18 of its
//    largest L1 distance to their box (plus 1e-9 M): every edge below has weight 0 from
//    r (integrate.h, "Side of a projected edge"), and no triangle below is nearly edge-on
//    (ReceiverIntegrator::facing's doubt needs 2^-20 of the Euclidean distance), so
//    validating them would neither add a piece nor mark the receiver doubtful.
// The bound on n.(r - a) is interval arithmetic over the normal ranges and the box.
// At a leaf each edge is also left on its own when its leaf's triangles are all active
// and r lies on the same side of both its triangles' planes (a double edge), farther
// than 2/32767 of (|r - a|_1 + the L1 extent of the leaf's triangle box) (plus 1e-9 M),
// measured from its endpoint a (in both planes; every vertex v of the two triangles has
// |r - v| <= |r - a|_1 + that extent) with the normals stored in 16 bits per component
// (rounding error 1/65534): weight 0 and neither triangle nearly edge-on, by the argument
// above. On a noisy scanned surface, where the nodes' normal ranges are wide
// and silhouettes are everywhere, this keeps the candidates near the edges that validate
// (CGAL's armadillo: 3,164 per receiver before, 505 after, 505 validated).
// Tests run in float: with coordinates below M the plane and box tests err by less than
// 1e-6 M (eps is 4e-6 M), and the facing bound by less than 2^-21 of the L1 distance
// (float products and sums, normals rounded to nearest), inside the margin's slack of
// 2^-19.
//
// Guarantee: every edge of the mesh that meets the frustum (up to eps) and is not proven
// weight 0 from r as above is returned (with its weight when the leaf test proves it,
// kWeightPlus2 and kWeightMinus2 below), once, in the walk's order (depth first from the
// starts; the integration's counts do not depend on the order). The solver then applies build_wedges'
// edge filters (below the light plane, never a silhouette w.r.t. L') and the weight, so a
// receiver integrates exactly the pieces the wedge indexes give it (the wedges contain
// the frustum's edges conservatively too); only which near-degenerate weight tests run
// (facing's doubt, answered by rays) may differ.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "lib/ssv/light_frame.h"
#include "lib/ssv/populated.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

// The frustum of one receiver and light: the light plane (h >= 0) and the planes through
// r and each edge of L', unit normals, inside positive; and its bounding box. Or the
// same for a box of receivers (hull(box, L'), the planes through each edge of L'
// supporting the box's corners): it holds the frustum of every receiver in the box.
struct EdgeFrustum {
  static constexpr int kMaxPlanes = 17;
  Vec3d n[kMaxPlanes];
  double d[kMaxPlanes];  // inside: dot(n, x) - d >= -eps
  int count = 0;
  Vec3d rlo{}, rhi{};  // the receiver (rlo = rhi) or the receivers' box
  AABBd box;
  // Planes whose normal cannot be formed in double (a receiver so far that two light
  // vertices are in the same direction) are left out: the frustum only grows.
  EdgeFrustum(const LightFrame& frame, const Vec3f& receiver);
  EdgeFrustum(const LightFrame& frame, const AABBd& receivers);
};

// The float unit normal the tree's build gives triangle (a, b, c): triangle_plane's
// unit() rounded to float, computed two lanes at a time (edge_tree.cpp); has_plane: its
// nn > 0 (else the normal is 0).
Vec3f tree_unit_normal(const Vec3f& a, const Vec3f& b, const Vec3f& c, bool& has_plane);

class EdgeTree {
 public:
  // A candidate is an edge index, with one of these bits set when the leaf's facing test
  // proved r in front of one of its triangles and behind the other, both beyond its
  // margin (no doubt either): the edge's weight sign(facing(T1)) - sign(facing(T2)) is
  // then +2 or -2 (integrate.h) without the solver's double test. Edge indices stay below
  // 2^30 (at most 1.5 edges per triangle, at most 5e7 triangles).
  static constexpr uint32_t kWeightPlus2 = 1u << 31, kWeightMinus2 = 1u << 30, kEdgeMask = kWeightMinus2 - 1;
  EdgeTree() = default;
  // Over every edge of `edges` (index = edge index); `M` bounds every coordinate (the
  // solver's tolerance scale). `m` must outlive the tree (its vertices are read by the
  // queries).
  // Each triangle's unit normal is triangle_plane(m, t)'s, rounded to float.
  EdgeTree(const std::vector<Edge>& edges, const mesh::PreparedMesh& m, double M);
  bool empty() const { return nodes_.empty(); }
  // The candidate edges of the receiver of `f` for the light of `frame` (see above),
  // in the walk's order, into `out` (cleared first), from the nodes `starts` (frontier()).
  // `eps`: the frustum tolerance (a distance, at least 4e-6 M: the float tests below
  // err by less than 1e-6 M).
  // `cap` > 0: the walk stops once `out` holds more than cap candidates (a prefix of the
  // list, of at most cap + 8); a list of at most cap is the whole list (the solver's
  // edge_rays rule casts a receiver's rays past the cap, ssv_solver.cpp).
  void query(const EdgeFrustum& f, const LightFrame& frame, float eps, const std::vector<uint32_t>& starts,
             std::vector<uint32_t>& out, uint32_t cap = 0) const;
  // The candidates of several receivers at once: outs[k] gets exactly what
  // query(fs[k], ...) gives (the same node and edge tests, float for float), from one
  // walk that tests up to eight receivers per node (AVX2 lanes; where the processor lacks
  // AVX2, or VISGATE_SSV_NO_AVX2 is set, one query per receiver). Neighbouring receivers
  // visit mostly the same nodes: one visit loads a node once for all of them.
  void query_batch(const EdgeFrustum* fs, size_t n, const LightFrame& frame, float eps,
                   const std::vector<uint32_t>& starts, std::vector<uint32_t>* outs, uint32_t cap = 0) const;
  // The nodes a walk from the root with the receivers' frustum `f` reaches and does not
  // leave, stopping at nodes of at most `max_edges` edges (or leaves): starts for the
  // queries of the receivers in f's box. A node it leaves meets no receiver's frustum, or
  // has weight 0 from each (the facing bound over the box holds for each of its points).
  void frontier(const EdgeFrustum& f, const LightFrame& frame, float eps, uint32_t max_edges,
                std::vector<uint32_t>& out) const;
  // Every triangle that may have vertices on both sides of the light plane of `frame`
  // (a superset: those of the leaves whose triangles' box is not more than 2e-6 M on one
  // side), ascending: the candidates of light_plane_cuts. Every triangle is incident to
  // some edge of `edges` (the edges the tree was built over).
  void crossing_triangles(const std::vector<Edge>& edges, const LightFrame& frame, std::vector<uint32_t>& out) const;
  // The edges of every leaf whose incident triangles' box has diagonal D with 2 D^4 >= nn
  // (a superset of the edges of the triangles t with |b - a|^2 |c - a|^2 >= nn, corners
  // a, b, c: those lie in the box of each leaf holding one of their edges), in leaf
  // order: planar_occluders' candidates, found without a pass over every triangle.
  void large_triangle_edges(double nn, std::vector<uint32_t>& out) const;
  size_t memory_bytes() const {
    return nodes_.capacity() * sizeof(Node) + order_.capacity() * sizeof(uint32_t) +
           ends_.capacity() * sizeof(uint32_t) + normals_.capacity() * sizeof(int16_t);
  }
  size_t node_count() const { return nodes_.size(); }

 private:
  // Leaves hold up to kLeaf consecutive edges of the Morton order; inner nodes two (or
  // one) consecutive nodes of the level below. Box of the edges first: what every visit
  // reads.
  static constexpr uint32_t kLeaf = 8;
  static constexpr uint32_t kMetEntries = 1024;  // the build's triangle cache (a power of two)
  // Zero bytes are Node{} (every default member initialiser is 0): a PopulatedArray.
  struct Node {
    float lo[3], hi[3];    // box of the edges below
    float tlo[3], thi[3];  // box of their incident triangles' vertices
    float nlo[3], nhi[3];  // ranges of those triangles' unit normals (rounded to nearest)
    uint32_t child = 0;    // inner: first child; leaf: first position in order_
    uint32_t edges = 0;    // edges below
    uint8_t n = 0;         // children (inner) or edges (leaf)
    uint8_t leaf = 0;
    uint8_t single = 0;    // some edge below has one triangle, or a triangle has no plane
  };
  void walk(const EdgeFrustum& f, const LightFrame& frame, float eps, const uint32_t* starts, size_t n_starts,
            uint32_t max_edges, std::vector<uint32_t>* edges, std::vector<uint32_t>* nodes, uint32_t cap = 0) const;
  void walk8(const EdgeFrustum* fs, size_t n, const LightFrame& frame, float eps, const std::vector<uint32_t>& starts,
             std::vector<uint32_t>* outs, uint32_t cap) const;
  PopulatedArray<Node> nodes_;       // leaves first, level by level, the root last
  PopulatedArray<uint32_t> order_;  // edges in leaf order
  // Their endpoints (vertex indices), two per edge in leaf order: the leaves' item boxes
  // come from the prepared mesh's vertices (8 bytes an edge instead of a 24-byte box:
  // fewer fresh pages per solve). The arrays are on populated mappings (populated.h).
  PopulatedArray<uint32_t> ends_;
  // Per edge in leaf order, the unit normals of its two triangles times 32767, rounded
  // (12 bytes; 0 for a single edge or a triangle without a plane): the leaves' per-edge
  // facing test.
  PopulatedArray<int16_t> normals_;
  const std::vector<Vec3f>* vertices_ = nullptr;
  double M_ = 0.0;
};

}  // namespace visgate::ssv
