// The `iss` Solver (see iss_solver.h for the guarantee): options, mesh preparation and
// the leaf caster's scene around the traversal of traversal.h.
#include "lib/iss/iss_solver.h"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <optional>

#include <sys/resource.h>

#include "lib/base/check.h"
#include "lib/geom/float_mode.h"
#include "lib/iss/radial_pairing.h"
#include "lib/iss/traversal.h"
#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_scene.h"

namespace visgate::iss {

namespace {
// Minor page faults of the process so far: the solve reports its own as a statistic
// (first touches of fresh memory cost microseconds each on a virtual machine).
double minor_faults() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return double(u.ru_minflt);
}
// The leaf rays' BVH quality (option embree_quality). Measured on rooms (26k triangles,
// callgrind): Embree's low (Morton) build takes about 1,850 fewer instructions per
// triangle than medium, and each leaf ray traced in it about 260 more (+34%). A solve
// casts at most one ray per relation, so with at most kLowBuildRelationsPerTriangle
// relations per triangle the low build cannot cost more (the custom caster's fallback
// rays count too: 1.6M of 4.2M relations on columns). Answers do not depend on the
// quality (embree_scene.h).
constexpr double kLowBuildRelationsPerTriangle = 7.0;
// The low build's replacement (Traversal::set_embree_upgrade): after half as many rays
// as triangles, when the rays extrapolate to 9 per triangle. At that point the low build
// (about 550 instructions per triangle) is spent and the medium one costs about 2,150
// per triangle (rooms 1024, callgrind) against 260 more per ray in the low one: the
// remaining 8 rays per triangle pay for it. Worst case (a scene that upgrades): about
// 810 instructions per triangle more than medium from the start.
constexpr double kUpgradeRaysPerTriangle = 9.0;
raycast::BuildQuality leaf_ray_build_quality(const std::string& opt, const Scene& scene, const TriangleSoup& leaf_mesh) {
  if (opt == "low") return raycast::BuildQuality::low;
  if (opt == "medium") return raycast::BuildQuality::medium;
  if (opt == "high") return raycast::BuildQuality::high;
  const bool few_rays = double(scene.relation_count()) <= kLowBuildRelationsPerTriangle * double(leaf_mesh.size());
  return few_rays ? raycast::BuildQuality::low : raycast::BuildQuality::medium;
}

// Lights whose shafts cannot pay (option dense_rays), decided from the scene alone
// before anything is built. A light's initial shaft on a dense mesh holds the band of
// Table 4.1's inconsistent triangles (about a tenth of a smooth closed surface, a
// quarter of the real meshes' under a wide light) and the boundaries of the clusters
// it takes whole, and every shaft below it filters that band again: its cost grows with
// the triangles in the root shaft, while the most it can save is its relations' rays.
// Measured (callgrind, scan 75k, 10 lights of 1024 receivers): at 0.9 relations per
// such triangle (64 samples) the shafts decided 21% of the relations for more than the
// rays of all of them cost (783M instructions against 642M), at 1.75 (128 samples)
// 1,197M against 1,082M, at 3.5 (256 samples) the shafts pay (1,590M against 1,888M);
// the real meshes (0.7-1.3) and scan 300k (0.2) are below. The crossover lies near 2.5,
// and the rays' packets take less time per instruction than the shafts (scan 75k x 64:
// 0.82 of the instructions, 0.75 of the seconds), so 3. A light whose root shaft (the
// receivers' box to the light's, apart, with a main axis) holds at least the clusters'
// threshold (8,192 triangles and an eighth of the mesh: a dense mesh) with fewer than
// `relations_per_triangle` relations per triangle there casts every relation instead.
// The count is estimated from at most kDenseRaySamples evenly spaced triangles of the
// soup (their boxes against the root shaft, may_intersect_box as the hierarchy's query
// tests them): a cost estimate, deterministic, which changes no guarantee (every
// relation is still a verified leaf ray).
constexpr size_t kDenseRaySamples = 4096;
constexpr size_t kDenseRayMinTriangles = 8192;
constexpr size_t kDenseRayChunk = 512;
std::vector<uint8_t> dense_ray_lights(const Scene& scene, double relations_per_triangle, double scale) {
  std::vector<uint8_t> dense(scene.lights.size(), 0);
  const size_t n = scene.mesh.size();
  if (scene.receivers.empty() || n < kDenseRayMinTriangles || relations_per_triangle <= 0) return dense;
  AABB rbox;
  for (const Receiver& r : scene.receivers) rbox.extend(r.p);
  const size_t step = std::max<size_t>(1, n / kDenseRaySamples);
  const double need = double(std::max(kDenseRayMinTriangles, n / 8));
  // The sampled triangles' boxes, built once for all lights as box arrays, and tested
  // four per vector (direct_cull: may_intersect_box's test and arithmetic); building
  // them per light was most of this estimate's cost (about 5% of rooms' solve at 1024
  // receivers, 27 lights). They are dealt round-robin into chunks of kDenseRayChunk,
  // each an even subsample of the soup, and a light stops at the first chunk after
  // which even every untested box in its shaft could not make it dense: the same
  // answer (the estimate only grows with the hits), at a fraction of the tests on
  // lights far from dense (rooms: a storey of three per root shaft).
  const size_t tested = (n + step - 1) / step;
  const size_t chunks = (tested + kDenseRayChunk - 1) / kDenseRayChunk, cp = kDenseRayChunk;
  std::vector<double> boxes(6 * cp * chunks, 0.0);  // padding lanes: a point box at the origin, never counted
  for (size_t t = 0, k = 0; t < n; t += step, ++k) {
    const auto& tri = scene.mesh.triangles[t];
    AABB tb;
    for (int c = 0; c < 3; ++c) tb.extend(scene.mesh.vertices[tri[c]]);
    const AABBd b = to_double(tb);
    double* chunk = boxes.data() + 6 * cp * (k % chunks);
    const size_t lane = k / chunks;
    for (int a = 0; a < 3; ++a) {
      chunk[size_t(a) * cp + lane] = b.lo[a];
      chunk[size_t(3 + a) * cp + lane] = b.hi[a];
    }
  }
  std::vector<int64_t> keep(cp);
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    const Light& light = scene.lights[li];
    AABB lbox;
    for (const AABB& jb : light.jitter_boxes) lbox.extend(jb);
    if (rbox.overlaps(lbox) || choose_main_axis(rbox, lbox).axis < 0) continue;
    const ShaftGeometry g(rbox, lbox, MainAxis{}, scale);
    const double relations = double(scene.receivers.size()) * double(light.samples);
    auto is_dense = [&](size_t hits) {
      const double in_shaft = double(hits) * double(n) / double(tested);
      return in_shaft >= need && relations < relations_per_triangle * in_shaft;
    };
    size_t hits = 0, done = 0;
    for (size_t c = 0; c < chunks && is_dense(hits + tested - done); ++c) {
      const size_t valid = (tested - c + chunks - 1) / chunks;  // lanes k < tested with k % chunks == c
      std::fill(keep.begin(), keep.end(), int64_t(-1));
      direct_cull(boxes.data() + 6 * cp * c, cp, g, keep.data());
      for (size_t k = 0; k < valid; ++k) hits += keep[k] != 0;
      done += valid;
    }
    dense[li] = done == tested && is_dense(hits);
  }
  return dense;
}

