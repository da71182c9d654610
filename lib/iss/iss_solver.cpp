// The ISS traversal (paper 000 sections 4.7-4.12, Figures 4.19, 4.31-4.33) and the
// `iss` Solver (see iss_solver.h for the guarantee).
#include "lib/iss/iss_solver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
#endif
#include <memory>
#include <optional>

#include "lib/base/check.h"
#include "lib/base/memory_budget.h"
#include "lib/geom/float_mode.h"
#include "lib/iss/blockers.h"
#include "lib/iss/radial_pairing.h"
#include "lib/iss/shaft.h"
#include "lib/iss/tree.h"
#include "lib/iss/triangle_bvh.h"
#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_solver.h"

namespace visgate::iss {

namespace {

#ifdef NDEBUG
bool g_validate = false;
#else
bool g_validate = true;
#endif

using Clock = std::chrono::steady_clock;

// Time breakdown of Table 5.4, one timer per row of the table (plus the blocker probe,
// which the thesis does not have); "miscellaneous" is the rest of the traversal.
enum TimerId {
  kTree, kShaftGeometry, kTriangleSurface, kCopy, kClassify, kFacings, kMerge, kSimplify, kSplit,
  kCombine, kLoose, kBounds, kBlocking, kRays, kProbe, kTimerCount
};
const char* const kTimerNames[kTimerCount] = {
    "time_tree_construction", "time_shaft_geometry", "time_triangle_surface", "time_copying_surfaces",
    "time_classifying_edges", "time_updating_facings", "time_merging_patches", "time_simplifying_patches",
    "time_splitting_surfaces", "time_combining_surfaces", "time_computing_loose_edges",
    "time_computing_surface_aabbs", "time_blocking_tests", "time_ray_casting", "time_probe"};

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
};

enum class SplitMode { Receiver, Light };

// Leaf sizes (section 4.3; the thesis sets them per scene, Table 5.1, SODA 16/16).
// Defaults measured with `visgate bench iss` and CPU-time A/B runs (README, ISS):
// 16 receivers, because the shafts of the rooms family are decided by walls only once
// the receiver nodes are a few grid cells wide; 256 samples, i.e. a light of up to 256
// samples is one light-tree leaf and never split: light splits decided few relations on
// rooms and none on columns, and their leaf rays go 16 per Embree packet anyway.
struct Params {
  int leaf_receivers = 16;
  int leaf_samples = 256;
  bool custom_rays = false;
  bool postpone = true;
  bool auto_rays = true;
};

// Automatic ray casting of shafts whose subdivision does not pay (option auto_rays;
// Embree leaf rays only). The thesis sets the leaf sizes by hand per scene (Table 5.1)
// and names choosing them automatically as missing (sections 5.1 and 5.4: subdividing
// further "was found to be of no help, since the fraction of relations solved by
// detecting blocked or empty shafts did not grow enough to balance the computation
// time"). Here the traversal measures that balance as it goes, per light, for shafts
// grouped by size (bucket = floor(log2(receivers x samples))): for every undecided
// shaft it subdivides it counts the shafts built below it and the relations they
// decide (blocked or empty). Once kAutoRayMinShafts shafts of a bucket have been
// subdivided and they decided fewer than kAutoRayRelationsPerShaft relations per shaft
// built below them, further undecided shafts of that bucket cast their relations
// directly (the leaf caster over the node ranges), except every kAutoRayExplore-th,
// which is still subdivided so that the bucket's figures follow the scene. Counts, not times: the
// choice, and with it every answer, is the same on every run. kAutoRayRelationsPerShaft
// is a quarter of what a shaft costs in leaf rays: 33 us of shaft operations against
// 84 ns per leaf ray on columns (511 shafts, 1M rays), 26 us against 120 ns on rooms
// (83k shafts, 16.8M rays), i.e. 220 to 400 rays. At 256 the rule took 9,248 rooms
// shafts (a third fewer shafts, 4.9M more rays) and rooms ran 5-12% slower in
// alternating runs: the small rooms shafts it took decided about 180 relations each
// and their penumbra rays cost more than the average; at 64 it takes 690 there
// (97.25% still decided by shafts against 97.28%) and on columns, where the shafts
// decide nothing, the same 34 of 511 (103 shafts built). Every relation is still
// decided by a shaft or by a verified Embree ray, so no guarantee changes.
constexpr int kAutoRayMinShafts = 8;
constexpr int kAutoRayExplore = 8;
constexpr double kAutoRayRelationsPerShaft = 64.0;
struct AutoRayBucket {
  int subdivided = 0, skipped = 0;
  double shafts_below = 0, decided_below = 0;
};

class Traversal {
 public:
  Traversal(const Scene& scene, const mesh::PreparedMesh& m, const Params& p, SolveResult& result)
      : scene_(scene), mesh_(m), p_(p), result_(result) {
    AABB b = scene.bounds();
    double s = 0;
    for (int k = 0; k < 3; ++k) s = std::max({s, std::abs(double(b.lo[k])), std::abs(double(b.hi[k]))});
    scale_ = std::max(s, 1e-30);
    ctx_.mesh = &mesh_;
    ctx_.scale = scale_;
    ScopedTimer t(times_[kTree]);
    tri_boxes_.resize(m.triangles.size());
    for (size_t t2 = 0; t2 < m.triangles.size(); ++t2) {
      AABB tb;
      for (int k = 0; k < 3; ++k) tb.extend(m.corner(t2, k));
      tri_boxes_[t2] = tb;
    }
    bvh_ = std::make_unique<TriangleBvh>(tri_boxes_);
    std::vector<AABB> boxes;
    std::vector<Vec3f> centers;
    for (const Receiver& r : scene.receivers) {
      boxes.emplace_back(r.p, r.p);
      centers.push_back(r.p);
    }
    std::vector<uint32_t> cand;
    bvh_->query_box(PointTree::bounds_of(boxes), cand);
    rtree_ = std::make_unique<PointTree>(std::move(boxes), std::move(centers), p.leaf_receivers, mesh_, tri_boxes_,
                                         &cand);
    // Probe candidates (see probe_blocked): per main axis, the triangles ordered by
    // their smaller box extent across that axis, largest first (ties by index). The
    // probe never takes more than max(64, triangles / 16) of them, so only that many
    // plus one are kept: a full prefix then says "more than the cap".
    size_t keep = std::min(m.triangles.size(), std::max<size_t>(64, m.triangles.size() / 16) + 1);
    for (int a = 0; a < 3; ++a) {
      std::vector<uint32_t>& w = wide_[a];
      w.resize(m.triangles.size());
      for (uint32_t t2 = 0; t2 < w.size(); ++t2) w[t2] = t2;
      cross_.resize(m.triangles.size());
      for (size_t t2 = 0; t2 < w.size(); ++t2) {
        Vec3f e = tri_boxes_[t2].extent();
        cross_[t2] = std::min(e[(a + 1) % 3], e[(a + 2) % 3]);
      }
      auto wider = [&](uint32_t x, uint32_t y) { return cross_[x] != cross_[y] ? cross_[x] > cross_[y] : x < y; };
      std::nth_element(w.begin(), w.begin() + long(keep) - (keep > 0), w.end(), wider);
      w.resize(keep);
      std::sort(w.begin(), w.end(), wider);
      wide_extent_[a].resize(w.size());
      for (size_t k = 0; k < w.size(); ++k) wide_extent_[a][k] = cross_[w[k]];
    }
    cross_ = {};
    wide_truncated_ = keep < m.triangles.size();
  }

