// The `iss` Solver (see iss_solver.h for the guarantee): options, mesh preparation and
// the leaf caster's scene around the traversal of traversal.h.
#include "lib/iss/iss_solver.h"

#include <algorithm>
#include <chrono>

#include "lib/base/check.h"
#include "lib/geom/float_mode.h"
#include "lib/iss/radial_pairing.h"
#include "lib/iss/traversal.h"
#include "lib/mesh/prepare.h"
#include "lib/raycast/embree_scene.h"

namespace visgate::iss {

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
      {"ray_queue", "queue the leaf rays of light leaves under 16 samples per receiver node until a full Embree packet is pending", {"on", "off"}},
      {"light_split", "per light, split the light into 4-sample leaves (with 64-receiver leaves) when a trial of its first shafts shows it pays; on: every light; off: leaf_samples is the light leaf", {"auto", "on", "off"}},
      {"clusters", "initial shafts' surfaces from pre-merged consistent triangle clusters (surface_clusters.h): auto once an initial shaft holds 8192 triangles and an eighth of the mesh, on always, off never", {"auto", "on", "off"}},
      {"auto_rays", "cast a shaft's relations directly once subdividing shafts of its size stops paying (Embree caster)", {"on", "off"}},
      {"split_samples", "light-tree leaf size once a light splits (light_split; default 4)", {}},
      {"split_receivers", "receiver leaf size once a light splits (light_split; default 64)", {}},
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
  p.direct_rays = opt.get_bool("direct_rays", true);
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
