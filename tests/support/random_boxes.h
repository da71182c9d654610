// Random axis-aligned boxes for the hierarchy tests (tests/accel): mixed sizes in a cube,
// a quarter of them points (degenerate boxes), about a tenth exact duplicates of earlier
// boxes (equal split keys, so ties are broken by index).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "lib/geom/aabb.h"

namespace visgate::test {

// n boxes with lower corners in [offset, offset + extent]^3 and sides up to max_side.
template <class T>
std::vector<AABBT<T>> random_boxes(size_t n, uint32_t seed, double offset, double extent, double max_side) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> pos(0.0, extent), side(0.0, max_side);
  std::vector<AABBT<T>> out;
  for (size_t i = 0; i < n; ++i) {
    if (i > 0 && rng() % 10 == 0) {
      out.push_back(out[rng() % out.size()]);
      continue;
    }
    const Vec3<T> lo(T(offset + pos(rng)), T(offset + pos(rng)), T(offset + pos(rng)));
    Vec3<T> hi = lo;
    if (rng() % 4 != 0) hi = lo + Vec3<T>(T(side(rng)), T(side(rng)), T(side(rng)));
    out.push_back(AABBT<T>(lo, hi));
  }
  return out;
}

}  // namespace visgate::test
