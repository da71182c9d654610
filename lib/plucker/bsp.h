// The lazy Plücker-space BSP of paper 002 section 4 (Algorithm 1): the equivalence
// classes of the lines stabbing the light polygon and the occluders of one receiver
// group, developed on demand by visibility queries from points.
//
// Structure (sections 4.1-4.2): each inner node holds the hyperplane of an occluder edge
// line a -> b (left: lines with side > 0, right: side < 0). A leaf is the invisible class
// (never stores occluders), a visible class (no occluders) or an undefined class
// (occluders that may affect it). bsp(o) for a one-sided convex occluder of k edges is a
// chain of k nodes; the left child of the last is the invisible leaf, the k right
// children are the visible leaves (Figure 4 for k = 3); see Occluder for two-sided ones. insertOccluder is conservative: an occluder
// whose occluded lines (Theorem 1, from its vvset) are mixed or undecided against a
// hyperplane goes to both subtrees. BSP_query walks the tree with the plane through the
// query point and each node's line, splits the fragment where needed, develops undefined
// leaves by merging a randomly chosen occluder (seeded: reproducible) and inserting the
// others, and returns the fragments reaching visible leaves. Iterative, with an explicit
// stack (section 4.4, implementation details).
//
// Guarantee: "exact" in the paper's sense (analytic fragments, no sampling); with exact
// arithmetic the fragments are exactly the visible region. Precision (the paper used
// float32 throughout): fragments are float32 points of the light in its local frame;
// query points and occluders are double local coordinates computed from the float
// inputs (exact unless exponents differ by more than 29); planes and insertion tests are
// evaluated in double with forward error bounds. Insertion signs (Theorem 1) undecided
// within the bound count as mixed (costs time, never correctness). Fragment splits use
// the computed plane through r and the node's line (fragment.cpp node_plane), with the
// evaluation of each vertex's side bounded and vertices within their own float rounding
// of the plane taken as on it; the computed plane differs from the true one by an angle
// of about u_d / sin(angle between the edge and the direction to r), so lines within
// that angle of a node's hyperplane may be sent to the wrong
// side (false visible/blocked slivers of that width; measured: no mismatch above the
// harness's tau on random-soup and columns). Degenerate cases, handled explicitly:
//  - query point on a node's line (SplitResult::OnLine): every line r -> x meets the
//    node's line, so its side is 0; none of them stabs the node's occluder properly and
//    no occluder stored only on the left can contain it (its vvset is strictly positive,
//    so by Theorem 1 its stabbing lines are strictly positive): the fragment goes right.
//  - zero-area fragments (all vertices on a splitting plane, or a split piece of fewer
//    than 3 vertices) are dropped: they hold no area and their points are boundary
//    points of other fragments.
//  - occluders must lie strictly between the receivers and the light: the caller clips
//    them (occluder_selection.cpp); occluders touching the light plane give vvset lines in
//    the light plane whose sides are undecided, hence mixed: handled by conservative
//    insertion.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "lib/base/check.h"
#include "lib/base/memory_budget.h"
#include "lib/geom/vec.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"

