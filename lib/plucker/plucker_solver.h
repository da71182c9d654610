// `plucker-bsp`: the soft-shadow framework of paper 002 section 4.4 (Algorithm 2) around
// the lazy Plücker BSP (bsp.h, Algorithm 1). Exact visible light fragments per receiver.
//
// Algorithm 2 as implemented:
//  - receivers are grouped by neighbourhood (section 5.5 recommends it over grouping by
//    triangle): tiles of `tile` x `tile` receivers of the scene's receiver grid, or, for
//    scattered receivers, runs of tile^2 receivers in Morton order;
//  - lights are handled in turn; for each light the groups are shaded in parallel (TBB);
//  - per group and light, the three phases Figure 8 times (group_state.h): occluders are
//    selected with Haines' shaft between the group's bounding box and the light's and
//    clipped to the slab strictly between the light plane and the group's nearest
//    receiver plane (occluder selection, occluder_selection.cpp), oriented and put in a
//    tree (tree initialisation, group_tree.cpp: vvsets, lazy BSP with one undefined
//    leaf), then every receiver of the group is queried in grid order (per-receiver
//    shading, shade_receiver.cpp), and the tree is dropped (bounded memory);
//  - triangle parts that are not strictly in front of every receiver of the group (the
//    band of the group's receiver plane, see occluder_selection.cpp), or whose plane separates the
//    group's receivers (two-sided: measured 25x more developments when kept in the
//    tree), are "near" polygons: rejected per receiver by the pyramid (r, light), else
//    clipped to that receiver's slab and subtracted from the fragments with the same
//    plane-through-the-query-point splits (bsp(o) walked once, nothing stored);
//  - insertOccluder bounds the occluded lines with two vvsets: occluder-light (Theorem 1)
//    and receiver region-occluder (bsp.h), the first decided one wins;
//  - coplanar convex patches of triangles (triangle_tree.h, exact predicates) are one
//    occluder or near polygon when all their triangles take the plain float path: the
//    same blocked set without node planes along inner edges (occluder_selection.cpp).
// Per receiver and light: the visible fragments (convex polygons on the light plane,
// counter-clockwise about the light normal), the visible fraction (sum of fragment areas
// over the light area), per-sample bits by point-in-fragment of sample_position(light, j,
// i), and the Lambert irradiance over the fragments (unit radiance).
//
// Domain (DESIGN section 2, "Scale"): every scene of finite float32 coordinates.
// Solver::solve hands this method the scene's unit copy (lib/scene/exact_transform.h:
// scaled by the power of two that brings its unit length into [2, 4)), so
// every tolerance below is relative to lengths near 2, and a scene and each of its exact
// 2^k copies
// get the same answers bit for bit.
//
// Semantics (DESIGN section 3): a triangle blocks r -> l only where it meets the open
// segment; parts behind the receiver (its plane parallel to the light) or beyond the
// light plane are clipped away before they reach the BSP.
//
// Local frame: all geometry of one light (occluder selection, clipping, vvsets, the
// BSP, fragments, point-in-fragment, segment tests, irradiance) is computed on
// coordinates relative to o = the light's first vertex (a float input, so no rounding
// of the origin itself). Light vertices, receivers and sample positions are translated
// per light, group or query, triangles as each group selects them (no copy of the
// scene). x - o is exact in float when every component of x is within a factor 2 of
// o's (Sterbenz: every point of a scene far from the world origin whose extent is small
// against its offset, e.g. the far-origin family at |x| ~ 1e5..1e6); otherwise it is
// rounded once, with an error of u |x_k - o_k| relative to the local coordinate, which
// is the scale every bound of lines.h / fragment.h is relative to. So the float
// guarantee below holds for the scene's extent, not its distance from the origin. o
// being an input vertex also makes the method translation-invariant bit for bit for
// translations that keep the inputs exact (fl((x+t) - (o+t)) = fl(x - o)).
// Fragments are reported in world coordinates (local + o, one float rounding per
// vertex: far from the origin they move by up to half the float spacing there);
// the fraction, the bits and the irradiance are computed on the local fragments.
//
// Guarantee: float32 data (inputs, fragments) with receivers, occluders and near
// polygons in double local coordinates and planes evaluated in double against forward
// error bounds (bsp.h lists what is bounded); the receiver's side of a near triangle's
// plane, and for a receiver within rounding of that plane the whole triangle, exactly
// (exact_orient.h, the near-plane path). Exact in the paper's sense: no sampling noise;
// the fraction is an area, not a sample count.
// Light points (DESIGN section 6 allows explicit samples anywhere; the relation is the
// open segment receiver -> sample): a sample on the light's plane (|h| within the
// plane's rounding bound) and inside the light polygon (point_in_fragment's bound) is
// decided by point-in-fragment, which projects it orthogonally onto the fragments'
// plane (it is on that plane up to rounding, so this is the central projection from
// the receiver up to rounding). Any other sample (off the plane, or on it outside the
// polygon) is decided by the float segment test of lines.h (segment_blocked: proper
// crossing by error-bounded orientation signs) against every triangle, in the local
// frame (stats "segment_relations"): the BSP only describes segments ending on the
// light polygon, and blockers beyond a sample or beyond the light plane matter there.
// Degenerate inputs: a receiver on the light's plane (|h| within the plane's rounding)
// has no pyramid to project through; its bits come from the same segment test, its
// fraction from the bits, and it reports no fragments (stats "fallback_receivers").
//
// Options: coherence=on|off (off: each tree is reset between queries, the paper's
// "modified version", section 5.1; the reset is excluded from the timings), tile=N
// (group side; default_tile below when absent or 0). Stats (Figure 8): peak_memory_bytes, occluder_selection_
// seconds / tree_init_seconds / query_seconds and their percentages, bsp_nodes;
// bsp_query_seconds (Algorithm 1 on the pieces the near polygons leave) and
// tree_seconds (every LazyBsp call of the queries: the hides_all walk too), the part of
// a coherent solve that the tree could share between queries (visgate bench plucker
// `falloff_bound_1t`).
#pragma once

