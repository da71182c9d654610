// The state of paper 002's soft-shadow framework (section 4.4, Algorithm 2) for one group
// of receivers and one light, and its three phases as Figure 8 (section 5.1) times them:
//  - occluder selection (Figure 8 "SC"; occluder_selection.cpp): Haines' shaft between
//    the group's box and the light's, clipped to the slab between the light plane and the
//    group's receivers, split into tree occluders and per-receiver "near" polygons;
//  - tree initialisation (Figure 8 "I"; group_tree.cpp): vvsets and one undefined leaf;
//  - per-receiver shading (Figure 8 "Q"; shade_receiver.cpp): near polygons, Algorithm 1
//    on what they leave, the exact paths, and the fraction, bits and irradiance.
// plucker_solver.cpp runs them per group (shade_group). Internal to lib/plucker.
#pragma once

#include <atomic>
#include <cmath>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "lib/plucker/bsp.h"
#include "lib/plucker/closed_surfaces.h"
#include "lib/plucker/interior_occluders.h"
#include "lib/plucker/local_light.h"
#include "lib/plucker/silhouette_region.h"
#include "lib/plucker/subtract.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/solver.h"

namespace visgate::plucker {

// A triangle part handled per receiver (plucker_solver.h "near" polygons).
struct NearPoly {
  uint32_t triangle;  // the scene triangle whose part this is (its plane, world coordinates)
  uint32_t begin, count;
  // Group-level data for the per-receiver tests: the polygon's box, and its triangle in
  // double local coordinates with the plane normal N = edge_plane_normal_err(t0, t1, t2)
  // (and N's error bound) and the 1-norms of two edges (near_side).
  Vec3d lo, hi;
  Vec3d t[3], n, err;
  double e1 = 0, e2 = 0, tmax = 0;
  // The largest |local coordinate| of the polygon's own vertices (max over lo and hi:
  // the same value as over the vertices), for the per-receiver rejection margins.
  double pmax = 0;
  // Of a closed surface's kept triangle (occluder_selection.cpp closed_surface_culling):
  // the side (+1, -1) of its plane a receiver must be on for a segment from it to cross
  // the triangle on the crossing side kept; a receiver strictly on the other side skips
  // it (closed_surfaces.h: each receiver needs only the crossings from that side). 0: no
  // such condition.
  int8_t keep_side = 0;
  // Its triangle's corners translate exactly to the local frame (local_light.h).
  bool exact_local = false;
  // A part of a coplanar convex patch (occluder_selection.cpp; `triangle` is its first):
  // the patch, all of whose triangles the exact paths subtract. Else -1.
  int32_t patch = -1;
};

// The solve's counters and timings (plucker_solver.h "Stats"), one per parallel task,
// merged at its end.
struct Totals {
  double select_s = 0, init_s = 0, query_s = 0, bsp_query_s = 0, tree_s = 0, irradiance = 0;
  uint64_t trees = 0, queries = 0, occluders = 0, near = 0, fragments = 0, fallback = 0, segment_relations = 0;
  uint64_t exact_triangles = 0, exact_receivers = 0, undecided_receivers = 0, unreported_slivers = 0;
  uint64_t far_triangles = 0, band_triangles = 0, rounded_triangles = 0, close_triangles = 0, level_triangles = 0;
  uint64_t plane_point_triangles = 0, patches = 0, patch_triangles = 0;
  uint64_t closed_dropped = 0;  // candidates of closed surfaces left out (closed_surfaces.h)
  uint64_t near_splits = 0;     // splits of the per-receiver subtractions (in bsp.splits too)
  uint64_t interior = 0;        // interior occluders added to trees (interior_occluders.h)
  uint64_t interior_covered = 0;  // candidates left out: every line through them stabs one
  uint64_t interior_skipped = 0;  // triangles of whole tree nodes left out that way (cover_nodes; not region surfaces')
  uint64_t near_merged = 0;  // per receiver: near triangles subtracted within another's polygon (shade_receiver.cpp)
  uint64_t closed_near = 0;  // one-sided triangles of dense closed surfaces put in the near list (closed_near)
  uint64_t bsp_nodes_max = 0;
  BspCounters bsp;
  SilhouetteCounters sil;  // silhouette regions (silhouette_region.h)
  void merge(const Totals& o);
};

// Live bytes of the trees shaded at the same time, and their maximum (Figure 8 "MS").
struct MemoryMeter {
  std::atomic<int64_t> current{0};
  std::atomic<int64_t> peak{0};
  MemoryBudget* budget = nullptr;  // SolveOptions::memory_budget_mb, counted by the trees
  void change(int64_t delta) {
    int64_t now = current.fetch_add(delta) + delta;
    int64_t p = peak.load();
    while (now > p && !peak.compare_exchange_weak(p, now)) {
    }
  }
};

// What every group of one solve shares.
struct SolveContext {
  const Scene* scene;
  SolveResult* result;
  std::vector<double>* irradiance;
  bool coherence;
  LazyBsp::Choice choice;
  const TriangleTree* tree;
  uint64_t seed;
  MemoryMeter* memory;
  const ClosedSurfaces* closed = nullptr;  // null: every candidate is modelled
  const InteriorOccluders* interior = nullptr;  // null: none added (interior_occluders.h)
  bool cover_nodes = true;  // the covered test on whole tree nodes (occluder_selection.cpp)
  bool near_merge = true;   // glued near triangles subtracted as one convex polygon (shade_receiver.cpp)
  bool closed_near = true;  // dense closed surfaces' one-sided triangles per receiver (occluder_selection.cpp)
  // Closed surfaces' shadows as silhouette regions (silhouette_region.h); null: off.
  const SurfaceTrees* surface_trees = nullptr;
  const TreeSurfaces* tree_surfaces = nullptr;  // with surface_trees: the tree's nodes by surface
  bool silhouette_estimate = true;  // auto: groups whose receivers see many turning edges decline
};

// One group and one light: the inputs, what occluder selection finds, and the working
// lists of the per-receiver shading. The lists are kept from group to group, one set per
// thread of a solve (ThreadWork): a group starts them empty but with the capacity earlier
// groups gave them, and the solve frees them when it returns (a thread-local set would
// outlive the solve and keep a larger scene's memory). shade_group runs no parallel work
// of its own, so a thread never uses two at once.
struct GroupState {
  // Inputs (set by start).
  const SolveContext* ctx = nullptr;
  size_t li = 0;                 // the light's index
  const LocalLight* lf = nullptr;
  const std::vector<uint32_t>* group = nullptr;
  float sigma = 1.0f;            // the receivers' side of the light plane (+1 or -1)
  size_t light_offset = 0;       // the light's first sample bit (Scene::light_offset)

