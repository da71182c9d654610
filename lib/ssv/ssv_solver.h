// `ssv`: the improved physically-based soft shadow volume algorithm of Lehtinen, Laine
// and Aila (paper 001): potential silhouette edges and penumbra wedges (section 2.1), the
// lazy 3D wedge BSP of section 4.1 (Figure 5) in place of the hemicube, silhouette
// regions (section 4.2, option silhouette_regions=on|off), and per receiver: BSP query,
// wedge validation, projection of the silhouette edges onto the light plane, integration
// of relative depth complexity per sample (integrate.h) and one reference ray.
//
// Each light is processed in turn with its own wedges and BSP. Per receiver and light:
// the samples of minimum relative depth complexity are visible iff one Embree ray
// (RTC_SCENE_FLAG_ROBUST) to one of them is unblocked; all others are blocked. The
// reference sample is chosen clear of every projected piece (integrate.h, "Reference-
// sample clearance": a sample exactly on a projected silhouette edge, common in
// grid-snapped scenes and in far-origin scenes whose coordinates round onto common lines,
// touches the edge, and its ray would decide its whole class by a degenerate answer);
// when none of the first 8 samples of the class is clear, the receiver is answered by one
// ray per sample (stat doubtful_receivers). Beyond the paper, a second (check) ray goes to
// a clear sample of the next-lowest class, which must be blocked; when it is not, the
// counters are inconsistent (a near-degenerate projection, e.g. a sample within rounding
// of an edge-on sliver, produced a spurious class) and that receiver is answered by one
// ray per sample (stats: inconsistent_receivers, fallback_relations).
//
// Precision. Projection and integration run in the light's frame (origin at the light's
// vertex average, coordinates computed in double and rounded once to float), so their
// rounding scales with the distance to the light, not with the distance to the world
// origin. Wedge planes and the BSP stay in world coordinates with a tolerance of 4e-6 of
// the largest coordinate (ssv_solver.cpp): far from the origin they are looser (less
// culling), never tighter, so correctness does not depend on them.
//
// Guarantee: float32, correct for inputs away from degeneracy, and for the exact
// degeneracies named above (reference sample on a projected edge, edges in the light
// plane, triangles touching the light plane) by construction. Remaining failure modes
// (all near-degenerate; see integrate.h and wedge.h for details): samples within rounding
// of a projected silhouette edge may get a wrong count (only their own answer, unless the
// check ray catches it); receivers within rounding of a triangle's plane; projected edges
// touching the boundary of the expanded light; edges through the receiver; rays
// inherit Embree's endpoint semantics (a surface touching the sample or the receiver).
// Receivers on or behind the light plane (frame height <= 0), and every receiver of a
// light whose jitter points lie off its plane by more than 1e-5 of its extent, are
// answered by one Embree ray per relation instead (counted in stats as
// fallback_relations).
//
// Stats (paper 001 Tables 2-4): queries, wedges_reported and wedges_validated (per query
// averages), acceptance_ratio, wedges, bsp_nodes, memory_mb (peak BSP plus wedges and
// per-light arrays), init_seconds (edges, wedges), embree_build_seconds, and the per-phase
// times bsp_build_query_seconds, validation_seconds, projection_integration_seconds,
// reference_ray_seconds summed over threads (thread-seconds; the ray time includes the
// fallback rays), reference_rays (reference and check rays), inconsistent_receivers and
// doubtful_receivers (answered by one ray per sample, see above), plus prepare_seconds (mesh
// preparation, excluded from `seconds`).
#pragma once

#include "lib/solver.h"

namespace visgate::ssv {

class SsvSolver : public Solver {
 public:
  std::string name() const override { return "ssv"; }
  std::vector<OptionSpec> options() const override {
    return {{"silhouette_regions", "cull wedges outside their silhouette regions in the BSP (section 4.2)", {"on", "off"}}};
  }
  SolveResult solve(const Scene& scene, const SolveOptions& opt) override;
};

}  // namespace visgate::ssv
