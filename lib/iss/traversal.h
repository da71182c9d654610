// The ISS traversal over one light's sample tree and the shared receiver tree (paper 000
// sections 4.7-4.12; the `iss` Solver in iss_solver.h states the guarantee). One class,
// its member functions in one file per paper step:
//   traversal.cpp           4.8 PRE-TRAVERSE (Fig. 4.32), 4.9 SHAFT-TRAVERSE (Fig. 4.33)
//                           and CHOOSE-SPLIT, automatic rays, setup and statistics
//   shaft_construction.cpp  4.7 CONSTRUCT-SUB-SHAFT (Fig. 4.19), 4.8 CONSTRUCT-INITIAL-
//                           SHAFT (Fig. 4.31) and the blocker probe, 4.13 shaft pools
//   leaf_rays.cpp           4.10 CAST-SHADOW-RAYS: Embree leaf rays, the custom caster
//   empty_shaft.cpp         4.12 the empty-shaft rule and its sloped-floor extension
// Internal to lib/iss.
#pragma once

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <unordered_map>
#include <vector>
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#endif

#include "lib/base/memory_budget.h"
#include "lib/iss/blockers.h"
#include "lib/iss/shaft.h"
#include "lib/iss/surface_clusters.h"
#include "lib/iss/tree.h"
#include "lib/iss/triangle_bvh.h"
#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_scene.h"
#include "lib/solver.h"

namespace visgate::iss {

// validate() after every operation on every surface (iss_solver.h set_validate_all).
extern bool g_validate;

// ShaftGeometry::may_intersect_box's test by every plane of `g` over box arrays (lo x, y,
// z, hi x, y, z, kp each, kp a multiple of 4), four boxes per vector, the same
// arithmetic: keep[k] is cleared where box k lies beyond a plane (leaf_rays.cpp). With
// keep set on entry, box k passes may_intersect_box iff keep[k] stays set.
void direct_cull(const double* box, size_t kp, const ShaftGeometry& g, int64_t* keep);

// The cells' certificate of one triangle (tri) against every segment from p into box,
// as the traversal takes it (leaf_rays.cpp): centre true, cell_box_body (side: with the
// plane-side miss, as node cells; false: as sample groups); centre false, the corners'
// cell_classify / cell_pairs. 1: blocks every segment, 2: misses every one, 0: neither.
// For tests.
int cell_certificate(const Vec3f tri[3], const Vec3f& p, const AABB& box, bool centre, bool side);

using Clock = std::chrono::steady_clock;

// Time breakdown of Table 5.4, one timer per row of the table (plus the blocker probe,
// which the thesis does not have); "miscellaneous" is the rest of the traversal.
enum TimerId {
  kTree, kShaftGeometry, kTriangleSurface, kCopy, kClassify, kFacings, kMerge, kSimplify, kSplit,
  kCombine, kLoose, kBounds, kBlocking, kRays, kProbe, kBand, kTimerCount
};

// Timer ticks: the time-stamp counter where available. The breakdown timers run around
// every refinement step of every surface, and steady_clock (clock_gettime, a system call
// on some virtual machines) cost about 8% of the whole solve there (perf, rooms). Ticks
// are converted to seconds with the tick rate measured over the whole traversal.
inline uint64_t ticks() {
#if defined(__x86_64__) || defined(__i386__)
  return __rdtsc();
#else
  return uint64_t(std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now().time_since_epoch()).count());
#endif
}

class ScopedTimer {
 public:
  explicit ScopedTimer(double& acc) : acc_(acc), t0_(ticks()) {}
  ~ScopedTimer() { acc_ += double(ticks() - t0_); }
  ScopedTimer(const ScopedTimer&) = delete;
  ScopedTimer& operator=(const ScopedTimer&) = delete;

 private:
  double& acc_;
  uint64_t t0_;
};

struct Shaft {
  int r = 0, l = 0;
  ShaftGeometry g;
  std::vector<Surface> surfaces;
  std::vector<AABBd> ghosts;  // boxes of removed redundant surfaces (section 4.7.8)
  size_t bytes = 0;
  // The lazy band (Params::lazy_band): mesh triangles that meet the shaft as far as
  // their box says, are valid blockers (in neither node's inside list) and are
  // inconsistent for it by Table 4.1, kept out of the surfaces. They never block (the
  // surfaces' edges along them are boundary edges), the shaft is never empty while one
  // is left, a sub-shaft drops those whose box misses it and builds into its surfaces
  // those that turn consistent for it (as gone triangles are built, section 4.7.1).
  std::vector<uint32_t> band;
};

enum class SplitMode { Receiver, Light };