// Lights decided at the roots, before the leaf caster's scene is built: the blocker
// probe of Traversal::probe_blocked (shaft_construction.cpp) on the root shaft, and the
// triangles the other lights' leaf rays can meet. A leaf ray runs from a receiver to a
// point of its light's jitter boxes, so it lies in the convex hull of the two root boxes,
// inside the root shaft (conservative planes, shaft.h); a triangle it meets has a point
// there, so its box meets the shaft and may_intersect_box keeps it. The caster's scene
// over those triangles answers every leaf ray as the whole mesh does (a hit is one
// triangle's test, verified in double; embree_scene.h). On rooms the upper storeys'
// lights are blocked by the floor slab at the root, so the scene holds the ground
// storey: a third of the triangles, and a third of the BVH build.
//
// The probe here is the traversal's with a coarser exclusion: a candidate is left out
// when its box meets a root box (a superset of the nodes' inside lists, tree.h), so
// its surface is built from a subset of the valid blockers, which BLOCKS-SHAFT allows
// (blockers.h). A light it decides is recorded blocked here and not traversed; its
// relations are blocked by the guarantee of BLOCKS-SHAFT.
struct RootPlan {
  std::vector<uint8_t> blocked;  // per light: the root shaft is blocked
  double blocked_relations = 0;
  std::vector<uint8_t> keep;     // per soup triangle: a leaf ray may meet it
  size_t kept = 0;
};

