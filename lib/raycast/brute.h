// `brute`: textbook float32 Möller-Trumbore against every triangle, no acceleration and
// no epsilon tricks (lib/geom/predicates.h). The fragile reference: it cracks between
// triangles sharing an edge and misjudges near-degenerate relations; every robust method
// must beat it. Open segment: hits with 0 < t < 1 only.
#pragma once

#include "lib/solver.h"

namespace visgate::raycast {

class BruteSolver : public Solver {
 public:
  std::string name() const override { return "brute"; }
  // A baseline: answers the scene as given (Solver::normalises_scale).
  bool normalises_scale() const override { return false; }

 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;
};

// One relation by brute force (exposed for tests and the minimiser).
bool brute_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to);

}  // namespace visgate::raycast
