// Brute-force float32 caster (see brute.h).
#include "lib/raycast/brute.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <chrono>

#include "lib/geom/float_mode.h"
#include "lib/geom/predicates.h"

namespace visgate::raycast {

bool brute_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to) {
  Vec3f dir = to - from;
  for (const auto& t : soup.triangles)
    if (segment_hits_triangle_mt(from, dir, soup.vertices[t[0]], soup.vertices[t[1]], soup.vertices[t[2]])) return true;
  return false;
}

SolveResult BruteSolver::solve_scene(const Scene& scene, const SolveOptions& opt) {
  ThreadLimit limit(opt.threads);
  auto t0 = std::chrono::steady_clock::now();
  SolveResult result = make_empty_result(scene);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, scene.receivers.size(), 4), [&](const tbb::blocked_range<size_t>& range) {
    // Textbook IEEE float32 on every thread: Embree leaves FTZ/DAZ on in TBB workers
    // (lib/geom/float_mode.h), which would make the answers depend on the thread.
    const IeeeFloatMode ieee;
    for (size_t i = range.begin(); i != range.end(); ++i) {
      ReceiverResult& rr = result.receivers[i];
      size_t bit = 0;
      for (const Light& light : scene.lights)
        for (int j = 0; j < light.samples; ++j, ++bit)
          rr.set_visible(bit, !brute_occluded(scene.mesh, scene.receivers[i].p, sample_position(light, j, i)));
    }
  });
  fractions_from_bits(scene, result);
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  result.stats.set("relations", double(scene.relation_count()));
  result.stats.set("triangle_tests", double(scene.relation_count()) * double(scene.mesh.size()));
  return result;
}

}  // namespace visgate::raycast
