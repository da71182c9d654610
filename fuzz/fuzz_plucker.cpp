// fuzz_plucker: differential target for `plucker-bsp` (DESIGN sections 4 and 5). Each input decodes
// (lib/scene/byte_decoder.h) to a small scene plus method options; the lazy Plücker BSP (paper 002)
// is run on it and every relation is compared with the exact relation oracle, one
// interior point of every fragment too, and the visible fractions of one receiver (every
// light), chosen by the input, with the exact region oracle.
// Cap: one receiver's fractions per run (fuzz/differential.h fraction_receivers): the
// exact region check of every receiver dominated a run's time (measurements in
// docs/log/fuzzing.md), and the option selector's unused high bits pick the receiver, so
// the fuzzer reaches every receiver of every scene by mutating them.
// A mismatch (margin >= tau) or an exception prints method, options, relation, exact
// class, margin and the hex-float scene, then aborts (fuzz/differential.h).
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

// ASan records a stack trace for every allocation (malloc_context_size, default 30); the
// region oracle's Epeck Boolean operations allocate so much that recording them costs a
// large share of the run (docs/log/fuzzing.md). Error detection is unchanged; only the
// allocation and free stacks of heap-error reports are left out (ASAN_OPTIONS, e.g.
// malloc_context_size=30, overrides this default when a report needs them).
extern "C" const char* __asan_default_options() { return "malloc_context_size=0"; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_plucker", data, size);
}
