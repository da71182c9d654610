// The ISS traversal (paper 000 sections 4.8 and 4.9, Figures 4.32 and 4.33): setup per
// scene and per light, PRE-TRAVERSE, SHAFT-TRAVERSE with CHOOSE-SPLIT and automatic rays,
// and the statistics of Table 5.4. See traversal.h for where the other steps live.
#include "lib/iss/traversal.h"

#include <algorithm>
#include <cmath>
#include <new>

namespace visgate::iss {

#ifdef NDEBUG
bool g_validate = false;
#else
bool g_validate = true;
#endif

namespace {

const char* const kTimerNames[kTimerCount] = {
    "time_tree_construction", "time_shaft_geometry", "time_triangle_surface", "time_copying_surfaces",
    "time_classifying_edges", "time_updating_facings", "time_merging_patches", "time_simplifying_patches",
    "time_splitting_surfaces", "time_combining_surfaces", "time_computing_loose_edges",
    "time_computing_surface_aabbs", "time_blocking_tests", "time_ray_casting", "time_probe", "time_lazy_band"};

}  // namespace

Traversal::Traversal(const Scene& scene, const mesh::PreparedMesh& m, const Params& p, SolveResult& result)
    : scene_(scene), mesh_(m), p_(p), result_(result) {
  AABB b = scene.bounds();
  double s = 0;
  for (int k = 0; k < 3; ++k) s = std::max({s, std::abs(double(b.lo[k])), std::abs(double(b.hi[k]))});
  scale_ = std::max(s, 1e-30);
  // Scenes beyond Embree's domain keep the caster whose fallback covers them.
  direct_ok_ = scale_ <= double(raycast::kEmbreeCoordinateBound);
  ctx_.mesh = &mesh_;
  ctx_.scale = scale_;
  if (p.rays_only) return;  // every light by cast_light: no hierarchy, no trees
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
  // Probe candidates (see probe_blocked): per main axis, on first use (probe_order).
  wide_truncated_ = probe_keep() < m.triangles.size();
}

// The probe never takes more than max(64, triangles / 16) candidates, so only that many
// plus one are kept: a full prefix then says "more than the cap".
size_t Traversal::probe_keep() const {
  return std::min(mesh_.triangles.size(), std::max<size_t>(64, mesh_.triangles.size() / 16) + 1);
}

// The triangles ordered by their smaller box extent across `a`, largest first (ties by
// index), the first probe_keep() of them. Built when a probe first needs the axis (the
// root shafts of a scene usually share one main axis): three sorts of the whole mesh
// in the constructor were half its cost on rooms.
void Traversal::probe_order(int a) {
  if (wide_done_[a]) return;
  wide_done_[a] = true;
  const size_t keep = probe_keep();
  std::vector<uint32_t>& w = wide_[a];
  w.resize(mesh_.triangles.size());
  for (uint32_t t2 = 0; t2 < w.size(); ++t2) w[t2] = t2;
  std::vector<float> cross(mesh_.triangles.size());
  for (size_t t2 = 0; t2 < w.size(); ++t2) {
    Vec3f e = tri_boxes_[t2].extent();
    cross[t2] = std::min(e[(a + 1) % 3], e[(a + 2) % 3]);
  }
  auto wider = [&](uint32_t x, uint32_t y) { return cross[x] != cross[y] ? cross[x] > cross[y] : x < y; };
  std::nth_element(w.begin(), w.begin() + long(keep) - (keep > 0), w.end(), wider);
  w.resize(keep);
  std::sort(w.begin(), w.end(), wider);
  wide_extent_[a].resize(w.size());
  for (size_t k = 0; k < w.size(); ++k) wide_extent_[a][k] = cross[w[k]];
}

void Traversal::run_light(size_t li) {
  if (scene_.receivers.empty()) return;
  if (p_.rays_only || (li < p_.dense_light.size() && p_.dense_light[li])) {
    cast_light(li);
    return;
  }
  light_ = &scene_.lights[li];
  light_offset_ = scene_.light_offset(li);
  auto_buckets_ = {};
  split_buckets_ = {};
  light_work_ = 0;
  trial_ = {};
  in_trial_ = false;
  cell_cache_ok_ = false;
  light_mode_ = p_.light_split_always ? LightMode::Split : p_.light_split_auto ? LightMode::Trial : LightMode::Whole;
  split_now_ = light_mode_ == LightMode::Split;
  const int tree_leaf = p_.light_split_auto || p_.light_split_always ? std::min(p_.leaf_samples, p_.split_samples) : p_.leaf_samples;
  {
    ScopedTimer t(times_[kTree]);
    std::vector<AABB> boxes(light_->jitter_boxes);
    std::vector<Vec3f> centers;
    for (const AABB& b : boxes) centers.push_back(b.center());
    std::vector<uint32_t> cand;
    bvh_->query_box(PointTree::bounds_of(boxes), cand);
    ltree_ = std::make_unique<PointTree>(std::move(boxes), std::move(centers), tree_leaf, mesh_, tri_boxes_,
                                         &cand, p_.leaf_samples);
    group_boxes_.clear();
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
  // Once the clusters are built an initial shaft at the roots walks the hierarchy
  // itself (construct_clustered_surface) and the array is not read: it is needed only
  // when the root boxes overlap (PRE-TRAVERSE narrows it down to the initial shafts).
  // Kept across lights (root_tris_): a fresh array per light grew by doubling into
  // fresh heap pages every light.
  // Before any initial shaft is built (so the cost rule cannot cast this one), an
  // initial shaft at the roots decides the clusters by the array's size alone
  // (construct_initial_shaft's rule): counted, not collected and sorted.
  std::vector<uint32_t>& tris = root_tris_;
  tris.clear();
  const bool at_roots = !rn(r0).box.overlaps(ln(l0).box) && choose_main_axis(rn(r0).box, ln(l0).box).axis >= 0;
  if (at_roots && p_.clusters && !clusters_ && initial_bucket_.subdivided == 0) {
    ScopedTimer t(times_[kTriangleSurface]);
    const size_t need = cluster_threshold();
    maybe_build_clusters(bvh_->count_shaft(ShaftGeometry(rn(r0).box, ln(l0).box, MainAxis{}, scale_), need));
  }
  if (!clusters_ || !at_roots) {
    ScopedTimer t(times_[kTriangleSurface]);
    bvh_->query_shaft(ShaftGeometry(rn(r0).box, ln(l0).box, MainAxis{}, scale_), tris);
  }
  pre_traverse(r0, l0, tris, false);
  flush_all_rays();
  if (light_mode_ == LightMode::Split) n_split_lights_ += 1;
  light_tree_bytes_peak_ = std::max(light_tree_bytes_peak_, ltree_->memory_bytes());
  ltree_.reset();
}

void Traversal::finish_stats(Stats& st) const {
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
  st.set("direct_ray_relations", n_direct_);
  st.set("direct_rays_uncertified", n_direct_uncertain_);
  st.set("cell_shafts", n_cells_);
  st.set("cell_shaft_relations", n_cell_decided_);
  st.set("cell_patch_relations", n_cell_patch_decided_);
  st.set("cell_backface_relations", n_cull_decided_);
  st.set("cell_surface_relations", n_surface_cull_decided_);
  st.set("cell_group_relations", n_group_decided_);
  st.set("cell_cache_relations", n_cell_cache_decided_);
  st.set("lights_split", n_split_lights_);
  st.set("cluster_patches", n_cluster_patches_);
  st.set("band_triangles_extracted", n_band_extracted_);
  st.set("band_triangles_built", n_band_built_);
  st.set("band_triangles_dropped", n_band_dropped_);
  st.set("band_triangles_kept", n_band_kept_);
  st.set("shaft_work", n_shaft_work_);
  st.set("cost_ray_shafts", n_cost_ray_shafts_);
  st.set("cost_ray_initial_shafts", n_cost_ray_initial_);
  st.set("dense_ray_lights", n_dense_lights_);
  st.set("light_split_trial_shafts", n_trial_shafts_);
  double peak = double(peak_bytes_ + (rtree_ ? rtree_->memory_bytes() : 0) + light_tree_bytes_peak_ +
                       (bvh_ ? bvh_->memory_bytes() : 0) +
                       (clusters_ ? clusters_->memory_bytes() : 0) + tri_pos_.capacity() * sizeof(uint32_t) +
                       tri_planes_.capacity() * sizeof(ConservativePlane) + tri_plane_ok_.capacity());
  st.set("peak_memory_mb", peak / (1024.0 * 1024.0));
  st.set("receiver_tree_nodes", rtree_ ? double(rtree_->node_count()) : 0.0);
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

// ---- section 4.9: traversal ------------------------------------------------------------
// CHOOSE-SPLIT (section 4.9): the strategy whose two sub-shafts bring the combined
// vertex centre closer to their boundaries on average. The four candidate geometries
// are built in `cand` (receiver split left, right, light split left, right; none when
// choose_split returns before building them), so that the two of the chosen split are
// not built again for the sub-shafts: they were a third of all shaft constructions.
SplitMode Traversal::choose_split(const Shaft& sh, SplitGeometries& cand) {
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
    new (&cand.g[0]) ShaftGeometry(rn(R.left).box, L.box, ax, scale_);
    new (&cand.g[1]) ShaftGeometry(rn(R.right).box, L.box, ax, scale_);
    new (&cand.g[2]) ShaftGeometry(R.box, ln(L.left).box, ax, scale_);
    new (&cand.g[3]) ShaftGeometry(R.box, ln(L.right).box, ax, scale_);
    cand.built = true;
  }
  double dr = 0.5 * (cand.g[0].boundary_distance(c) + cand.g[1].boundary_distance(c));
  double dl = 0.5 * (cand.g[2].boundary_distance(c) + cand.g[3].boundary_distance(c));
  return dr <= dl ? SplitMode::Receiver : SplitMode::Light;
}

// SHAFT-TRAVERSE (Figure 4.33).
void Traversal::shaft_traverse(Shaft& sh) {
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
  // Not for a shaft too thin to clip into (shaft_too_thin, blockers.h): clipping the
  // blockers to such a slab can lose them all.
  // A band triangle left in the shaft (Shaft::band) may meet it: never empty then.
  if (sh.surfaces.empty() && sh.band.empty() && !L.had_triangles && !shaft_too_thin(sh.g) &&
      (!R.had_triangles || node_triangles_face_away(sh.r, L.box))) {
    record_visible(sh.r, sh.l);
    return;
  }
  // LightSplit trial (traversal.h): this shaft's subtree one way or the other, its cost
  // counted; once both ways have kSplitTrialShafts the light keeps the cheaper one.
  if (light_mode_ == LightMode::Trial && !in_trial_ && !L.is_leaf && L.size() <= uint32_t(p_.leaf_samples) &&
      R.size() <= uint32_t(p_.split_receivers)) {
    const int way = trial_.shafts[0] >= kSplitTrialEarly && trial_.shafts[1] < trial_.shafts[0] ? 1 : 0;
    const double shafts0 = n_shafts_, rays0 = leaf_relations();
    in_trial_ = true;
    split_now_ = way == 1;
    shaft_subdivide(sh);
    in_trial_ = false;
    split_now_ = false;
    n_trial_shafts_ += 1;
    trial_.shafts[way] += 1;
    trial_.relations[way] += double(R.size()) * double(L.size());
    trial_.cost[way] += (n_shafts_ - shafts0) * kShaftRayCost + (leaf_relations() - rays0);
    // Cost per relation of each way, cross-multiplied; decided early when one way costs
    // less than half the other after kSplitTrialEarly shafts each (the trial's own cost
    // was 8% of rooms' traversal instructions with all 2 x 8 shafts on every light).
    const double c_split = trial_.cost[1] * trial_.relations[0], c_whole = trial_.cost[0] * trial_.relations[1];
    const bool early = trial_.shafts[1] >= kSplitTrialEarly && (2 * c_split < c_whole || 2 * c_whole < c_split);
    // Whole-light shafts that already decide (cost under kWholeDecides rays per relation)
    // keep the light whole without trying light splits: then the trial costs nothing.
    const bool whole_decides =
        trial_.shafts[0] == kSplitTrialEarly && trial_.shafts[1] == 0 && trial_.cost[0] < kWholeDecides * trial_.relations[0];
    if (whole_decides) {
      light_mode_ = LightMode::Whole;
    } else if (early || trial_.shafts[1] >= kSplitTrialShafts) {
      const bool split = c_split < c_whole;
      light_mode_ = split ? LightMode::Split : LightMode::Whole;
      split_now_ = split;
    }
    return;
  }
  shaft_subdivide(sh);
}

void Traversal::shaft_subdivide(Shaft& sh) {
  TreeNode& R = rn(sh.r);
  TreeNode& L = ln(sh.l);
  // Lines 5-8.
  if (receiver_leaf(R) && light_leaf(L)) {
    double n = double(R.size()) * double(L.size());
    if (!sh.surfaces.empty() || !sh.band.empty()) n_leaf_surfaces_ += n;
    else if (!sh.ghosts.empty()) n_leaf_ghosts_ += n;
    else n_leaf_node_tris_ += n;
    cast_rays(sh.r, sh.l, &sh, nullptr);
    return;
  }
  // Automatic ray casting (Params): this shaft's relations by leaf rays when
  // subdividing shafts of its size has not paid in this light.
  const int bucket = std::min(63, std::ilogb(std::max(1.0, double(R.size()) * double(L.size()))));
  AutoRayBucket& ab = (split_now_ ? split_buckets_ : auto_buckets_)[size_t(bucket)];
  const double threshold = split_now_ ? p_.split_auto_ray_relations : p_.auto_ray_relations;
  // And by cost (Params::cost_rays): the shafts built below subdivided shafts of this
  // size went through more blocker elements than cost_factor * work_per_ray per relation
  // they decided, so subdividing costs more than casting saves. That happens where a dense
  // mesh leaves most receivers in penumbra (the real meshes' scenes, where a shaft holds
  // thousands of band entries); it is judged after one subdivided shaft of the size, so
  // that the largest shafts, of which a light has one or two, are judged too. Counts,
  // not times: the same choice on every run.
  const bool not_paying = ab.subdivided >= kAutoRayMinShafts && ab.decided_below < threshold * ab.shafts_below;
  const bool too_costly =
      cost_rays() && ab.subdivided >= 1 && ab.work_below > p_.cost_factor * p_.work_per_ray * ab.decided_below;
  if (p_.auto_rays && !p_.custom_rays && (not_paying || too_costly) && ++ab.skipped % kAutoRayExplore != 0) {
    n_cost_ray_shafts_ += !not_paying;
    n_auto_shafts_ += 1;
    n_auto_relations_ += double(R.size()) * double(L.size());
    cast_rays(sh.r, sh.l, &sh, nullptr);
    return;
  }
  const double shafts0 = n_shafts_, decided0 = shaft_decided(), work0 = light_work_;
  SplitMode mode;
  SplitGeometries cand;
  if (receiver_leaf(R)) mode = SplitMode::Light;
  else if (light_leaf(L)) mode = SplitMode::Receiver;
  else mode = choose_split(sh, cand);
  if (mode == SplitMode::Receiver) {
    { ScopedTimer t(times_[kTree]); rtree_->split(sh.r); }
    if (!rn(sh.r).split_done()) {  // could not be split after all (identical points)
      if (light_leaf(ln(sh.l))) { cast_rays(sh.r, sh.l, &sh, nullptr); return; }
      mode = SplitMode::Light;
    }
  }
  if (mode == SplitMode::Light) {
    { ScopedTimer t(times_[kTree]); ltree_->split(sh.l); }
    if (!ln(sh.l).split_done()) {
      if (receiver_leaf(rn(sh.r)) || !(rtree_->split(sh.r), rn(sh.r).split_done())) {
        cast_rays(sh.r, sh.l, &sh, nullptr);
        return;
      }
      mode = SplitMode::Receiver;
    }
  }
  // The direct test's candidate lists (leaf_rays.cpp) below this shaft filter from its.
  if (cand_depth_ == cand_stack_.size()) cand_stack_.emplace_back();
  cand_stack_[cand_depth_].g = &sh.g;
  cand_stack_[cand_depth_].ready = false;
  ++cand_depth_;
  for (int side = 0; side < 2; ++side) {
    int r = sh.r, l = sh.l, split;
    if (mode == SplitMode::Receiver) split = r = side == 0 ? rn(sh.r).left : rn(sh.r).right;
    else split = l = side == 0 ? ln(sh.l).left : ln(sh.l).right;
    const TreeNode& sn = mode == SplitMode::Receiver ? rn(split) : ln(split);
    const ShaftGeometry* made = cand.get(size_t((mode == SplitMode::Receiver ? 0 : 2) + side));
    Shaft sub = construct_sub_shaft(r, l, sn, sh, side == 1, made);
    shaft_traverse(sub);
    release(sub);
  }
  --cand_depth_;
  ab.subdivided += 1;  // auto_buckets_ is a fixed array: `ab` outlives the recursion
  ab.shafts_below += n_shafts_ - shafts0;
  ab.decided_below += shaft_decided() - decided0;
  ab.work_below += light_work_ - work0;
}

// Lines 20-25 of Figure 4.32: splits the receiver or light node and pre-traverses the
// two children; false when the node could not be split (identical points).
bool Traversal::pre_traverse_children(SplitMode mode, int r, int l, const std::vector<uint32_t>& tris) {
  PointTree& tree = mode == SplitMode::Receiver ? *rtree_ : *ltree_;
  const int n = mode == SplitMode::Receiver ? r : l;
  { ScopedTimer t(times_[kTree]); tree.split(n); }
  if (!tree.node(n).split_done()) return false;
  const int a = tree.node(n).left, b = tree.node(n).right;
  if (mode == SplitMode::Receiver) {
    pre_traverse(a, l, tris);
    pre_traverse(b, l, tris);
  } else {
    pre_traverse(r, a, tris);
    pre_traverse(r, b, tris);
  }
  return true;
}

// PRE-TRAVERSE (Figure 4.32).
// `probe`: run the blocker probe before an initial shaft (false when the caller did).
void Traversal::pre_traverse(int r, int l, const std::vector<uint32_t>& tris, bool probe) {
  TreeNode& R = rn(r);
  TreeNode& L = ln(l);
  if (!R.box.overlaps(L.box)) {
    MainAxis ax = choose_main_axis(R.box, L.box);
    if (ax.axis >= 0) {
      if (probe && probe_blocked(r, l, ax, tris.size())) {
        record_blocked(r, l);
        return;
      }
      if (initial_shaft_by_rays(r, l)) return;
      const double work0 = light_work_, decided0 = shaft_decided();
      Shaft sh = construct_initial_shaft(r, l, ax, tris);
      shaft_traverse(sh);
      release(sh);
      initial_bucket_.subdivided += 1;
      initial_bucket_.work_below += light_work_ - work0;
      initial_bucket_.decided_below += shaft_decided() - decided0;
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
  // Split the node with the larger box (a light leaf: the receiver node), else the
  // light node, else the receiver node.
  double rd = R.box.diagonal(), ld = L.box.diagonal();
  if (!receiver_leaf(R) && (rd > ld || light_leaf(L)) && pre_traverse_children(SplitMode::Receiver, r, l, new_tris))
    return;
  if (!light_leaf(ln(l)) && pre_traverse_children(SplitMode::Light, r, l, new_tris)) return;
  if (!receiver_leaf(rn(r)) && pre_traverse_children(SplitMode::Receiver, r, l, new_tris)) return;
  // Both nodes are leaves: cannot continue (line 26).
  cast_rays(r, l, nullptr, &new_tris);
}

}  // namespace visgate::iss
