// Silhouette regions of closed surfaces (paper 002 section 4.4 leaves the occluder set
// open; this replaces a closed surface's triangles by one region per receiver).
//
// Let S be a closed surface (closed_surfaces.h), r a receiver outside S's box, and every
// vertex of S strictly on r's side of the light's plane (the region oracle's Newell
// plane, exact), so a segment r -> l, l on the light, meets S iff the ray from r through
// l does. Let c(l) count the triangles of S that the segment r -> l crosses with r
// strictly on the positive side of their plane. Since w(r) = w(l) = 0 (both outside S's
// convex hull), a segment in general position that crosses S crosses it at least once
// with r on each side, so r -> l is blocked iff c(l) >= 1. As l moves, c changes only
// where the segment passes an edge whose two faces do not both have r strictly on one
// side: across an edge between two faces with r positive one crossing is traded for the
// other, across one with r negative on both none counts. So c, and with it the blocked
// set, is constant on every connected part of the light that the projections of these
// "silhouette" edges do not cut (a face with r in its plane counts for both:
// conservative). Within such a part a point touching S (an edge or vertex) has blocked
// points around it, so the closed segment test at one interior point classifies the
// whole part. Edges the selection leaves out as covered by an interior polygon
// (interior_occluders.h) need no cut: every line through them stabs a polygon inside S,
// so c >= 1 on both sides of their projection and the blocked set does not change there.
//
// Per group and light (select_region_surfaces): the surfaces that meet these conditions
// for every receiver of the group, decided before the selection's shaft walk, which
// leaves their triangles out (the group's edges are the surface edges with a face the
// walk would list, decided on demand: SilhouetteGroup::candidate).
// Per receiver (subtract_silhouette_regions): the group's edges whose faces have
// different exact sides from r (or one with r in its plane) and that may meet the
// pyramid of r and the light, found in the surfaces' edge trees built once per solve
// (SurfaceEdges); each cuts the fragments that reach its projection, first at the planes through
// r and its ends (a fragment wholly beyond one is left whole), then at the plane through
// r and the edge (split_fragment); each piece classified by its vertex average p,
// accepted only when the exact orientation of p against every edge plane the piece lies
// on one side of agrees with that side (strict), and by the exact closed segment test
// r -> p against the surfaces' triangles (SurfaceTrees). Blocked pieces are dropped. A
// plane that float cannot place (r within rounding of an edge's line), a piece whose
// point the exact tests do not confirm, and a segment lying in a triangle's plane leave
// the decision open: the caller shades that receiver again by the exact path.
// Precision: the pieces are cut in double with split_fragment's bounds (fragment.h), as
// every other subtraction; every classification is exact.
#pragma once

#include <cstdint>
#include <functional>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/geom/predicates.h"
#include "lib/plucker/bsp.h"
#include "lib/plucker/closed_surfaces.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

// The exact side (+1, -1, 0) of p against the plane of the float triangle a, b, c
// (orient3d(a, b, c, p)): a double filter, then orient3d_filtered, then exact.
int exact_side(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& p);

// A surface's edge tree (SurfaceEdges): the edges in the order of their lower face's rank
// (SurfaceTrees::rank), halved down to leaves of at most kLeaf edges; pre-order nodes as
// accel::Bvh's (the left child of node i is i + 1). A receiver's walk only prunes by it,
// so the edges it uses do not depend on the tree's shape (the estimate's float count may,
// by an edge whose double sides are wrong in a node the cones skip: a path choice, never
// an answer).
struct EdgeTree {
  static constexpr uint32_t kLeaf = 4;
  struct Node {
    AABBd box;
    uint32_t first = 0;  // leaf: first position in order; inner: the right child
    uint32_t count = 0;  // edges below (a leaf iff count <= kLeaf)
  };
  std::vector<Node> nodes;
  std::vector<uint32_t> order;      // leaf order -> edge
  bool empty() const { return nodes.empty(); }
  size_t node_count() const { return nodes.size(); }
  const Node& node(uint32_t i) const { return nodes[i]; }
  bool is_leaf(const Node& n) const { return n.count <= kLeaf; }
  uint32_t left(uint32_t i) const { return i + 1; }
  uint32_t right(uint32_t i) const { return nodes[i].first; }
  uint32_t item(uint32_t pos) const { return order[pos]; }
  // Over n boxes in leaf order, box_at(k) giving the k-th (float or double; no array of
  // them is written): order is the identity, each leaf's box the double of its edges'
  // boxes' union in order (float -> double is exact and monotone) and each inner box
  // the union of its children's. The nodes hold the boxes; an edge's own box is not kept
  // (the walks take it from the edge's faces).
  template <class BoxAt>
  void build_in_order_by(uint32_t n, const BoxAt& box_at) {
    if (start(n)) build_node(box_at, 0, n);
  }