// Leaf rays per Embree packet (EmbreeScene::occluded_fan traces up to 16 as one packet).
constexpr uint32_t kFanWidth = 16;

// Leaf sizes (section 4.3; the thesis sets them per scene, Table 5.1, SODA 16/16).
// Defaults measured with `visgate bench iss` and A/B runs (docs/log/iss-performance.md):
// receiver leaves of one point, so automatic rays (below), not a fixed leaf size, decide
// where the receiver subdivision stops (rooms at 1024 receivers: 2.4% of the relations
// ray-cast against 13.4% at 16, no slower on the other families); 256 samples, i.e. a
// light of up to 256 samples is one light-tree leaf unless the per-light trial
// (LightMode below) finds that light splits pay, as on columns and never on rooms.
struct Params {
  int leaf_receivers = 1;
  int leaf_samples = 256;
  // Light splits chosen per light (LightSplit below): light-tree leaves of
  // split_samples, treated as leaves of leaf_samples (the whole light up to 256
  // samples) unless the light's trial shows that splitting lights pays.
  bool light_split_auto = true;
  bool light_split_always = false;  // light_split=on: every light in Split mode (measuring, tests)
  int split_samples = 4;       // light leaf once a light splits (Table 5.1, COLUMNS)
  int split_receivers = 64;    // receiver leaf once a light splits (Table 5.1, COLUMNS)
  double split_auto_ray_relations = 16.0;
  bool custom_rays = false;
  bool postpone = true;
  bool auto_rays = true;
  double auto_ray_relations = 64.0;  // kAutoRayRelationsPerShaft, see below
  bool ray_queue = true;  // queue_rays: full packets at light leaves under kFanWidth
  // Leaf relations by the direct test against the shaft's candidate triangles
  // (direct_rays, leaf_rays.cpp) when a shaft has at most direct_max_candidates of them.
  bool direct_rays = true;
  int direct_max_candidates = 48;
  // Cell shafts (cell_rays, leaf_rays.cpp; option cell_shafts, with direct_rays): the
  // leaf relations of a whole-light leaf with at most cell_max_candidates candidates,
  // receiver by receiver, by shafts from the receiver point to the light node's box and
  // to its subtree's boxes down to cell_depth levels below it. Defaults measured on rooms
  // at 1024 receivers (docs/log/iss-performance.md, tenth and eleventh rounds): deeper cells and more
  // candidates decide more relations but cost more than the direct test and the rays they
  // replace (a light cell was left mixed about three times in four at every level).
  bool cell_shafts = true;
  int cell_max_candidates = 192;
  int cell_depth = 0;
  // Cell shafts also blocked by planar patches of exactly coplanar neighbours (a wall's
  // face split in two triangles covers a cell that neither covers alone;
  // cell_patch_blocks).
  bool cell_patches = true;
  // A leaf shaft with more than cell_max_candidates candidates still gets cells when,
  // without the faces of closed star-shaped surfaces turned strictly away from every
  // point of the receiver node's box (cull_back_faces), at most that many are left.
  bool cell_backfaces = true;
  // A culled leaf still over cell_max_candidates takes cells receiver by receiver where,
  // without the closed surfaces whose box lies outside the pyramid from the receiver
  // over the light node's box, at most cell_surface_candidates are left
  // (cell_surface_receivers). Measured on rooms at 1024 receivers (docs/log/
  // iss-performance.md, thirteenth round): above about 96 candidates a receiver's cells
  // cost more than its Embree rays.
  bool cell_surfaces = true;
  int cell_surface_candidates = 96;
  // A cell left mixed over more than cell_group_samples samples with at most
  // cell_group_candidates mixed candidates takes a cell at each group of that many
  // samples (cell_group) before the direct test; groups above cell_group_min samples
  // left mixed take cells at their halves. Measured on rooms at 1024 receivers
  // (docs/log/iss-performance.md, fourteenth round): groups of 16 on at most 24
  // candidates cost less than the direct test they replace; on more candidates, more.
  // With the centre certificates (seventeenth round) halves down to 8 samples pay on
  // every rooms scene measured; down to 4, not on rooms at 4096 receivers.
  bool cell_groups = true;
  int cell_group_samples = 16;
  int cell_group_min = 8;
  int cell_group_candidates = 24;
  // Cells' certificates over a box from its centre and half extents (leaf_rays.cpp
  // cell_box_body) rather than at its corners: the node cells (cell_centre) and the
  // sample groups (cell_group_centre).
  bool cell_centre = true;
  bool cell_group_centre = true;
  // Receivers of one leaf are neighbours, and a wall that hides the whole light from one
  // usually hides it from the next: a node cell first tries the four candidates of the
  // vector that last blocked a node cell of this light (cell_receiver), one vector's
  // terms and certificate instead of every candidate's.
  bool cell_cache = true;
  // Initial shafts from pre-merged clusters (surface_clusters.h). The first initial
  // shaft over at least cluster_min_triangles triangles, and an eighth of the mesh,
  // builds them (once per solve); from then on every initial shaft uses them. On scenes
  // whose initial shafts are small (rooms) building them cost more than they saved.
  // Option clusters: auto (this), on (cluster_min_triangles 0), off.
  bool clusters = true;
  size_t cluster_min_triangles = 8192;
  // Where the normal cone cannot prove a node's facing, nodes of at most this many
  // triangles are decided by their triangles' own Table 4.1 facings (planes kept by
  // the clusters), so a consistent node near the band is still taken whole. 0: off.
  size_t cluster_exact_max = 512;
  // Lazy band (Shaft::band): on, off, or auto (on once the clusters are built, i.e.
  // on dense meshes). Never with the custom caster, which tests the surfaces' triangles.
  bool lazy_band_on = false, lazy_band_auto = true;
  // Build a band triangle into a sub-shaft's surfaces once it is consistent there. Off
  // by default: on scan and the real meshes the rebuilding cost more than the relations
  // it let shafts decide (docs/log/iss-scan.md, the lazy band).
  bool band_build = false;
  // Automatic rays by cost (traversal.cpp, shaft_subdivide): shafts of a size whose
  // subdivisions went through more than cost_factor * work_per_ray blocker elements per
  // relation they decided cast their relations. work_per_ray: a verified leaf ray cost
  // about 1,100-1,300 instructions on scan and the bunny, a blocker element about
  // 300-500 in the shaft constructions (callgrind, docs/log/iss-scan.md).
  // auto: with the lazy band (dense meshes), where shafts hold thousands of elements;
  // rooms and columns keep the rule they were tuned with (cost_rays=on there moved
  // rooms at 1024 x 64 from 17.9% to 19.8% ray-cast).
  bool cost_rays_on = false, cost_rays_auto = true;
  double work_per_ray = 3.0, cost_factor = 2.0;
  // The same rule for initial shafts, over the lights (cost_initial): once the initial
  // shafts built so far and the shafts below them went through more than cost_factor *
  // work_per_ray elements per relation they decided, a further initial shaft is not
  // built and its relations are cast (every kAutoRayExplore-th is still built). An
  // initial shaft of a dense mesh costs about as much as all its relations' rays, and
  // nothing before it can tell whether it will decide them. With cost_rays only.
  bool cost_initial = true;
  double cost_initial_factor = 1.0;
  // Lights cast whole before any shaft (option dense_rays; decided by iss_solver.cpp's
  // dense_ray_lights from the scene alone): per light, 1 when every relation of the
  // light is a leaf ray. rays_only: every light is, so the traversal builds no
  // triangle hierarchy and no receiver tree (and the prepared mesh is empty).
  std::vector<uint8_t> dense_light;
  bool rays_only = false;
};

