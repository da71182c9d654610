// Embree baseline (see embree_solver.h).
#include "lib/raycast/embree_solver.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>

namespace visgate::raycast {

SolveResult EmbreeSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  auto t0 = std::chrono::steady_clock::now();
  EmbreeScene es(scene.mesh, robust_, /*verify_hits=*/false);  // the baseline as users run it
  auto t1 = std::chrono::steady_clock::now();
  SolveResult result = make_empty_result(scene);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, scene.receivers.size(), 16), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t i = range.begin(); i != range.end(); ++i) {
      ReceiverResult& rr = result.receivers[i];
      const Vec3f& r = scene.receivers[i].p;
      size_t bit = 0;
      for (const Light& light : scene.lights)
        for (int j = 0; j < light.samples; ++j, ++bit)
          rr.set_visible(bit, !es.occluded(r, sample_position(light, j, i)));
    }
  });
  auto t2 = std::chrono::steady_clock::now();
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(t2 - t0).count();
  result.stats.set("build_seconds", std::chrono::duration<double>(t1 - t0).count());
  result.stats.set("trace_seconds", std::chrono::duration<double>(t2 - t1).count());
  result.stats.set("relations", double(scene.relation_count()));
  result.stats.set("rays", double(scene.relation_count()));
  result.stats.set("fallback_rays", double(es.fallback_rays()));
  return result;
}

}  // namespace visgate::raycast