namespace visgate::plucker {

// An occluder is a triangle or a coplanar convex patch of up to 8 corners
// (triangle_tree.h kMaxPatchVertices) clipped to the slab between the receivers and the
// light: a triangle gains at most 2 corners (two clips), a patch 1 (occluder_selection.cpp
// clips patches at one plane only); one more for safety.
constexpr int kMaxOccluderVertices = 10;

// A convex occluder polygon. One-sided (the paper's case): oriented so that every
// receiver of the group lies strictly on the negative side of (v1 - v0) x (v2 - v0), so
// the lines from the receivers that stab it are positive against all its edge lines
// (lines.h convention) and bsp(o) has one invisible leaf (Figure 4). Two-sided: the
// group's receivers lie on both sides of its plane, so lines stab it in both directions;
// bsp(o) then has two invisible leaves, all-positive and all-negative (an extension of
// Figure 4: the first edge's right child starts a second chain for the negative class).
// Vertices in double: the solver's local coordinates of a clipped triangle, computed in
// double from the float input and not rounded (fragment.cpp: in float a node's plane
// moved shadow edges of a small light by more than the fraction tolerance).
struct Occluder {
  Vec3d v[kMaxOccluderVertices];
  int n = 0;
  bool two_sided = false;
};

// Convex polygons, their vertices in `verts` (polys: first vertex, count). Written by
// add() they are back to back; subtract_polygon (subtract.h) may leave the vertices of
// replaced fragments behind (`garbage` of them) and put new ones at the end, so the
// order of the polygons is that of `polys`, not of `verts`.
struct FragmentList {
  std::vector<Vec3d> verts;
  // A polygon's place in verts, and of its box in a box list kept beside the fragments
  // (subtract.h): add() gives polygon k box k, so a box list built in the polygons'
  // order fits; subtract_polygon appends its pieces' boxes and leaves the replaced ones
  // behind, so a replacement moves these 12 bytes a fragment, not the 32 of a box too.
  // Trivially copyable (std::pair is not: its assignment is user-provided), so moving
  // and copying a list of them is a memmove.
  struct Span {
    uint32_t first = 0, second = 0;  // first vertex, count
    uint32_t box = 0;                // the polygon's box in the box list beside it
    Span() = default;
    Span(uint32_t f, uint32_t n, uint32_t b) : first(f), second(n), box(b) {}
  };
  std::vector<Span> polys;
  size_t garbage = 0;  // vertices in verts that no polygon uses

  void clear() { verts.clear(); polys.clear(); garbage = 0; }
  size_t size() const { return polys.size(); }
  const Vec3d* data(size_t k) const { return verts.data() + polys[k].first; }
  int count(size_t k) const { return int(polys[k].second); }
  void add(const Vec3d* p, size_t n) {
    polys.emplace_back(uint32_t(verts.size()), uint32_t(n), uint32_t(polys.size()));
    verts.insert(verts.end(), p, p + n);
  }
  // Drops the fragments from the n-th on (n <= size()); the vertices must be back to
  // back (no garbage).
  void truncate(size_t n) {
    VG_DCHECK(garbage == 0);
    if (n >= polys.size()) return;
    verts.resize(polys[n].first);
    polys.resize(n);
  }
};

struct BspCounters {
  uint64_t nodes_created = 0;    // inner nodes and leaves ever created (resets included)
  uint64_t developments = 0;     // undefined leaves developed (Algorithm 1 lines 31-35)
  uint64_t insert_tests = 0;     // vvset orientation tests (Theorem 1)
  uint64_t splits = 0;           // fragment splits (line 25)
  uint64_t on_line = 0;          // degenerate: query point on a node's line
  uint64_t zero_area = 0;        // degenerate: zero-area fragments dropped
  uint64_t occlusion_tests = 0;  // Choice::Relevant: occluders classified at undefined leaves
  uint64_t lazy_visible = 0;     // Choice::Relevant: fragments returned visible from an undefined leaf
  uint64_t merged = 0;           // splits undone in a query: every piece came out visible
  uint64_t visits = 0;           // inner nodes a query fragment was classified against (lines 17-27)
  uint64_t list_compactions = 0; // the leaves' list arena compacted (grow_lists)
  uint64_t insert_reused = 0;    // insert_tests answered from an earlier merge of the same occluder (develop)
  uint64_t deferred_cuts = 0;    // subtract_polygon: cuts put off to the end of a fragment's walk (subtract.h)
};

class LazyBsp {
 public:
  // Tree initialisation (Figure 8 "Init"): stores the occluders, the light polygon (m
  // vertices) and the receiver region; the tree is one undefined leaf holding them all.
  // The vvsets (Theorem 1) are not stored: every orientation test of insertOccluder is
  // against an edge of the occluder being merged, so develop() computes per edge the
  // EdgeFan of the light and of the region (lines.h) and each test is then n x m dot
  // products (measured: 1.5x fewer instructions in insertion than one cross product per
  // occluder vertex and test, and no per-occluder vvset storage).
  //
  // `receivers` (nr points, may be empty) span a convex region holding every query point
  // of the tree (the corners of the group's receiver box). The lines that an occluder
  // hides from the queries stab the receivers' region, the occluder and the light, so
  // their orientation is also bounded by the vvset between the receiver region and the
  // occluder (Theorem 1 holds for the convex hulls of any two point sets: the proof only
  // combines vertices with barycentric weights). insertOccluder takes the first decided
  // orientation of the two vvsets: still conservative, and far fewer mixed insertions
  // for occluders close to the receivers.
  LazyBsp(const Vec3d* light, int m, std::vector<Occluder> occluders, uint64_t seed, const Vec3d* receivers = nullptr,
          int nr = 0);

