// Axis-aligned bounding boxes in float32 and the conservative triangle/box overlap test
// used by the point trees (paper 000 section 4.3) and the acceleration structures.
#pragma once

#include <limits>

#include "lib/geom/vec.h"

namespace visgate {

struct AABB {
  Vec3f lo{std::numeric_limits<float>::infinity(), std::numeric_limits<float>::infinity(),
           std::numeric_limits<float>::infinity()};
  Vec3f hi{-std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
           -std::numeric_limits<float>::infinity()};

  AABB() = default;
  AABB(const Vec3f& a, const Vec3f& b) : lo(vmin(a, b)), hi(vmax(a, b)) {}

  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const Vec3f& p) { lo = vmin(lo, p); hi = vmax(hi, p); }
  void extend(const AABB& b) { lo = vmin(lo, b.lo); hi = vmax(hi, b.hi); }
  Vec3f extent() const { return hi - lo; }
  Vec3f center() const { return (lo + hi) * 0.5f; }
  int longest_axis() const { return max_axis(extent()); }
  float surface_area() const {
    if (empty()) return 0.0f;
    Vec3f e = extent();
    return 2.0f * (e.x * e.y + e.y * e.z + e.z * e.x);
  }
  double diagonal() const { return empty() ? 0.0 : length(to_double(hi) - to_double(lo)); }
  bool contains(const Vec3f& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  bool overlaps(const AABB& b) const {
    return lo.x <= b.hi.x && b.lo.x <= hi.x && lo.y <= b.hi.y && b.lo.y <= hi.y && lo.z <= b.hi.z &&
           b.lo.z <= hi.z;
  }
};

// Triangle/box overlap by the separating axis theorem (Akenine-Moller), evaluated in
// double on float inputs and with the box grown by a relative margin, so that it never
// answers "disjoint" for a triangle that touches the box: the products of float32
// inputs are exact in double and the few remaining roundings are far below the margin.
// Conservative: may answer "overlaps" for a triangle just outside the box.
bool triangle_overlaps_aabb(const Vec3f& a, const Vec3f& b, const Vec3f& c, const AABB& box);

}  // namespace visgate
