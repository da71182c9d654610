// The verified Embree scene: the ray caster that ISS's leaf relations and SSV's
// reference rays share (paper 000 section 4.10 uses Embree for the leaves), and the
// double-precision segment tests behind its hit verification and its fallback. The
// `embree` baselines (embree_solver.h) use it with verification off.
//
// Embree's input domain. Embree treats a float as valid input only when its magnitude is
// below FLT_LARGE = 1.844e18 (embree common/math/constants.h, "we consider floating point
// numbers in that range as valid input numbers"): a ray with |org| or |dir| above it
// fails `ray.valid()` (an assertion abort in Debian's libembree3 3.13.5) and a triangle
// with a vertex above it is silently dropped from the BVH. Below that bound its
// intersectors can still overflow: the watertight test of RTC_SCENE_FLAG_ROBUST computes
// U = dot(cross(e0, v2 + v0), D) and T = 2 dot(v0, Ng) (and Möller-Trumbore the same
// degree), products of three coordinate differences. With every coordinate (vertex,
// receiver, light point) bounded by B: a vertex relative to the origin is <= 2B, an edge
// and the sum of two relative vertices <= 4B, the direction <= 2B, a cross product
// component <= 2 (4B)^2 = 32 B^2, a dot product <= 3 * 32 B^2 * 2B = 192 B^3 and twice
// it 384 B^3 < 2^9 B^3. Requiring 2^9 B^3 < 2^128 (FLT_MAX ~ 2^128) gives B <= 2^39
// (2^9 * 2^117 = 2^126), so kEmbreeCoordinateBound = 2^39 ~ 5.5e11: every intermediate
// stays finite and every ray is valid (|dir| <= 2^40 << FLT_LARGE). A relation with an
// endpoint beyond the bound, or any relation of a mesh with a vertex beyond it, is
// decided without Embree by `fallback_occluded` (double-precision plane and edge tests over
// every triangle; never aborts), and counted in the stat "fallback_rays".
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "lib/scene/scene.h"

namespace visgate::raycast {

// Largest coordinate magnitude handed to Embree (derivation above).
inline constexpr float kEmbreeCoordinateBound = 0x1p39f;

// True when every coordinate of p has magnitude <= kEmbreeCoordinateBound (false for NaN).
bool within_embree_bound(const Vec3f& p);

// The segment from `from` to `to` against every triangle of `soup`, without Embree, in
// double (float inputs): the endpoints' plane sides from the triangle's normal, the
// crossing point computed from the endpoint nearer to the plane, then a closed 2D
// point-in-triangle test. Float-class guarantee: the error is about 1e-16 relative to
// the triangle's size and the nearer endpoint's distance, so only relations within that
// of a degeneracy can be misjudged (not exact). Embree's endpoint convention: hits with
// t in (0, 1] (the receiver end excluded, the light end included), closed triangle
// edges; a segment in the triangle's plane is a miss.
bool fallback_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to);
// The same over a parameter range of the line from + t (to - from): hits with t in
// [t0, t1] (0 <= t0 <= t1; t1 may exceed 1; closed at both ends like Embree's robust
// intersector, which includes tnear as well as tfar), same tests and error.
bool fallback_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to, double t0, double t1);

// The test of fallback_occluded for one triangle (a, b, c), with the same conventions.
bool segment_hits_triangle(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& from, const Vec3f& to);

