// The textbook Möller-Trumbore caster (mt_caster.h) as a visgate plugin:
//   visgate check --family shared-edge-fan --count 4 --methods plugin:./libmt_caster_plugin.so
// It uses only include/visgate/plugin.h (the C ABI), no visgate library.
#include <cstdio>

#include "mt_caster.h"
#include "visgate/plugin.h"

namespace {

int solve(void*, const visgate_scene_v1_t* s, const visgate_option_v1_t*, size_t, uint64_t, int,
          visgate_output_v1_t* out) {
  if (!s->relation_points) {
    std::snprintf(out->error, out->error_size, "no relation points");
    return 1;
  }
  for (uint64_t i = 0; i < s->receiver_count; ++i) {
    const mt_caster::V3 r = mt_caster::at(s->receiver_points, i);
    for (uint64_t b = 0; b < s->relations_per_receiver; ++b) {
      const mt_caster::V3 l = mt_caster::at(s->relation_points, i * s->relations_per_receiver + b);
      if (!mt_caster::occluded(s->vertices, s->triangles, s->triangle_count, r, l))
        out->visible_bits[i * out->words_per_receiver + b / 64] |= uint64_t(1) << (b % 64);
    }
  }
  return 0;  // fractions: left NaN, visgate derives them from the bits
}

const visgate_method_v1_t kMethod = {VISGATE_METHOD_ABI_VERSION, 0, "mt-caster", nullptr, 0, nullptr, solve, nullptr};

}  // namespace

extern "C" __attribute__((visibility("default"))) const visgate_method_v1_t* visgate_method_v1(void) { return &kMethod; }
