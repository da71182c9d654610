// Repair's exact backend: ExactPredicates (lib/repair/repair.h) implemented with CGAL.
// Epick's filtered predicates are exact on double input (collinearity, orientation,
// coplanar orientation, segment/triangle and triangle/triangle intersection); distances
// and volume sums use interval filters backed by exact rationals. The only file of
// lib/repair that includes CGAL (DESIGN section 2: production methods never do).
#pragma once

#include "lib/repair/repair.h"

namespace visgate::mesh {

class CgalExactPredicates final : public ExactPredicates {
 public:
  bool collinear(const Vec3d& a, const Vec3d& b, const Vec3d& c) const override;
  int orientation(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d) const override;
  int coplanar_side(const Vec3d& a, const Vec3d& b, const Vec3d& p, const Vec3d& q) const override;
  bool segment_triangle_intersect(const Vec3d& s0, const Vec3d& s1, const Vec3d& t0, const Vec3d& t1,
                                  const Vec3d& t2) const override;
  bool triangles_intersect(const Vec3d& a0, const Vec3d& a1, const Vec3d& a2, const Vec3d& b0, const Vec3d& b1,
                           const Vec3d& b2) const override;
  int compare_distance(const Vec3d& p, const Vec3d& q, double t) const override;
  int volume_sign(const std::vector<Vec3d>& v, const std::vector<std::array<uint32_t, 3>>& tris,
                  const std::vector<uint32_t>& subset) const override;
};

}  // namespace visgate::mesh
