// fuzz_iss: differential target for `iss` (DESIGN sections 4 and 5). Each input decodes
// (fuzz/decoder.h) to a small scene plus method options; Incremental Shaft Subdivision (paper 000 chapter 4)
// is run on it and every relation is compared with the exact relation oracle.
// A mismatch (margin >= tau) or an exception prints method, options, relation, exact
// class, margin and the hex-float scene, then aborts (fuzz/differential.h).
// Until `iss` is registered in lib/registry.cpp every input returns at once.
#include <cstddef>
#include <cstdint>

#include "fuzz/differential.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return visgate::fuzz::run_differential("fuzz_iss", data, size);
}