// The probe's candidates are the traversal's (Traversal::probe_order), and so are the
// triangle boxes.
bool root_probe_blocked(const mesh::PreparedMesh& m, Traversal& tr, const AABB& rbox, const AABB& lbox, MainAxis ax,
                        double scale, Workspace& ws, std::vector<Surface>& out) {
  const int a = ax.axis, b = (a + 1) % 3, c = (a + 2) % 3;
  const Vec3f re = rbox.extent(), le = lbox.extent();
  const float thr = std::min(std::min(re[b], le[b]), std::min(re[c], le[c]));
  tr.probe_order(a);
  const std::vector<float>& ext = tr.probe_extents(a);
  const std::vector<AABB>& boxes = tr.triangle_boxes();
  const size_t n =
      size_t(std::lower_bound(ext.begin(), ext.end(), thr, [](float x, float v) { return x >= v; }) - ext.begin());
  const size_t cap = std::max<size_t>(64, m.triangles.size() / 16);
  // Not few: the traversal builds the shaft (a full prefix means more than the cap).
  if (n == 0 || n > cap || (tr.probe_truncated() && n == ext.size())) return false;
  std::vector<uint32_t> cand(tr.probe_triangles(a).begin(), tr.probe_triangles(a).begin() + long(n));
  std::sort(cand.begin(), cand.end());
  TreeNode rn, ln;
  for (uint32_t t : cand) {
    if (boxes[t].overlaps(rbox)) rn.inside.push_back(t);
    if (boxes[t].overlaps(lbox)) ln.inside.push_back(t);
  }
  BlockerContext ctx{&m, scale};
  ShaftGeometry g(rbox, lbox, ax, scale);
  Surface s = construct_triangle_surface(ctx, cand, g, rn, ln, ws);
  if (s.patches.empty()) {
    ws.recycle(std::move(s));
    return false;
  }
  // Lines 14-18 of Figure 4.19 for a new surface, as Traversal::refine.
  classify_edges(s, g);
  update_patch_facings(ctx, s, g);
  merge_patches(s, ws);
  simplify_patches(s, g, ws);
  out.clear();
  split_surface(std::move(s), out, ws);
  bool blocked = false;
  for (Surface& ps : out) {
    compute_bounds(ps, g);
    blocked = blocked || blocks_shaft(ps, g);
    ws.recycle(std::move(ps));
  }
  out.clear();
  return blocked;
}

// The lights decided by plan_roots, in the traversal's statistics (finish_stats): their
// relations are blocked by a shaft.
void add_root_plan_stats(const RootPlan& plan, Stats& st) {
  if (plan.blocked_relations == 0) return;
  const double rel = st.get("relations");
  const double by_shaft = st.get("relations_blocked_by_shaft") + plan.blocked_relations;
  st.set("relations_blocked_by_shaft", by_shaft);
  double lights = 0;
  for (uint8_t b : plan.blocked) lights += b;
  st.set("initial_shafts_blocked_by_probe", st.get("initial_shafts_blocked_by_probe") + lights);
  if (rel <= 0) return;
  st.set("percent_blocked", 100.0 * (by_shaft + st.get("rays_blocked")) / rel);
  st.set("percent_decided_by_shafts", 100.0 * (by_shaft + st.get("relations_visible_by_empty_shaft")) / rel);
}

// The traversal's clock starts at its construction, before plan_roots and the Embree
// build (which need its triangle hierarchy); finish_stats' time_traversal and
// miscellaneous then hold that setup, reported apart (time_root_plan,
// time_embree_build): it is taken out again.
void exclude_setup_time(Stats& st, double setup) {
  const double secs = std::max(0.0, st.get("time_traversal") - setup);
  st.set("time_traversal", secs);
  st.set("time_miscellaneous", std::max(0.0, st.get("time_miscellaneous") - setup));
  const double rays = st.get("time_ray_casting");
  st.set("percent_time_ray_casting", secs > 0 ? 100.0 * rays / secs : 0.0);
  st.set("percent_time_shaft_operations", secs > 0 ? 100.0 * (secs - rays) / secs : 0.0);
}

