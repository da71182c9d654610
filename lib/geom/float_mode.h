// IEEE float mode for exact and float32 computations (DESIGN section 2).
//
// Embree's device makes every TBB worker thread run with flush-to-zero (FTZ) and
// denormals-are-zero (DAZ) set in MXCSR once an Embree scene exists (measured: 0x9fc0
// inside parallel_for bodies, 0x1fa0 on the main thread). Under DAZ a denormal input
// reads as 0 and under FTZ a denormal result becomes 0: a method would solve a slightly
// different scene than the one it was given, its answers would depend on which thread
// ran a receiver (a vertex at 1.2e-38 read as 0 can flip a relation of margin 1e-3), and
// CGAL's filtered predicates, whose error bounds assume IEEE
// gradual underflow, could return a wrong sign. Code that must see the inputs as given
// (the oracles, the methods, the double-precision ray tests) opens an IeeeFloatMode
// scope: both modes cleared, the previous MXCSR restored on exit. Rounding stays
// round-to-nearest (Embree never changes it).
#pragma once

#if defined(__SSE2__)
#include <xmmintrin.h>
#endif

namespace visgate {

class IeeeFloatMode {
 public:
#if defined(__SSE2__)
  static constexpr unsigned kFlushToZero = 0x8000u, kDenormalsAreZero = 0x0040u;
  IeeeFloatMode() : IeeeFloatMode(current_csr()) {}
  // The same with the caller's MXCSR already read (`csr`, from current_csr() on this
  // thread): hot callbacks skip the read (stmxcsr costs about as much as a small
  // geometric test on some cores).
  explicit IeeeFloatMode(unsigned csr) : saved_(csr) {
    if (saved_ & (kFlushToZero | kDenormalsAreZero)) _mm_setcsr(saved_ & ~(kFlushToZero | kDenormalsAreZero));
  }
  static unsigned current_csr() { return _mm_getcsr(); }
  ~IeeeFloatMode() {
    if (saved_ & (kFlushToZero | kDenormalsAreZero)) _mm_setcsr(saved_);
  }
#else
  IeeeFloatMode() = default;
  explicit IeeeFloatMode(unsigned) {}
  static unsigned current_csr() { return 0; }
#endif
  IeeeFloatMode(const IeeeFloatMode&) = delete;
  IeeeFloatMode& operator=(const IeeeFloatMode&) = delete;

 private:
#if defined(__SSE2__)
  unsigned saved_;
#endif
};

}  // namespace visgate