  void run_light(size_t li) {
    if (scene_.receivers.empty()) return;
    light_ = &scene_.lights[li];
    light_offset_ = scene_.light_offset(li);
    auto_buckets_ = {};
    {
      ScopedTimer t(times_[kTree]);
      std::vector<AABB> boxes(light_->jitter_boxes);
      std::vector<Vec3f> centers;
      for (const AABB& b : boxes) centers.push_back(b.center());
      std::vector<uint32_t> cand;
      bvh_->query_box(PointTree::bounds_of(boxes), cand);
      ltree_ = std::make_unique<PointTree>(std::move(boxes), std::move(centers), p_.leaf_samples, mesh_, tri_boxes_,
                                           &cand);
    }
    // COMPUTE-SHADOWS (Figure 4.32), with the triangle array restricted to the
    // triangles whose box may meet the root shaft (triangle_bvh.h) instead of all. The
    // root's blocker probe runs first: when it decides the light no array is needed.
    int r0 = rtree_->root(), l0 = ltree_->root();
    if (!rn(r0).box.overlaps(ln(l0).box)) {
      MainAxis ax = choose_main_axis(rn(r0).box, ln(l0).box);
      if (ax.axis >= 0 && probe_blocked(r0, l0, ax, mesh_.triangles.size())) {
        record_blocked(r0, l0);
        light_tree_bytes_peak_ = std::max(light_tree_bytes_peak_, ltree_->memory_bytes());
        ltree_.reset();
        return;
      }
    }
    std::vector<uint32_t> tris;
    {
      ScopedTimer t(times_[kTriangleSurface]);
      bvh_->query_shaft(ShaftGeometry(rn(r0).box, ln(l0).box, MainAxis{}, scale_), tris);
    }
    pre_traverse(r0, l0, tris, false);
    light_tree_bytes_peak_ = std::max(light_tree_bytes_peak_, ltree_->memory_bytes());
    ltree_.reset();
  }

  void set_embree(const raycast::EmbreeScene* es) { embree_ = es; }
  void set_memory_budget(MemoryBudget* b) { budget_ = b; }  // counts the live shafts
  // Relations some rule decided (blocked shaft, empty shaft, leaf or automatic rays).
  // Bits start blocked (make_empty_result), so a relation no rule reached would read as
  // blocked without a word: solve checks that these add up to every relation.
  double decided_relations() const { return n_blocked_shaft_ + n_empty_ + n_rays_; }
  void finish_stats(Stats& st) const {
    double rel = double(scene_.relation_count());
    st.set("relations", rel);
    st.set("relations_blocked_by_shaft", n_blocked_shaft_);
    st.set("relations_visible_by_empty_shaft", n_empty_);
    st.set("relations_ray_cast", n_rays_);
    st.set("rays_blocked", n_rays_blocked_);
    double blocked = n_blocked_shaft_ + n_rays_blocked_;
    st.set("percent_blocked", rel > 0 ? 100.0 * blocked / rel : 0.0);
    st.set("percent_ray_cast", rel > 0 ? 100.0 * n_rays_ / rel : 0.0);
    st.set("percent_decided_by_shafts", rel > 0 ? 100.0 * (n_blocked_shaft_ + n_empty_) / rel : 0.0);
    st.set("shafts_built", n_shafts_);
    st.set("blocking_tests", n_blocking_tests_);
    st.set("surfaces_removed", n_removed_);
    st.set("surfaces_postponed", n_postponed_);
    st.set("surfaces_combined", n_combined_);
    st.set("surfaces_unchanged", n_unchanged_);
    st.set("surfaces_dropped_outside", n_dropped_);
    st.set("surfaces_kept_beyond_clip_planes", n_kept_beyond_);
    st.set("embree_fallback_rays", n_fallback_);
    st.set("initial_shafts_blocked_by_probe", n_probe_blocked_);
    st.set("leaf_rays_with_surfaces", n_leaf_surfaces_);
    st.set("leaf_rays_with_removed_only", n_leaf_ghosts_);
    st.set("leaf_rays_empty_with_node_triangles", n_leaf_node_tris_);
    st.set("auto_ray_shafts", n_auto_shafts_);
    st.set("auto_ray_relations", n_auto_relations_);
    double peak = double(peak_bytes_ + rtree_->memory_bytes() + light_tree_bytes_peak_ + bvh_->memory_bytes());
    st.set("peak_memory_mb", peak / (1024.0 * 1024.0));
    st.set("receiver_tree_nodes", double(rtree_->node_count()));
    double secs = std::chrono::duration<double>(Clock::now() - clock0_).count();
    double tick_count = double(ticks() - tick0_);
    double per_tick = tick_count > 0 ? secs / tick_count : 0.0;
    double timed = 0;
    for (int i = 0; i < kTimerCount; ++i) {
      st.set(kTimerNames[i], times_[i] * per_tick);
      timed += times_[i] * per_tick;
    }
    // Table 5.4's top rows: shaft operations against ray casting, over the traversal.
    st.set("time_miscellaneous", std::max(0.0, secs - timed));
    st.set("time_traversal", secs);
    double rays = times_[kRays] * per_tick;
    st.set("percent_time_ray_casting", secs > 0 ? 100.0 * rays / secs : 0.0);
    st.set("percent_time_shaft_operations", secs > 0 ? 100.0 * (secs - rays) / secs : 0.0);
  }

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
    sh.bytes = sizeof(Shaft) + sh.ghosts.capacity() * sizeof(AABBd);
    for (const Surface& s : sh.surfaces) sh.bytes += s.bytes();
    live_bytes_ += sh.bytes;
    peak_bytes_ = std::max(peak_bytes_, live_bytes_);
    if (budget_) budget_->change(int64_t(sh.bytes), "shafts");
    ++n_shafts_;
  }
  // The shaft is done: its surfaces, and its two arrays, go back to the pools (section
  // 4.13), so that the next shaft's arrays need no allocation.
  void release(Shaft& sh) {
    live_bytes_ -= sh.bytes;
    if (budget_) budget_->change(-int64_t(sh.bytes), "shafts");
    for (Surface& s : sh.surfaces) ws_.recycle(std::move(s));
    sh.surfaces.clear();
    sh.ghosts.clear();
    if (surface_lists_.size() < 256) {
      surface_lists_.push_back(std::move(sh.surfaces));
      ghost_lists_.push_back(std::move(sh.ghosts));
    }
  }
  // A shaft with pooled (empty) arrays.
  void init_shaft(Shaft& sh) {
    if (surface_lists_.empty()) return;
    sh.surfaces = std::move(surface_lists_.back());
    sh.ghosts = std::move(ghost_lists_.back());
    surface_lists_.pop_back();
    ghost_lists_.pop_back();
  }

