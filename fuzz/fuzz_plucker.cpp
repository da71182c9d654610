// fuzz_plucker: differential target for `plucker-bsp` (DESIGN sections 4 and 5). Each input decodes
// (fuzz/decoder.h) to a small scene plus method options; the lazy Plücker BSP (paper 002)
// is run on it and every relation is compared with the exact relation oracle,
// and every receiver's visible fraction with the exact region oracle.
// A mismatch (margin >= tau) or an exception prints method, options, relation, exact
// class, margin and the hex-float scene, then aborts (fuzz/differential.h).
// Until `plucker-bsp` is registered in lib/registry.cpp every input returns at once.
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_plucker", data, size);
}