// True when the segment p q (float end points in double) certainly crosses the open
// triangle (a, b, c) at a parameter strictly inside (0, 1): such a segment is blocked
// under every endpoint and edge convention, and segment_hits_triangle confirms it. With
// A = a - p, B = b - p, C = c - p and d = q - p (differences rounded in double, as in
// Shewchuk's orient3d), the line crosses the triangle's interior exactly when the
// triple products w_a = d.(B x C), w_b = d.(C x A), w_c = d.(A x B) share one strict
// sign, and it crosses the plane at t = det(A, B, C) / (w_a + w_b + w_c). Each product
// is within 8 eps of its permanent (Shewchuk's orient3d error bound A,
// (7 + 56 eps) eps, eps = 2^-53), bounded here by the largest coordinates of the
// differences; every sign and the comparison |det| < |sum| must clear those bounds,
// else the answer is false (not certain; not a miss). The
// verification filter accepts a segment query's candidate hit on it before running the
// double-precision test: no division and no branch on a projection axis, about a third
// of that test's cost. Exact answer whenever it is true.
bool certainly_crosses_interior(const Vec3d& p, const Vec3d& q, const Vec3f& a, const Vec3f& b, const Vec3f& c);
// The same test in the default build (no AVX2 kernels), whatever the CPU: the AVX2 build,
// which certainly_crosses_interior and the verification filter run where the CPU has it
// (VISGATE_ISS_NO_AVX2 unset), gives the same answer bit for bit; tests compare the two.
bool certainly_crosses_interior_default(const Vec3d& p, const Vec3d& q, const Vec3f& a, const Vec3f& b,
                                        const Vec3f& c);

// A committed Embree scene over a triangle soup, for methods that cast rays (ISS leaves,
// SSV's reference ray) as well as for the baseline itself. Thread-safe queries. All
// scenes share one Embree device per process (created on first use, thread-safe, kept
// until exit): creating a device costs about a millisecond, more than a small solve.
// `soup` must outlive the EmbreeScene (the fallback reads it).
//
// Hit verification (verify_hits, on by default; the `embree` and `embree-robust`
// baselines switch it off to be measured as users run Embree). RTC_SCENE_FLAG_ROBUST
// can report hits that do not exist for segments nearly in a triangle's plane (its
// watertight test sees the triangle edge-on in ray space; a libembree3 3.13.5 case is in
// corpus/embree-robust/sliver/). With verification an occlusion filter re-tests every
// candidate hit with segment_hits_triangle (ranged queries: the ranged test of
// fallback_occluded) and rejects the ones it does not confirm, so a hit needs both
// Embree and the double-precision test; misses are Embree's alone (the filter sees
// only candidates). The filter runs on hits only, which occlusion rays stop at; a
// segment query's hit that certainly_crosses_interior proves needs no further test.
// Embree's BVH build quality (RTC_BUILD_QUALITY_*). `medium`, Embree's default, is what
// the baselines use. `low` (Morton-code build) builds several times faster and traces
// somewhat slower: it pays for a method that casts few rays into a large mesh (SSV's
// reference rays, ISS's leaf rays where shafts decide most relations). Answers do not
// depend on it: the same triangles, the same intersection kernel.
enum class BuildQuality { low, medium, high };

// What Embree's BVH holds. `triangles`: one primitive per triangle. `paired_quads`:
// triangles k and k + 1 that share an edge in opposite orientations (a mesh written
// quad by quad, as scan's, pairs them all; k advances by two after a pair) become one Embree
// quad (v0, v1, v2, v3), which Embree intersects as the triangles (v0, v1, v3) and
// (v2, v3, v1): the pair's own corners, each triangle's listed from another corner. An
// unpaired triangle (a, b, c) is the quad (a, b, c, c), so that every ray traverses one
// BVH; a soup without any pair stays triangles. Half the primitives for the build (scan 300k,
// Morton build: rtcCommitScene 128.1M -> 71.9M instructions). Answers of a verified
// scene stand as with triangles: Embree's watertight edge tests of the same corners
// (an edge function depends on its two end points alone, so shared edges stay
// watertight), and a candidate hit on a quad stands only when the double-precision test
// confirms it on one of the quad's two triangles (Embree does not say which one it hit).
enum class Primitives { triangles, paired_quads };

class EmbreeScene {
 public:
  EmbreeScene(const TriangleSoup& soup, bool robust, bool verify_hits = true,
              BuildQuality quality = BuildQuality::medium, Primitives primitives = Primitives::triangles);
  ~EmbreeScene();
  EmbreeScene(const EmbreeScene&) = delete;
  EmbreeScene& operator=(const EmbreeScene&) = delete;