  void record_blocked(int r, int l) { n_blocked_shaft_ += double(rn(r).size()) * double(ln(l).size()); }

  void record_visible(int r, int l) {
    const TreeNode& R = rn(r);
    const TreeNode& L = ln(l);
    const auto& ro = rtree_->order();
    const auto& lo = ltree_->order();
    for (uint32_t a = R.begin; a < R.end; ++a) {
      ReceiverResult& rr = result_.receivers[ro[a]];
      for (uint32_t b = L.begin; b < L.end; ++b) rr.set_visible(light_offset_ + lo[b], true);
    }
    n_empty_ += double(R.size()) * double(L.size());
  }

  // CAST-SHADOW-RAYS. With the custom caster (section 4.10) the shaft's blockers, the
  // leaf nodes' inside triangles (Figure 4.35) and, in pre-traversal, the pruned
  // triangle list decide the ray.
  void cast_rays(int r, int l, const Shaft* sh, const std::vector<uint32_t>* tris) {
    ScopedTimer t(times_[kRays]);
    const TreeNode& R = rn(r);
    const TreeNode& L = ln(l);
    const auto& ro = rtree_->order();
    const auto& lo = ltree_->order();
    size_t blocked = 0;
    for (uint32_t a = R.begin; a < R.end; ++a) {
      uint32_t i = ro[a];
      ReceiverResult& rr = result_.receivers[i];
      const Vec3f& rp = scene_.receivers[i].p;
      if (p_.custom_rays) {
        for (uint32_t b = L.begin; b < L.end; ++b) {
          int j = int(lo[b]);
          bool occ = custom_occluded(rp, sample_position(*light_, j, i), R, L, sh, tris);
          rr.set_visible(light_offset_ + size_t(j), !occ);
          n_rays_blocked_ += occ;
        }
        continue;
      }
      // The standard caster: the receiver's segments to the leaf's samples form a
      // coherent fan, traced 16 at a time as one Embree packet (occluded_fan).
      const uint64_t prefix = relation_hash_prefix(i, light_->seed);
      for (uint32_t b0 = L.begin; b0 < L.end; b0 += 16) {
        int n = int(std::min<uint32_t>(16, L.end - b0));
        Vec3f to[16];
        bool occ[16];
        for (int k = 0; k < n; ++k) to[k] = leaf_sample_at(*light_, int(lo[b0 + uint32_t(k)]), prefix);
        embree_->occluded_fan(rp, to, n, occ);
        for (int k = 0; k < n; ++k) {
          // Bits start blocked (make_empty_result): only visible ones are written.
          if (!occ[k]) rr.set_visible(light_offset_ + size_t(lo[b0 + uint32_t(k)]), true);
          blocked += occ[k];
        }
      }
    }
    n_rays_ += double(R.size()) * double(L.size());
    n_rays_blocked_ += double(blocked);
  }

