// `plucker-bsp`: paper 002 Algorithm 2 around the lazy BSP; see plucker_solver.h. This
// file runs the framework (section 4.4): lights in turn, groups of receivers in parallel,
// and per group and light the three phases Figure 8 times (group_state.h).
#include "lib/plucker/plucker_solver.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <mutex>

#include "lib/geom/float_mode.h"
#include "lib/geom/morton.h"
#include "lib/plucker/group_state.h"
#include "lib/scene/rng.h"

namespace visgate::plucker {

void Totals::merge(const Totals& o) {
  select_s += o.select_s; init_s += o.init_s; query_s += o.query_s; bsp_query_s += o.bsp_query_s; tree_s += o.tree_s;
  irradiance += o.irradiance;
  trees += o.trees; queries += o.queries; occluders += o.occluders; near += o.near;
  fragments += o.fragments; fallback += o.fallback; segment_relations += o.segment_relations;
  closed_dropped += o.closed_dropped;
  interior += o.interior;
  near_splits += o.near_splits;
  interior_covered += o.interior_covered;
  interior_skipped += o.interior_skipped;
  near_merged += o.near_merged;
  closed_near += o.closed_near;
  exact_triangles += o.exact_triangles;
  far_triangles += o.far_triangles;
  band_triangles += o.band_triangles;
  rounded_triangles += o.rounded_triangles;
  close_triangles += o.close_triangles;
  level_triangles += o.level_triangles;
  plane_point_triangles += o.plane_point_triangles;
  patches += o.patches;
  patch_triangles += o.patch_triangles;
  exact_receivers += o.exact_receivers;
  undecided_receivers += o.undecided_receivers;
  unreported_slivers += o.unreported_slivers;
  bsp_nodes_max = std::max(bsp_nodes_max, o.bsp_nodes_max);
  bsp.nodes_created += o.bsp.nodes_created; bsp.developments += o.bsp.developments;
  bsp.insert_tests += o.bsp.insert_tests; bsp.splits += o.bsp.splits;
  bsp.occlusion_tests += o.bsp.occlusion_tests; bsp.lazy_visible += o.bsp.lazy_visible;
  bsp.on_line += o.bsp.on_line; bsp.zero_area += o.bsp.zero_area; bsp.merged += o.bsp.merged; bsp.visits += o.bsp.visits;
  bsp.list_compactions += o.bsp.list_compactions;
  sil.groups += o.sil.groups; sil.declined += o.sil.declined; sil.edges += o.sil.edges; sil.receiver_edges += o.sil.receiver_edges;
  sil.pieces += o.sil.pieces; sil.blocked += o.sil.blocked; sil.undecided += o.sil.undecided; sil.dropped += o.sil.dropped; sil.listed += o.sil.listed;
}

void GroupState::clear() {
  for (auto* v : {&rloc, &near_verts, &poly0, &lower, &upper, &region, &pyramid, &pyramid_err, &cur, &pos, &neg, &q,
                  &patch})
    v->clear();
  for (const NearPoly& np : near)
    if (np.triangle < near_of_tri.size()) near_of_tri[np.triangle] = -1;
  near.clear();
  near_sorted.clear();
  near_key.clear();
  near_blocks.clear();
  near_spatial.clear();
  near_pick_bits.clear();
  occluders.clear();
  interior.clear();
  closed_keep.clear();
  region_drop.clear();
  sil.surfaces.clear();
  cand_skipped.clear();
  cover_n.clear();
  cover_err.clear();
  cover_at.clear();
  rloc_exact = false;
  for (auto* v : {&on_plane0, &on_level, &skip, &merged}) v->clear();
  vals.clear();
  for (auto* v : {&exact_tris, &cand, &cand_all, &exact_done, &patch_at}) v->clear();
  sample_grid.clear();
  frags.clear();
  tmp.clear();
  boxes.clear();
  tmp_boxes.clear();
}

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Algorithm 2 for one group of receivers (all strictly on the side `sigma` of the light
// plane) and one light: the three phases of Figure 8, timed as it times them, with the
// tree's memory metered and, without coherence, the tree reset between queries (the
// paper's modified version, section 5.1; the reset is excluded from the timings).
void shade_group(const SolveContext& ctx, size_t li, const LocalLight& lf, const std::vector<uint32_t>& group,
                 float sigma, uint64_t tree_seed, ThreadWork& work, Totals& tot) {
  GroupState& gs = work.state;
  gs.start(ctx, li, lf, group, sigma);

  Clock::time_point t0 = Clock::now();
  select_occluders(gs, tot);
  tot.select_s += seconds_since(t0);

  t0 = Clock::now();
  LazyBsp& bsp = init_group_tree(gs, work, tree_seed, tot);
  tot.init_s += seconds_since(t0);
  auto live_bytes = [&]() {
    return int64_t(bsp.memory_bytes() + gs.near_verts.capacity() * sizeof(Vec3d) + gs.near.capacity() * sizeof(NearPoly) +
                   gs.near_blocks.capacity() * sizeof(GroupState::NearBlock) +
                   (gs.near_spatial.capacity() + gs.near_done.capacity()) * sizeof(uint32_t) +
                   gs.near_pick_bits.capacity() * sizeof(uint64_t) +
                   gs.near_of_tri.capacity() * sizeof(int32_t));
  };
  int64_t reported = live_bytes();
  ctx.memory->change(reported);

  // Every receiver of the group, in grid order.
  BspCounters near_counters;
  for (size_t gk = 0; gk < group.size(); ++gk) {
    Clock::time_point tq = Clock::now();
    shade_receiver(gs, bsp, gk, near_counters, tot);
    ++tot.queries;
    tot.query_s += seconds_since(tq);
    int64_t now = live_bytes();
    ctx.memory->change(now - reported);
    reported = now;
    if (!ctx.coherence) bsp.reset();
  }
  ctx.memory->change(-reported);
  tot.bsp_nodes_max = std::max<uint64_t>(tot.bsp_nodes_max, bsp.node_count());
  const BspCounters& c = bsp.counters();
  tot.bsp.nodes_created += c.nodes_created;
  tot.bsp.developments += c.developments;
  tot.bsp.insert_tests += c.insert_tests;
  tot.bsp.occlusion_tests += c.occlusion_tests;
  tot.bsp.lazy_visible += c.lazy_visible;
  tot.bsp.merged += c.merged;
  tot.bsp.visits += c.visits;
  tot.bsp.list_compactions += c.list_compactions;
  tot.bsp.splits += c.splits + near_counters.splits;
  tot.near_splits += near_counters.splits;
  tot.bsp.on_line += c.on_line + near_counters.on_line;
  tot.bsp.zero_area += c.zero_area + near_counters.zero_area;
}

// The side of the light plane a receiver p lies on: +1 the emitting side, -1 the other,
// 0 on the plane. Decided in float against the plane's rounding bound; undecided there:
// exactly, for an exactly planar light (test ReceiverAtAGrazingAngle), else against the
// region oracle's exact plane of the light (Newell normal through the exact centroid;
// test ReceiverBelowALongLightUndecidedInFloat). Only a receiver exactly on that plane,
// where the oracle defines no region, gets 0 (and falls back).
int light_side(const LocalLight& lf, const Vec3f& p) {
  Vec3f d = to_local(p, lf.origin) - lf.p0;
  float h = dot(lf.n, d);
  float tol = lf.plane_tol + kDotErr * norm1(lf.n) * norm1(d);
  int sd = h > tol ? 1 : (h < -tol ? -1 : 0);
  if (sd == 0) {
    const auto& v = lf.light->polygon;
    sd = lf.planar ? lf.emit_sign * to_int(orient3d_exact(v[0], v[size_t(lf.p1)], v[size_t(lf.p2)], p))
                   : newell_side_exact(v.data(), int(v.size()), p);
  }
  return sd;
}

}  // namespace

std::vector<std::vector<uint32_t>> receiver_groups(const Scene& scene, int tile) {
  tile = std::max(1, tile);
  std::vector<std::vector<uint32_t>> groups;
  size_t n = scene.receivers.size();
  if (scene.grid && size_t(scene.grid->nu) * size_t(scene.grid->nv) == n) {
    // Tiles of the receiver grid, row-major inside each tile (scanline order).
    int nu = scene.grid->nu, nv = scene.grid->nv;
    for (int tb = 0; tb < nv; tb += tile)
      for (int ta = 0; ta < nu; ta += tile) {
        std::vector<uint32_t> g;
        for (int b = tb; b < std::min(nv, tb + tile); ++b)
          for (int a = ta; a < std::min(nu, ta + tile); ++a) g.push_back(uint32_t(size_t(b) * size_t(nu) + size_t(a)));
        groups.push_back(std::move(g));
      }
    return groups;
  }
  // Spatial clustering: Morton order of the receivers, runs of tile^2.
  AABB box;
  for (const auto& r : scene.receivers) box.extend(r.p);
  Vec3d lo = to_double(box.lo), ext = to_double(box.hi) - lo;
  std::vector<std::pair<uint64_t, uint32_t>> keys(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3d p = to_double(scene.receivers[i].p) - lo;
    uint32_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = ext[a] > 0 ? uint32_t(std::min(1023.0, std::max(0.0, p[a] / ext[a] * 1023.0))) : 0u;
    const uint32_t code = morton_spread10(c[0]) | (morton_spread10(c[1]) << 1) | (morton_spread10(c[2]) << 2);
    keys[i] = {uint64_t(code), uint32_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  size_t run = size_t(tile) * size_t(tile);
  for (size_t k = 0; k < n; k += run) {
    std::vector<uint32_t> g;
    for (size_t m = k; m < std::min(n, k + run); ++m) g.push_back(keys[m].second);
    groups.push_back(std::move(g));
  }
  return groups;
}

int default_tile(const Scene& scene, const ClosedSurfaces* cs, const InteriorOccluders* io) {
  if (!cs || !io || scene.lights.empty() || scene.mesh.size() == 0) return kDefaultTile;
  // The triangles of closed surfaces with at least one interior polygon.
  std::vector<size_t> polys(cs->count(), 0), tris(cs->count(), 0);
  for (const InteriorOccluders::Entry& e : io->entries()) ++polys[size_t(e.surface)];
  for (uint32_t t = 0; t < scene.mesh.size(); ++t)
    if (const int32_t sf = cs->surface(t); sf >= 0) ++tris[size_t(sf)];
  size_t covered = 0;
  for (size_t sf = 0; sf < cs->count(); ++sf)
    if (polys[sf] > 0) covered += tris[sf];
  return 2 * covered >= scene.mesh.size() ? kConvexSolidTile : kDefaultTile;
}

SolveResult solve_plucker(const Scene& scene, const SolveOptions& opt, std::vector<double>* irradiance) {
  ThreadLimit limit(opt.threads);
  Clock::time_point start = Clock::now();
  SolveResult result = make_empty_result(scene);
  for (auto& rr : result.receivers) rr.fragments.assign(scene.lights.size(), {});
  if (irradiance) irradiance->assign(scene.receivers.size() * scene.lights.size(), 0.0);
  bool coherence = opt.get_bool("coherence", true);
  int tile = int(opt.get_int("tile", 0));  // 0: default_tile below
  LazyBsp::Choice choice = opt.get("choice", "relevant") == "random" ? LazyBsp::Choice::Random : LazyBsp::Choice::Relevant;
  MemoryMeter memory;
  MemoryBudget budget("plucker-bsp", opt.memory_budget_mb);  // outlives the trees in thread_work
  memory.budget = &budget;
  // The triangle hierarchy for occluder selection, built once (counted as selection).
  Clock::time_point tt = Clock::now();
  // The tree's patches and the closed surfaces; freed once they are built, so the later
  // builds reuse its memory instead of faulting in fresh pages.
  mesh::PreparedMesh prepared = mesh::prepare_mesh(scene.mesh);
  TriangleTree tree(scene.mesh, prepared);
  double tree_s = seconds_since(tt);
  memory.change(int64_t(tree.memory_bytes()));
  SolveContext ctx{&scene, &result, irradiance, coherence, choice, &tree, opt.seed, &memory};
  // Closed surfaces (closed_surfaces.h), found once per solve (counted as selection).
  std::optional<ClosedSurfaces> closed;
  MemoryCharge closed_charge;  // counted against the budget like the trees (declared after it)
  if (opt.get_bool("closed", true)) {
    tt = Clock::now();
    closed.emplace(scene.mesh, prepared);
    tree_s += seconds_since(tt);
    memory.change(int64_t(closed->memory_bytes()));
    closed_charge.bind(&budget, "closed surfaces");
    closed_charge.set(closed->memory_bytes());
    if (closed->count() > 0) ctx.closed = &*closed;
  }
  prepared = mesh::PreparedMesh();
  // Per closed surface a hierarchy for the silhouette regions' segment tests, once per solve.
  std::optional<SurfaceTrees> surface_trees;
  std::optional<TreeSurfaces> tree_surfaces;
  MemoryCharge surface_charge;
  const std::string regions = opt.get("silhouette_regions", "auto");
  ctx.silhouette_estimate = regions != "on";
  if (ctx.closed && regions != "off") {
    tt = Clock::now();
    // The triangle tree doubles as the hierarchy of a surface holding every triangle.
    static_assert(TriangleTree::kRule.split == kTriangleHierarchyRule.split &&
                  TriangleTree::kRule.leaf_size == kTriangleHierarchyRule.leaf_size &&
                  TriangleTree::kRule.item_boxes == kTriangleHierarchyRule.item_boxes);
    surface_trees.emplace(scene.mesh, *closed, ctx.silhouette_estimate ? kMinRegionTriangles : 0u, &tree.bvh());
    tree_surfaces.emplace(tree, *closed);
    tree_s += seconds_since(tt);
    memory.change(int64_t(surface_trees->memory_bytes() + tree_surfaces->memory_bytes()));
    surface_charge.bind(&budget, "silhouette regions");
    surface_charge.set(surface_trees->memory_bytes() + tree_surfaces->memory_bytes());
    ctx.surface_trees = &*surface_trees;
    ctx.tree_surfaces = &*tree_surfaces;
  }
  // Interior occluders of the closed surfaces (interior_occluders.h), once per solve, on the
  // surface trees' triangle hierarchies when they exist.
  std::optional<InteriorOccluders> interior;
  MemoryCharge interior_charge;
  if (ctx.closed && opt.get_bool("interior", true)) {
    tt = Clock::now();
    interior.emplace(scene, *closed, size_t(std::max(0L, opt.get_int("interior_extra", long(InteriorOccluders::kDefaultExtra)))),
                     surface_trees ? &*surface_trees : nullptr);
    tree_s += seconds_since(tt);
    memory.change(int64_t(interior->memory_bytes()));
    interior_charge.bind(&budget, "interior occluders");
    interior_charge.set(interior->memory_bytes());
    if (!interior->entries().empty()) ctx.interior = &*interior;
  }
  ctx.cover_nodes = opt.get_bool("cover_nodes", true);
  ctx.near_merge = opt.get_bool("near_merge", true);
  ctx.closed_near = opt.get_bool("closed_near", true);
  if (tile <= 0) tile = default_tile(scene, ctx.closed, ctx.interior);
  auto groups = receiver_groups(scene, tile);
  AABB rbox_all;
  for (const auto& rcv : scene.receivers) rbox_all.extend(rcv.p);
  const Vec3d focus = scene.receivers.empty() ? Vec3d(0, 0, 0) : (to_double(rbox_all.lo) + to_double(rbox_all.hi)) * 0.5;
  Totals totals;
  std::mutex merge_mutex;
  tbb::enumerable_thread_specific<ThreadWork> thread_work;  // freed when the solve returns

  // Multiple lights in turn (Algorithm 2 line 2); groups of one light in parallel.
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    LocalLight lf = make_local_light(scene.lights[li], focus);
    tbb::parallel_for(size_t(0), groups.size(), [&](size_t g) {
      const IeeeFloatMode ieee;  // TBB workers run with FTZ/DAZ once Embree exists (lib/geom/float_mode.h)
      Totals tot;
      // Split the group by the side of the light plane; receivers on it fall back.
      std::vector<uint32_t> side[2];
      for (uint32_t i : groups[g]) {
        const int sd = light_side(lf, scene.receivers[i].p);
        if (sd > 0) side[0].push_back(i);
        else if (sd < 0) side[1].push_back(i);
        else shade_fallback(ctx, li, lf, i, tot);
      }
      for (int s = 0; s < 2; ++s) {
        if (side[s].empty()) continue;
        // One tree per group, light and side; its random stream depends only on them.
        uint64_t seed = splitmix64(opt.seed ^ splitmix64((uint64_t(g) << 1 | uint64_t(s)) ^ splitmix64(li + 0x9E37)));
        shade_group(ctx, li, lf, side[s], s == 0 ? 1.0f : -1.0f, seed, thread_work.local(), tot);
      }
      std::lock_guard<std::mutex> lock(merge_mutex);
      totals.merge(tot);
    });
  }

  totals.select_s += tree_s;
  result.seconds = seconds_since(start);
  Stats& st = result.stats;
  st.set("relations", double(scene.relation_count()));
  st.set("groups", double(groups.size()));
  st.set("trees", double(totals.trees));
  st.set("queries", double(totals.queries));
  st.set("occluders", double(totals.occluders));
  st.set("near_polygons", double(totals.near));
  st.set("fragments", double(totals.fragments));
  st.set("bsp_nodes", double(totals.bsp.nodes_created));
  st.set("bsp_nodes_max", double(totals.bsp_nodes_max));
  st.set("developments", double(totals.bsp.developments));
  st.set("insert_tests", double(totals.bsp.insert_tests));
  st.set("occlusion_tests", double(totals.bsp.occlusion_tests));
  st.set("lazy_visible", double(totals.bsp.lazy_visible));
  st.set("merged_splits", double(totals.bsp.merged));
  st.set("splits", double(totals.bsp.splits));
  st.set("node_visits", double(totals.bsp.visits));
  st.set("bsp_list_compactions", double(totals.bsp.list_compactions));
  st.set("degenerate_on_line", double(totals.bsp.on_line));
  st.set("degenerate_zero_area", double(totals.bsp.zero_area));
  st.set("fallback_receivers", double(totals.fallback));
  st.set("segment_relations", double(totals.segment_relations));
  st.set("exact_triangles", double(totals.exact_triangles));
  st.set("far_triangles", double(totals.far_triangles));
  st.set("band_triangles", double(totals.band_triangles));
  st.set("rounded_triangles", double(totals.rounded_triangles));
  st.set("close_triangles", double(totals.close_triangles));
  st.set("level_triangles", double(totals.level_triangles));
  st.set("plane_point_triangles", double(totals.plane_point_triangles));
  st.set("patches", double(totals.patches));
  st.set("patch_triangles", double(totals.patch_triangles));
  st.set("closed_dropped", double(totals.closed_dropped));
  st.set("interior_occluders", double(totals.interior));
  st.set("near_splits", double(totals.near_splits));
  st.set("interior_covered", double(totals.interior_covered));
  st.set("interior_skipped", double(totals.interior_skipped));
  st.set("near_merged", double(totals.near_merged));
  st.set("closed_near_triangles", double(totals.closed_near));
  st.set("exact_receivers", double(totals.exact_receivers));
  st.set("undecided_receivers", double(totals.undecided_receivers));
  st.set("unreported_slivers", double(totals.unreported_slivers));
  st.set("silhouette_groups", double(totals.sil.groups));
  st.set("silhouette_declined", double(totals.sil.declined));
  st.set("silhouette_edges", double(totals.sil.edges));
  st.set("silhouette_receiver_edges", double(totals.sil.receiver_edges));
  st.set("silhouette_pieces", double(totals.sil.pieces));
  st.set("silhouette_blocked", double(totals.sil.blocked));
  st.set("silhouette_undecided", double(totals.sil.undecided));
  st.set("silhouette_listed", double(totals.sil.listed));
  st.set("peak_memory_bytes", double(memory.peak.load()));
  st.set("peak_memory_kb", double(memory.peak.load()) / 1024.0);
  st.set("occluder_selection_seconds", totals.select_s);
  st.set("tree_init_seconds", totals.init_s);
  st.set("query_seconds", totals.query_s);
  st.set("bsp_query_seconds", totals.bsp_query_s);
  st.set("tree_seconds", totals.tree_s);
  double sum = totals.select_s + totals.init_s + totals.query_s;
  if (sum > 0) {
    st.set("occluder_selection_percent", 100.0 * totals.select_s / sum);
    st.set("tree_init_percent", 100.0 * totals.init_s / sum);
    st.set("query_percent", 100.0 * totals.query_s / sum);
  }
  st.set("irradiance_sum", totals.irradiance);
  st.set("coherence", coherence ? 1.0 : 0.0);
  return result;
}

std::vector<OptionSpec> PluckerSolver::options() const {
  return {{"coherence", "on: queries reuse the tree; off: reset between queries (paper 002 section 5.1)", {"on", "off"}},
          {"tile", "receivers per group side (grid tiles, or tile^2 receivers in Morton order); 0, the default: 16 "
                   "when most triangles are on closed surfaces with interior polygons, else 8",
           {}},
          {"choice", "relevant: develop with an occluder the query sees (bsp.h); random: the paper's random occluder",
           {"relevant", "random"}},
          {"closed", "on: occluder selection keeps of a closed surface only what one crossing side needs "
                     "(closed_surfaces.h); off: every candidate", {"on", "off"}},
          {"interior", "on: convex polygons inside closed surfaces join the trees as occluders that block nothing "
                       "new (interior_occluders.h); off: none", {"on", "off"}},
          {"interior_extra", "further interior polygons per closed surface and light where the first one's "
                             "projection leaves the cross-sections (non-convex solids; interior_occluders.h); 0: one",
           {}},
          {"cover_nodes", "on: occluder selection leaves out whole triangle-tree nodes covered by an interior "
                          "occluder; off: the covered test per candidate only", {"on", "off"}},
          {"near_merge", "on: glued near triangles of a closed surface that a receiver sees as one convex polygon "
                         "are subtracted as that polygon; off: one by one", {"on", "off"}},
          {"closed_near", "on: with interior occluders in the group's tree, the one-sided triangles of closed "
                          "surfaces of at least 1024 triangles are near polygons (per receiver, glued ones merged) "
                          "instead of tree occluders; off: in the tree", {"on", "off"}},
          {"silhouette_regions", "on: a closed surface apart from a group's receivers and wholly before the "
                                 "light's plane is shaded per receiver as one region cut along its silhouette "
                                 "edges (silhouette_region.h); auto: the same where a few receivers of the group "
                                 "see few turning edges near their light; off: triangle by triangle",
           {"auto", "on", "off"}}};
}

SolveResult PluckerSolver::solve_scene(const Scene& scene, const SolveOptions& opt) { return solve_plucker(scene, opt, nullptr); }

}  // namespace visgate::plucker
