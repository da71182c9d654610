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
//
// Scale: a baseline answers the scene as given (Solver::normalises_scale is false), as its
// users run it; `visgate bench stability` charts its mismatch rate per exact 2^k copy.
//
// The rays go through EmbreeScene (embree_scene.h) with hit verification off, so the
// baseline is measured as users run Embree.
#pragma once

#include "lib/raycast/embree_scene.h"
#include "lib/solver.h"

namespace visgate::raycast {

class EmbreeSolver : public Solver {
 public:
  explicit EmbreeSolver(bool robust) : robust_(robust) {}
  std::string name() const override { return robust_ ? "embree-robust" : "embree"; }
  // A baseline: answers the scene as given (Solver::normalises_scale).
  bool normalises_scale() const override { return false; }

 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;

 private:
  bool robust_;
};

}  // namespace visgate::raycast
