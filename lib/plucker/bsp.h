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
// Guarantee: float32 as in the paper, "exact" in the paper's sense (analytic fragments,
// no sampling); with exact arithmetic the fragments are exactly the visible region.
// What is float and what is bounded: insertion signs (Theorem 1) are decided against the
// forward error bound of lines.h (undecided counts as mixed: costs time, never
// correctness). Fragment splits use the computed plane through r and the node's line,
// with only the evaluation of each vertex's side bounded (fragment.cpp): the computed
// plane (lines.h edge_plane_normal) differs from the true one by an angle of about
// u / sin(angle between the edge and the direction to r), so lines within that angle of a node's hyperplane may be sent to the wrong
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
//    them (plucker_solver.cpp); occluders touching the light plane give vvset lines in
//    the light plane whose sides are undecided, hence mixed: handled by conservative
//    insertion.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/geom/vec.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/scene/rng.h"

namespace visgate::plucker {

// A triangle clipped to the slab between the receivers and the light has at most
// 3 + 2 vertices; one more for safety of float clipping.
constexpr int kMaxOccluderVertices = 6;

// A convex occluder polygon. One-sided (the paper's case): oriented so that every
// receiver of the group lies strictly on the negative side of (v1 - v0) x (v2 - v0), so
// the lines from the receivers that stab it are positive against all its edge lines
// (lines.h convention) and bsp(o) has one invisible leaf (Figure 4). Two-sided: the
// group's receivers lie on both sides of its plane, so lines stab it in both directions;
// bsp(o) then has two invisible leaves, all-positive and all-negative (an extension of
// Figure 4: the first edge's right child starts a second chain for the negative class).
struct Occluder {
  Vec3f v[kMaxOccluderVertices];
  int n = 0;
  bool two_sided = false;
};

// Convex polygons stored back to back.
struct FragmentList {
  std::vector<Vec3f> verts;
  std::vector<std::pair<uint32_t, uint32_t>> polys;  // (first vertex, count)

  void clear() { verts.clear(); polys.clear(); }
  size_t size() const { return polys.size(); }
  const Vec3f* data(size_t k) const { return verts.data() + polys[k].first; }
  int count(size_t k) const { return int(polys[k].second); }
  void add(const Vec3f* p, size_t n) {
    polys.emplace_back(uint32_t(verts.size()), uint32_t(n));
    verts.insert(verts.end(), p, p + n);
  }
};

struct BspCounters {
  uint64_t nodes_created = 0;    // inner nodes and leaves ever created (resets included)
  uint64_t developments = 0;     // undefined leaves developed (Algorithm 1 lines 31-35)
  uint64_t insert_tests = 0;     // vvset orientation tests (Theorem 1)
  uint64_t splits = 0;           // fragment splits (line 25)
  uint64_t on_line = 0;          // degenerate: query point on a node's line
  uint64_t zero_area = 0;        // degenerate: zero-area fragments dropped
};

class LazyBsp {
 public:
  // Tree initialisation (Figure 8 "Init"): stores the occluders and their vvsets against
  // the light polygon (m vertices); the tree is one undefined leaf holding them all.
  //
  // `receivers` (nr points, may be empty) span a convex region holding every query point
  // of the tree (the corners of the group's receiver box). The lines that an occluder
  // hides from the queries stab the receivers' region, the occluder and the light, so
  // their orientation is also bounded by the vvset between the receiver region and the
  // occluder (Theorem 1 holds for the convex hulls of any two point sets: the proof only
  // combines vertices with barycentric weights). insertOccluder takes the first decided
  // orientation of the two vvsets: still conservative, and far fewer mixed insertions
  // for occluders close to the receivers.
  LazyBsp(const Vec3f* light, int m, std::vector<Occluder> occluders, uint64_t seed, const Vec3f* receivers = nullptr,
          int nr = 0);

  // Algorithm 1 BSP_query(root, L, r): appends the visible fragments of the light seen
  // from r to `out` (cleared first).
  void query(const Vec3f& r, FragmentList& out);

  // The paper's "modified version" (section 5.1): back to the root holding every
  // occluder, so the next query cannot reuse anything.
  void reset();

  size_t node_count() const { return nodes_.size(); }
  size_t occluder_count() const { return occ_.size(); }
  // Bytes held by the tree, its occluder lists, the occluders and their vvsets.
  size_t memory_bytes() const;
  const BspCounters& counters() const { return counters_; }

 private:
  enum Kind : uint8_t { kInner, kLeaf, kInvisible };
  struct Node {
    Vec3f a, b;                // inner: the line a -> b
    int32_t left = -1, right = -1;
    uint32_t occ_begin = 0, occ_count = 0;  // leaf: occluder list (undefined when count > 0)
    Kind kind = kLeaf;
  };
  struct Work {
    int32_t node;
    uint32_t begin, count;  // fragment vertices in work_
  };

  // Algorithm 1 lines 31-35: replace the undefined leaf by bsp(ro) for a random ro of its
  // occluders and insert the others into bsp(ro) (insertOccluder, lines 1-13).
  void develop(int32_t leaf);

  std::vector<Vec3f> light_;
  std::vector<Occluder> occ_;
  std::vector<Vec3f> vvdir_;   // vvset directions, occluder-major: l_j - o_i
  std::vector<uint32_t> vvbegin_;
  std::vector<Vec3f> recv_;     // receiver region corners
  std::vector<Vec3f> rvdir_;    // receiver-to-occluder vvset directions: o_j - c_i
  std::vector<uint32_t> rvbegin_;
  Orientation orientation(uint32_t id, const Vec3f& a, const Vec3f& b) const;
  std::vector<Node> nodes_;
  std::vector<uint32_t> lists_;  // occluder lists of leaves, back to back
  Rng rng_;
  BspCounters counters_;

  // Scratch reused across queries.
  std::vector<Vec3f> work_, cur_, pos_, neg_;
  std::vector<Work> stack_;
  std::vector<uint32_t> list_scratch_;
  std::vector<uint32_t> leaf_lists_[2 * kMaxOccluderVertices];
  std::vector<int32_t> new_leaves_;
};

}  // namespace visgate::plucker