// Automatic ray casting of shafts whose subdivision does not pay (option auto_rays;
// Embree leaf rays only). The thesis sets the leaf sizes by hand per scene (Table 5.1)
// and names choosing them automatically as missing (sections 5.1 and 5.4). Here the
// traversal measures that balance as it goes, per light, for shafts grouped by size
// (bucket = floor(log2(receivers x samples))): for every undecided shaft it subdivides
// it counts the shafts built below it and the relations they decide (blocked or empty).
// Once kAutoRayMinShafts shafts of a bucket have been subdivided and they decided fewer
// than kAutoRayRelationsPerShaft relations per shaft built below them, further undecided
// shafts of that bucket cast their relations directly (the leaf caster over the node
// ranges), except every kAutoRayExplore-th, which is still subdivided so that the
// bucket's figures follow the scene. Counts, not times: the choice, and with it every
// answer, is the same on every run. kAutoRayRelationsPerShaft is a quarter of what a
// shaft costs in leaf rays (220 to 400 rays on columns and rooms; the measurements are in
// docs/log/iss-performance.md). Every relation is still decided by a shaft or by a
// verified Embree ray, so no guarantee changes.
constexpr int kAutoRayMinShafts = 8;
constexpr int kAutoRayExplore = 8;
constexpr double kAutoRayRelationsPerShaft = 64.0;
struct AutoRayBucket {
  int subdivided = 0, skipped = 0;
  double shafts_below = 0, decided_below = 0;
  double work_below = 0;  // blocker elements the shafts below went through (cost_rays)
};