 private:
  // Empties the tree; for n > 0 sets order to the identity and returns true.
  bool start(uint32_t n);
  // Node over order[begin, end) and its subtree (left half floor(m / 2)); returns its id.
  template <class BoxAt>
  uint32_t build_node(const BoxAt& box_at, uint32_t begin, uint32_t end) {
    const uint32_t id = uint32_t(nodes.size());
    nodes.emplace_back();
    nodes[id].count = end - begin;
    if (end - begin <= kLeaf) {
      auto b = box_at(begin);
      for (uint32_t k = begin + 1; k < end; ++k) b.extend(box_at(k));
      nodes[id].box = AABBd{Vec3d(b.lo), Vec3d(b.hi)};
      nodes[id].first = begin;
      return id;
    }
    const uint32_t mid = begin + (end - begin) / 2;
    build_node(box_at, begin, mid);
    const uint32_t right = build_node(box_at, mid, end);
    AABBd b = nodes[id + 1].box;
    b.extend(nodes[right].box);
    nodes[id].box = b;
    nodes[id].first = right;
    return id;
  }
};

// Per closed surface, its edges once each, built once per solve (world coordinates, so
// one tree serves every light and group): edge i is traversed as (t0, k0), the edge from
// corner k0 to k0 + 1 of triangle t0, and, when k1 < 3, in the opposite direction as
// (t1, k1); k1 == 3 when t1's matching edge was not found (t1 = t0's neighbour there).
// Paired edges have t0 < t1. The tree's boxes hold both faces' corners of the edge, its
// node_normals the box of the unit normals of the nodes' edges' faces ([-1, 1]^3 when one
// is too ill-conditioned to bound; normal cones, faces_one_side).
struct SurfaceEdges {
  struct Edge {
    uint32_t t0 = 0, t1 = 0;
    uint8_t k0 = 0, k1 = 3;
  };
  std::vector<Edge> edges;
  EdgeTree tree;
  std::vector<AABBd> node_normals;
  size_t memory_bytes() const;
};

// The hierarchy over the boxes of triangles tris (items index tris; MedianAxis, leaves
// of 4): SurfaceTrees' per surface, and InteriorOccluders' without them.
inline constexpr accel::BuildRule kTriangleHierarchyRule{accel::Split::MedianAxis, 4, false};
accel::Bvh<float> triangle_hierarchy(const TriangleSoup& mesh, const std::vector<uint32_t>& tris);

// Per closed surface, a hierarchy over its triangles for the exact segment test.
class SurfaceTrees {
 public:
  // Edge trees (edges(s)) only for surfaces of at least min_edge_triangles triangles: the
  // others are never region surfaces (kMinRegionTriangles with the estimate).
  // mesh_tree (optional): triangle_hierarchy over every triangle of the mesh in index
  // order (TriangleTree's, built by the same rule from the same boxes): a surface that
  // holds every triangle takes a copy of it, the tree its own build would give; one that
  // holds at least kDerivedNum / kDerivedDen of them takes it restricted to its triangles
  // (accel::Bvh::restricted: a linear pass instead of a median build; another tree than
  // its own build would give, with boxes still the exact unions of its triangles'). The
  // other surfaces build their own.
  static constexpr uint32_t kDerivedNum = 9, kDerivedDen = 10;
  SurfaceTrees(const TriangleSoup& mesh, const ClosedSurfaces& cs, uint32_t min_edge_triangles = 0,
               const accel::Bvh<float>* mesh_tree = nullptr);
  // +1 when the closed segment r -> p meets a triangle of surface s (touching counts),
  // 0 when it meets none, -1 when undecided (r and p both in a triangle's plane). r is
  // outside the surface's box. pd: p rounded to double (world), for the box tests.
  int segment_meets(int32_t s, const TriangleSoup& mesh, const Vec3f& r, const SumPoint& p, const Vec3d& pd) const;
  // The same for one triangle t.
  static int triangle_meets(const TriangleSoup& mesh, uint32_t t, const Vec3f& r, const SumPoint& p);
  // f(t) for every triangle of surface s in a leaf reached through nodes whose box (float,
  // world) may_meet(box, leaf) accepts.
  template <class Pred, class F>
  void for_each(int32_t s, Pred&& may_meet, F&& f) const {
    visit(s, may_meet, [&](uint32_t t) {
      f(t);
      return false;
    });
  }
  // Per input triangle of a surface its position in the surfaces' leaf orders, surface
  // after surface (a spatial order, the surfaces' edge trees' order).
  uint32_t rank(uint32_t t) const { return rank_[t]; }
  // Surface s's edges (the groups' silhouette edges are those of their candidates).
  const SurfaceEdges& edges(int32_t s) const { return edges_[size_t(s)]; }
  // Surface s's input triangles (ascending) and its hierarchy (triangle_hierarchy over
  // them, or the mesh tree's, above): InteriorOccluders walks the same one.
  const std::vector<uint32_t>& triangles(int32_t s) const { return tris_[size_t(s)]; }
  const accel::Bvh<float>& hierarchy(int32_t s) const { return bvh_[size_t(s)]; }
  size_t memory_bytes() const;

