// A plugin (include/visgate/plugin.h) for tests/external/external_test.cpp. `--opt mode=` picks
// what it does:
//   mt            the textbook Möller-Trumbore caster of examples/mt-caster (the default)
//   crash         writes through a null pointer (SIGSEGV)
//   abort         calls abort() (SIGABRT)
//   error         returns 7 with a reason
//   bad-fraction  answers with a visible fraction of 2
//   fraction      the mt answer plus a visible fraction of 0.25 for every light
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "examples/mt-caster/mt_caster.h"
#include "include/visgate/plugin.h"

namespace {

const char* mode_of(const visgate_option_v1_t* opts, size_t n) {
  for (size_t k = 0; k < n; ++k)
    if (std::strcmp(opts[k].key, "mode") == 0) return opts[k].value;
  return "mt";
}

int solve(void*, const visgate_scene_v1_t* s, const visgate_option_v1_t* opts, size_t nopts, uint64_t, int,
          visgate_output_v1_t* out) {
  const char* mode = mode_of(opts, nopts);
  if (std::strcmp(mode, "crash") == 0) {
    volatile int* p = nullptr;
    *p = 1;
  }
  if (std::strcmp(mode, "abort") == 0) std::abort();
  if (std::strcmp(mode, "error") == 0) {
    std::snprintf(out->error, out->error_size, "refused on purpose");
    return 7;
  }
  for (uint64_t i = 0; i < s->receiver_count; ++i) {
    const mt_caster::V3 r = mt_caster::at(s->receiver_points, i);
    for (uint64_t b = 0; b < s->relations_per_receiver; ++b) {
      const mt_caster::V3 l = mt_caster::at(s->relation_points, i * s->relations_per_receiver + b);
      if (!mt_caster::occluded(s->vertices, s->triangles, s->triangle_count, r, l))
        out->visible_bits[i * out->words_per_receiver + b / 64] |= uint64_t(1) << (b % 64);
    }
  }
  if (std::strcmp(mode, "bad-fraction") == 0) out->visible_fraction[0] = 2.0f;
  if (std::strcmp(mode, "fraction") == 0)
    for (uint64_t k = 0; k < s->receiver_count * s->light_count; ++k) out->visible_fraction[k] = 0.25f;
  return 0;
}

const visgate_option_spec_v1_t kOptions[] = {
    {"mode", "what the test plugin does", "mt|crash|abort|error|bad-fraction|fraction"}};
const visgate_method_v1_t kMethod = {VISGATE_METHOD_ABI_VERSION, 0, "test-plugin", kOptions, 1, nullptr, solve, nullptr};

}  // namespace

extern "C" __attribute__((visibility("default"))) const visgate_method_v1_t* visgate_method_v1(void) { return &kMethod; }