// Per-light choice between whole-light leaves and light splits (option light_split,
// default auto). The thesis sets leaf sizes per scene (Table 5.1): whole lights suit
// rooms (small lights behind walls: a light split adds shafts that decide nothing), 4-
// sample light leaves with 64-receiver leaves suit columns (one large light partly hidden
// from every floor point: no shaft on the whole light is ever blocked or empty). Each
// light starts with a trial: the first undecided shafts that reach a whole-light leaf
// with at most split_receivers receivers are traversed whole first and then, unless the
// whole-light way already decides (kWholeDecides), alternately both ways; the light
// continues with the way of lower measured cost per relation (a shaft counted as
// kShaftRayCost rays). Counts, not times: every run makes the same choice. Every
// relation is decided by a shaft or a verified ray either way, so no guarantee changes.
enum class LightMode { Trial, Whole, Split };
constexpr int kSplitTrialShafts = 8;     // trial shafts per way and light
constexpr int kSplitTrialEarly = 2;      // per way, before a clear winner may end the trial
// The whole-light way goes first; light splits are tried only when its first
// kSplitTrialEarly shafts cost at least this many rays per relation: no less than
// casting every relation, i.e. shafts ending on the whole light were neither blocked nor
// empty (measured: rooms 0.2-0.9, scan 0.15-0.5, columns 1.02).
constexpr double kWholeDecides = 1.0;
constexpr double kShaftRayCost = 20.0;   // ~3 us per shaft against ~0.15 us per ray (columns)
struct SplitTrial {
  int shafts[2] = {0, 0};
  double relations[2] = {0, 0}, cost[2] = {0, 0};
};

class Traversal {
 public:
  Traversal(const Scene& scene, const mesh::PreparedMesh& m, const Params& p, SolveResult& result);

  // COMPUTE-SHADOWS (Figure 4.32) for light `li`.
  void run_light(size_t li);

  void set_embree(const raycast::EmbreeScene* es) { embree_ = es; }
  // The leaf caster built cheaply (Embree's low build) with a better one on call:
  // `upgrade` replaces it once the rays cast reach `min_rays` and, extrapolated from the
  // share of the decided relations they took, would reach `upgrade_rays` over the
  // `relations` the traversal decides (iss_solver.cpp's embree_quality=auto). The
  // answers do not depend on the scene's build (embree_scene.h).
  void set_embree_upgrade(std::function<const raycast::EmbreeScene*()> upgrade, double min_rays, double upgrade_rays,
                          double relations) {
    upgrade_ = std::move(upgrade);
    upgrade_min_rays_ = min_rays;
    upgrade_rays_ = upgrade_rays;
    upgrade_relations_ = relations;
  }
  bool embree_upgraded() const { return embree_upgraded_; }
  const TriangleBvh& triangle_bvh() const { return *bvh_; }  // over the prepared mesh
  const std::vector<AABB>& triangle_boxes() const { return tri_boxes_; }  // per prepared triangle
  // The blocker probe's candidates for main axis `a` (probe_blocked): the triangles by
  // their smaller box extent across `a`, largest first, ties by index, and those
  // extents; only the first max(64, triangles / 16) + 1 (truncated: fewer than all).
  void probe_order(int a);
  const std::vector<uint32_t>& probe_triangles(int a) const { return wide_[a]; }
  const std::vector<float>& probe_extents(int a) const { return wide_extent_[a]; }
  bool probe_truncated() const { return wide_truncated_; }
  // Counts the live shafts and the clusters (charged when built, after this call).
  void set_memory_budget(MemoryBudget* b) { budget_ = b; ws_.bind_budget(b); }
  // Relations some rule decided (blocked shaft, empty shaft, leaf or automatic rays).
  // Bits start blocked (make_empty_result), so a relation no rule reached would read as
  // blocked without a word: solve checks that these add up to every relation.
  double decided_relations() const { return n_blocked_shaft_ + n_empty_ + n_rays_; }
  void finish_stats(Stats& st) const;

 private:
  // ---- helpers -------------------------------------------------------------------------
  TreeNode& rn(int i) { return rtree_->node(i); }
  TreeNode& ln(int i) { return ltree_->node(i); }

  void check(const Surface& s, const char* after) {
    if (!g_validate) return;
    std::string err = validate(s, &mesh_);
    if (!err.empty()) throw InternalError(err + " (after " + after + ")");
  }

  ShaftGeometry geometry(int r, int l, MainAxis ax) {
    ScopedTimer t(times_[kShaftGeometry]);
    return ShaftGeometry(rn(r).box, ln(l).box, ax, scale_);
  }

