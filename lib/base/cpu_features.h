// Run-time choice of the AVX2 kernels (compiled with __attribute__((target("avx2")))
// beside their default builds).
#pragma once

#include <cstdlib>

namespace visgate {

// Whether AVX2 kernels may run: the CPU has AVX2 and the environment variable
// `disable_env` is unset (set, it selects the default kernels, to check them against the
// AVX2 ones on a machine that has both). Callers keep the answer in a static.
inline bool avx2_enabled(const char* disable_env) {
#if defined(__GNUC__) && defined(__x86_64__)
  return __builtin_cpu_supports("avx2") && std::getenv(disable_env) == nullptr;
#else
  (void)disable_env;
  return false;
#endif
}

}  // namespace visgate
