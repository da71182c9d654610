// The built-in `embree` method behind the plugin ABI (include/visgate/plugin.h), to
// measure what the ABI costs (`visgate bench plugin-overhead`, docs/external-methods.md):
// it rebuilds the scene from the flat arrays (lights from polygon, samples, pattern,
// jitter and seed, so sample_position gives the very same points; it asks for no
// relation points) and runs raycast::EmbreeSolver on it, copying its bits.
#include <cstdio>
#include <cstring>
#include <exception>

#include "include/visgate/plugin.h"
#include "lib/raycast/embree_solver.h"
#include "lib/scene/scene.h"

namespace {

using namespace visgate;

Vec3f at(const float* p, uint64_t k) { return Vec3f(p[3 * k], p[3 * k + 1], p[3 * k + 2]); }

void* create(const visgate_option_v1_t*, size_t, char*, size_t) { return new raycast::EmbreeSolver(false); }
void destroy(void* state) { delete static_cast<raycast::EmbreeSolver*>(state); }

int solve(void* state, const visgate_scene_v1_t* s, const visgate_option_v1_t*, size_t, uint64_t seed, int threads,
          visgate_output_v1_t* out) {
  try {
    Scene scene;
    scene.name = s->name;
    scene.mesh.vertices.reserve(s->vertex_count);
    for (uint64_t v = 0; v < s->vertex_count; ++v) scene.mesh.vertices.push_back(at(s->vertices, v));
    scene.mesh.triangles.resize(s->triangle_count);
    std::memcpy(scene.mesh.triangles.data(), s->triangles, s->triangle_count * 3 * sizeof(uint32_t));
    scene.receivers.resize(s->receiver_count);
    for (uint64_t i = 0; i < s->receiver_count; ++i)
      scene.receivers[i] = {at(s->receiver_points, i), at(s->receiver_normals, i)};
    size_t jitter_base = 0;
    for (uint64_t l = 0; l < s->light_count; ++l) {
      Light L;
      for (uint64_t k = s->light_polygon_offsets[l]; k < s->light_polygon_offsets[l + 1]; ++k)
        L.polygon.push_back(at(s->light_polygons, k));
      L.samples = int(s->light_offsets[l + 1] - s->light_offsets[l]);
      L.jitter = int(s->light_jitter[l]);
      L.seed = s->light_seed[l];
      const uint32_t p = s->light_pattern[l];
      L.pattern = p == VISGATE_PATTERN_RANDOM     ? SamplePattern::Random
                  : p == VISGATE_PATTERN_GRID     ? SamplePattern::Grid
                  : p == VISGATE_PATTERN_EXPLICIT ? SamplePattern::Explicit
                                                  : SamplePattern::Stratified;
      if (L.pattern == SamplePattern::Explicit)
        for (int j = 0; j < L.samples; ++j) L.explicit_samples.push_back(at(s->jitter_points, jitter_base + size_t(j)));
      jitter_base += size_t(L.samples) * size_t(L.jitter);
      Status st = prepare_light(L, "lights[" + std::to_string(l) + "]");
      if (!st) {
        std::snprintf(out->error, out->error_size, "%s", st.error().message.c_str());
        return 1;
      }
      scene.lights.push_back(std::move(L));
    }
    SolveOptions so;
    so.seed = seed;
    so.threads = threads;
    SolveResult r = static_cast<raycast::EmbreeSolver*>(state)->solve(scene, so);
    for (uint64_t i = 0; i < s->receiver_count; ++i)
      std::memcpy(out->visible_bits + i * out->words_per_receiver, r.receivers[i].visible_bits.data(),
                  out->words_per_receiver * sizeof(uint64_t));
    return 0;
  } catch (const std::exception& e) {
    std::snprintf(out->error, out->error_size, "%s", e.what());
    return 1;
  }
}

const visgate_method_v1_t kMethod = {VISGATE_METHOD_ABI_VERSION, VISGATE_METHOD_NO_RELATION_POINTS, "embree-plugin",
                                     nullptr, 0, create, solve, destroy};

}  // namespace

extern "C" __attribute__((visibility("default"))) const visgate_method_v1_t* visgate_method_v1(void) { return &kMethod; }