  // The same tree initialisation on an existing object, which keeps the capacity of its
  // lists (nodes, occluder lists, query scratch): the solver keeps one tree per thread
  // and rebuilds it for every group (group_tree.cpp). `occluders` is
  // taken by swapping: it comes back empty, holding the previous tree's storage.
  // Everything else is as after the constructor (choice Relevant, no light plane).
  void rebuild(const Vec3d* light, int m, std::vector<Occluder>& occluders, uint64_t seed,
               const Vec3d* receivers = nullptr, int nr = 0);

  // How an undefined leaf is developed (Algorithm 1 line 31).
  //  - Random: the paper's choice, a random occluder of the leaf (seeded).
  //  - Relevant (default): first the leaf's occluders are classified against the query
  //    fragment F seen from r (Occlusion below): one that hides all of F is merged (F then
  //    walks straight into its invisible class); otherwise one among those that hide
  //    part of F: with the light's plane known (set_light_plane) the one whose shadow
  //    box overlaps F's box the most (largest_overlap), else a random one (seeded);
  //    if none hides any part of F, F is returned visible and the
  //    leaf stays undefined for later queries. Still exact: conservative insertion puts
  //    every occluder that can block a line of the leaf's class into the leaf, so an F
  //    that none of them meets is visible. Lazier than the paper (section 4.3 "Tree
  //    growth": only the classes a query needs are developed) and it merges only
  //    occluders the query sees: measured on columns (4096 receivers) 7x fewer
  //    developments, on rooms (27 lights) 50x fewer (plucker_solver.h, README).
  enum class Choice : uint8_t { Random, Relevant };
  void set_choice(Choice c) { choice_ = c; }

  // With the light's plane known (local frame, fragment.h LightPlane), Choice::Relevant
  // first compares the box of an occluder's shadow from r (shadow_box, computed once per
  // query point and occluder) with the fragment's box: disjoint boxes are a Miss without
  // the edge-plane classification. Exact like the classification it skips (disjoint
  // convex sets), and it only answers Miss.
  void set_light_plane(const LightPlane& lp) {
    plane_ = lp;
    have_plane_ = true;
  }

  // Algorithm 1 BSP_query(root, L, r): appends the visible fragments of the light seen
  // from r to `out` (cleared first). Beyond the paper, a split (line 25) all of whose
  // pieces come out visible is undone: `out` receives the fragment that was split
  // (counters().merged), so fragments are cut only where something is hidden.
  void query(const Vec3d& r, FragmentList& out);
  // The same query for parts of the light only: `in` holds disjoint convex pieces of the
  // light polygon (each walked from the root as L in Algorithm 1); `out` receives the
  // visible parts of them.
  void query(const Vec3d& r, const FragmentList& in, FragmentList& out);

  // True when the tree shows that every line from r to the light is blocked: the whole
  // light polygon, walked without splitting, reaches an invisible class (a node whose
  // plane splits it, a visible class or an undefined leaf without an occluder hiding
  // all of it give false; with Choice::Relevant such an occluder is merged, as the
  // query would). A cheap first step of a query (shade_receiver.cpp).
  bool hides_all(const Vec3d& r);

  // The paper's "modified version" (section 5.1): back to the root holding every
  // occluder, so the next query cannot reuse anything.
  void reset();

  // The most bytes develop() keeps of insertion orientations for later merges of the
  // same occluder (4 MB by default; 0: none kept). The same tree and answers either way.
  void set_orient_cache_bytes(size_t bytes) { orient_cache_bytes_ = bytes; }