  // Occluder selection: the slab (occluder_selection.cpp). g points towards the
  // light; g-values are relative to `ref` (a receiver); gmin, gmax bound the receivers'
  // g-values; a part beyond gcut = gmax + delta is between every receiver and the light.
  std::vector<Vec3d> rloc;       // the receivers, local
  Vec3d dlo{}, dhi{};            // their box (local, double)
  // Its corners in world coordinates (float box) and local: the distinct ones first
  // (nwcorners, ncorners: 4 for a flat box such as a receiver grid, fewer for a line or
  // a point), in the order of their first occurrence among the 8, the other slots
  // repeating the first (distinct_corners).
  Vec3f wcorners[8];
  Vec3d corners[8];
  int nwcorners = 8, ncorners = 8;
  Vec3d ref{}, g{};
  double gmin = 0, gmax = 0, delta = 0, gcut = 0;
  double light_width = 0;        // the light's longest side, or area over it when smaller
  double work_scale = 0;         // the extent the float path's roundings are relative to
  std::vector<Occluder> occluders;  // the tree's (bsp.h)
  std::vector<Occluder> interior;   // the interior occluders among them (interior_occluders.h)
  bool rloc_exact = false;          // every receiver of the group translates exactly
  std::vector<NearPoly> near;       // per receiver, largest over distance first
  std::vector<Vec3d> near_verts;    // their vertices (NearPoly::begin, count)
  std::vector<uint32_t> exact_tris;  // subtracted exactly per receiver
  std::vector<uint32_t> cand;        // the shaft's candidate triangles (sorted)
  // Subtrees of candidates left out whole as covered by an interior occluder: the exact
  // path of extreme receivers, which uses no tree, still subtracts them (cand_all; a
  // superset of the shaft's candidates: any scene triangle's exact shadow is blocked).
  std::vector<TriangleTree::Range> cand_skipped;
  std::vector<uint32_t> cand_all;
  // Per candidate: 0 kept, else left out as a closed surface's (occluder_selection.cpp);
  // per closed surface met: its slot in closed_count (-1 none), reset after each group.
  std::vector<uint8_t> closed_drop;
  std::vector<int8_t> closed_keep;   // per candidate kept: NearPoly::keep_side
  std::vector<int32_t> closed_slot;
  std::vector<uint32_t> closed_count;  // per slot: candidates crossable with r positive, negative
  std::vector<int32_t> closed_used;    // the surfaces with a slot
  // The group's region surfaces and silhouette edges (silhouette_region.h); per candidate
  // 1 when it is a region surface's (left out of the selection), else 0 (or empty).
  SilhouetteGroup sil;
  std::vector<uint8_t> region_drop;