  bool custom_occluded(const Vec3f& rpf, const Vec3f& lpf, const TreeNode& R, const TreeNode& L, const Shaft* sh,
                       const std::vector<uint32_t>* tris) {
    Vec3d rp = to_double(rpf), lp = to_double(lpf);
    auto hits = [&](uint32_t t) {
      return segment_hits_triangle_d(rp, lp, to_double(mesh_.corner(t, 0)), to_double(mesh_.corner(t, 1)),
                                     to_double(mesh_.corner(t, 2)));
    };
    if (!sh) {
      for (uint32_t t : *tris)
        if (hits(t)) return true;
      return false;
    }
    for (uint32_t t : R.inside)
      if (hits(t)) return true;
    for (uint32_t t : L.inside)
      if (hits(t)) return true;
    // BLOCKS-RAY clamps a surface's boundary to the segment's extent on the main axis.
    // Rays of the shaft start and end inside the node boxes, not on the clip planes (the
    // boxes' outer faces), so a surface may reach past an endpoint's level; clamping then
    // flattens that part onto the endpoint's plane, right at the endpoint, where the
    // winding's signs are decided by rounding (fuzz_iss 27ee46b1...: a ground triangle
    // 2^-82 beside a receiver's box and 0.125 below the receiver, flattened onto the
    // receiver's level 2e-25 from it, was counted as crossed: false-blocked at margin
    // 1e-3). A surface entirely beyond an endpoint's level cannot meet the segment (one
    // touching that level can meet it only at the endpoint, which does not block); one
    // reaching past it is left to the ray.
    const int ax = sh->g.main_axis();
    const double lo = std::min(rp[ax], lp[ax]), hi = std::max(rp[ax], lp[ax]);
    for (const Surface& s : sh->surfaces) {
      // Where the triangles are is the hull's to say; a boundary missing the slab while
      // the hull does not (a merged or collapsed patch, Surface::hull) leaves the ray.
      if (misses_slab(s.hull, ax, lo, hi, lo < hi)) continue;
      if (misses_slab(s.box, ax, lo, hi, lo < hi) || s.box.lo[ax] < lo || s.box.hi[ax] > hi) {
        ++n_fallback_;
        return embree_->occluded(rpf, lpf);
      }
      if (blocks_ray(ctx_, s, ax, rp, lp)) return true;
    }
    for (const AABBd& gb : sh->ghosts) {
      if (segment_may_hit_box(rp, lp, gb, 0x1p-40 * scale_)) {
        ++n_fallback_;
        return embree_->occluded(rpf, lpf);
      }
    }
    return false;
  }

  // ---- section 4.7: sub-shaft construction ---------------------------------------------
  // Lines 14-18 of Figure 4.19 for one surface. `settled`: the surface is as the parent
  // shaft's construction left it (merged, simplified, one component), not a new triangle
  // surface and not postponed there.
  void refine(Surface&& s, const ShaftGeometry& g, std::vector<Surface>& out, bool settled) {
    size_t left, became;
    { ScopedTimer t(times_[kClassify]); left = classify_edges(s, g); }
    check(s, "classify_edges");
    { ScopedTimer t(times_[kFacings]); became = update_patch_facings(ctx_, s, g); }
    check(s, "update_patch_facings");
    // Early exit (section 4.13). Merging needs a patch whose facing just became
    // consistent (inside edges only ever leave, facings only ever settle), simplifying
    // an edge that just left the shaft (the fresh marks), splitting a connecting edge
    // that just left; with none of them the three passes would reproduce the surface.
    if (settled && left == 0 && became == 0) {
      s.unchanged = true;
      ++n_unchanged_;
      out.push_back(std::move(s));
      return;
    }
    s.unchanged = false;
    { ScopedTimer t(times_[kMerge]); merge_patches(s, ws_); }
    check(s, "merge_patches");
    { ScopedTimer t(times_[kSimplify]); simplify_patches(s, g, ws_); }
    check(s, "simplify_patches");
    size_t before = out.size();
    { ScopedTimer t(times_[kSplit]); split_surface(std::move(s), out, ws_); }
    for (size_t k = before; k < out.size(); ++k) {
      out[k].refined = true;
      check(out[k], "split_surface");
    }
  }

  void finish_surfaces(Shaft& sh, std::vector<Surface>& temp) {
    {
      ScopedTimer t(times_[kLoose]);
      for (Surface& s : temp)
        if (!s.unchanged) compute_loose_edges(ctx_, s);  // unchanged: still current
    }
    {
      ScopedTimer t(times_[kCombine]);
      size_t before = temp.size();
      sh.surfaces.reserve(before);
      combine_surfaces(ctx_, temp, sh.surfaces, sh.g, ws_);
      if (sh.surfaces.size() < before) n_combined_ += double(before - sh.surfaces.size());
    }
    {
      ScopedTimer t(times_[kBounds]);
      for (Surface& s : sh.surfaces)
        if (!s.unchanged) compute_bounds(s, sh.g);
    }
    for (const Surface& s : sh.surfaces) check(s, "combine_surfaces");
  }

  // CONSTRUCT-SUB-SHAFT (Figure 4.19). The parent's surfaces are copied for the first
  // child and moved into the second (section 4.13: no needless copies).
  // `made`: this sub-shaft's geometry when choose_split has built it already (the same
  // nodes, main axis and scale, so the same bits).
  Shaft construct_sub_shaft(int r, int l, const TreeNode& split_node, Shaft& parent, bool move_parent,
                            const ShaftGeometry* made = nullptr) {
    MainAxis ax{parent.g.main_axis(), parent.g.dir()};
    // The geometry is built in place: a default-constructed one assigned afterwards cost
    // two fills and a copy of its plane and corner arrays (1.2 kB) per shaft.
    // Two whole initialisers: each branch's prvalue initialises `sub` itself, so the
    // geometry() branch still builds in place (no temporary and copy).
    Shaft sub = made ? Shaft{r, l, *made, {}, {}, 0} : Shaft{r, l, geometry(r, l, ax), {}, {}, 0};
    init_shaft(sub);
    for (const AABBd& gb : parent.ghosts)
      if (sub.g.may_intersect_box(gb)) sub.ghosts.push_back(gb);
    std::vector<Surface>& temp = temp_;  // not re-entrant: no traversal in between
    temp.clear();
    for (Surface& ps : parent.surfaces) {
      // Early exit (section 4.13): a surface whose box, clamped to the sub-shaft's clip
      // planes, misses the sub-shaft has every edge outside it, cannot block it (the
      // clamped boundary lies in that box, and a plane through the test line separates
      // them) nor any later sub-shaft (their clamped boxes miss them too: the receiver
      // or light box of the sub-shaft lies between), and has no loose edge to combine
      // through, so SHAFT-TRAVERSE would remove it as redundant (section 4.7.8) right
      // after the refinement. It is dropped before the copy; no removed-surface box is
      // needed either, since no segment inside the shaft meets it.
      if (!sub.g.may_intersect_box(clamped_box(ps.box, sub.g))) {
        ++n_dropped_;
        continue;
      }
      // A surface beyond a clip plane (the outer faces of the node boxes on the main
      // axis) meets no segment of the shaft, and one touching it meets only segments'
      // end points there (the boxes are disjoint along the main axis, so every segment
      // leaves that plane at once), which do not block (DESIGN 3). Clamping would instead
      // flatten it onto the plane, where the receiver is: fuzz_iss 621ee63f..., a
      // triangle reaching z = 0.5 below a leaf whose receiver is at z = 0.5, 2^-149 beside
      // its plane, was clamped into a sliver through the receiver and blocked the shaft.
      // The test is the hull's (Surface::hull): a merged or collapsed patch's boundary
      // may lie beyond while the triangles it stands for cross the sub-shaft; such a
      // surface is kept, never blocks and is never removed (stands_beyond_clip_planes),
      // so its relations go to the rays.
      if (beyond_clip_planes(ps.hull, sub.g)) {
        ++n_dropped_;
        continue;
      }
      if (beyond_clip_planes(ps.box, sub.g)) ++n_kept_beyond_;
      Surface s;
      {
        ScopedTimer t(times_[kCopy]);
        if (move_parent) {
          s = std::move(ps);
        } else {
          s = ws_.take_surface();
          s = ps;  // DUPLICATE-SURFACE into pooled arrays: no allocation when they fit
        }
      }
      // Section 4.7.9: postpone the refinement when the vertex centre stays inside and
      // the surface cannot block the shaft yet.
      if (p_.postpone && s.vcount > 0 && sub.g.may_contain_point(s.vsum * (1.0 / s.vcount)) &&
          !can_block_shaft(s.box, sub.g)) {
        s.refined = false;
        s.unchanged = true;  // loose edges and bounds stay as computed for the parent
        ++n_postponed_;
        temp.push_back(std::move(s));
        continue;
      }
      bool settled = s.refined;
      refine(std::move(s), sub.g, temp, settled);
    }
    Surface nt;
    {
      ScopedTimer t(times_[kTriangleSurface]);
      nt = construct_triangle_surface(ctx_, split_node.gone, sub.g, rn(r), ln(l), ws_);
    }
    check(nt, "construct_triangle_surface");
    if (!nt.patches.empty()) refine(std::move(nt), sub.g, temp, false);
    else ws_.recycle(std::move(nt));
    finish_surfaces(sub, temp);
    temp.clear();
    account(sub);
    return sub;
  }

