// Structure-aware scene decoder for the fuzz targets (../shared/STYLE.md "Fuzzing";
// DESIGN sections 3 and 5). Turns arbitrary bytes into a small, valid Scene or an Error,
// never throws, never crashes and keeps every scene tiny (hard caps below) so one run of
// a differential target stays in milliseconds.
//
// It lives in lib/scene (library target vg_fuzz_decode, built by fuzz/CMakeLists.txt with
// the fuzz builds' coverage flags; links vg_scene only) so that `visgate minimize` reads a
// fuzzer crash file through exactly the same decoding as the target that wrote it,
// without a tool including a fuzz header:
//
//   auto bytes = read the crash file;
//   auto c = visgate::fuzz::decode_case(bytes.data(), bytes.size(), visgate::fuzz::method_limits(method));
//   if (!c) -> exit 2 with c.error().message;
//   c->scene                                   the scene the target solved
//   visgate::fuzz::decode_options(c->option_selector, solver->options())
//                                              the method options the target used
//   visgate::fuzz::target_method("fuzz_iss")   the method ("iss")
//
// Input layout of the differential targets (fuzz_iss, fuzz_ssv, fuzz_plucker,
// fuzz_embree): [4 bytes option selector, little endian][scene bytes]. The scene bytes are
// what `decode_scene` reads; fuzz_prepare feeds its whole input to `decode_scene`.
//
// Scene bytes, consumed with FuzzedDataProvider (integers come from the end of the input,
// raw bytes from the front; short input decodes as zeros, so every byte string is valid):
//   1. mode: one of the DESIGN section 7 families (generated with small parameters, then
//      cut down to the caps) or a "raw" soup whose vertex coordinates are small integers
//      times a power-of-two step (so coincident vertices, shared edges, vertices exactly on
//      segments and coplanar triangles are reached), with optional explicit light samples;
//   2. optional grid snapping of every coordinate to a power-of-two grid (exact
//      degeneracies in family scenes);
//   3. a list of perturbations of single coordinates: raw IEEE bits (NaN, Inf, subnormals
//      and huge values are reachable), flips of low mantissa bits, steps of a few ulps,
//      copies of another coordinate (exact coincidences), and sign flips;
//   4. an exact axis map (permutation with mirrors) and a power-of-two scale 2^k, k in
//      [-120, 124] clamped to where the copy is exact (fuzz_embree: k = 0).
// Non-finite coordinates are rejected with an Error naming the element, as the scene
// reader does (DESIGN section 2); lights that are no longer planar convex polygons are
// rejected by prepare_light. The decoded scene never has a receiver grid (receivers are
// an explicit list), so write_scene_json writes back exactly what was decoded.
#pragma once

#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "lib/base/result.h"
#include "lib/scene/scene.h"

namespace visgate::fuzz {

// Hard caps on the decoded scene. Defaults keep a differential run (method + relation
// oracle) well under a millisecond for the ray-casting methods; target_limits gives
// each target's own (smaller for fuzz_plucker).
struct DecodeLimits {
  size_t max_triangles = 48;     // blocker triangles
  size_t max_receivers = 6;
  int max_samples = 16;          // samples per light
  size_t max_lights = 2;
  size_t max_relations = 96;     // receivers * samples over all lights
  size_t max_perturbations = 12;
  // The exponents k of the 2^k scale the decoder may apply.
  int min_scale_exponent = -120, max_scale_exponent = 124;
};

// The limits a differential target decodes with; every reader of that target's inputs
// (the target, its replay build, `visgate minimize`) must use them, or a crash file
// decodes to another scene. fuzz_plucker: at most 24 triangles. Its run was the exact
// region check of every receiver-light pair (Epeck, CGAL's Boolean operations; now of
// one receiver's pairs, differential.h fraction_receivers) and
// plucker-bsp's exact paths, both growing faster than linearly with the triangles; with
// 48 it made about a tenth of the other targets' runs per CPU-second (README "Speed
// (exec/s) and campaigns"). The cap changes what a count byte decodes to (the value is
// taken modulo the range), so seeds decode to other scenes, but the open finding
// corpus/fuzz/open/fuzz_plucker/9386076d... (21 triangles; stored first as 6339247d...,
// see its note) decodes to the same scene
// under 24 (not under 16 to 23, checked) and still fails. Fewer receivers or lights
// would lose it: with coherence on, dropping its receivers 3 and 4 hides the mismatch
// at receiver 2. Every other target: DecodeLimits{}.
DecodeLimits target_limits(const std::string& target);
// The same for the target that exercises `method` (target_method's inverse):
// "plucker-bsp" -> fuzz_plucker's limits; DecodeLimits{} for any other method.
DecodeLimits method_limits(const std::string& method);

// Decodes scene bytes (see the file comment). Errors: non-finite coordinates ("decoded
// scene: mesh vertex 3: coordinate is NaN or infinite"), lights rejected by
// prepare_light, families that are not built, scenes left without receivers or lights.
Result<Scene> decode_scene(const uint8_t* data, size_t size, const DecodeLimits& limits);

// Option selector bytes in front of the scene bytes of a differential target.
constexpr size_t kOptionSelectorBytes = 4;

struct DecodedCase {
  Scene scene;
  uint32_t option_selector = 0;
};
// Splits a differential target's input into option selector and scene and decodes the
// scene. Input shorter than the selector decodes with selector 0 and empty scene bytes.
Result<DecodedCase> decode_case(const uint8_t* data, size_t size, const DecodeLimits& limits);

// Method options from the selector: for each option in declaration order, a value taken
// from the remaining selector bits: one of `values`, or, for integer options (empty
// `values`), an integer in 1..8. `Spec` is visgate::OptionSpec (lib/solver.h); any type
// with `name` and `values` members works, so this header needs only vg_scene.
template <class Spec>
std::map<std::string, std::string> decode_options(uint32_t selector, const std::vector<Spec>& specs) {
  std::map<std::string, std::string> out;
  for (const auto& s : specs) {
    if (s.values.empty()) {
      out[s.name] = std::to_string(1 + selector % 8);
      selector /= 8;
    } else {
      out[s.name] = s.values[selector % s.values.size()];
      selector /= uint32_t(s.values.size());
    }
  }
  return out;
}

// The selector bits decode_options leaves unused: the quotient left after every option's
// value is taken, in the same order. The targets draw their own choices from it
// (differential.cpp: which receiver gets fuzz_plucker's exact fraction check), so the
// scene and the options an input decodes to do not depend on those choices.
template <class Spec>
uint32_t selector_rest(uint32_t selector, const std::vector<Spec>& specs) {
  for (const auto& s : specs) selector /= s.values.empty() ? 8u : uint32_t(s.values.size());
  return selector;
}

// The method a fuzz target exercises: "fuzz_iss" -> "iss", "fuzz_ssv" -> "ssv",
// "fuzz_plucker" -> "plucker-bsp", "fuzz_embree" -> "embree-robust"; "" for the input
// targets.
std::string target_method(const std::string& target);

// The mode list the first choice indexes: the DESIGN section 7 families in that order
// except `rooms` (too large to generate per run), then "raw".
const std::vector<std::string>& decoder_modes();

}  // namespace visgate::fuzz
