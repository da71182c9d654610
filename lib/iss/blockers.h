// Blocker representation inside a shaft and the operations on it (paper 000 sections
// 4.4.2, 4.5, 4.6 and 4.7): RawEdge / Edge / Patch / Surface (Figures 4.7 and 4.9),
// CONSTRUCT-TRIANGLE-SURFACE with clipping (Figure 4.20), CLASSIFY-EDGES (4.21),
// UPDATE-PATCH-FACINGS (4.22, Table 4.1), MERGE-PATCHES (4.23), SIMPLIFY-PATCHES (4.7.5),
// SPLIT-SURFACE (4.25), COMPUTE-LOOSE-EDGES (4.26), COMBINE-SURFACES with glue edges
// (4.27-4.29), the blocking test BLOCKS-SHAFT (4.18) and its ray variant (4.10), and
// validate() (4.13). Implemented in one file per step (blockers.cpp lists them).
//
// Storage (section 4.13, "avoid copying, in place"): a surface owns three flat arrays.
// Raw edges refer to patches by index, a patch owns a contiguous range of the edge
// array, and an Edge is a raw-edge index plus a flip bit; so DUPLICATE-SURFACE is three
// vector copies with no pointer remapping, and every operation rebuilds the arrays in
// place from reusable scratch buffers.
//
// Orientation: a triangle patch lists its edges in the mesh triangle's vertex order; a
// non-flipped Edge is traversed by its owner neighbors[1] from vertices[0] to
// vertices[1] (GET-OWNER of Figure 4.7), a flipped one by neighbors[0] the other way.
// A surface is therefore an oriented 2-chain whose boundary is the set of raw edges
// with one neighbour, directed as their single owner traverses them.
//
// Guarantee of BLOCKS-SHAFT (see also iss_solver.h): a true answer means every open
// segment from a point of the receiver box to a point of the light box meets a blocker
// triangle. Reasoning: every blocker piece is a clipped mesh triangle that does not meet
// either node box (membership in the nodes' conservative inside lists), collapsed
// simplification triangles lie outside the extended shaft E (shaft.h), glue edges add
// only zero-area pieces, and merging or splitting does not change the chain. The
// intersection number of a segment with the chain is constant over all segments from
// box to box when no boundary edge meets the shaft (checked conservatively), and the
// winding number computed for the test segment between the outer node faces equals it
// because clamping never projects chain parts onto a node face (E invariant). A nonzero
// intersection number implies an actual intersection. Evaluation is in double on float32
// input and double clip vertices; the test segment stays at least the plane tolerance of
// shaft.h away from every boundary edge, far above the rounding of the winding test.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "lib/base/memory_budget.h"
#include "lib/iss/shaft.h"
#include "lib/iss/tree.h"
#include "lib/mesh/prepare.h"

namespace visgate::iss {

enum class Facing : uint8_t { TowardsReceiver, TowardsLight, Inconsistent };

constexpr int32_t kNoPatch = -1;
constexpr int32_t kClipEdge = -1;  // mesh_edge of clip, glue and collapsed edges

struct RawEdge {
  Vec3d v[2];
  int32_t nb[2] = {kNoPatch, kNoPatch};  // neighbour patches (indices in the surface)
  int32_t mesh_edge = kClipEdge;          // mesh edge label or kClipEdge
  uint8_t inside = 1;                     // at least partially inside the shaft
  uint8_t fresh = 0;  // left the shaft since the last SIMPLIFY-PATCHES (section 4.13:
                      // only patches with such an edge are simplified again)
};

struct Edge {
  uint32_t raw = 0;
  uint8_t flipped = 0;
};

struct Patch {
  uint32_t first = 0, count = 0;  // range in Surface::edges
  Facing facing = Facing::Inconsistent;
  int32_t tri = -1;  // mesh triangle if facing == Inconsistent
};

struct Surface {
  std::vector<RawEdge> raw;
  std::vector<Edge> edges;
  std::vector<Patch> patches;
  std::vector<int32_t> loose;  // loose edge labels (section 4.4.2)
  AABBd box = empty_box();  // of the raw edges (compute_bounds)
  // Box of the clipped triangles the surface stands for, a superset: set from the
  // triangles' edges when they are built into patches, carried through copies and
  // splits, joined by combining, never shrunk. The boundary's `box` need not hold them:
  // MERGE-PATCHES (4.7.3) forgets the edges inside a merged patch and SIMPLIFY-PATCHES
  // (4.7.5) collapses outside edges away, so a pouch's merged patch keeps only its rim
  // (corpus/iss/other/b8a6e1e8...) and a collapsed one may keep nothing near its
  // triangles (corpus/iss/pouch/8f524c6c...). Whatever claims to
  // know where the triangles are (beyond_clip_planes drops, the ray caster's slab
  // test) asks the hull, never the boundary.
  AABBd hull = empty_box();
  Vec3d vsum{0, 0, 0};  // vertex centre data (section 4.7.9): sum and count of the
  double vcount = 0;    // endpoints of edges inside the shaft
  bool refined = true;  // false when postponed in the last construction
  // Transient, set by the traversal: refinement found nothing to change (no edge left
  // the shaft, no facing changed), so the loose edges and bounds are still current.
  bool unchanged = false;

