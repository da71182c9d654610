// Haines' shaft between two axis-aligned boxes ("Shaft culling for efficient ray-cast
// radiosity", Haines & Wallace 1991; Haines, "Graphics Gems" / [Hai00] as cited by paper
// 002 section 4.4 implementation details): the bounding box of both boxes cut by the
// planes through one edge of each box that support the convex hull of the two (candidate
// planes shared with ISS: lib/geom/haines_shaft.h, which names the differences). Used to
// select the occluders of a receiver group and a light.
//
// Guarantee: conservative. The planes are built and evaluated in double on float inputs
// and a triangle is culled only when all its vertices are outside one plane by more than
// a margin of 2^-20 of the shaft's extent plus its distance from the origin, far above
// the double rounding of these evaluations (about 1e-15 relative); a triangle meeting
// the convex hull of the two boxes is never culled.
#pragma once

#include <vector>

#include "lib/geom/aabb.h"
#include "lib/geom/plane.h"
#include "lib/geom/vec.h"

namespace visgate::plucker {

class Shaft {
 public:
  Shaft(const AABB& a, const AABB& b);
  // True when the triangle certainly misses the convex hull of the two boxes.
  bool culls(const Vec3f& p0, const Vec3f& p1, const Vec3f& p2) const;
  // True when the box [lo, hi] certainly misses the convex hull of the two boxes: outside
  // the bounding box, or all of it outside one plane (its corner nearest the plane's
  // inner side), with the same margin as culls(). A box that is not culled may still hold
  // only culled triangles.
  bool culls_box(const Vec3f& lo, const Vec3f& hi) const;
  size_t plane_count() const { return planes_.size(); }

 private:
  Vec3d lo_, hi_;
  double margin_ = 0.0;
  std::vector<Planed> planes_;  // unit normals
};

}  // namespace visgate::plucker