RootPlan plan_roots(const Scene& scene, const mesh::PreparedMesh& m, Traversal& tr, double scale) {
  RootPlan plan;
  plan.blocked.assign(scene.lights.size(), 0);
  plan.keep.assign(scene.mesh.size(), 0);
  if (scene.receivers.empty()) return plan;
  const TriangleBvh& bvh = tr.triangle_bvh();
  AABB rbox;
  for (const Receiver& r : scene.receivers) rbox.extend(r.p);
  Workspace ws;
  std::vector<Surface> out;
  std::vector<ShaftGeometry> open;
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    const Light& light = scene.lights[li];
    AABB lbox;
    for (const AABB& jb : light.jitter_boxes) lbox.extend(jb);
    if (!rbox.overlaps(lbox)) {
      const MainAxis ax = choose_main_axis(rbox, lbox);
      if (ax.axis >= 0 && root_probe_blocked(m, tr, rbox, lbox, ax, scale, ws, out)) {
        plan.blocked[li] = 1;
        plan.blocked_relations += double(scene.receivers.size()) * double(light.samples);
        continue;
      }
    }
    open.emplace_back(rbox, lbox, MainAxis{}, scale);
  }
  // The prepared mesh's triangles by their soup index (mesh::PreparedTriangle::source);
  // a soup triangle that preparation dropped (degenerate) is kept as it is.
  std::vector<uint8_t> prepared(scene.mesh.size(), 0);
  for (const auto& pt : m.triangles) prepared[pt.source] = 1;
  // The union is walked when it may leave much out: some light was decided here (its
  // shaft's triangles may be seen by no other light), or a single light sees the
  // scene. Lights all open on a compact object (scan: 10 lights, 74,896 of 74,904
  // triangles kept) cost the walk (2% of the solve) and save nothing.
  bool walk = open.size() < scene.lights.size() || scene.lights.size() == 1;
  // A shaft whose planes all pass the mesh box's farthest corner would take every
  // triangle: plane values are monotone in each coordinate as evaluated
  // (classify_box_plane), so each triangle box's nearest corner passes too, which is
  // may_intersect_box's test. One light above a compact mesh (the real meshes'
  // file: scenes) then skips the walk and keeps the same triangles.
  if (walk && !open.empty() && !m.triangles.empty()) {
    AABBd mb = to_double(bvh.tree().node(0).box);
    auto contains = [&](const ShaftGeometry& g) {
      for (int i = 0; i < g.plane_count(); ++i) {
        const ConservativePlane& p = g.plane(i);
        const Vec3d far(p.n.x > 0 ? mb.hi.x : mb.lo.x, p.n.y > 0 ? mb.hi.y : mb.lo.y, p.n.z > 0 ? mb.hi.z : mb.lo.z);
        if (!(p.eval(far) <= p.tol)) return false;
      }
      return true;
    };
    if (std::any_of(open.begin(), open.end(), contains)) walk = false;
  }
  std::vector<uint32_t> hit;
  if (walk && !open.empty()) bvh.query_shafts(open, hit);
  for (uint32_t t : hit) plan.keep[m.triangles[t].source] = 1;
  for (size_t t = 0; t < scene.mesh.size(); ++t) {
    plan.keep[t] |= uint8_t(!walk || !prepared[t]);
    plan.kept += plan.keep[t];
  }
  return plan;
}

}  // namespace

void set_validate_all(bool on) { g_validate = on; }
bool validate_all() { return g_validate; }

