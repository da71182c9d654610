// Three floats in the low lanes of an SSE2 register (lane 3 is don't-care), for bounds
// taken a point at a time: lanes_min(acc, x) and lanes_max(acc, x) are the comparisons of
// std::min(acc, x) and std::max(acc, x) per component (x < acc ? x : acc and
// acc < x ? x : acc, NaNs included), so a box accumulated here has the floats the scalar
// form (AABB::extend) gives, with a third of its operations.
#pragma once

#include <algorithm>
#include <cmath>

#include "lib/geom/aabb.h"
#include "lib/geom/vec.h"

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

namespace visgate {

static_assert(sizeof(Vec3f) == 3 * sizeof(float));

#if defined(__SSE2__)
using Lanes = __m128;
inline Lanes lanes_load(const float* p) {
  return _mm_movelh_ps(_mm_loadl_pi(_mm_setzero_ps(), reinterpret_cast<const __m64*>(p)), _mm_load_ss(p + 2));
}
inline Lanes lanes_set(float v) { return _mm_set1_ps(v); }
inline Lanes lanes_min(Lanes acc, Lanes x) { return _mm_min_ps(x, acc); }
inline Lanes lanes_max(Lanes acc, Lanes x) { return _mm_max_ps(x, acc); }
inline void lanes_store(Lanes v, float* p) {
  alignas(16) float t[4];
  _mm_store_ps(t, v);
  p[0] = t[0], p[1] = t[1], p[2] = t[2];
}
#else
struct Lanes {
  float v[3];
};
inline Lanes lanes_load(const float* p) { return {{p[0], p[1], p[2]}}; }
inline Lanes lanes_set(float v) { return {{v, v, v}}; }
inline Lanes lanes_min(Lanes acc, Lanes x) {
  for (int c = 0; c < 3; ++c) acc.v[c] = std::min(acc.v[c], x.v[c]);
  return acc;
}
inline Lanes lanes_max(Lanes acc, Lanes x) {
  for (int c = 0; c < 3; ++c) acc.v[c] = std::max(acc.v[c], x.v[c]);
  return acc;
}
inline void lanes_store(Lanes v, float* p) { p[0] = v.v[0], p[1] = v.v[1], p[2] = v.v[2]; }
#endif
inline Lanes lanes_load(const Vec3f& v) { return lanes_load(&v.x); }

// A box accumulated a point at a time in lanes: box() has the floats of AABB::extend
// over the same points in the same order.
struct LanesBox {
  Lanes lo = lanes_set(INFINITY), hi = lanes_set(-INFINITY);
  void add(const Vec3f& v) {
    const Lanes x = lanes_load(v);
    lo = lanes_min(lo, x);
    hi = lanes_max(hi, x);
  }
  AABB box() const {
    AABB b;
    lanes_store(lo, &b.lo.x);
    lanes_store(hi, &b.hi.x);
    return b;
  }
};

}  // namespace visgate
