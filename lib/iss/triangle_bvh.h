// A static bounding volume hierarchy over the triangle boxes of the prepared mesh, built
// once per solve and shared by every light. It answers the two queries that otherwise
// scan the whole mesh once per light (paper 000 sections 4.3 and 4.8): the triangles
// whose box meets a light tree's root box (the root's inside list, Figure 4.2) and the
// triangles whose box may meet the root shaft (the triangle array that COMPUTE-SHADOWS,
// Figure 4.32, starts PRE-TRAVERSE with, which the thesis fills with every triangle);
// and the triangles the leaf rays of several lights may meet (the union over their root
// shafts, iss_solver.cpp).
//
// The shared hierarchy (lib/accel/bvh.h) with its Morton rule: Morton order of the box
// centres (radix sort), then balanced halving of that order down to leaves of 8; linear
// in the triangle count.
//
// Guarantee: both queries return a superset, sorted by index, of what they select:
// a triangle is left out only when its box (float32, exact) is disjoint from the query
// box, or when a node box that contains it is outside a shaft plane by more than the
// plane's tolerance (ShaftGeometry::may_intersect_box, conservative; the shaft query
// returns whole leaves). Every consumer re-tests each returned triangle exactly as it
// tested the whole mesh before, so the results do not change, only the cost.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/geom/aabb.h"
#include "lib/iss/shaft.h"

namespace visgate::iss {

class TriangleBvh {
 public:
  static constexpr accel::BuildRule kRule{accel::Split::MortonHalves, 8, false};

  // The boxes must outlive the tree (the box query tests them).
  explicit TriangleBvh(const std::vector<AABB>& triangle_boxes);

  // Triangles whose box overlaps `box` (closed boxes).
  void query_box(const AABB& box, std::vector<uint32_t>& out) const;
  // Triangles whose box may intersect the shaft `g` (and others of the same leaves).
  void query_shaft(const ShaftGeometry& g, std::vector<uint32_t>& out) const;
  // The size query_shaft's `out` would have when it is below `limit`, else some count
  // of at least `limit` (the walk stops there), without collecting or sorting.
  size_t count_shaft(const ShaftGeometry& g, size_t limit) const;
  // Triangles whose box may intersect one of the shafts: one walk for all, a node
  // entered and a triangle taken when some shaft may meet its box. Each triangle is
  // tested: a leaf's other triangles may be large (a floor slab), and every one in the
  // leaf caster's scene costs its rays.
  void query_shafts(const std::vector<ShaftGeometry>& gs, std::vector<uint32_t>& out) const;

  size_t node_count() const { return bvh_.node_count(); }
  const accel::Bvh<float>& tree() const { return bvh_; }
  size_t memory_bytes() const { return bvh_.memory_bytes(); }

 private:
  template <class Pred>
  void collect(Pred&& visit, bool test_leaf_triangles, std::vector<uint32_t>& out) const;

  const std::vector<AABB>& boxes_;
  accel::Bvh<float> bvh_;
};

}  // namespace visgate::iss