  size_t node_count() const { return nodes_.size(); }
  size_t occluder_count() const { return occ_.size(); }
  // Bytes held by the tree, its occluder lists, the occluders and their vvsets.
  size_t memory_bytes() const;
  const BspCounters& counters() const { return counters_; }
  // Counts memory_bytes() against `budget` from now on, after every development (which
  // throws MemoryBudgetExceeded past it); nullptr: not counted.
  void set_memory_budget(MemoryBudget* budget) {
    budget_charge_.bind(budget, "BSP nodes and occluder lists");
    budget_charge_.set(memory_bytes());
  }

 private:
  enum Kind : uint8_t { kInner, kLeaf, kInvisible };
  struct Node {
    int32_t left = -1, right = -1;
    uint32_t occ_begin = 0, occ_count = 0;  // leaf: occluder list (undefined when count > 0)
    Kind kind = kLeaf;
    uint8_t edge = 0;          // inner: its line is edge `edge` of occluder `occ`
    uint32_t occ = 0;          //   (a -> b = occ.v[edge] -> occ.v[edge + 1])
  };
  static constexpr uint32_t kNoSplit = ~uint32_t(0);
  struct Work {
    int32_t node;
    uint32_t begin, count;  // fragment vertices in work_
    uint32_t split;         // the split it is a piece of (splits_), or kNoSplit
    CenterBox box;          // a box holding the fragment: its input piece's, widened (box_side)
  };
  // A split of one query (line 25) whose pieces are still being walked. When every piece
  // has come out visible, the pieces' output is replaced by the fragment that was split
  // (query): the split was the tree's, not the shadow's.
  struct Split {
    uint32_t parent;        // the split the fragment itself is a piece of, or kNoSplit
    uint32_t begin, count;  // the fragment's vertices in work_
    uint32_t out_mark;      // out_spans_.size() when it was split: its pieces' output follows
    uint8_t pending;        // pieces not yet finished
    bool visible;           // every finished piece came out visible, none dropped
  };

  // Algorithm 1 lines 31-35: replace the undefined leaf by bsp(ro) for ro = `forced`, or
  // a random occluder of the leaf when forced < 0, and insert the others into bsp(ro)
  // (insertOccluder, lines 1-13).
  void develop(int32_t leaf, int64_t forced = -1);

  // The lines r -> x, x in the fragment f (n vertices), against occluder id: Miss (some
  // edge has the whole fragment on its non-stabbing side, or r on its line: no line
  // stabs it properly), Cover (every edge has the fragment on its stabbing side: every
  // line stabs its closure) or Partial. Signs from classify_fragment (fragment.h).
  enum class Occlusion : uint8_t { Miss, Partial, Cover };
  // `box` holds the fragment's vertices (box_side, fragment.h): an edge whose plane it
  // lies beyond is decided without the vertex loop (the same sign).
  Occlusion occlusion(uint32_t id, const Vec3d* f, int n, const CenterBox& box);
  // occlusion() preceded by the shadow-box test against the fragment's box `fbox`.
  Occlusion occlusion(uint32_t id, const Vec3d& r, const Vec3d* f, int n, const UVBox& fbox, const CenterBox& box);
  // Among candidates_ (occluders hiding part of a fragment with box fbox, their shadow
  // boxes valid for this query): the one whose shadow box overlaps fbox the most, the
  // first of equal ones (Choice::Relevant with the light's plane known).
  uint32_t largest_overlap(const UVBox& fbox) const;
  // The per-query caches (shadow boxes, edge planes) and the per-occluder edge hints of
  // occlusion(), sized here; the caches are valid for query point shadow_r_.
  void begin_query(const Vec3d& r);
  // The plane through the query point and edge `edge` of occluder `id` (fragment.h
  // node_plane, based near the light's centroid), computed once per query: every node
  // line and every occlusion test is an occluder edge, and the same edges are met by many
  // fragments of one query (measured: node_plane was 20% of the instructions on
  // columns before).
  // The cache lookup is inline (about 700k lookups a columns solve, most of them hits);
  // the plane itself is computed out of line.
  const NodePlane& edge_plane(uint32_t id, int edge) {
    const size_t slot = size_t(id) * size_t(kMaxOccluderVertices) + size_t(edge);
    if (plane_stamp_[slot] != stamp_) compute_edge_plane(id, edge, slot);
    return plane_cache_[slot];
  }
  void compute_edge_plane(uint32_t id, int edge, size_t slot);

