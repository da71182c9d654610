// fuzz_embree: differential target for `embree-robust` (DESIGN sections 4 and 5). Each input decodes
// (lib/scene/byte_decoder.h) to a small scene plus method options; Embree with RTC_SCENE_FLAG_ROBUST
// is run on it and every relation is compared with the exact relation oracle.
// A mismatch (margin >= tau) or an exception prints method, options, relation, exact
// class, margin and the hex-float scene, then aborts (fuzz/differential.h).
// Embree is third-party: what this target finds is stored as an `open` case with a note
// (corpus/embree-robust/ or corpus/fuzz/open/fuzz_embree/), never patched in Embree. The
// known robust-mode false hit on near-coplanar segments is counted once, not reported
// again (differential.cpp); lib/raycast's EmbreeScene verifies hits for ISS and SSV.
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_embree", data, size);
}
