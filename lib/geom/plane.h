// Planes n.x = d in float32 and double.
#pragma once

#include "lib/geom/vec.h"

namespace visgate {

template <class T>
struct PlaneT {
  Vec3<T> n{};  // not necessarily unit length
  T d{};
  PlaneT() = default;
  PlaneT(const Vec3<T>& n_, T d_) : n(n_), d(d_) {}
  static PlaneT through(const Vec3<T>& a, const Vec3<T>& b, const Vec3<T>& c) {
    Vec3<T> nn = cross(b - a, c - a);
    return PlaneT(nn, dot(nn, a));
  }
  T eval(const Vec3<T>& p) const { return dot(n, p) - d; }
};
using Plane = PlaneT<float>;
using Planed = PlaneT<double>;

}  // namespace visgate