std::vector<OptionSpec> IssSolver::options() const {
  return {
      {"leaf_receivers", "maximum receiver points in a receiver-tree leaf (default 1, automatic rays deciding where to stop; 16 with ray_caster=custom)", {}},
      {"leaf_samples", "maximum light samples in a light-tree leaf (default 256)", {}},
      {"ray_caster", "leaf relations by Embree rays or the custom shaft ray caster of section 4.10", {"embree", "custom"}},
      {"postpone", "postpone surface refinement by the vertex-centre heuristic of section 4.7.9", {"on", "off"}},
      {"auto_ray_relations", "relations a subdivided shaft must decide per shaft built below it before auto_rays lets its size subdivide (default 64)", {}},
      {"direct_rays", "leaf relations of shafts with few candidate triangles by a certified segment test against those (Embree rays where it cannot certify)", {"on", "off"}},
      {"cell_shafts", "with direct_rays, the leaf relations of a whole-light leaf with at most cell_candidates candidate triangles, receiver by receiver, first by a shaft from the receiver point to the light node's box (blocked or visible by the direct test's certified predicates at the box corners), then to its subtree's boxes down to cell_depth levels, the direct test against the candidates left and Embree for the relations still undecided", {"on", "off"}},
      {"cell_depth", "cell_shafts: light-tree levels below the leaf's light node that cells descend while mixed (default 0: the light node's box only)", {}},
      {"cell_patches", "cell_shafts: a cell is also blocked by a planar patch of exactly coplanar neighbouring triangles whose plane separates the receiver from the cell, with no boundary edge meeting the cell's segments and one segment through its inside", {"on", "off"}},
      {"cell_backfaces", "cell_shafts: a leaf shaft with more than cell_candidates candidates still gets cells when at most that many are left without the faces of closed star-shaped surfaces turned strictly away from the whole receiver node (a segment from outside such a surface that meets it first crosses a face turned towards its start)", {"on", "off"}},
      {"cell_surfaces", "cell_backfaces: a leaf still over cell_candidates after that takes cells receiver by receiver where at most cell_surface_candidates are left without the closed surfaces whose box lies outside the pyramid from the receiver over the light node's box", {"on", "off"}},
      {"cell_groups", "cell_shafts: a cell left mixed over more than cell_group_samples samples, with at most cell_group_candidates mixed candidates, takes a cell at each group of that many of them (in light-tree order, the union of their jitter boxes) against its mixed candidates, blocked or visible by the w pairs and the block over the group box (at its corners, or from its centre with cell_group_centre); the direct test takes the samples of the groups left mixed", {"on", "off"}},
      {"cell_group_samples", "cell_groups: samples per group (default 16)", {}},
      {"cell_group_candidates", "cell_groups: the most mixed candidates a cell takes groups with (default 24; more go to the direct test at once)", {}},
      {"cell_centre", "cell_shafts: a cell's certificates over its light node's box from the box's centre and half extents (each w within w(centre) +- h.|grad w|, with its rounding bound) rather than at its corners: the same tests at about half the cost", {"on", "off"}},
      {"cell_group_centre", "cell_groups: the groups' certificates from the group box's centre and half extents rather than its corners (as cell_centre)", {"on", "off"}},
      {"cell_cache", "cell_shafts: a receiver's node cell first tries the four candidates whose vector last blocked a node cell of this light (a triangle that certainly blocks every segment into the light node's box decides the cell whatever the other candidates are); stat cell_cache_relations", {"on", "off"}},
      {"cell_group_min", "cell_groups: a group left mixed with more samples than this takes cells at its two halves too (default 8)", {}},
      {"cell_surface_candidates", "cell_surfaces: the most candidates a receiver takes cells on after that (default 96; more go to Embree rays)", {}},
      {"cell_candidates", "cell_shafts: most candidate triangles of a leaf shaft that cells take (default 192; more go to the direct test or Embree rays)", {}},
      {"ray_queue", "queue the leaf rays of light leaves under 16 samples per receiver node until a full Embree packet is pending", {"on", "off"}},
      {"light_split", "per light, split the light into 4-sample leaves (with 64-receiver leaves) when a trial of its first shafts shows it pays; on: every light; off: leaf_samples is the light leaf", {"auto", "on", "off"}},
      {"clusters", "initial shafts' surfaces from pre-merged consistent triangle clusters (surface_clusters.h): auto once an initial shaft holds 8192 triangles and an eighth of the mesh, on always, off never", {"auto", "on", "off"}},
      {"cluster_exact", "with the clusters, nodes of at most this many triangles whose normal cone proves no facing are taken whole when every triangle's own Table 4.1 facing is the same (default 512; 0 off)", {}},
      {"lazy_band", "keep the triangles a shaft finds inconsistent (Table 4.1) out of its surfaces as a list that sub-shafts filter by box (never blocking, never empty): auto once the clusters are built (dense meshes), on always, off never (Embree caster only)", {"auto", "on", "off"}},
      {"band_build", "with the lazy band, build a band triangle into a sub-shaft's surfaces once it is consistent there (default off: it stays in the band, never blocking)", {"on", "off"}},
      {"cost_rays", "with auto_rays, also cast the relations of shafts of a size once subdividing them went through more blocker elements (raw edges, band entries) per relation decided below than cost_factor rays' worth (every 8th still subdivides): auto with the lazy band (dense meshes), on always, off never", {"auto", "on", "off"}},
      {"cost_initial", "with cost_rays, the same rule for initial shafts over the lights: once the initial shafts built so far went through more blocker elements per relation they decided than cost_factor rays' worth, a light's initial shaft is not built and its relations are cast (every 8th is still built)", {"on", "off"}},
      {"cost_initial_factor", "cost_initial casts once the initial shafts went through more than cost_initial_factor * 3 blocker elements per relation they decided (default 1)", {}},
      {"cost_factor", "cost_rays casts the shafts of a size once the shafts below its subdivisions went through more than cost_factor * 3 blocker elements per relation they decided (default 2)", {}},
      {"auto_rays", "cast a shaft's relations directly once subdividing shafts of its size stops paying (Embree caster)", {"on", "off"}},
      {"split_samples", "light-tree leaf size once a light splits (light_split; default 4)", {}},
      {"split_receivers", "receiver leaf size once a light splits (light_split; default 64)", {}},
      {"embree_quality", "build quality of the leaf rays' Embree BVH (raycast::BuildQuality): auto takes low when the scene has at most 7 relations per triangle, medium when every light is cast by rays, else low replaced by medium once the rays cast extrapolate to 9 per triangle (stat embree_upgraded)", {"auto", "low", "medium", "high"}},
      {"split_auto_ray_relations", "auto_ray_relations for the shafts of split lights (default 16)", {}},
      {"dense_rays", "with auto_rays (Embree caster), cast every relation of a light whose root shaft holds a dense mesh (8192 triangles and an eighth of the mesh) with fewer than dense_ray_relations relations per triangle there, building no shaft for it; when every light is so, no mesh preparation, hierarchy or tree is built either", {"on", "off"}},
      {"dense_ray_relations", "dense_rays casts a light with fewer relations than this many per triangle of its root shaft (default 3)", {}},
  };
}