#include <vector>

#include "lib/solver.h"

namespace visgate::plucker {

// The solve with per-receiver irradiance: irradiance[i * lights + l] (when non-null).
SolveResult solve_plucker(const Scene& scene, const SolveOptions& opt, std::vector<double>* irradiance);

// The group side when the option `tile` is absent or 0: kConvexSolidTile when at least
// half of the scene's triangles lie on closed surfaces with an interior polygon
// (interior_occluders.h: dense solids, whose shadow the polygons hide in the trees, so
// that the per-receiver near polygons do the work), else kDefaultTile. Measured
// (callgrind, the whole `visgate solve` process, 1024 receivers): scan (16 samples per
// light) tile 8 / 12 / 16 / 24 / 32 7.36G / 7.29G / 6.49G / 7.01G / 7.16G instructions at
// 75k triangles, tile 8 / 16 / 32 30.2G / 25.5G / 28.2G at 300k; CGAL's bunny (64 samples)
// 80.0G at tile 8, 56.7G at 16. Larger groups share one selection among more receivers
// and the trees hold little there (scan at 16: 42 tree occluders). Scenes of open or
// small surfaces (columns, rooms) keep 8.
constexpr int kDefaultTile = 8;
constexpr int kConvexSolidTile = 16;
class ClosedSurfaces;
class InteriorOccluders;
int default_tile(const Scene& scene, const ClosedSurfaces* cs, const InteriorOccluders* io);

// Receiver groups of Algorithm 2 (exposed for tests): every receiver in exactly one group.
std::vector<std::vector<uint32_t>> receiver_groups(const Scene& scene, int tile);

class PluckerSolver : public Solver {
 public:
  std::string name() const override { return "plucker-bsp"; }
  std::vector<OptionSpec> options() const override;
  bool reports_fragments() const override { return true; }
 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;
};

}  // namespace visgate::plucker
