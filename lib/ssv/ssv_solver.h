// `ssv`: the improved physically-based soft shadow volume algorithm of Lehtinen, Laine
// and Aila (paper 001): potential silhouette edges and penumbra wedges (section 2.1), the
// lazy 3D wedge BSP of section 4.1 (Figure 5) in place of the hemicube, silhouette
// regions (section 4.2, option silhouette_regions=on|off), and per receiver: BSP query,
// wedge validation, projection of the silhouette edges onto the light plane, integration
// of relative depth complexity per sample (integrate.h) and one reference ray.
//
// Each light is processed in turn with its own wedges and BSP. Per receiver and light:
// the samples of minimum relative depth complexity are visible iff one Embree ray
// (RTC_SCENE_FLAG_ROBUST) to the first of them is unblocked; all others are blocked.
// Beyond the paper, a second (check) ray goes to a sample of the next-lowest class, which
// must be blocked; when it is not, the counters are inconsistent (a near-degenerate
// projection, e.g. a sample within rounding of an edge-on sliver, produced a spurious
// class) and that receiver is answered by one ray per sample (stats:
// inconsistent_receivers, fallback_relations).
//
// Guarantee: float32, correct for inputs away from degeneracy. Failure modes (all
// near-degenerate; see integrate.h and wedge.h for details): samples within rounding of a
// projected silhouette edge; receivers within rounding of a triangle's plane; projected
// edges touching the boundary of the expanded light; edges through the receiver; the
// reference ray inherits Embree's endpoint semantics (a surface touching the sample or
// the receiver). Receivers on or behind the light plane (frame height <= 0), and every
// receiver of a light whose jitter points lie off its plane by more than 1e-5 of its
// extent, are answered by one Embree ray per relation instead (counted in stats as
// fallback_relations).
//
// Stats (paper 001 Tables 2-4): queries, wedges_reported and wedges_validated (per query
// averages), acceptance_ratio, wedges, bsp_nodes, memory_mb (peak BSP plus wedges and
// per-light arrays), init_seconds (edges, wedges), embree_build_seconds, and the per-phase
// times bsp_build_query_seconds, validation_seconds, projection_integration_seconds,
// reference_ray_seconds summed over threads (thread-seconds; the ray time includes the
// fallback rays), reference_rays (reference and check rays), plus prepare_seconds (mesh
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