  // Blocker probe before CONSTRUCT-INITIAL-SHAFT (an addition to section 4.8, in the
  // spirit of the early exits of section 4.13). A surface built from any subset of the
  // valid blockers of a shaft (triangles that meet the shaft and neither node) that
  // passes BLOCKS-SHAFT blocks every box-to-box segment (blockers.h), whatever the other
  // triangles are. A blocking surface spans the shaft's cross-section, so the probe
  // builds the surfaces of the few triangles whose box is at least as wide as the
  // narrower node on both cross axes, and tests them. On rooms this decides the shafts
  // from the ground-floor receivers to every upper-floor light with a handful of slab
  // triangles instead of the whole mesh. The probe is skipped when the candidates are
  // not few (then it would cost about as much as the full construction).
  bool probe_blocked(int r, int l, MainAxis ax, size_t n_tris) {
    ScopedTimer timer(times_[kProbe]);
    const TreeNode& R = rn(r);
    const TreeNode& L = ln(l);
    int a = ax.axis, b = (a + 1) % 3, c = (a + 2) % 3;
    Vec3f re = R.box.extent(), le = L.box.extent();
    float thr = std::min(std::min(re[b], le[b]), std::min(re[c], le[c]));
    const std::vector<float>& ext = wide_extent_[a];
    // Number of triangles with cross extent >= thr (ext is descending; a full prefix
    // means more than any cap).
    size_t n = size_t(std::lower_bound(ext.begin(), ext.end(), thr, [](float x, float v) { return x >= v; }) - ext.begin());
    size_t cap = std::max<size_t>(64, n_tris / 16);
    if (n == 0 || n > cap || (wide_truncated_ && n == ext.size())) return false;
    probe_tris_.assign(wide_[a].begin(), wide_[a].begin() + long(n));
    ShaftGeometry g = geometry(r, l, ax);
    Surface s = construct_triangle_surface(ctx_, probe_tris_, g, R, L, ws_);
    check(s, "construct_triangle_surface (probe)");
    if (s.patches.empty()) {
      ws_.recycle(std::move(s));
      return false;
    }
    probe_out_.clear();
    refine(std::move(s), g, probe_out_, false);
    bool blocked = false;
    for (Surface& ps : probe_out_) {
      compute_bounds(ps, g);
      ++n_blocking_tests_;
      if (!blocked && blocks_shaft(ps, g)) {
        ++n_probe_blocked_;
        blocked = true;
      }
      ws_.recycle(std::move(ps));
    }
    probe_out_.clear();
    return blocked;
  }

  // CONSTRUCT-INITIAL-SHAFT (Figure 4.31).
  Shaft construct_initial_shaft(int r, int l, MainAxis ax, const std::vector<uint32_t>& tris) {
    Shaft sh{r, l, geometry(r, l, ax), {}, {}, 0};  // in place, as in construct_sub_shaft
    init_shaft(sh);
    Surface s;
    {
      ScopedTimer t(times_[kTriangleSurface]);
      s = construct_triangle_surface(ctx_, tris, sh.g, rn(r), ln(l), ws_);
    }
    check(s, "construct_triangle_surface");
    std::vector<Surface> temp;
    if (!s.patches.empty()) refine(std::move(s), sh.g, temp, false);
    finish_surfaces(sh, temp);
    account(sh);
    return sh;
  }

