// Axis-aligned bounding boxes (float32 and double) and the conservative triangle/box overlap test
// used by the point trees (paper 000 section 4.3) and the acceleration structures.
#pragma once

#include <limits>

#include "lib/geom/vec.h"

namespace visgate {

template <class T>
struct AABBT {
  Vec3<T> lo{std::numeric_limits<T>::infinity(), std::numeric_limits<T>::infinity(),
             std::numeric_limits<T>::infinity()};
  Vec3<T> hi{-std::numeric_limits<T>::infinity(), -std::numeric_limits<T>::infinity(),
             -std::numeric_limits<T>::infinity()};

  AABBT() = default;
  AABBT(const Vec3<T>& a, const Vec3<T>& b) : lo(vmin(a, b)), hi(vmax(a, b)) {}

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const Vec3<T>& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  void extend(const AABBT& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
  Vec3<T> extent() const { return hi - lo; }
  Vec3<T> center() const { return (lo + hi) * T(0.5); }
  int longest_axis() const { return max_axis(extent()); }
  T surface_area() const {
    if (empty()) return T(0);
    Vec3<T> e = extent();
    return T(2) * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
  double diagonal() const { return empty() ? 0.0 : length(Vec3d(hi) - Vec3d(lo)); }
  bool contains(const Vec3<T>& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  bool overlaps(const AABBT& b) const {
    return lo.x <= b.hi.x && b.lo.x <= hi.x && lo.y <= b.hi.y && b.lo.y <= hi.y && lo.z <= b.hi.z &&
           b.lo.z <= hi.z;
  }
};
// The one box type: float32 for scene data, double for exact-in-double derived data.
using AABB = AABBT<float>;
using AABBd = AABBT<double>;

// Triangle/box overlap by the separating axis theorem (Akenine-Moller), evaluated in
// double on float inputs and with the box grown by a relative margin, so that it never
// answers "disjoint" for a triangle that touches the box: the products of float32
// inputs are exact in double and the few remaining roundings are far below the margin.
// Conservative: may answer "overlaps" for a triangle just outside the box.
bool triangle_overlaps_aabb(const Vec3f& a, const Vec3f& b, const Vec3f& c, const AABB& box);

}  // namespace visgate
