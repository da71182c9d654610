// The candidate pairs of mesh repair (self-intersection pairs, T-junction vertex/edge
// pairs): the shared hierarchy (lib/accel/bvh.h) over closed double boxes, median splits
// of four boxes per leaf, item boxes kept in leaf order for the leaf scans. Boxes are
// min/max of input coordinates, which is exact, and the overlap test compares them
// exactly, so no overlapping pair is ever missed (the tree is a filter; every decision is
// made afterwards by an exact predicate).
//
// The build and self_pairs_parallel run on TBB; node numbering and leaf order do not
// depend on the thread count, so neither do the pairs reported.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/accel/bvh_pairs.h"
#include "lib/geom/aabb.h"

namespace visgate::mesh {

using Box3d = AABBd;

inline bool boxes_overlap(const Box3d& a, const Box3d& b) { return a.overlaps(b); }

class BoxTree {
 public:
  static constexpr accel::BuildRule kRule{accel::Split::MedianAxis, 4, true};

  explicit BoxTree(const std::vector<Box3d>& boxes) : bvh_(boxes, kRule) {}

  // f(i) for every box i with may_meet(box i), visiting only nodes with may_meet(node
  // box). may_meet must be conservative: true for every box that holds a wanted element
  // and for every box containing such a box.
  template <class Pred, class F>
  void query_if(Pred&& may_meet, F&& f) const {
    bvh_.query_if(may_meet, f);
  }

  // f(i) for every box i overlapping q.
  template <class F>
  void query(const Box3d& q, F&& f) const {
    bvh_.query_if([&](const Box3d& b) { return b.overlaps(q); }, f);
  }

  // f(i, j) once for every unordered pair i != j of overlapping boxes.
  template <class F>
  void self_pairs(F&& f) const {
    accel::self_pairs(bvh_, f);
  }

  // The same pairs, f(local, i, j) called concurrently from TBB worker threads with
  // local = locals.local() of the calling thread (lib/accel/bvh_pairs.h).
  template <class Local, class F>
  void self_pairs_parallel(tbb::enumerable_thread_specific<Local>& locals, F&& f) const {
    accel::self_pairs_parallel(bvh_, locals, f);
  }

 private:
  accel::Bvh<double> bvh_;
};

}  // namespace visgate::mesh
