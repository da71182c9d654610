// `embree` and `embree-robust`: one Embree occlusion ray per relation (DESIGN section 4).
//
// Guarantee: none beyond Embree's own float32 behaviour. The ray of relation (r, l) has
// origin r, direction l - r (not normalised), tnear = 0 and tfar = 1, so its parameter
// range is exactly the segment; Embree's intersectors accept hits with t in roughly
// (tnear, tfar], so a surface touching the light end may count as a hit and one touching
// the receiver end may not. These endpoint contacts are relations the oracle classifies
// with margin 0 (or as degenerate), outside the gate, and no epsilon offset is added:
// the baseline is measured as users would run it. `embree-robust` sets
// RTC_SCENE_FLAG_ROBUST (watertight traversal and intersection, no cracks between
// triangles that share an edge).
#pragma once

#include "lib/solver.h"

namespace visgate::raycast {

// A committed Embree scene over a triangle soup, for methods that cast rays (ISS leaves,
// SSV's reference ray) as well as for the baseline itself. Thread-safe queries.
class EmbreeScene {
 public:
  EmbreeScene(const TriangleSoup& soup, bool robust);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // True when some triangle blocks the segment from `from` to `to` (parameter range
  // [0, 1] of from + t (to - from), Embree's own endpoint semantics).
  bool occluded(const Vec3f& from, const Vec3f& to) const;

 private:
  void* device_;
  void* scene_;
};

class EmbreeSolver : public Solver {
 public:
  explicit EmbreeSolver(bool robust) : robust_(robust) {}
  std::string name() const override { return robust_ ? "embree-robust" : "embree"; }
  SolveResult solve(const Scene& scene, const SolveOptions& opt) override;

 private:
  bool robust_;
};

}  // namespace visgate::raycast