// plan_roots' answer when nothing was walked: no light blocked, every triangle kept.
RootPlan keep_everything(const Scene& scene) {
  RootPlan plan;
  plan.blocked.assign(scene.lights.size(), 0);
  plan.keep.assign(scene.mesh.size(), 1);
  plan.kept = scene.mesh.size();
  return plan;
}

SolveResult IssSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  const IeeeFloatMode ieee;  // the caller may be a TBB worker with FTZ/DAZ on (lib/geom/float_mode.h)
  Params p;
  p.custom_rays = opt.get("ray_caster", "embree") == "custom";
  // Automatic rays, which stop the default one-point receiver leaves from being reached
  // everywhere, are Embree's only: the custom caster keeps the leaves of 16 it was
  // measured with.
  if (p.custom_rays) p.leaf_receivers = 16;
  p.leaf_receivers = int(std::max(1L, opt.get_int("leaf_receivers", p.leaf_receivers)));
  p.leaf_samples = int(std::max(1L, opt.get_int("leaf_samples", p.leaf_samples)));
  p.postpone = opt.get_bool("postpone", true);
  p.auto_rays = opt.get_bool("auto_rays", true);
  p.ray_queue = opt.get_bool("ray_queue", true);
  p.direct_rays = opt.get_bool("direct_rays", true);
  p.cell_shafts = opt.get_bool("cell_shafts", true);
  p.cell_depth = int(std::max(0L, opt.get_int("cell_depth", p.cell_depth)));
  p.cell_max_candidates = int(std::max(0L, opt.get_int("cell_candidates", p.cell_max_candidates)));
  p.cell_patches = opt.get_bool("cell_patches", true);
  p.cell_backfaces = opt.get_bool("cell_backfaces", true);
  p.cell_surfaces = opt.get_bool("cell_surfaces", true);
  p.cell_groups = opt.get_bool("cell_groups", true);
  p.cell_group_samples = int(std::max(1L, opt.get_int("cell_group_samples", p.cell_group_samples)));
  p.cell_group_min = int(std::max(1L, opt.get_int("cell_group_min", p.cell_group_min)));
  p.cell_centre = opt.get_bool("cell_centre", true);
  p.cell_group_centre = opt.get_bool("cell_group_centre", true);
  p.cell_cache = opt.get_bool("cell_cache", true);
  p.cell_group_candidates = int(std::max(0L, opt.get_int("cell_group_candidates", p.cell_group_candidates)));
  p.cell_surface_candidates =
      int(std::max(0L, opt.get_int("cell_surface_candidates", p.cell_surface_candidates)));
  p.clusters = opt.get("clusters", "auto") != "off";
  if (opt.get("clusters", "auto") == "on") p.cluster_min_triangles = 0;
  p.cluster_exact_max = size_t(std::max(0L, opt.get_int("cluster_exact", long(p.cluster_exact_max))));
  p.lazy_band_on = opt.get("lazy_band", "auto") == "on";
  p.lazy_band_auto = opt.get("lazy_band", "auto") == "auto";
  p.band_build = opt.get_bool("band_build", false);
  p.cost_rays_on = opt.get("cost_rays", "auto") == "on";
  p.cost_rays_auto = opt.get("cost_rays", "auto") == "auto";
  p.cost_initial = opt.get_bool("cost_initial", true);
  p.cost_initial_factor = double(std::max(0L, opt.get_int("cost_initial_factor", long(p.cost_initial_factor))));
  p.cost_factor = double(std::max(0L, opt.get_int("cost_factor", long(p.cost_factor))));
  // The trial compares costs in automatic-ray terms: Embree leaf rays only.
  p.light_split_auto = opt.get("light_split", "auto") == "auto" && !p.custom_rays;
  p.light_split_always = opt.get("light_split", "auto") == "on";
  p.auto_ray_relations = double(std::max(0L, opt.get_int("auto_ray_relations", long(p.auto_ray_relations))));
  p.split_samples = int(std::max(1L, opt.get_int("split_samples", p.split_samples)));
  p.split_receivers = int(std::max(1L, opt.get_int("split_receivers", p.split_receivers)));
  p.split_auto_ray_relations =
      double(std::max(0L, opt.get_int("split_auto_ray_relations", long(p.split_auto_ray_relations))));

  // The scale of Traversal (the largest coordinate magnitude), for the same shaft bits.
  double scale = 0;
  {
    const AABB b = scene.bounds();
    for (int k = 0; k < 3; ++k) scale = std::max({scale, std::abs(double(b.lo[k])), std::abs(double(b.hi[k]))});
    scale = std::max(scale, 1e-30);
  }
  // Lights cast whole (dense_ray_lights); with the custom caster, whose leaves are not
  // Embree rays, or without automatic rays, every light keeps its shafts.
  const auto td = Clock::now();
  if (opt.get_bool("dense_rays", true) && p.auto_rays && !p.custom_rays) {
    const double k = double(std::max(0L, opt.get_int("dense_ray_relations", 3)));
    p.dense_light = dense_ray_lights(scene, k, scale);
    p.rays_only = !p.dense_light.empty() &&
                  std::all_of(p.dense_light.begin(), p.dense_light.end(), [](uint8_t d) { return d != 0; });
  }
  // Counted in the method's seconds (preparation is not).
  const double dense_seconds = std::chrono::duration<double>(Clock::now() - td).count();
  // Leaf rays alone need no prepared mesh (the Embree scene is the soup's).
  auto tp0 = Clock::now();
  mesh::PreparedMesh m;
  size_t paired = 0;
  if (!p.rays_only) {
    m = mesh::prepare_mesh(scene.mesh);
    paired = pair_nonmanifold_edges(m);  // radial_pairing.h: part of preparation
  }
  auto t0 = Clock::now();
  const double faults0 = minor_faults();
  SolveResult result = make_empty_result(scene);
  // The Embree scene (robust flags) is needed for leaf rays, and by the custom caster
  // only as a fallback next to removed surfaces; it holds the triangles those rays may
  // meet (plan_roots).
  double embree_build = 0;
  MemoryBudget budget("iss", opt.memory_budget_mb);  // outlives the traversal
  Traversal tr(scene, m, p, result);
  tr.set_memory_budget(&budget);
  auto tb = Clock::now();
  const RootPlan plan = p.rays_only ? keep_everything(scene) : plan_roots(scene, m, tr, scale);
  const double root_plan_seconds = std::chrono::duration<double>(Clock::now() - tb).count();
  // The leaf caster's mesh: the triangles a leaf ray may meet, when that leaves some out.
  TriangleSoup ray_mesh;
  const bool subset = plan.kept < scene.mesh.size();
  if (subset) {
    ray_mesh.vertices = scene.mesh.vertices;
    ray_mesh.triangles.reserve(plan.kept);
    for (size_t t = 0; t < scene.mesh.size(); ++t)
      if (plan.keep[t]) ray_mesh.triangles.push_back(scene.mesh.triangles[t]);
  }
  const TriangleSoup& leaf_mesh = subset ? ray_mesh : scene.mesh;
  const std::string quality_opt = opt.get("embree_quality", "auto");
  raycast::BuildQuality quality = leaf_ray_build_quality(quality_opt, scene, leaf_mesh);
  // Past the relation rule the shafts still decide most relations (rooms 1024 x 64: 20,160
  // Embree rays, 2.6 per triangle, of 1.77M relations), so the low build goes first and
  // the medium one replaces it when the rays extrapolate past the crossover.
  const bool upgrade = quality_opt == "auto" && quality == raycast::BuildQuality::medium && !p.rays_only;
  if (upgrade) quality = raycast::BuildQuality::low;
  std::optional<raycast::EmbreeScene> es;
  es.emplace(leaf_mesh, true, true, quality);
  // The low build's hit counts, kept when the medium one replaces it. The low scene is
  // released first (no ray is in flight: the traversal is single-threaded), so the two
  // BVHs are never held at once.
  size_t low_rejected = 0, low_unverified = 0;
  if (upgrade) {
    const double tris = double(leaf_mesh.size());
    tr.set_embree_upgrade(
        [&]() {
          low_rejected = es->rejected_hits();
          low_unverified = es->unverified_hits();
          es.reset();
          es.emplace(leaf_mesh, true, true, raycast::BuildQuality::medium);
          return &*es;
        },
        tris / 2, kUpgradeRaysPerTriangle * tris, double(scene.relation_count()) - plan.blocked_relations);
  }
  embree_build = std::chrono::duration<double>(Clock::now() - tb).count() - root_plan_seconds;
  const double faults_build = minor_faults();
  const auto t_setup = Clock::now();
  tr.set_embree(&*es);
  for (size_t l = 0; l < scene.lights.size(); ++l)
    if (!plan.blocked[l]) tr.run_light(l);
  auto t1 = Clock::now();
  const double faults1 = minor_faults();
  // Exact: integer counts far below 2^53.
  VG_CHECK(tr.decided_relations() + plan.blocked_relations == double(scene.relation_count()));
  tr.finish_stats(result.stats);  // before the fractions: the breakdown covers the traversal
  exclude_setup_time(result.stats, std::chrono::duration<double>(t_setup - tb).count());
  add_root_plan_stats(plan, result.stats);
  result.stats.set("leaf_ray_triangles", double(leaf_mesh.size()));
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(t1 - t0).count() + dense_seconds;
  result.stats.set("prepare_seconds", std::chrono::duration<double>(t0 - tp0).count());
  result.stats.set("time_embree_build", embree_build);
  result.stats.set("time_root_plan", root_plan_seconds);
  result.stats.set("page_faults_setup", faults_build - faults0);
  result.stats.set("page_faults_traversal", faults1 - faults_build);
  // The build that cast the rays after the upgrade, if any (low only when never upgraded).
  result.stats.set("embree_build_low", quality == raycast::BuildQuality::low && !tr.embree_upgraded() ? 1.0 : 0.0);
  result.stats.set("embree_upgraded", tr.embree_upgraded() ? 1.0 : 0.0);
  // Both builds' rays when the medium one replaced the low one.
  result.stats.set("embree_rejected_hits", double(low_rejected + es->rejected_hits()));
  result.stats.set("embree_unverified_hits", double(low_unverified + es->unverified_hits()));
  result.stats.set("nonmanifold_edges_paired", double(paired));
  result.stats.set("leaf_receivers", p.leaf_receivers);
  result.stats.set("leaf_samples", p.leaf_samples);
  return result;
}

}  // namespace visgate::iss
