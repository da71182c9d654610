// A pooled allocator for GMP's limb buffers in the differential fuzz targets.
//
// Why: the region oracle and plucker-bsp's exact paths work on GMP rationals (CGAL's
// Lazy_exact_nt<mpq_class>, Epeck), and every mpq_init, every temporary of a gmpxx
// expression and every exact value a lazy number computes allocates its numerator's
// and denominator's limbs through GMP's allocation functions. Replaying 800
// fuzz_plucker inputs under ASan made 1.09M allocations, 67% of them GMP's (an
// allocation hook with sampled stacks, 2026-12-03), and ASan's allocator with
// libFuzzer's malloc and free hooks was about a quarter to a third of the target's
// samples (perf with frame pointers: Allocate, MallocHook, quarantine recycling).
//
// What: install_gmp_pool() points GMP's allocate/reallocate/free functions
// (mp_set_memory_functions) at per-thread free lists of 16-byte size classes up to
// 512 bytes, carved from one reserved address range (mmap, reserved on first use and
// never returned). Larger blocks and blocks that GMP allocated before the pool was
// installed (static CGAL or gmpxx objects) go to malloc/realloc/free: a block is the
// pool's exactly when its address lies in the reserved range, so installing the pool
// at any time is safe. Any thread may free a block (it joins that thread's list).
//
// What it changes for the sanitizers: GMP itself is not instrumented, so ASan never
// checked its limb accesses; what it no longer sees is a use of limbs after their mpq
// is cleared through a dangling pointer of ours (the mpq structs themselves stay in our
// objects, which ASan still watches). VISGATE_FUZZ_GMP_POOL=0 in the environment
// leaves GMP on malloc, for a report that needs it.
#pragma once

namespace visgate::fuzz {

// Installs the pool once per process (later calls do nothing). Returns true when the
// pool is in use (false: switched off by VISGATE_FUZZ_GMP_POOL=0, or the address range
// could not be reserved).
bool install_gmp_pool();

}  // namespace visgate::fuzz
