// `iss`: the Incremental Shaft Subdivision algorithm, paper 000 chapter 4 (DESIGN
// section 4). Lazy receiver and light-sample trees (4.3, one light tree per light, the
// receiver tree shared), shafts between tree nodes (4.4.1), blockers as patches and
// surfaces (4.4.2), clipping and clamping (4.5), the winding-number blocking test (4.6),
// incremental sub-shaft construction (4.7, with postponing 4.7.9 as an option), the two
// traversal stages with CHOOSE-SPLIT (4.8, 4.9), leaf relations by Embree rays or by the
// custom ray caster (4.10), jitter boxes (4.11) and empty shafts (4.12). Where each step
// lives: traversal.h (4.7-4.12) and blockers.h (4.4.2-4.7).
//
// Options: leaf_receivers, leaf_samples (maximum points in a leaf), ray_caster =
// embree | custom, postpone = on | off.
//
// Guarantee. A relation is reported blocked without a ray only when a shaft containing
// it passed BLOCKS-SHAFT, which is conservative (blockers.h): every open segment between
// the two node boxes then meets a blocker triangle (touching counts, as in DESIGN 3). A
// relation is reported visible without a ray only by the empty-shaft rule: no surface in
// the shaft, no removed (redundant) surface whose box meets the shaft, and no triangle in
// either node's conservative inside list; every triangle that can meet the shaft is
// represented (gone lists, conservative shaft tests), so no triangle meets the segment.
// Every geometric predicate is evaluated in double with the outward margins of shaft.h,
// so float rounding only ever sends a relation down to a ray. The remaining relations
// are answered by the leaf ray caster and carry its guarantee: Embree with
// RTC_SCENE_FLAG_ROBUST (float32, endpoint behaviour as embree_scene.h; one 16-wide
// packet per receiver and up to 16 samples of its queued light leaves), or the custom
// caster (double-precision orientation tests and winding numbers, falling back to the
// Embree ray where a removed surface's box meets the ray). Both can misjudge only
// relations within float rounding of a degenerate configuration (oracle margin ~1e-7
// relative), i.e. below the gate's tau.
//
// Domain (DESIGN section 2, "Scale"): every scene of finite float32 coordinates.
// Solver::solve hands this method the scene's unit copy (lib/scene/exact_transform.h:
// scaled by the power of two that brings its unit length into [2, 4)), so
// every tolerance below is relative to lengths near 2, and a scene and each of its exact
// 2^k copies
// get the same answers bit for bit.
//
// Threads: the traversal is single-threaded (the thesis measures one thread); the
// Embree BVH build uses TBB within opt.threads.
#pragma once

#include "lib/solver.h"

namespace visgate::iss {

// Runs validate() after every operation on every surface when set (tests switch it
// on; debug builds start with it on). Not thread-safe to toggle during a solve.
void set_validate_all(bool on);
bool validate_all();

// sample_position (lib/scene/scene.h) with the jitter index h mod K computed as
// h & (K - 1) when K is a power of two (the default K = 4): the same point without a
// 64-bit division per leaf relation (perf, columns: the division's latency was about a
// third of the leaf loop). leaf_sample_at takes the receiver's hash prefix
// (relation_hash_prefix(i, light.seed)), computed once for all samples of a leaf fan:
// relation_hash chains three splitmix64 finalisers per relation, two of them the
// receiver's (perf, columns: 4.5% of ISS's instructions). iss_test checks both against
// sample_position.
// leaf_jitter_index: the index of that point among sample j's jitter points.
// The form with the jitter count k = light.jitter lets a loop keep k in a register.
inline int leaf_jitter_index(uint64_t k, int j, uint64_t receiver_prefix) {
  uint64_t h = relation_hash_step(receiver_prefix, uint64_t(j));
  return int((k & (k - 1)) == 0 ? (h & (k - 1)) : h % k);
}
inline int leaf_jitter_index(const Light& light, int j, uint64_t receiver_prefix) {
  return leaf_jitter_index(uint64_t(light.jitter), j, receiver_prefix);
}
inline const Vec3f& leaf_sample_at(const Light& light, int j, uint64_t receiver_prefix) {
  return light.jitter_point(j, leaf_jitter_index(light, j, receiver_prefix));
}
inline const Vec3f& leaf_sample_position(const Light& light, int j, size_t i) {
  return leaf_sample_at(light, j, relation_hash_prefix(i, light.seed));
}

class IssSolver : public Solver {
 public:
  std::string name() const override { return "iss"; }
  std::vector<OptionSpec> options() const override;
 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions& opt) override;
};

}  // namespace visgate::iss
