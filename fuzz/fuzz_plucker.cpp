// fuzz_plucker: differential target for `plucker-bsp` (DESIGN sections 4 and 5). Each input decodes
// (lib/scene/byte_decoder.h) to a small scene plus method options; the lazy Plücker BSP (paper 002)
// is run on it and every relation is compared with the exact relation oracle, one
// interior point of every fragment too, and the visible fractions of one receiver (every
// light), chosen by the input, with the exact region oracle.
// Cap: one receiver's fractions per run (fuzz/differential.h fraction_receivers). The
// exact region check of every receiver was about 60% of a run's CPU time (perf, clang-14
// -O1 ASan+UBSan, 2026-12-02); with one, a run costs about half (README "Speed (exec/s)
// and campaigns"), and the option selector's unused high bits pick the receiver, so the
// fuzzer reaches every receiver of every scene by mutating them.
// A mismatch (margin >= tau) or an exception prints method, options, relation, exact
// class, margin and the hex-float scene, then aborts (fuzz/differential.h).
// Until `plucker-bsp` is registered in lib/registry.cpp every input returns at once.
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

// ASan records a stack trace for every allocation (malloc_context_size, default 30);
// the region oracle's Epeck Boolean operations allocate so much that recording them was
// 18% of the samples (perf, clang-14 -O1 ASan+UBSan, 2026-12-01) and 1000 runs took 20%
// more CPU time (33.7 s against 30.3 s, -seed=5 -runs=1000). Error detection is
// unchanged; only the allocation and free stacks of heap-error reports are left out (set
// ASAN_OPTIONS=malloc_context_size=30 to get them when a report needs them; ASAN_OPTIONS
// overrides this default).
extern "C" const char* __asan_default_options() { return "malloc_context_size=0"; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_plucker", data, size);
}