  void account(Shaft& sh) {
    sh.bytes = sizeof(Shaft) + sh.ghosts.capacity() * sizeof(AABBd) + sh.band.capacity() * sizeof(uint32_t);
    for (const Surface& s : sh.surfaces) sh.bytes += s.bytes();
    live_bytes_ += sh.bytes;
    peak_bytes_ = std::max(peak_bytes_, live_bytes_);
    if (budget_) budget_->change(int64_t(sh.bytes), "shafts");
    ++n_shafts_;
  }
  void release(Shaft& sh);
  void init_shaft(Shaft& sh);

  // The traversal's own rules (automatic rays, the light-split trial, the initial-shaft
  // cost rule) count a leaf's relations as leaf relations however the leaf decides them:
  // cell shafts (cell_rays) change how a leaf is decided, never which shafts are built.
  double shaft_decided() const { return n_blocked_shaft_ + n_empty_ - n_cell_decided_; }
  double leaf_relations() const { return n_rays_ + n_cell_decided_; }

  void record_blocked(int r, int l) { n_blocked_shaft_ += double(rn(r).size()) * double(ln(l).size()); }

  // ---- section 4.10: leaf rays (leaf_rays.cpp) -------------------------------------------
  void cast_rays(int r, int l, const Shaft* sh, const std::vector<uint32_t>* tris);
  // Embree leaf rays of light leaves smaller than a packet are queued per receiver node
  // and cast once a packet's worth of samples is pending, so the fans stay full at
  // small light leaves (a 4-sample leaf filled a quarter of a 16-wide packet, and its
  // rays cost 2.5 times as much each on columns). Each relation still gets the one
  // query it got before; only the grouping into packets changes.
  void queue_rays(int r, int l);
  void flush_rays(int r);
  void flush_all_rays();
  void fan_rays(uint32_t receiver, const uint32_t* samples, size_t n);
  // Every relation of light `li` by leaf rays, receiver by receiver in index order,
  // each receiver's samples in order as fans (Params::dense_light).
  void cast_light(size_t li);
  // The leaf relations of shaft `sh` by the certified segment-triangle test of
  // leaf_rays.cpp against the triangles that may meet the shaft, Embree rays for the
  // relations it cannot certify; false (nothing cast) when there are more than
  // Params::direct_max_candidates candidates.
  bool direct_rays(int r, int l, const Shaft& sh);
  bool direct_rays_cands(int r, int l);  // direct_rays with direct_cand_ gathered
  // Into direct_cand_; false when an ancestor's list was too long to gather (with
  // query_leaf, only when g's own list is: then the hierarchy is queried for g).
  bool direct_candidates(const ShaftGeometry& g, bool query_leaf = false);
  size_t direct_load_corners();
  // Cell shafts (section 4.9's light splits, specialised to a one-point receiver node
  // below a leaf): in the penumbra of a whole light most of a leaf's relations are rays,
  // and a full sub-shaft per light split (about 54k instructions on rooms) costs more
  // than the rays it decides. Per receiver of R, the light subtree of L is descended
  // with a shaft from the receiver point to each node box, decided against the leaf
  // shaft's candidate triangles by the direct test's certified predicates over the box
  // (leaf_rays.cpp cell_classify at its corners, cell_box_body from its centre with
  // cell_centre): blocked when one candidate blocks every segment into the box,
  // visible when every candidate misses them all, split while mixed, the mixed
  // light-tree leaves by the direct test per relation and Embree.
  // Shafts with more than cell_max_candidates go to direct_rays. False (nothing
  // decided) when the candidates are too many to gather or test.
  bool cell_rays(int r, int l, const Shaft& sh);
  void cell_descend(int c, size_t depth, uint32_t i, const double* od, uint64_t prefix);
  bool patch_interior_edge(uint32_t t, int e) const;
  // The per-receiver part of cell_rays: cells of receiver i against cell_levels_[0]
  // (kp lanes, the corners in direct_corners_).
  void cell_receiver(int l, uint32_t i, size_t kp);
  void flood_closed_surface(uint32_t t0);
  void cull_prepare();
  void cull_back_faces(const Vec3f* pts, int np, const AABB& box);
  void cell_surface_receivers(int r, int l);
  struct CellLevel;
  void cell_group(const CellLevel& lev, uint32_t b, uint32_t e, const AABB* heap, size_t node, const double* od,
                  uint32_t i);
  size_t cell_group_heap_size() const;
  void cell_group_fill(uint32_t b, uint32_t e, AABB* heap, size_t node) const;
  const std::vector<AABB>& cell_group_boxes(int c);
  AABB jitter_union(uint32_t b, uint32_t e) const;
  size_t load_cell_top();
  void cell_direct(const CellLevel& lev, const uint32_t* js, uint32_t count, const double* od, uint64_t prefix,
                   uint32_t i);
  void flood_cell_patch(uint32_t t);
  bool custom_occluded(const Vec3f& rpf, const Vec3f& lpf, const TreeNode& R, const TreeNode& L, const Shaft* sh,
                       const std::vector<uint32_t>* tris);

