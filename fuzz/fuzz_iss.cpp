// fuzz_iss: differential target for `iss` (DESIGN sections 4 and 5). Each input decodes
// (fuzz/decoder.h) to a small scene plus method options; Incremental Shaft Subdivision
// (paper 000 chapter 4) is run on it and every relation is compared with the exact
// relation oracle. A mismatch (margin >= tau) or an exception prints method, options,
// relation, exact class, margin and the hex-float scene, then aborts
// (fuzz/differential.h).
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

// No allocation stack traces in ASan (malloc_context_size, default 30), as fuzz_plucker.cpp
// explains: ISS allocates per shaft (surfaces, patch lists) and the oracle per run, and
// recording every allocation's stack was about 6% of the samples (StackDepot::Put,
// UnwindFast). Error detection is unchanged; ASAN_OPTIONS=malloc_context_size=30 brings
// the allocation and free stacks back for a report.
extern "C" const char* __asan_default_options() { return "malloc_context_size=0"; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_iss", data, size);
}