  size_t bytes() const {
    return raw.capacity() * sizeof(RawEdge) + edges.capacity() * sizeof(Edge) + patches.capacity() * sizeof(Patch) +
           loose.capacity() * sizeof(int32_t) + sizeof(Surface);
  }
};

inline const Vec3d& edge_vertex(const Surface& s, const Edge& e, int k) {
  return s.raw[e.raw].v[e.flipped ? k ^ 1 : k];
}
inline int32_t edge_neighbor(const Surface& s, const Edge& e) { return s.raw[e.raw].nb[e.flipped ? 1 : 0]; }
inline int32_t edge_owner(const Surface& s, const Edge& e) { return s.raw[e.raw].nb[e.flipped ? 0 : 1]; }

// Read-only context shared by the operations.
struct BlockerContext {
  const mesh::PreparedMesh* mesh = nullptr;
  double scale = 1.0;  // S of shaft.h
};

// A vertex of a triangle being clipped (CONSTRUCT-CLIPPED-PATCH) and the label of the
// edge that starts at it.
struct PolyVertex {
  Vec3d p;
  int32_t label;
};

// Reusable scratch storage (section 4.13: no allocation in the inner loops) and the
// pool of surfaces (section 4.13: "a custom pool-based memory manager for data
// structures that are allocated and deallocated often"): a surface that is no longer
// needed is cleared and kept with its arrays' capacity, and the next surface a
// construction needs is taken from the pool, so that copying a parent's surface into a
// sub-shaft usually reuses memory instead of allocating four arrays.
struct Workspace {
  std::vector<int32_t> label_slot;
  std::vector<uint32_t> label_stamp;
  uint32_t stamp = 0;
  std::vector<int32_t> uf, remap, remap2;
  std::vector<RawEdge> raw_tmp;
  std::vector<Edge> edge_tmp, edge_tmp2;
  std::vector<Patch> patch_tmp, patch_tmp2;
  std::vector<Edge> loop;
  std::vector<uint32_t> order, fill, group_start;
  std::vector<int32_t> next, local_patch, local_raw, sets, members;
  std::vector<uint8_t> used, fail;
  std::vector<PolyVertex> poly, poly_tmp;
  std::vector<std::pair<int32_t, Edge>> extra;     // combine: edges appended to a patch
  std::vector<std::pair<uint32_t, Edge>> replace;  // combine: raw edge -> edge instead
  std::vector<Surface> spare;                      // the surface pool
  // The one large surface kept (arrays above kMaxSpareEdges): the largest recycled so
  // far, taken by the next construction that expects that many edges. An initial
  // shaft's triangle surface holds a raw edge per clipped triangle edge of most of the
  // mesh; building it into fresh arrays each light cost a page fault per 4 kB touched
  // (about 900 per solve on rooms at 26k triangles, microseconds each on a virtual
  // machine) and the copies of vector growth. Counted against the memory budget
  // (bind_budget) while kept.
  Surface big;
  MemoryCharge big_charge;
  void bind_budget(MemoryBudget* b) { big_charge.bind(b, "surface pool"); }
  void reset_labels(size_t n);
  // An empty surface: the large one when `expect_raw` (raw edges the caller expects)
  // is above kMaxSpareEdges and it is kept, else from the pool when it holds one.
  Surface take_surface(size_t expect_raw = 0);
  // Returns a surface to the pool (cleared; a surface with arrays above kMaxSpareEdges
  // replaces the kept large one when it is larger, else it is freed; the pool keeps at
  // most kMaxSpare surfaces).
  void recycle(Surface&& s);
  static constexpr size_t kMaxSpare = 1024, kMaxSpareEdges = 4096;
};

// Section 4.7.1 / Figure 4.20: one clipped patch per triangle of `tris` that may
// intersect the shaft and is in neither node's inside list; neighbours by edge label.
Surface construct_triangle_surface(const BlockerContext& ctx, const std::vector<uint32_t>& tris,
                                   const ShaftGeometry& g, const TreeNode& rnode, const TreeNode& lnode, Workspace& ws);
// CLASSIFY-EDGES (Figure 4.21); returns the number of raw edges that left the shaft.
size_t classify_edges(Surface& s, const ShaftGeometry& g);
// CLASSIFY-AABB-PLANE (Figure 4.22): 0 FRONT (every corner beyond pl.tol), 1 BACK (every
// corner below -pl.tol), 2 INTERSECTS (conservative); from the two corners the signs of
// pl.n pick, the same answer as from all eight.
int classify_box_plane(const AABBd& b, const ConservativePlane& pl);
// Table 4.1 for a triangle with plane `pl` (plane_through at the shaft's scale) in shaft
// g: Inconsistent for a zero-area triangle, as UPDATE-PATCH-FACINGS decides it.
Facing triangle_facing(const ConservativePlane& pl, const ShaftGeometry& g);
// UPDATE-PATCH-FACINGS (Figure 4.22); returns the number of patches that became consistent.
size_t update_patch_facings(const BlockerContext& ctx, Surface& s, const ShaftGeometry& g);
void merge_patches(Surface& s, Workspace& ws);                                 // Figure 4.23
// The lazy band (an addition to sections 4.7.1-4.7.3 in the spirit of 4.13; Traversal's
// Shaft::band): removes every inconsistent triangle patch of `s` and appends its mesh
// triangle to `band`. What is left is the chain of a subset of the same valid blockers,
// which is all BLOCKS-SHAFT needs (see the guarantee above); the edges a removed patch
// shared with the rest become boundary edges (labelled, so loose edges for COMBINE), so
// the rest cannot block a shaft they stay inside. The result may be disconnected: the
// caller splits it (SPLIT-SURFACE) before any removal test relies on connectivity.
// Returns the number of patches removed.
size_t extract_inconsistent(Surface& s, std::vector<uint32_t>& band, Workspace& ws);
void simplify_patches(Surface& s, const ShaftGeometry& g, Workspace& ws);     // section 4.7.5
void split_surface(Surface&& s, std::vector<Surface>& out, Workspace& ws);    // Figure 4.25
void compute_loose_edges(const BlockerContext& ctx, Surface& s);              // Figure 4.26
void combine_surfaces(const BlockerContext& ctx, std::vector<Surface>& in, std::vector<Surface>& out,
                      const ShaftGeometry& g, Workspace& ws);                  // Figure 4.27-4.29
void compute_bounds(Surface& s, const ShaftGeometry& g);  // box and vertex centre
bool all_edges_outside(const Surface& s);

// `box` with its main-axis interval clamped into [lo, hi] (section 4.5 clamping moves
// every boundary vertex into it; a box entirely beyond a clip plane becomes flat on it).
AABBd clamp_box(const AABBd& box, int axis, double lo, double hi);
// The same for the shaft's clip planes.
AABBd clamped_box(const AABBd& box, const ShaftGeometry& g);
// True when a box's extent on `axis` ends before lo or starts after hi, or, with
// `touching_misses`, only reaches lo or hi (for a slab whose segments leave its end
// planes at once, so a box touching one meets them only at their end points).
bool misses_slab(const AABBd& box, int axis, double lo, double hi, bool touching_misses);
// The gap between the shaft's boxes along the main axis (negative when they overlap).
double main_axis_gap(const ShaftGeometry& g);
// True when the shaft's boxes are closer on the main axis than 2^-30 of the scale (or it
// has no main axis): thinner than its planes' tolerances (2^-40 of the scale) resolve.
// Clipping to such a slab and the winding signs inside it are rounding, so neither the
// blocking test nor the empty-shaft rule may decide its relations (blocks_shaft,
// traversal.cpp): they go to sub-shafts and rays.
bool shaft_too_thin(const ShaftGeometry& g);
// True when a surface with this box meets no open segment between the shaft's boxes:
// misses_slab between the clip planes, touching counting as missing when the boxes have
// a gap on the main axis. Sound for a box that holds the triangles: a surface's hull,
// not its boundary's box.
bool beyond_clip_planes(const AABBd& box, const ShaftGeometry& g);
// A surface whose boundary's box is beyond or touching a clip plane of `g`
// (beyond_clip_planes) while its hull is not: it may stand for blockers inside the
// shaft, so it is neither dropped nor removed, and it never blocks the shaft (its
// clamped boundary lies on the clip plane, where the winding's sign at the node face is
// not reliable); its relations go down to the rays.
bool stands_beyond_clip_planes(const Surface& s, const ShaftGeometry& g);
// CAN-BLOCK-SHAFT (line 1 of Figure 4.18): false when a surface with this box cannot
// block the shaft: its box clamped to the clip planes misses one of three box-to-box
// segments.
bool can_block_shaft(const AABBd& box, const ShaftGeometry& g);
// BLOCKS-SHAFT, Figure 4.18, with a third answer. Clear: proven not to block (the box
// test, a hole, or a zero winding number), so a surface with every edge outside may be
// removed (section 4.7.8). Unknown: not tested, or the clamped boundary lands on a node
// face (see blocking_test in blockers.cpp), or the shaft is too thin (shaft_too_thin),
// or the surface stands beyond a clip plane (stands_beyond_clip_planes): it neither
// blocks nor may be removed, so the shaft is not called empty either.
enum class BlockTest { Blocked, Clear, Unknown };
BlockTest blocking_test(const Surface& s, const ShaftGeometry& g);
// blocking_test(s, g) == BlockTest::Blocked.
bool blocks_shaft(const Surface& s, const ShaftGeometry& g);
// Section 4.10: BLOCKS-RAY, per patch (a consistent patch is crossed by every ray in the
// same direction, so its winding number is nonzero iff the ray crosses it; an
// inconsistent patch is its single triangle, tested directly).
bool blocks_ray(const BlockerContext& ctx, const Surface& s, int main_axis, const Vec3d& r, const Vec3d& l);

// Section 4.13: every index, loop and neighbour relation. Empty string when valid.
std::string validate(const Surface& s, const mesh::PreparedMesh* mesh);

}  // namespace visgate::iss
