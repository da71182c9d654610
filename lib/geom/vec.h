// Vec3<T>: 3-vectors over any number type (float for production code, double for
// estimates, an exact rational in the oracle). The formulas are written once here and
// instantiated per number type (CGAL kernel style, ../shared/STYLE.md).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>

namespace visgate {

template <class T>
struct Vec3 {
  T x{}, y{}, z{};

  constexpr Vec3() = default;
  constexpr Vec3(T x_, T y_, T z_) : x(x_), y(y_), z(z_) {}
  template <class U>
  constexpr explicit Vec3(const Vec3<U>& o) : x(T(o.x)), y(T(o.y)), z(T(o.z)) {}

  constexpr T& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr const T& operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }

  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(const T& s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(const T& s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr Vec3& operator-=(const Vec3& o) { x -= o.x; y -= o.y; z -= o.z; return *this; }
  constexpr Vec3& operator*=(const T& s) { x *= s; y *= s; z *= s; return *this; }
  constexpr bool operator==(const Vec3& o) const { return x == o.x && y == o.y && z == o.z; }
  constexpr bool operator!=(const Vec3& o) const { return !(*this == o); }
};

using Vec3f = Vec3<float>;
using Vec3d = Vec3<double>;

template <class T> constexpr Vec3<T> operator*(const T& s, const Vec3<T>& v) { return v * s; }
template <class T> constexpr T dot(const Vec3<T>& a, const Vec3<T>& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
template <class T> constexpr Vec3<T> cross(const Vec3<T>& a, const Vec3<T>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <class T> inline T length(const Vec3<T>& a) { return std::sqrt(dot(a, a)); }
template <class T> inline Vec3<T> normalize(const Vec3<T>& a) { return a / length(a); }
template <class T> constexpr Vec3<T> vmin(const Vec3<T>& a, const Vec3<T>& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
template <class T> constexpr Vec3<T> vmax(const Vec3<T>& a, const Vec3<T>& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
template <class T> constexpr T max_component(const Vec3<T>& a) { return std::max(a.x, std::max(a.y, a.z)); }
template <class T> constexpr int max_axis(const Vec3<T>& a) {
  return (a.x >= a.y && a.x >= a.z) ? 0 : (a.y >= a.z ? 1 : 2);
}
template <class T> inline Vec3<T> vabs(const Vec3<T>& a) { return {std::abs(a.x), std::abs(a.y), std::abs(a.z)}; }

inline Vec3d to_double(const Vec3f& v) { return Vec3d(v); }

// True when every coordinate is finite (not NaN, not +-Inf).
inline bool is_finite(const Vec3f& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Bit pattern of a float with -0 mapped to +0, so that positions that compare equal
// as floats hash equal (used by welding).
inline uint32_t canonical_bits(float f) {
  if (f == 0.0f) f = 0.0f;
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  return u;
}

}  // namespace visgate