  // ---- sections 4.7, 4.8: shaft construction (shaft_construction.cpp) --------------------
  void refine(Surface&& s, const ShaftGeometry& g, std::vector<Surface>& out, bool settled);
  bool cost_rays() const { return p_.cost_rays_on || (p_.cost_rays_auto && lazy_band()); }
  bool lazy_band() const { return !p_.custom_rays && (p_.lazy_band_on || (p_.lazy_band_auto && clusters_)); }
  // Table 4.1 for mesh triangle t in shaft g (update_patch_facings' rule).
  Facing triangle_facing(uint32_t t, const ShaftGeometry& g);
  Facing band_facing(uint32_t t, const ShaftGeometry& g, bool light_same);
  void filter_band(const Shaft& parent, Shaft& sub, const std::vector<uint32_t>& gone, std::vector<uint32_t>& build);
  void finish_surfaces(Shaft& sh, std::vector<Surface>& temp);
  Shaft construct_sub_shaft(int r, int l, const TreeNode& split_node, Shaft& parent, bool move_parent,
                            const ShaftGeometry* made = nullptr);
  bool probe_blocked(int r, int l, MainAxis ax, size_t n_tris);
  // The cost rule across initial shafts (Params::cost_initial, shaft_construction.cpp):
  // true when the relations of r x l were cast instead of building its initial shaft.
  bool initial_shaft_by_rays(int r, int l);
  Shaft construct_initial_shaft(int r, int l, MainAxis ax, const std::vector<uint32_t>& tris);
  // Builds the clusters (Params::clusters) when an initial shaft over `n_tris` triangles,
  // at least cluster_threshold(), is the first to want them.
  void maybe_build_clusters(size_t n_tris);
  size_t cluster_threshold() const {
    return std::max(p_.cluster_min_triangles, (mesh_.triangles.size() + 7) / 8);
  }

  // ---- section 4.12: empty shafts (empty_shaft.cpp) --------------------------------------
  void record_visible(int r, int l);
  bool node_triangles_face_away(int r, const AABB& light_box);

  // ---- sections 4.8, 4.9: traversal (traversal.cpp) --------------------------------------
  // CHOOSE-SPLIT's four candidate geometries (receiver split left, right, light split
  // left, right), left unconstructed until choose_split builds all four: an array of
  // std::optional was zero-filled in full (6.6 kB) for every subdivided shaft, 16% of
  // shaft_subdivide's own instructions on columns (section 4.13, avoid work).
  // ShaftGeometry is trivially destructible, so nothing is destroyed.
  struct SplitGeometries {
    SplitGeometries() {}
    const ShaftGeometry* get(size_t k) const { return built ? &g[k] : nullptr; }
    bool built = false;
    union {
      ShaftGeometry g[4];
    };
  };
  static_assert(std::is_trivially_destructible_v<ShaftGeometry>);
  SplitMode choose_split(const Shaft& sh, SplitGeometries& cand);
  void shaft_traverse(Shaft& sh);
  void shaft_subdivide(Shaft& sh);  // lines 5-19 of Figure 4.33, after the tests
  bool pre_traverse_children(SplitMode mode, int r, int l, const std::vector<uint32_t>& tris);
  void pre_traverse(int r, int l, const std::vector<uint32_t>& tris, bool probe = true);

