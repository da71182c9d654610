// Conservative triangle/AABB separating-axis test (see aabb.h).
#include "lib/geom/aabb.h"

#include <cmath>

namespace visgate {

bool triangle_overlaps_aabb(const Vec3f& a, const Vec3f& b, const Vec3f& c, const AABB& box) {
  if (box.empty()) return false;
  // Box bounds first: the cheapest early exit.
  Vec3f tlo = vmin(a, vmin(b, c)), thi = vmax(a, vmax(b, c));
  if (!AABB(tlo, thi).overlaps(box)) return false;

  Vec3d center = (to_double(box.lo) + to_double(box.hi)) * 0.5;
  Vec3d half = (to_double(box.hi) - to_double(box.lo)) * 0.5;
  // Grow by 2^-20 of the box size plus the magnitude of the coordinates: the
  // remaining double roundings (relative 2^-52 per operation, a few dozen operations)
  // stay many orders of magnitude below this.
  double mag = std::max({std::abs(center.x), std::abs(center.y), std::abs(center.z),
                         max_component(half)});
  double grow = mag * 0x1p-20 + 1e-300;
  half = half + Vec3d(grow, grow, grow);

  Vec3d v0 = to_double(a) - center, v1 = to_double(b) - center, v2 = to_double(c) - center;
  Vec3d e[3] = {v1 - v0, v2 - v1, v0 - v2};

  // Nine cross-product axes.
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) {
      Vec3d axis_unit(0, 0, 0);
      axis_unit[k] = 1.0;
      Vec3d ax = cross(axis_unit, e[i]);
      double p0 = dot(v0, ax), p1 = dot(v1, ax), p2 = dot(v2, ax);
      double r = half.x * std::abs(ax.x) + half.y * std::abs(ax.y) + half.z * std::abs(ax.z);
      double mn = std::min({p0, p1, p2}), mx = std::max({p0, p1, p2});
      if (mn > r || mx < -r) return false;
    }
  }
  // Triangle plane.
  Vec3d n = cross(e[0], v2 - v0);
  double d = dot(n, v0);
  double r = half.x * std::abs(n.x) + half.y * std::abs(n.y) + half.z * std::abs(n.z);
  if (std::abs(d) > r) return false;
  return true;
}

}  // namespace visgate
