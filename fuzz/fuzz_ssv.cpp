// fuzz_ssv: differential target for `ssv` (DESIGN sections 4 and 5). Each input decodes
// (fuzz/decoder.h) to a small scene plus method options; soft shadow volumes with the
// lazy wedge BSP (paper 001) are run on it and every relation is compared with the exact
// relation oracle. A mismatch (margin >= tau) or an exception prints method, options,
// relation, exact class, margin and the hex-float scene, then aborts
// (fuzz/differential.h).
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

// No allocation stack traces in ASan (malloc_context_size, default 30), as in
// fuzz_plucker.cpp and fuzz_iss.cpp: recording them (StackDepot::Put) was 4.9% of
// fuzz_ssv's samples. Error detection is unchanged;
// ASAN_OPTIONS=malloc_context_size=30 brings the allocation and free stacks back.
extern "C" const char* __asan_default_options() { return "malloc_context_size=0"; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_ssv", data, size);
}
