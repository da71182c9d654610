// An orthonormal frame in double: origin and axes U, V, N with U x V = N. Local
// coordinates are dot products with the axes, computed in double (each within a few
// ulps of the exact value; the float variant rounds once more).
#pragma once

#include "lib/geom/vec.h"

namespace visgate {

struct Frame3d {
  Vec3d origin{}, U{}, V{}, N{};

  Vec3d to_local(const Vec3d& p) const {
    const Vec3d d = p - origin;
    return Vec3d(dot(d, U), dot(d, V), dot(d, N));
  }
  Vec3d to_local(const Vec3f& p) const { return to_local(Vec3d(p)); }
  Vec3f to_local_f(const Vec3f& p) const {
    const Vec3d l = to_local(p);
    return Vec3f(float(l.x), float(l.y), float(l.z));
  }
  double height(const Vec3d& p) const { return dot(p - origin, N); }
};

}  // namespace visgate