  // True when some triangle blocks the segment from `from` to `to` (parameter range
  // [0, 1] of from + t (to - from), Embree's own endpoint semantics). Segments outside
  // Embree's domain (see above) go to fallback_occluded.
  bool occluded(const Vec3f& from, const Vec3f& to) const;
  // The same over the parameter range [tnear, tfar] of from + t (to - from) (Embree's
  // ray range: 0 <= tnear <= tfar, tfar may exceed 1), for methods that must tell hits
  // near an endpoint from hits inside the segment (SSV's reference ray).
  bool occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar) const;
  // The same, also telling whether the verification rejected a candidate hit of this
  // query (`disputed`; always false without verification and for the fallback). A miss
  // with a dispute is not watertight: the segment passes within Embree's rounding of the
  // rejected triangle's boundary, and where that boundary is an edge shared with a
  // neighbour, Embree's watertight test may give the crossing to the rejected triangle
  // while the double-precision test gives it to the neighbour, which Embree never
  // reported (a segment along an interior edge of a fan). Callers that let one ray
  // stand for other relations must not trust such a miss.
  bool occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar, bool& disputed) const;

  // occluded(from, to[k]) for k < n (n <= 16), traced as Embree packets of the
  // machine's native width (rtcOccluded16 with AVX-512, else two rtcOccluded8; rays set
  // up exactly as occluded() does, inactive lanes masked):
  // segments from one point to nearby points are coherent and a packet traverses the
  // BVH once for all of them. Segments outside Embree's domain go to fallback_occluded
  // one by one. Embree's packet and single-ray kernels may disagree only where its own
  // float tests are at a tie (robust scenes: watertight in both).
  void occluded_fan(const Vec3f& from, const Vec3f* to, int n, bool* out) const;

  // Primitives::paired_quads: the pairs of triangles Embree holds as quads (0 for
  // Primitives::triangles, and for a soup without pairs, which stays triangles).
  size_t quad_count() const { return pairs_; }

  // Queries answered by fallback_occluded so far.
  size_t fallback_rays() const { return fallback_rays_.load(std::memory_order_relaxed); }
  // Candidate hits the verification filter rejected so far.
  size_t rejected_hits() const { return rejected_hits_.load(std::memory_order_relaxed); }
  // Verified scenes: queries Embree answered blocked although the filter let no hit of
  // theirs stand, answered again by fallback_occluded. Embree applies the filter to
  // every candidate, so this stays 0 unless some kernel skips it; the count makes
  // "a hit needs both Embree and the double-precision test" a checked rule instead of
  // a trust in every ISA's kernels (a CI machine with AVX-512, whose kernels this
  // machine cannot run, reported an ISS false-blocked relation that no run here shows).
  size_t unverified_hits() const { return unverified_hits_.load(std::memory_order_relaxed); }

 private:
  // ranged: the filter confirms with the ranged test, else with segment_hits_triangle.
  bool occluded_embree(const Vec3f& from, const Vec3f& to, float tnear, float tfar, bool ranged,
                       size_t* rejected = nullptr) const;
  // Results of fan lanes [0, n) from their bits (active: traced by Embree, blocked: came
  // back blocked, accepted: the filter let a hit of theirs stand): lanes outside
  // Embree's domain go to occluded(), and blocked lanes without an accepted hit are
  // answered again by fallback_occluded (unverified_hits).
  void finish_lanes(const Vec3f& from, const Vec3f* to, int n, uint32_t active, uint32_t blocked, uint32_t accepted,
                    bool* out) const;

  const TriangleSoup* soup_;
  // Primitives::paired_quads: per quad its first triangle (the second is the next one),
  // or with the top bit set its only triangle; pairs_: the quads of two triangles.
  std::vector<uint32_t> quad_first_;
  size_t pairs_ = 0;
  std::unique_ptr<uint32_t[]> quad_index_;  // the quads' corners, Embree's shared index buffer
  bool verify_;
  uint64_t id_;  // distinct per scene: key of the verification's per-thread terms cache
  void* scene_ = nullptr;       // nullptr when the mesh is outside Embree's domain
  bool mesh_in_bound_ = true;
  mutable std::atomic<size_t> fallback_rays_{0}, rejected_hits_{0}, unverified_hits_{0};
};

}  // namespace visgate::raycast
