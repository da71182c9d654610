// The near polygons' pyramid test (shade_receiver.cpp subtract_near, block_outside): a
// point strictly outside a side plane of the pyramid (r, light) by the test's margin.
// Internal to lib/plucker; a header of its own for its test (pyramid_side_test.cpp).
#pragma once

#include <cmath>
#include <cstdint>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lib/geom/vec.h"

namespace visgate::plucker {

// What the test reads of the pyramid's side plane j for one receiver: n its normal, l
// its point (light vertex j), w the weights of its evaluation bound dot_err(d, n, err) =
// sum |d_i| w_i and c = 4 u_d |n|_1, the shift's factor (shade_receiver.cpp
// pyramid_planes).
struct PyramidPlane {
  Vec3d n, l, w;
  double c = 0.0;
#if defined(__SSE2__)
  // n, l and w, each coordinate in both lanes (all_outside; set_lanes).
  __m128d nx, ny, nz, lx, ly, lz, wx, wy, wz;
#endif
  void set_lanes() {
#if defined(__SSE2__)
    nx = _mm_set1_pd(n.x), ny = _mm_set1_pd(n.y), nz = _mm_set1_pd(n.z);
    lx = _mm_set1_pd(l.x), ly = _mm_set1_pd(l.y), lz = _mm_set1_pd(l.z);
    wx = _mm_set1_pd(w.x), wy = _mm_set1_pd(w.y), wz = _mm_set1_pd(w.z);
#endif
  }
};

// d = x - l strictly outside side plane pp by the pyramid test's margin: dot(n, d) <
// -16 dot_err(d, n, err) - shift. Shared by block_outside and subtract_near; a value
// not below 0 cannot be below -16 e - shift <= 0, so the bound is skipped there.
inline bool outside_side(const PyramidPlane& pp, const Vec3d& d, double shift) {
  const double s = dot(pp.n, d);
  if (!(s < 0.0)) return false;
  const double e = std::abs(d.x) * pp.w.x + std::abs(d.y) * pp.w.y + std::abs(d.z) * pp.w.z;
  return s < -16.0 * e - shift;
}

// Every vertex of pv[0, n) outside side plane pp (outside_side at each, pp.set_lanes()
// called since pp last changed). With SSE2 two vertices at a time: per lane the scalar
// test's value s = dot(n, v - l), its bound e and the comparison s < -16 e - shift, the
// same operations in the same order (the scalar test's s < 0 first only skips e: where
// s >= 0, -16 e - shift <= 0 rejects it too, NaN included); the answer, every vertex
// outside, does not depend on their order. The near polygons have about four vertices
// (columns: 784k vertex tests, 135k rejected polygons of 3.98 vertices).
inline bool all_outside(const PyramidPlane& pp, const Vec3d* pv, uint32_t n, double shift) {
  uint32_t k = 0;
#if defined(__SSE2__)
  const __m128d sh = _mm_set1_pd(shift), m16 = _mm_set1_pd(-16.0), sgn = _mm_set1_pd(-0.0);
  for (; k + 2 <= n; k += 2) {
    const __m128d dx = _mm_sub_pd(_mm_loadh_pd(_mm_load_sd(&pv[k].x), &pv[k + 1].x), pp.lx);
    const __m128d dy = _mm_sub_pd(_mm_loadh_pd(_mm_load_sd(&pv[k].y), &pv[k + 1].y), pp.ly);
    const __m128d dz = _mm_sub_pd(_mm_loadh_pd(_mm_load_sd(&pv[k].z), &pv[k + 1].z), pp.lz);
    const __m128d sv = _mm_add_pd(_mm_add_pd(_mm_mul_pd(pp.nx, dx), _mm_mul_pd(pp.ny, dy)), _mm_mul_pd(pp.nz, dz));
    const __m128d e =
        _mm_add_pd(_mm_add_pd(_mm_mul_pd(_mm_andnot_pd(sgn, dx), pp.wx), _mm_mul_pd(_mm_andnot_pd(sgn, dy), pp.wy)),
                   _mm_mul_pd(_mm_andnot_pd(sgn, dz), pp.wz));
    if (_mm_movemask_pd(_mm_cmplt_pd(sv, _mm_sub_pd(_mm_mul_pd(m16, e), sh))) != 3) return false;
  }
#endif
  for (; k < n; ++k)
    if (!outside_side(pp, pv[k] - pp.l, shift)) return false;
  return true;
}

}  // namespace visgate::plucker