 private:
  // f(t) for the triangles of surface s in the leaves reached through nodes that
  // enter(box, leaf) accepts, in the tree's order, until f returns true.
  template <class Enter, class F>
  void visit(int32_t s, Enter&& enter, F&& f) const {
    const std::vector<uint32_t>& tris = tris_[size_t(s)];
    const accel::Bvh<float>& bvh = bvh_[size_t(s)];
    bvh.walk(enter, [&](const accel::Bvh<float>::Node& nd) {
      for (uint32_t item : bvh.leaf_items(nd))
        if (f(tris[item])) return true;
      return false;
    });
  }

  std::vector<accel::Bvh<float>> bvh_;          // per surface, items index tris_[s]
  std::vector<std::vector<uint32_t>> tris_;     // per surface: its input triangles
  std::vector<uint32_t> rank_;                  // per input triangle (0 off the surfaces)
  std::vector<SurfaceEdges> edges_;             // per surface
};

// Per node of the occluder selection's triangle tree (TriangleTree::bvh()), built once
// per solve: the closed surface holding every triangle below it (-1: none, or several),
// its parent (the root's is itself), and per triangle its leaf. The selection leaves a
// region surface's whole subtrees out of its walk (occluder_selection.cpp), and a
// receiver asks the walk's verdict on a face only when its edge walk reaches it
// (SilhouetteGroup::candidate), from the leaf up.
struct TreeSurfaces {
  std::vector<int32_t> node_surface;
  std::vector<uint32_t> parent;
  std::vector<uint32_t> leaf_of;  // per input triangle
  TreeSurfaces(const TriangleTree& tree, const ClosedSurfaces& cs);
  size_t memory_bytes() const {
    return node_surface.capacity() * sizeof(int32_t) + (parent.capacity() + leaf_of.capacity()) * sizeof(uint32_t);
  }
};

// A candidate silhouette edge of a group: a -> b (world floats, as in face f0; local
// la, lb), shared by faces f0 and f1 (input triangles).
struct SilEdge {
  Vec3f a, b;
  Vec3d la, lb;
  uint32_t f0 = 0, f1 = 0;
};

// One face's plane for the per-receiver sides: corner a, normal n = (b - a) x (c - a) in
// double and the product of its edges' 1-norms (the filter's scale).
struct FacePlane {
  Vec3d a, n;
  double s12 = 0.0;
  uint32_t t = 0;
};

// A group's silhouette data (GroupState::sil).
struct SilhouetteGroup {
  std::vector<int32_t> surfaces;  // the region surfaces of the group
  std::vector<uint8_t> is_region;  // per closed surface: 1 when in `surfaces` (reset by clear)
  // A surface edge is the group's when a face of it is a candidate: a triangle the
  // selection's shaft walk lists (TriangleTree::candidates), i.e. every node from the
  // root to its leaf passes the walk's own test, `node_passes` (the shaft does not cull
  // its box and, with interior occluders, the box is not covered), set by the selection
  // (the same floats as its walk). Decided on demand, per node and per triangle, and
  // kept for the group (stamped with `serial`, not cleared): a receiver asks about the
  // faces its edge walk reaches, not the group about every triangle in its shaft.
  std::function<bool(uint32_t)> node_passes;
  const TreeSurfaces* tree_surfaces = nullptr;
  std::vector<uint32_t> in_cand, node_stamp;  // stamps
  std::vector<uint8_t> tri_ok, node_ok, counted;  // the verdicts; per triangle the edges counted (bits k)
  uint32_t serial = 0;
  bool candidate(uint32_t t) { return in_cand[t] == serial ? tri_ok[t] != 0 : decide(t); }
  // Starts a group: the verdicts above forgotten (serial), sizes for mesh and tree.
  void new_group(size_t triangles, size_t nodes, size_t surfaces);

