// The `iss` Solver (see iss_solver.h for the guarantee): options, mesh preparation and
// the leaf caster's scene around the traversal of traversal.h.
#include "lib/iss/iss_solver.h"

#include <algorithm>
#include <chrono>

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
raycast::BuildQuality leaf_ray_build_quality(const std::string& opt, const Scene& scene) {
  if (opt == "low") return raycast::BuildQuality::low;
  if (opt == "medium") return raycast::BuildQuality::medium;
  if (opt == "high") return raycast::BuildQuality::high;
  const bool few_rays = double(scene.relation_count()) <= kLowBuildRelationsPerTriangle * double(scene.mesh.size());
  return few_rays ? raycast::BuildQuality::low : raycast::BuildQuality::medium;
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
      {"ray_queue", "queue the leaf rays of light leaves under 16 samples per receiver node until a full Embree packet is pending", {"on", "off"}},
      {"light_split", "per light, split the light into 4-sample leaves (with 64-receiver leaves) when a trial of its first shafts shows it pays; on: every light; off: leaf_samples is the light leaf", {"auto", "on", "off"}},
      {"clusters", "initial shafts' surfaces from pre-merged consistent triangle clusters (surface_clusters.h): auto once an initial shaft holds 8192 triangles and an eighth of the mesh, on always, off never", {"auto", "on", "off"}},
      {"auto_rays", "cast a shaft's relations directly once subdividing shafts of its size stops paying (Embree caster)", {"on", "off"}},
      {"split_samples", "light-tree leaf size once a light splits (light_split; default 4)", {}},
      {"split_receivers", "receiver leaf size once a light splits (light_split; default 64)", {}},
      {"embree_quality", "build quality of the leaf rays' Embree BVH (raycast::BuildQuality): auto takes low when the scene has at most 7 relations per triangle, else medium", {"auto", "low", "medium", "high"}},
      {"split_auto_ray_relations", "auto_ray_relations for the shafts of split lights (default 16)", {}},
  };
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
  p.clusters = opt.get("clusters", "auto") != "off";
  if (opt.get("clusters", "auto") == "on") p.cluster_min_triangles = 0;
  // The trial compares costs in automatic-ray terms: Embree leaf rays only.
  p.light_split_auto = opt.get("light_split", "auto") == "auto" && !p.custom_rays;
  p.light_split_always = opt.get("light_split", "auto") == "on";
  p.auto_ray_relations = double(std::max(0L, opt.get_int("auto_ray_relations", long(p.auto_ray_relations))));
  p.split_samples = int(std::max(1L, opt.get_int("split_samples", p.split_samples)));
  p.split_receivers = int(std::max(1L, opt.get_int("split_receivers", p.split_receivers)));
  p.split_auto_ray_relations =
      double(std::max(0L, opt.get_int("split_auto_ray_relations", long(p.split_auto_ray_relations))));

  auto tp0 = Clock::now();
  mesh::PreparedMesh m = mesh::prepare_mesh(scene.mesh);
  size_t paired = pair_nonmanifold_edges(m);  // radial_pairing.h: part of preparation
  auto t0 = Clock::now();
  const double faults0 = minor_faults();
  SolveResult result = make_empty_result(scene);
  // The Embree scene (robust flags) is needed for leaf rays, and by the custom caster
  // only as a fallback next to removed surfaces.
  double embree_build = 0;
  auto tb = Clock::now();
  const raycast::BuildQuality quality = leaf_ray_build_quality(opt.get("embree_quality", "auto"), scene);
  raycast::EmbreeScene es(scene.mesh, true, true, quality);
  embree_build = std::chrono::duration<double>(Clock::now() - tb).count();
  const double faults_build = minor_faults();
  MemoryBudget budget("iss", opt.memory_budget_mb);  // outlives the traversal
  Traversal tr(scene, m, p, result);
  tr.set_embree(&es);
  tr.set_memory_budget(&budget);
  for (size_t l = 0; l < scene.lights.size(); ++l) tr.run_light(l);
  auto t1 = Clock::now();
  const double faults1 = minor_faults();
  // Exact: integer counts far below 2^53.
  VG_CHECK(tr.decided_relations() == double(scene.relation_count()));
  tr.finish_stats(result.stats);  // before the fractions: the breakdown covers the traversal
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(t1 - t0).count();
  result.stats.set("prepare_seconds", std::chrono::duration<double>(t0 - tp0).count());
  result.stats.set("time_embree_build", embree_build);
  result.stats.set("page_faults_embree_build", faults_build - faults0);
  result.stats.set("page_faults_traversal", faults1 - faults_build);
  result.stats.set("embree_build_low", quality == raycast::BuildQuality::low ? 1.0 : 0.0);
  result.stats.set("embree_rejected_hits", double(es.rejected_hits()));
  result.stats.set("embree_unverified_hits", double(es.unverified_hits()));
  result.stats.set("nonmanifold_edges_paired", double(paired));
  result.stats.set("leaf_receivers", p.leaf_receivers);
  result.stats.set("leaf_samples", p.leaf_samples);
  return result;
}

}  // namespace visgate::iss