  // Scratch of the phases.
  std::vector<Vec3d> poly0, lower, upper, region, pyramid, pyramid_err, cur, pos, neg, q, patch;
  std::vector<Vec3d> cover_n, cover_err;  // per receiver: planes through r and the interior occluders' edges
  std::vector<uint32_t> cover_at;         // per interior occluder: its first edge's plane in cover_n
  std::vector<NearPoly> near_sorted;
  std::vector<std::pair<double, uint32_t>> near_key;
  // The near polygons in blocks of nearby ones (occluder_selection.cpp sort_near): the
  // union of their boxes, their largest coordinate, and their indices in `near` (in
  // near_spatial[begin, begin + count)). Empty for short lists.
  struct NearBlock {
    Vec3d lo, hi;
    double pmax;
    uint32_t begin, count;
  };
  std::vector<NearBlock> near_blocks;
  std::vector<uint32_t> near_spatial;
  std::vector<uint64_t> near_pick_bits;  // per receiver: the near polygons of its blocks (shade_receiver.cpp)
  // Closed surfaces only: per input triangle its near polygon's index when that polygon
  // is the whole triangle's only part (-1 none, -2 several parts), reset at clear();
  // per near polygon the last receiver (near_serial) that subtracted it merged.
  std::vector<int32_t> near_of_tri;
  std::vector<uint32_t> near_done;
  uint32_t near_serial = 0;
  std::vector<uint8_t> on_plane0, on_level, skip, merged;
  std::vector<uint8_t> no_skip;  // all 0, grow-only: the skips of a near polygon with no edge on r's level
  std::vector<double> vals;
  std::vector<uint32_t> exact_done, patch_at;
  UVBoxGrid sample_grid;  // sample_bits' fragments by cell
  FragmentList frags, tmp;
  // Fragment k's box is boxes[frags.polys[k].box] (subtract.h): made in the fragments'
  // order it is boxes[k]; subtract_polygon appends and leaves garbage.
  std::vector<UVBox> boxes, tmp_boxes;
  FragmentRuns runs;  // over frags and boxes (subtract.h)

  void start(const SolveContext& c, size_t light, const LocalLight& l, const std::vector<uint32_t>& g_,
             float side) {
    clear();
    ctx = &c;
    li = light;
    lf = &l;
    group = &g_;
    sigma = side;
    light_offset = c.scene->light_offset(light);
  }
  void clear();
};

// The corners of the box [lo, hi] without repeats: corner c (bit a of c set: hi on axis
// a, else lo) unless some axis with lo == hi (the same bits) has its bit set, which
// repeats the corner without it. Written to out[0..count) in increasing c, the other
// slots a copy of out[0]; returns count. A sign test over the box's corners that asks
// every corner for one common strict sign gives the same answer on these.
template <class V>
int distinct_corners(const V& lo, const V& hi, V out[8]) {
  int flat = 0;
  for (int a = 0; a < 3; ++a)
    if (lo[a] == hi[a] && std::signbit(lo[a]) == std::signbit(hi[a])) flat |= 1 << a;
  int n = 0;
  for (int c = 0; c < 8; ++c)
    if ((c & flat) == 0) out[n++] = V((c & 1) ? hi.x : lo.x, (c & 2) ? hi.y : lo.y, (c & 4) ? hi.z : lo.z);
  for (int k = n; k < 8; ++k) out[k] = out[0];
  return n;
}

struct ThreadWork {
  GroupState state;
  std::unique_ptr<LazyBsp> tree;  // made at the thread's first group, rebuilt per group
};

// Figure 8 "SC": fills the slab, the occluders, the near polygons and the exact list.
void select_occluders(GroupState& gs, Totals& tot);

// Figure 8 "I": the group's tree over gs.occluders (vvsets, one undefined leaf).
LazyBsp& init_group_tree(GroupState& gs, ThreadWork& work, uint64_t tree_seed, Totals& tot);

// Figure 8 "Q": receiver gk of the group, its fragments, fraction, bits and irradiance
// written to the solve's result. `near_counters` gathers the near polygons' splits.
void shade_receiver(GroupState& gs, LazyBsp& bsp, size_t gk, BspCounters& near_counters, Totals& tot);

// One receiver on the light plane: float segment tests in the local frame
// (plucker_solver.h, degenerate).
void shade_fallback(const SolveContext& ctx, size_t li, const LocalLight& lf, size_t i, Totals& tot);

}  // namespace visgate::plucker