 private:
  bool decide(uint32_t t);

 public:
  // Per receiver: the edges used, in the group's edge order (by the face each is taken
  // from, then its k), and their keys (t << 2 | k).
  std::vector<SilEdge> edges;
  std::vector<uint64_t> edge_keys;
  std::vector<uint32_t> used;  // per receiver: the edges used (indices into edges)
  std::vector<NodePlane> planes;
  // Per receiver: each piece's point, 1 when the piece has no area, 2 when its point is
  // unconfirmed (else 0), its segment test's result; with several pieces, those to test
  // sorted by the point's u, and their u.
  std::vector<Vec3d> pts;
  std::vector<uint8_t> zero;
  std::vector<int8_t> meet;
  std::vector<uint32_t> order;
  std::vector<double> order_u;
  FragmentList out;
  std::vector<Vec3d> pos, neg, cur;
  void clear();
};

// Counters (plucker_solver.h stats).
struct SilhouetteCounters {
  // edges: per group the distinct edges its receivers used (receiver_edges: per receiver).
  uint64_t groups = 0, declined = 0, edges = 0, receiver_edges = 0, pieces = 0, blocked = 0, undecided = 0, dropped = 0;
  uint64_t listed = 0;  // receivers whose pieces were tested triangle by triangle (more than 16)
};

// Normal cones: true only when u . (r - x) is of one strict sign for every u in
// `normals` and x in `box` (interval bounds beyond a margin of 2^-24 of |r - x|'s bound
// plus 2^-30 of the largest coordinate), so that every plane through a point of box
// whose unit normal, rounded by less than 2^-25, lies in normals has r strictly on
// that sign's side.
bool faces_one_side(const AABBd& box, const AABBd& normals, const Vec3d& r);

// Group level: fills g.surfaces (and g.is_region) with the closed surfaces whose box
// the group's shaft does not cull (shaft in local coordinates about `origin`) and that
// meet the conditions above; the caller then leaves their triangles out of its
// candidates (g.node_passes and g.tree_surfaces set and g.new_group called before).
// rbox: the receivers' world box; light: the light's float polygon; sigma: the
// receivers' side of its Newell plane; origin: the light's local frame; trees: the
// surfaces' edge trees.
// rloc: the group's receivers and lpoly the light's vertices, local. With `estimate`, a
// group where a few
// spread receivers each see more than kMaxSampledEdges candidate edges turning near
// their pyramid keeps its surfaces on the triangle path (a float estimate: it chooses
// the path, never an answer): each piece costs an exact point test, and where many
// silhouette edges cross the light (a light large next to a detailed surface: CGAL's
// meshes) their pieces outnumber the triangles' shadows.
constexpr size_t kMaxSampledEdges = 64;
// Also with `estimate`, only surfaces of at least this many triangles: a small solid's
// triangles cost the triangle path little per receiver, less than the regions' walks
// and point tests (columns' cylinders and rooms' boxes: 1.7x and 2.9x the time).
constexpr uint32_t kMinRegionTriangles = 1024;
void select_region_surfaces(const TriangleSoup& mesh, const ClosedSurfaces& cs, const SurfaceTrees& trees,
                            const Shaft& shaft, const AABB& rbox, const Vec3f* light, int m, float sigma,
                            const Vec3f& origin, const std::vector<Vec3d>& rloc, const std::vector<Vec3d>& lpoly,
                            bool estimate, SilhouetteGroup& g, SilhouetteCounters& c);

// Per receiver: removes the region surfaces' shadows from `frags` (local coordinates
// about `origin`). rw: the receiver (world), r: local. pyramid, pyramid_err: the
// pyramid's side planes (shade_receiver.cpp pyramid_planes) through light[j]. False when
// undecided (frags then unchanged in meaning but possibly split): the caller shades the
// receiver exactly.
bool subtract_silhouette_regions(const TriangleSoup& mesh, const SurfaceTrees& trees, SilhouetteGroup& g,
                                 const Vec3f& rw, const Vec3d& r, const Vec3f& origin,
                                 const std::vector<Vec3d>& light, const std::vector<Vec3d>& pyramid,
                                 const std::vector<Vec3d>& pyramid_err, const LightBounds& bounds,
                                 const LightPlane& lp, FragmentList& frags, SilhouetteCounters& c);

}  // namespace visgate::plucker