  // CHOOSE-SPLIT (section 4.9): the strategy whose two sub-shafts bring the combined
  // vertex centre closer to their boundaries on average. The four candidate geometries
  // are built in `cand` (receiver split left, right, light split left, right; empty when
  // not built), so that the two of the chosen split are not built again for the
  // sub-shafts: they were a third of all shaft constructions.
  using SplitGeometries = std::array<std::optional<ShaftGeometry>, 4>;
  SplitMode choose_split(const Shaft& sh, SplitGeometries& cand) {
    TreeNode& R = rn(sh.r);
    TreeNode& L = ln(sh.l);
    Vec3d sum(0, 0, 0);
    double cnt = 0;
    for (const Surface& s : sh.surfaces) {
      sum += s.vsum;
      cnt += s.vcount;
    }
    double rd = R.box.diagonal(), ld = L.box.diagonal();
    if (cnt == 0) return rd > ld ? SplitMode::Receiver : SplitMode::Light;
    Vec3d c = sum * (1.0 / cnt);
    {
      ScopedTimer t(times_[kTree]);
      rtree_->split(sh.r);
      ltree_->split(sh.l);
    }
    if (!R.split_done()) return SplitMode::Light;
    if (!L.split_done()) return SplitMode::Receiver;
    MainAxis ax{sh.g.main_axis(), sh.g.dir()};
    {
      ScopedTimer t(times_[kShaftGeometry]);
      cand[0].emplace(rn(R.left).box, L.box, ax, scale_);
      cand[1].emplace(rn(R.right).box, L.box, ax, scale_);
      cand[2].emplace(R.box, ln(L.left).box, ax, scale_);
      cand[3].emplace(R.box, ln(L.right).box, ax, scale_);
    }
    double dr = 0.5 * (cand[0]->boundary_distance(c) + cand[1]->boundary_distance(c));
    double dl = 0.5 * (cand[2]->boundary_distance(c) + cand[3]->boundary_distance(c));
    return dr <= dl ? SplitMode::Receiver : SplitMode::Light;
  }

  // Extension of the empty-shaft rule (section 4.12, the sloped-floor case): a triangle
  // in the receiver node's inside list cannot meet an open segment from one of the
  // node's points to the light box when all those points lie on one closed side of its
  // plane and the whole light box strictly on the same side: every interior point of
  // such a segment is then strictly on that side. Receivers lying on a floor (columns)
  // or on a table top therefore no longer disable the rule. Evaluated in double with the
  // plane tolerance of shaft.h on both sides, so a receiver within that tolerance of the
  // plane counts as on it: wrong only for relations within double rounding of touching
  // (the oracle margin makes those undecidable anyway, iss_solver.h). The per-node
  // classification is computed once (the receiver tree is shared by all lights), with
  // an O(1) box test before the scan of the points and an exit at the first point on
  // the other side.
  bool node_triangles_face_away(int r, const AABB& light_box) {
    TreeNode& R = rn(r);
    if (R.sides_state == 0) {
      ScopedTimer t(times_[kTree]);
      R.sides_state = 2;
      const auto& ord = rtree_->order();
      AABBd rb = to_aabbd(R.box);
      for (uint32_t tri : R.inside) {
        Plane4d pl = plane_through(to_double(mesh_.corner(tri, 0)), to_double(mesh_.corner(tri, 1)),
                                   to_double(mesh_.corner(tri, 2)), scale_);
        if (pl.n == Vec3d(0, 0, 0)) { R.sides_state = 1; break; }  // degenerate: no plane
        double mn = 1e300, mx = -1e300;
        for (int i = 0; i < 8; ++i) {
          double e = pl.eval(Vec3d(i & 1 ? rb.hi.x : rb.lo.x, i & 2 ? rb.hi.y : rb.lo.y, i & 4 ? rb.hi.z : rb.lo.z));
          mn = std::min(mn, e);
          mx = std::max(mx, e);
        }
        bool neg = mx <= pl.tol, pos = mn >= -pl.tol;
        if (!neg && !pos) {  // the box straddles the plane: look at the points
          neg = pos = true;
          for (uint32_t k = R.begin; k < R.end && (neg || pos); ++k) {
            double e = pl.eval(to_double(scene_.receivers[ord[k]].p));
            if (e > pl.tol) neg = false;
            if (e < -pl.tol) pos = false;
          }
        }
        if (!neg && !pos) { R.sides_state = 1; break; }
        if (neg && pos) {
          R.flat.push_back(pl);
          continue;
        }
        if (!neg) { pl.n = pl.n * -1.0; pl.d = -pl.d; }
        R.sides.push_back(pl);
      }
      if (R.sides_state == 1) {
        R.sides = {};
        R.flat = {};
      }
    }
    if (R.sides_state != 2) return false;
    AABBd lb = to_aabbd(light_box);
    auto box_max = [&](const Plane4d& pl) {
      return pl.eval(Vec3d(pl.n.x > 0 ? lb.hi.x : lb.lo.x, pl.n.y > 0 ? lb.hi.y : lb.lo.y, pl.n.z > 0 ? lb.hi.z : lb.lo.z));
    };
    auto box_min = [&](const Plane4d& pl) {
      return pl.eval(Vec3d(pl.n.x > 0 ? lb.lo.x : lb.hi.x, pl.n.y > 0 ? lb.lo.y : lb.hi.y, pl.n.z > 0 ? lb.lo.z : lb.hi.z));
    };
    // The light box strictly on the points' (non-positive) side of every one-sided
    // plane, and strictly on either side of every plane that contains the points.
    for (const Plane4d& pl : R.sides)
      if (!(box_max(pl) < -pl.tol)) return false;
    for (const Plane4d& pl : R.flat)
      if (!(box_max(pl) < -pl.tol) && !(box_min(pl) > pl.tol)) return false;
    return true;
  }

