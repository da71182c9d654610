// `ssv`: the improved physically-based soft shadow volume algorithm of Lehtinen, Laine
// and Aila (paper 001): potential silhouette edges and penumbra wedges (section 2.1), the
// lazy 3D wedge BSP of section 4.1 (Figure 5) in place of the hemicube, silhouette
// regions (section 4.2, option silhouette_regions=on|off), and per receiver: BSP query,
// wedge validation, projection of the silhouette edges onto the light plane, integration
// of relative depth complexity per sample (integrate.h) and one reference ray.
//
// Culling (docs/methods/ssv.md, "Culling"), each conservative: receivers a planar
// occluder hides from a light are answered blocked without integration (occluders.h).
// With wedge_index=edges (chosen by the default, auto, for meshes of at least 16 edges per
// receiver) no wedge is built: each receiver's candidate edges come from a walk of the
// edge hierarchy (edge_tree.h) that leaves out the subtrees outside its frustum to L' or
// proven weight 0 from it and the edges its leaves prove weight 0; build_wedges' edge
// tests and the weight validate the rest. With wedge_index=receivers (auto's choice
// otherwise), only edges inside the remaining receivers' shafts to the light get wedges
// and the wedges are scattered through the receiver tree (wedge_scatter.h);
// wedge_index=bsp keeps the lazy BSP of section 4.1.
//
// Each light is processed in turn with its own wedges. Per receiver and light:
// the samples of minimum relative depth complexity are visible iff one ray to a point
// of that class is unblocked; all others are blocked. Every ray asks Embree's robust
// scene with lib/raycast's hit verification: a hit stands only when the double-
// precision test of the same query confirms it (stat ray_disputes). Triangles narrower than
// 2^-20 of their length are left out of counting and rays alike (they decide only
// relations of margin below 1e-6; stat slivers_dropped), and SSV computes with FTZ and
// DAZ cleared (Embree sets them in TBB workers), so it reads denormal inputs as the
// oracle does (ssv_solver.cpp).
// Beyond the paper, a check ray to a class above the minimum must find it blocked. The
// reference point is kept clear of every projected piece and in general position, and
// hits within 2^-18 of either end of its segment are told apart from interior hits; a
// miss for which lib/raycast's hit verification rejected a candidate (the segment runs
// within Embree's rounding of a triangle's boundary, such as an interior edge) is not
// conclusive either (ssv_solver.cpp, "Reference rays"): one ray decides a whole class,
// so it must never be a near-degenerate relation. A receiver is answered by one ray per sample instead when
// its integration met an edge through the receiver (doubtful), when no reference among
// the first 8 clear samples of the minimum class is conclusive (doubtful), or when the
// check finds a class above the minimum unblocked (inconsistent); all counted in stats.
//
// Domain (DESIGN section 2, "Scale"): every scene of finite float32 coordinates.
// Solver::solve hands this method the scene's unit copy (lib/scene/exact_transform.h:
// scaled by the power of two that brings its unit length into [2, 4)), so
// every tolerance below is relative to lengths near 2, and a scene and each of its exact
// 2^k copies
// get the same answers bit for bit.
//
// Precision. Projection and integration run in the light's frame (origin at the light's
// vertex average): vertices and receivers are transformed, clipped to the pyramid over
// L' and projected in double and rounded once to float in the light plane, so the
// rounding scales with the light's extent, not with the distance to the world origin or
// to the receiver. Wedge planes and the BSP stay in world coordinates with a tolerance
// of 4e-6 of the largest coordinate (ssv_solver.cpp): far from the origin they are looser
// (less culling), never tighter, so correctness does not depend on them.
//
// Guarantee: float32 answers, correct for inputs away from degeneracy, and for the exact
// degeneracies named above (reference on a projected edge or vertex, light points on
// faces in the light plane, edges in the light plane, triangles touching the light
// plane) by construction. Remaining failure modes (all near-degenerate, see integrate.h
// and wedge.h): receivers within rounding of a triangle's plane (nearly edge-on ones
// are doubtful); projected edges touching the boundary of the expanded light;
// rays inherit Embree's endpoint semantics for the samples answered by rays. A sample
// within the counter's margin (1e-6 of the light-plane magnitudes) of a projected piece
// may be miscounted by that piece's weight, and its relation may still be decided far
// from degeneracy by another triangle: each such sample gets its own ray (stat
// unclear_relations; 12 of 1M relations on columns). Receivers on,
// behind or grazing the light plane (frame height at most 2^-20 of their distance
// scale, where heights are rounding noise: ssv_solver.cpp), and every receiver of a light whose
// jitter points lie off its plane by more than 1e-5 of its extent or far outside its
// polygon (light_frame.h), are answered by one Embree ray per relation instead (counted
// in stats as fallback_relations).
//
// Stats (paper 001 Tables 2-4): queries, wedges_reported and wedges_validated (per query
// averages; with the edge index: candidate edges and edges of nonzero weight), acceptance_ratio, wedges, bsp_nodes, memory_mb (peak BSP plus wedges and
// per-light arrays), init_seconds (edges, wedges), embree_build_seconds, and the per-phase
// times bsp_build_query_seconds, validation_seconds, projection_integration_seconds,
// reference_ray_seconds summed over threads (thread-seconds; the ray time includes the
// fallback rays), reference_rays (reference and check rays, ranged), fallback_relations,
// inconsistent_receivers and doubtful_receivers (answered by one ray per sample, see
// above), unchecked_receivers (no clear sample above the minimum class to check),
// unclear_relations, ray_disputes, slivers_dropped, the culling's occluders,
// occluded_relations, hidden_lights, edges_outside_shafts, scattered_candidates,
// edge_index (1 when the edge hierarchy answered), ray_solve (1 when every receiver was
// answered by its rays: docs/methods/ssv.md, "Solves by rays"), packet_undecided (segments packet_rays left to the verified ray) and occluder_seconds, plus prepare_seconds (mesh preparation, excluded from `seconds`).
#pragma once