  std::vector<Vec3d> light_;
  std::vector<Occluder> occ_;
  std::vector<Vec3d> recv_;     // receiver region corners
  // insertOccluder's orientation test (Theorem 1) of occluder id against edge `edge` of
  // the occluder being merged, through the fans below.
  Orientation orientation(uint32_t id, int edge) const;
  // The same after making the fans of `edge` if this development has not yet. develop()
  // keeps the answers per (merged occluder, occluder, edge) in orient_: they depend only
  // on the tree's occluders, light and receiver region, not on the leaf, and the same
  // occluder is merged at many leaves of one tree (columns: 61% of developments merge an
  // occluder merged before in the same tree).
  Orientation fresh_orientation(uint32_t id, int edge);
  void set_fans(int edge);
  // Per edge of the occluder being merged (develop): its EdgeFan against the light's
  // vertices and against the receiver region's corners (lines.h), made when first needed
  // (fans_ready_ bit `edge`).
  EdgeFan light_fans_[kMaxOccluderVertices];
  EdgeFan region_fans_[kMaxOccluderVertices];
  const Occluder* fan_occ_ = nullptr;  // the occluder being merged
  uint32_t fans_ready_ = 0;
  // orient_: per merged occluder (orient_block_, kNoBlock until it is first merged in this
  // tree), occ_.size() * kMaxOccluderVertices entries, entry id * kMaxOccluderVertices +
  // edge: 0 not yet tested, else 1 + Orientation. At most orient_cache_bytes_ in all
  // (set_orient_cache_bytes); past it the tests are made as before (the same answers).
  // Bounded scratch like the query's, so not in memory_bytes (memory_budget.h).
  static constexpr uint32_t kNoBlock = ~uint32_t(0);
  size_t orient_cache_bytes_ = size_t(1) << 22;
  std::vector<uint32_t> orient_block_;
  std::vector<uint8_t> orient_;
  std::vector<Node> nodes_;
  // Occluder lists of leaves, back to back. A developed leaf's list is dead space
  // (`dead_` entries) until grow_lists compacts the arena.
  std::vector<uint32_t> lists_;
  size_t dead_ = 0;
  // Makes room for `add` more entries in lists_: compacts it when at least half is dead
  // and it would otherwise reallocate, and charges a reallocation to the budget before
  // it allocates (so a tree stops at the budget, not one doubling past it).
  void grow_lists(size_t add);
  Rng rng_;
  BspCounters counters_;

  // Scratch reused across queries.
  std::vector<Vec3d> work_;  // query(): every fragment of a query, used as a buffer
  std::vector<Work> stack_;
  std::vector<Split> splits_;
  // query(): the visible fragments so far, as ranges of work_, in output order.
  std::vector<FragmentList::Span> out_spans_;
  std::vector<uint32_t> list_scratch_;
  std::vector<uint32_t> leaf_lists_[2 * kMaxOccluderVertices];
  std::vector<int32_t> new_leaves_;
  std::vector<uint32_t> candidates_;
  Choice choice_ = Choice::Relevant;
  LightPlane plane_;
  bool have_plane_ = false;
  Vec3d shadow_r_{};
  uint32_t stamp_ = 0;
  std::vector<uint32_t> shadow_stamp_;  // per occluder: stamp_ when shadow_box_ is valid
  std::vector<UVBox> shadow_box_;
  std::vector<uint8_t> miss_edge_;      // per occluder: the edge occlusion() last found separating
  std::vector<uint32_t> plane_stamp_;   // per occluder edge: stamp_ when plane_cache_ is valid
  std::vector<NodePlane> plane_cache_;
  LightBounds light_bounds_;  // every query fragment is a piece of the light (node_plane)
  CenterBox light_box_;  // the light polygon's box, widened by 2^-41 mag (hides_all's tests)
  // light_bounds_.dist1 of every occluder vertex (slot id * kMaxOccluderVertices + k) and
  // of the query point: node_plane's base choice, computed once per tree and query.
  std::vector<double> vertex_dist_;
  double shadow_dist_ = 0.0;
  MemoryCharge budget_charge_;
};

}  // namespace visgate::plucker