  // ---- section 4.9: traversal ------------------------------------------------------------
  // SHAFT-TRAVERSE (Figure 4.33).
  void shaft_traverse(Shaft& sh) {
    // Lines 1-4: blocked? drop redundant surfaces (section 4.7.8).
    for (size_t k = 0; k < sh.surfaces.size();) {
      Surface& s = sh.surfaces[k];
      BlockTest test;
      {
        ScopedTimer t(times_[kBlocking]);
        ++n_blocking_tests_;
        test = blocking_test(s, sh.g);
      }
      if (test == BlockTest::Blocked) {
        record_blocked(sh.r, sh.l);
        return;
      }
      // Removal needs the winding test's proof (Clear), not a refusal to test (Unknown):
      // a surface kept only because its test was refused, say in a shaft too thin to
      // test, may block a later, thicker sub-shaft.
      if (test == BlockTest::Clear && all_edges_outside(s)) {
        sh.ghosts.push_back(s.hull);
        ++n_removed_;
        ws_.recycle(std::move(s));
        if (k + 1 != sh.surfaces.size()) sh.surfaces[k] = std::move(sh.surfaces.back());
        sh.surfaces.pop_back();
        continue;
      }
      ++k;
    }
    TreeNode& R = rn(sh.r);
    TreeNode& L = ln(sh.l);
    // Section 4.12: an empty shaft between nodes free of triangles is all visible.
    // Removed surfaces (section 4.7.8) do not count, as in the paper: a surface is
    // removed only when every edge is outside the shaft and the winding test says it
    // does not block. Surfaces are connected through inside edges (4.7.6), so such a
    // surface is a single patch; a single patch whose boundary is outside the shaft is
    // crossed by either every box-to-box segment or none (its intersection number is
    // constant, and a consistent patch or a single triangle is crossed at most once,
    // always in the same direction), and the winding number (= that intersection
    // number, blockers.h) is zero, so none crosses it. Stale inside flags of postponed
    // surfaces only err towards "inside", so the rule stays conservative.
    // Not for a shaft too thin to clip into (shaft_too_thin, blockers.h): fuzz_iss
    // 2ddae6b5..., a light with one sample 1.9e33 below the receivers left only the x
    // axis separating the boxes, by 1.9e-39; clipping the blockers to that slab lost the
    // fan that blocks receiver 0, and the empty shaft called it visible (margin 0.014).
    if (sh.surfaces.empty() && !L.had_triangles && !shaft_too_thin(sh.g) &&
        (!R.had_triangles || node_triangles_face_away(sh.r, L.box))) {
      record_visible(sh.r, sh.l);
      return;
    }
    // Lines 5-8.
    if (R.is_leaf && L.is_leaf) {
      double n = double(R.size()) * double(L.size());
      if (!sh.surfaces.empty()) n_leaf_surfaces_ += n;
      else if (!sh.ghosts.empty()) n_leaf_ghosts_ += n;
      else n_leaf_node_tris_ += n;
      cast_rays(sh.r, sh.l, &sh, nullptr);
      return;
    }
    // Automatic ray casting (Params): this shaft's relations by leaf rays when
    // subdividing shafts of its size has not paid in this light.
    const int bucket = std::min(63, std::ilogb(std::max(1.0, double(R.size()) * double(L.size()))));
    AutoRayBucket& ab = auto_buckets_[size_t(bucket)];
    if (p_.auto_rays && !p_.custom_rays && ab.subdivided >= kAutoRayMinShafts &&
        ab.decided_below < kAutoRayRelationsPerShaft * ab.shafts_below && ++ab.skipped % kAutoRayExplore != 0) {
      n_auto_shafts_ += 1;
      n_auto_relations_ += double(R.size()) * double(L.size());
      cast_rays(sh.r, sh.l, &sh, nullptr);
      return;
    }
    const double shafts0 = n_shafts_, decided0 = n_blocked_shaft_ + n_empty_;
    SplitMode mode;
    SplitGeometries cand;
    if (R.is_leaf) mode = SplitMode::Light;
    else if (L.is_leaf) mode = SplitMode::Receiver;
    else mode = choose_split(sh, cand);
    if (mode == SplitMode::Receiver) {
      { ScopedTimer t(times_[kTree]); rtree_->split(sh.r); }
      if (!rn(sh.r).split_done()) {  // could not be split after all (identical points)
        if (ln(sh.l).is_leaf) { cast_rays(sh.r, sh.l, &sh, nullptr); return; }
        mode = SplitMode::Light;
      }
    }
    if (mode == SplitMode::Light) {
      { ScopedTimer t(times_[kTree]); ltree_->split(sh.l); }
      if (!ln(sh.l).split_done()) {
        if (rn(sh.r).is_leaf || !(rtree_->split(sh.r), rn(sh.r).split_done())) {
          cast_rays(sh.r, sh.l, &sh, nullptr);
          return;
        }
        mode = SplitMode::Receiver;
      }
    }
    for (int side = 0; side < 2; ++side) {
      int r = sh.r, l = sh.l, split;
      if (mode == SplitMode::Receiver) split = r = side == 0 ? rn(sh.r).left : rn(sh.r).right;
      else split = l = side == 0 ? ln(sh.l).left : ln(sh.l).right;
      const TreeNode& sn = mode == SplitMode::Receiver ? rn(split) : ln(split);
      const std::optional<ShaftGeometry>& made = cand[size_t((mode == SplitMode::Receiver ? 0 : 2) + side)];
      Shaft sub = construct_sub_shaft(r, l, sn, sh, side == 1, made ? &*made : nullptr);
      shaft_traverse(sub);
      release(sub);
    }
    ab.subdivided += 1;  // auto_buckets_ is a fixed array: `ab` outlives the recursion
    ab.shafts_below += n_shafts_ - shafts0;
    ab.decided_below += n_blocked_shaft_ + n_empty_ - decided0;
  }

  // PRE-TRAVERSE (Figure 4.32).
  // `probe`: run the blocker probe before an initial shaft (false when the caller did).
  void pre_traverse(int r, int l, const std::vector<uint32_t>& tris, bool probe = true) {
    TreeNode& R = rn(r);
    TreeNode& L = ln(l);
    if (!R.box.overlaps(L.box)) {
      MainAxis ax = choose_main_axis(R.box, L.box);
      if (ax.axis >= 0) {
        if (probe && probe_blocked(r, l, ax, tris.size())) {
          record_blocked(r, l);
          return;
        }
        Shaft sh = construct_initial_shaft(r, l, ax, tris);
        shaft_traverse(sh);
        release(sh);
        return;
      }
    }
    std::vector<uint32_t> new_tris;
    {
      ShaftGeometry g = geometry(r, l, MainAxis{});
      for (uint32_t t : tris)
        if (g.may_intersect_triangle(to_double(mesh_.corner(t, 0)), to_double(mesh_.corner(t, 1)),
                                     to_double(mesh_.corner(t, 2))))
          new_tris.push_back(t);
    }
    double rd = R.box.diagonal(), ld = L.box.diagonal();
    if (!R.is_leaf && (rd > ld || L.is_leaf)) {
      { ScopedTimer t(times_[kTree]); rtree_->split(r); }
      if (rn(r).split_done()) {
        int a = rn(r).left, b = rn(r).right;
        pre_traverse(a, l, new_tris);
        pre_traverse(b, l, new_tris);
        return;
      }
    }
    if (!ln(l).is_leaf) {
      { ScopedTimer t(times_[kTree]); ltree_->split(l); }
      if (ln(l).split_done()) {
        int a = ln(l).left, b = ln(l).right;
        pre_traverse(r, a, new_tris);
        pre_traverse(r, b, new_tris);
        return;
      }
    }
    if (!rn(r).is_leaf) {
      { ScopedTimer t(times_[kTree]); rtree_->split(r); }
      if (rn(r).split_done()) {
        int a = rn(r).left, b = rn(r).right;
        pre_traverse(a, l, new_tris);
        pre_traverse(b, l, new_tris);
        return;
      }
    }
    // Both nodes are leaves: cannot continue (line 26).
    cast_rays(r, l, nullptr, &new_tris);
  }