  const Scene& scene_;
  const mesh::PreparedMesh& mesh_;
  Params p_;
  SolveResult& result_;
  BlockerContext ctx_;
  double scale_ = 1.0;
  std::vector<AABB> tri_boxes_;
  std::unique_ptr<TriangleBvh> bvh_;
  std::unique_ptr<SurfaceClusters> clusters_;  // built on first need (Params::clusters)
  MemoryCharge clusters_charge_;
  std::unique_ptr<PointTree> rtree_, ltree_;
  const Light* light_ = nullptr;
  size_t light_offset_ = 0;
  std::vector<uint64_t> visible_masks_;  // record_visible's word masks of a light node
  const raycast::EmbreeScene* embree_ = nullptr;
  // Counts the leaf caster's rays (set_embree_upgrade) and returns the caster to use.
  const raycast::EmbreeScene& leaf_caster(int rays) {
    embree_rays_ += double(rays);
    if (upgrade_ && embree_rays_ >= upgrade_min_rays_) leaf_caster_upgrade();
    return *embree_;
  }
  void leaf_caster_upgrade();
  std::function<const raycast::EmbreeScene*()> upgrade_;
  double embree_rays_ = 0, upgrade_min_rays_ = 0, upgrade_rays_ = 0, upgrade_relations_ = 0;
  bool embree_upgraded_ = false;
  Workspace ws_;
  double times_[kTimerCount] = {};  // in ticks()
  Clock::time_point clock0_ = Clock::now();
  uint64_t tick0_ = ticks();
  double n_blocked_shaft_ = 0, n_empty_ = 0, n_rays_ = 0, n_rays_blocked_ = 0, n_shafts_ = 0, n_blocking_tests_ = 0;
  double n_removed_ = 0, n_postponed_ = 0, n_combined_ = 0, n_fallback_ = 0, n_unchanged_ = 0, n_dropped_ = 0;
  double n_kept_beyond_ = 0;
  double n_leaf_surfaces_ = 0, n_leaf_ghosts_ = 0, n_leaf_node_tris_ = 0, n_probe_blocked_ = 0;
  double n_auto_shafts_ = 0, n_auto_relations_ = 0;
  double n_direct_ = 0, n_direct_uncertain_ = 0;  // relations given to direct_rays / left to Embree by it
  bool direct_ok_ = false;  // every coordinate within raycast::kEmbreeCoordinateBound
  double n_cells_ = 0, n_cell_decided_ = 0;  // cell shafts classified / relations they decided
  // Per level of cell_descend: the candidates left mixed (count, padded kp) and their terms.
  struct CellLevel {
    std::vector<double> terms;
    size_t count = 0, kp = 0;
    std::vector<uint32_t> tris;  // the candidates' triangles (count of them)
  };
  // Planar patches (flood_cell_patch): per triangle its patch, kNoPatch when alone or
  // kPatchUnknown before its first need, and its boundary edges (bit e: edge e, vertex e
  // to e + 1).
  static constexpr uint32_t kNoPatch = ~uint32_t(0), kPatchUnknown = ~uint32_t(1);
  std::vector<uint32_t> patch_of_, patch_stack_;
  std::vector<uint8_t> patch_edges_;
  std::vector<std::pair<uint32_t, uint32_t>> cell_members_;  // (patch, candidate)
  std::vector<uint8_t> cell_flags_;
  double n_cell_patch_decided_ = 0;  // relations blocked by cell_patch_blocks
  bool cell_patch_blocks(const CellLevel& lev, const double* cd, int nc);
  std::vector<CellLevel> cell_levels_;
  // Closed star-shaped surfaces (flood_closed_surface): per triangle its surface's index
  // in closed_, kNoPatch when it is on none, kPatchUnknown before its first need.
  struct ClosedSurface {
    AABB box;
  };
  std::vector<uint32_t> closed_of_, closed_stack_, cull_members_;
  std::vector<ClosedSurface> closed_;
  std::vector<uint32_t> cull_all_;  // a culled leaf's candidates on no closed surface
  struct CullFace {  // a culled leaf's candidate on a closed surface
    uint32_t t = 0, surface = 0;
    Vec3d a, n, perm;  // its first corner, (b - a) x (c - a), and that cross product's permanent
  };
  std::vector<CullFace> cull_faces_;
  double n_cull_decided_ = 0;  // relations of leaves that took cells only after cull_back_faces
  // cull_back_faces' kept faces as (surface, triangle), and for cell_surface_receivers,
  // once sorted, the end of each surface's run.
  std::vector<std::pair<uint32_t, uint32_t>> cull_group_;
  std::vector<uint32_t> cull_surfaces_;
  double n_surface_cull_decided_ = 0;  // relations of receivers that took cells only after that
  std::vector<uint8_t> cell_out_;
  // cell_cache: the corners (SoA, 9 x 4 lanes) of the candidate vector that last blocked
  // a node cell of this light; valid when cell_cache_ok_ (cleared per light).
  double cell_cache_c_[9 * 4] = {};
  bool cell_cache_ok_ = false;
  double n_cell_cache_decided_ = 0;  // relations blocked by the cached vector
  bool cell_cache_blocks(const AABB& box, const double* od);
  void cell_cache_store(const CellLevel& lev, size_t vec);
  std::vector<uint32_t> cell_uncertain_;  // samples of the current receiver left to Embree
  std::vector<uint32_t> cell_samples_;  // samples cell_group left to the direct test
  // cell_group_boxes, per light node of this light (cleared with the light tree).
  std::unordered_map<int, std::vector<AABB>> group_boxes_;
  std::vector<AABB> group_scratch_;
  double n_group_decided_ = 0;  // relations decided by cell_group
  std::vector<uint32_t> direct_query_, direct_cand_;
  std::vector<double> direct_corners_, direct_terms_, direct_query_box_;
  std::vector<int64_t> direct_keep_;
  // The direct test's grouping (direct_rays): light points of a receiver's fan; hash
  // prefixes, jitter points and members of a chunk's receivers per sample.
  std::vector<const Vec3f*> direct_q_;
  std::vector<uint64_t> direct_prefix_;
  std::vector<uint32_t> direct_jp_, direct_members_, direct_start_, direct_fill_;
  // A group's segments (dx, dy, dz, n each) and their answers (direct_rays).
  std::vector<double> direct_d_;
  std::vector<uint8_t> direct_out_;
  // Candidate lists of the shafts being subdivided, outermost first (direct_candidates).
  // The direct test's scratch is bounded (20 bytes per receiver of a kDirectChunk chunk,
  // lists of at most kCandQueryMax triangles per level of the recursion): a few MB, not
  // charged to the memory budget, like the other per-traversal scratch vectors.
  struct CandLevel {
    const ShaftGeometry* g = nullptr;
    bool ready = false;
    bool too_many = false;  // the hierarchy's answer exceeded kCandQueryMax
    std::vector<uint32_t> tris;
    std::vector<double> box;  // the triangles' boxes, SoA (direct_candidates)
  };
  static constexpr size_t kCandUp = 4, kCandQueryMax = 1024, kDirectChunk = 16384;
  std::vector<CandLevel> cand_stack_;
  size_t cand_depth_ = 0;
  std::array<AutoRayBucket, 64> auto_buckets_{}, split_buckets_{};
  // LightSplit state of the current light; split_now_: the subtree being traversed
  // uses light splits (Split mode or the split way of a trial shaft).
  LightMode light_mode_ = LightMode::Whole;
  bool split_now_ = false, in_trial_ = false;
  SplitTrial trial_;
  double n_split_lights_ = 0, n_trial_shafts_ = 0;
  double n_cluster_patches_ = 0;  // cluster nodes taken whole (surface_clusters.h)
  double n_band_extracted_ = 0, n_band_built_ = 0, n_band_dropped_ = 0, n_band_kept_ = 0;
  // Shaft work (Params::cost_rays): blocker elements the shaft constructions went
  // through (the parent's raw edges and band entries, the new triangles' edges).
  double light_work_ = 0, n_shaft_work_ = 0, n_cost_ray_shafts_ = 0;
  // Initial shafts over all lights (Params::cost_initial): their work and decided
  // relations (the shaft and every shaft below), and those cast instead.
  AutoRayBucket initial_bucket_;
  double n_cost_ray_initial_ = 0, n_dense_lights_ = 0;
  std::vector<uint32_t> band_build_;
  // Per mesh triangle, built on the first use of the band (counted against the memory
  // budget as "band order and planes"): its position in the triangle hierarchy's leaf
  // order (a band is kept in that order, so consecutive entries are near each other and
  // are tested by chunks, filter_band) and, with Params::band_build, its plane with
  // plane_through's tolerance at the solve's scale, which the facing test asks once per
  // sub-shaft.
  std::vector<uint32_t> tri_pos_;
  std::vector<ConservativePlane> tri_planes_;
  std::vector<uint8_t> tri_plane_ok_;
  MemoryCharge band_charge_;
  static constexpr size_t kBandChunk = 8;
  void prepare_band();
  const ConservativePlane& tri_plane(uint32_t t);
  std::vector<std::vector<uint32_t>> band_lists_;
  bool light_leaf(const TreeNode& L) const {
    return L.is_leaf || (!split_now_ && L.size() <= uint32_t(p_.leaf_samples));
  }
  bool receiver_leaf(const TreeNode& R) const {
    return R.is_leaf || (split_now_ && R.size() <= uint32_t(p_.split_receivers));
  }
  std::vector<uint32_t> wide_[3];
  std::vector<float> wide_extent_[3];
  bool wide_done_[3] = {false, false, false};
  bool wide_truncated_ = false;
  size_t probe_keep() const;
  struct PendingRays {
    std::vector<std::pair<uint32_t, uint32_t>> ranges;  // light-tree order ranges
    uint32_t samples = 0;
  };
  std::unordered_map<int, PendingRays> pending_;  // by receiver node, this light only
  std::vector<uint32_t> pending_samples_;
  std::vector<uint32_t> light_samples_;  // 0 .. samples - 1 (cast_light)
  std::vector<uint32_t> probe_tris_, root_tris_;
  std::vector<Surface> probe_out_, temp_, band_split_;
  std::vector<std::vector<Surface>> surface_lists_;
  std::vector<std::vector<AABBd>> ghost_lists_;
  size_t live_bytes_ = 0, peak_bytes_ = 0, light_tree_bytes_peak_ = 0;
  MemoryBudget* budget_ = nullptr;
};

}  // namespace visgate::iss