#include "lib/solver.h"

namespace visgate::ssv {

class SsvSolver : public Solver {
 public:
  std::string name() const override { return "ssv"; }
  std::vector<OptionSpec> options() const override {
    return {{"silhouette_regions", "cull wedges outside their silhouette regions in the BSP (section 4.2)", {"on", "off"}},
            {"occluder_culling", "skip receivers a planar occluder hides from a light (occluders.h)", {"on", "off"}},
            {"shaft_culling", "build wedges only for edges inside the receivers' shafts to a light", {"on", "off"}},
            {"wedge_index", "find candidate edges per receiver in the edge hierarchy (edge_tree.h, no wedges), or candidate wedges by scattering them through the receiver tree or by the lazy BSP (section 4.1); auto: the edges for meshes of at least 16 edges per receiver, else the scattered wedges", {"auto", "edges", "receivers", "bsp"}},
            {"edge_rays", "answer a receiver and light by one ray per sample (Embree packets, verified hits) when it has more than edge_ray_limit candidate edges per sample: their integration would cost more than the rays; the edge walk stops there", {"on", "off"}},
            {"edge_ray_limit", "edge_rays' limit in candidate edges per sample (default 4)", {}},
            {"ray_solve", "auto (with edge_rays=on and wedge_index=auto): when edge_rays' probe (the sampled count, or the edge tree's capped walk on meshes of at least 16 edges per receiver) finds at least half of its receivers past edge_ray_limit, answer every receiver by its rays (Embree packets, verified hits) without building or walking any index; off: decide receiver by receiver", {"auto", "off"}},
            {"packet_rays", "answer the receivers that ray_solve or edge_rays give to rays (when the probe chose rays) by shared-origin packets: up to 64 segments from the receiver walk a triangle BVH together, 8 triangles tested per step with certified signs (packet_caster.h); the segments it cannot certify take the verified Embree ray; off: Embree packets for every segment", {"on", "off"}},
            {"embree_quads", "pair triangles that share an edge into Embree quads for the rays' scene: half the primitives to build, the same answers (embree_scene.h); auto: for meshes of at least one triangle per receiver and light", {"auto", "on", "off"}}};
  }
 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;
};

}  // namespace visgate::ssv