  const Scene& scene_;
  const mesh::PreparedMesh& mesh_;
  Params p_;
  SolveResult& result_;
  BlockerContext ctx_;
  double scale_ = 1.0;
  std::vector<AABB> tri_boxes_;
  std::unique_ptr<TriangleBvh> bvh_;
  std::unique_ptr<PointTree> rtree_, ltree_;
  const Light* light_ = nullptr;
  size_t light_offset_ = 0;
  const raycast::EmbreeScene* embree_ = nullptr;
  Workspace ws_;
  double times_[kTimerCount] = {};  // in ticks()
  Clock::time_point clock0_ = Clock::now();
  uint64_t tick0_ = ticks();
  double n_blocked_shaft_ = 0, n_empty_ = 0, n_rays_ = 0, n_rays_blocked_ = 0, n_shafts_ = 0, n_blocking_tests_ = 0;
  double n_removed_ = 0, n_postponed_ = 0, n_combined_ = 0, n_fallback_ = 0, n_unchanged_ = 0, n_dropped_ = 0;
  double n_kept_beyond_ = 0;
  double n_leaf_surfaces_ = 0, n_leaf_ghosts_ = 0, n_leaf_node_tris_ = 0, n_probe_blocked_ = 0;
  double n_auto_shafts_ = 0, n_auto_relations_ = 0;
  std::array<AutoRayBucket, 64> auto_buckets_{};
  std::vector<uint32_t> wide_[3];
  std::vector<float> wide_extent_[3], cross_;
  bool wide_truncated_ = false;
  std::vector<uint32_t> probe_tris_;
  std::vector<Surface> probe_out_, temp_;
  std::vector<std::vector<Surface>> surface_lists_;
  std::vector<std::vector<AABBd>> ghost_lists_;
  size_t live_bytes_ = 0, peak_bytes_ = 0, light_tree_bytes_peak_ = 0;
  MemoryBudget* budget_ = nullptr;
};

}  // namespace

void set_validate_all(bool on) { g_validate = on; }
bool validate_all() { return g_validate; }

std::vector<OptionSpec> IssSolver::options() const {
  return {
      {"leaf_receivers", "maximum receiver points in a receiver-tree leaf (default 16)", {}},
      {"leaf_samples", "maximum light samples in a light-tree leaf (default 256)", {}},
      {"ray_caster", "leaf relations by Embree rays or the custom shaft ray caster of section 4.10", {"embree", "custom"}},
      {"postpone", "postpone surface refinement by the vertex-centre heuristic of section 4.7.9", {"on", "off"}},
      {"auto_rays", "cast a shaft's relations directly once subdividing shafts of its size stops paying (Embree caster)", {"on", "off"}},
  };
}

SolveResult IssSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  const IeeeFloatMode ieee;  // the caller may be a TBB worker with FTZ/DAZ on (lib/geom/float_mode.h)
  Params p;
  p.leaf_receivers = int(std::max(1L, opt.get_int("leaf_receivers", p.leaf_receivers)));
  p.leaf_samples = int(std::max(1L, opt.get_int("leaf_samples", p.leaf_samples)));
  p.custom_rays = opt.get("ray_caster", "embree") == "custom";
  p.postpone = opt.get_bool("postpone", true);
  p.auto_rays = opt.get_bool("auto_rays", true);

  auto tp0 = Clock::now();
  mesh::PreparedMesh m = mesh::prepare_mesh(scene.mesh);
  size_t paired = pair_nonmanifold_edges(m);  // radial_pairing.h: part of preparation
  auto t0 = Clock::now();
  SolveResult result = make_empty_result(scene);
  // The Embree scene (robust flags) is needed for leaf rays, and by the custom caster
  // only as a fallback next to removed surfaces.
  double embree_build = 0;
  auto tb = Clock::now();
  raycast::EmbreeScene es(scene.mesh, true);
  embree_build = std::chrono::duration<double>(Clock::now() - tb).count();
  MemoryBudget budget("iss", opt.memory_budget_mb);  // outlives the traversal
  Traversal tr(scene, m, p, result);
  tr.set_embree(&es);
  tr.set_memory_budget(&budget);
  for (size_t l = 0; l < scene.lights.size(); ++l) tr.run_light(l);
  auto t1 = Clock::now();
  // Exact: integer counts far below 2^53.
  VG_CHECK(tr.decided_relations() == double(scene.relation_count()));
  tr.finish_stats(result.stats);  // before the fractions: the breakdown covers the traversal
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(t1 - t0).count();
  result.stats.set("prepare_seconds", std::chrono::duration<double>(t0 - tp0).count());
  result.stats.set("time_embree_build", embree_build);
  result.stats.set("embree_rejected_hits", double(es.rejected_hits()));
  result.stats.set("embree_unverified_hits", double(es.unverified_hits()));
  result.stats.set("nonmanifold_edges_paired", double(paired));
  result.stats.set("leaf_receivers", p.leaf_receivers);
  result.stats.set("leaf_samples", p.leaf_samples);
  return result;
}

}  // namespace visgate::iss
