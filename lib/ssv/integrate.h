// Projection of silhouette edges onto the light plane and integration of relative depth
// complexity (paper 001 section 2.1, the integration step of [LAA*05]).
//
// Depth complexity. For a receiver r above the light plane (frame height h_r > 0) and a
// point s of the light plane, D(s) = number of triangles T meeting the open segment
// (r, s). The segment lies in the slab 0 < h < h_r, so D(s) = sum_T 1[s in R_T], where
// R_T is the central projection from r of T clipped to the slab: triangles behind the
// receiver or beyond the light plane add nothing, triangles crossing either plane add the
// projection of their part inside. R_T is convex. Its boundary is made of projected
// pieces of T's edges (clipped to the slab) and, when T crosses the light plane, of the
// segment where T cuts the light plane (its "cut segment"; the slab's top face projects
// to infinity).
//
// Side of a projected edge. For an edge a -> b in T's winding, the plane (a, b, r) meets
// the light plane in the projected line P -> Q, and T lies on the side of that plane
// where its third vertex c is. In the right-handed light frame (u, v, h),
// orient3d(a, b, r, s) = -h_r * alpha * beta * cross2(Q - P, s - P) with alpha, beta > 0
// (a = r + alpha (P - r), likewise b), and orient3d(a, b, r, c) = -orient3d(a, b, c, r) =
// -facing(T). Hence R_T lies to the LEFT of P -> Q iff facing(T) > 0 (r on T's front
// side), to the right iff facing(T) < 0, and is empty iff facing(T) = 0. Summed over the
// triangles of an edge label (lib/mesh: a single edge has one triangle, a double edge two
// neighbours traversing it in opposite directions), the edge a -> b carries the weight
//   w = sign(facing(T1)) - sign(facing(T2))        (second term absent for single edges),
// which is 0 unless the edge is a silhouette from r (exactly one triangle front-facing),
// and +-2 for a silhouette double edge. The cut segment E -> F of a triangle crossing the
// light plane (E where the winding leaves h >= 0, F where it re-enters) carries
// w = sign(facing(T)) by the same argument (E and F have alpha = 1). Every triangle's
// facing is evaluated once per receiver by the same double expression, so the pieces of
// one triangle always form a closed boundary with one consistent side.
//
// Integration rule (crossing numbers). For a bounded region X with counter-clockwise
// boundary, 1[s in X] = sum over boundary segments e of dir(e) * [the ray from s towards
// +u crosses e], dir = +1 for upward (v increasing) and -1 for downward segments, with the
// half-open convention v in [v_low, v_high) so that a ray through a shared vertex counts
// once. Apply it to X = R_T n L' (L' the expanded light, light_frame.h, convex and
// containing every sample): its boundary is the part of R_T's boundary inside L' (edges
// clipped to the pyramid from r over L') plus the part of L's boundary inside R_T. A ray
// towards +u from a sample inside L' crosses L's boundary once, on its right chain (the
// edges along which v increases), never on the left chain. On the right chain the
// boundary of X runs upward, from the point where R_T's boundary leaves L' through the
// right chain to where it re-enters. So the rule per weighted piece P -> Q (R_T on its
// left, weight w) is:
//   1. samples with v in [min(v_P, v_Q), max(v_P, v_Q)) strictly left of the piece's
//      line (smaller u) get +w if v_Q > v_P, -w if v_Q < v_P;
//   2. if the piece leaves L' through a right-chain edge at Q: +w to every sample with
//      v >= v_Q; if it enters through a right-chain edge at P: -w to every sample with
//      v >= v_P.
// Rule 2 telescopes: exit and re-entry of one region give +w on [v_exit, v_entry); a
// region containing the top or bottom of the right chain gives a step plus a constant.
// The result equals D(s) up to an additive constant per receiver, which the reference
// ray removes. Pieces whose projection misses L' add nothing, so culling wedges that
// exclude the receiver is exact.
//
// Sub-linear integration. Each sample lies in its jitter box (the box of its K jitter
// points in (u, v)); the samples are ordered once per light by the boxes' v_lo and cut
// into ceil(sqrt(N)) strips of consecutive v_lo, each ordered by the boxes' u_hi
// (SampleStrips). Per receiver only the picked points are filled in: no receiver sorts
// or filters anything. A piece updates the strips whose v-extent (the union of their
// boxes' v-ranges) meets its v-range. In a strip inside the v-range, every sample whose
// box lies left of the line's u-range over the strip (u_hi below it, with a margin) is
// surely left: a prefix of the u_hi order, one difference-array update. Samples further
// in the order are tested one by one until u_hi exceeds the line's u-range by the
// widest box (beyond, every box lies right of the line). Strips that only partly meet
// the v-range are tested one by one. Rule 2 is one difference-array update in v_lo order
// (boxes at or above the threshold) plus one-by-one tests of the boxes that straddle it.
// Every bulk decision is one the one-by-one test would make, so the result does not
// depend on the boxes; they only decide how much is tested one by one. Cost per piece
// O(sqrt(N) log N + samples whose boxes are near the line), against O(N). A piece whose
// v-range reaches at most 512 boxes tests those one by one instead (four per SSE2 step,
// eight with AVX2 where the processor has it:
// cheaper than the searches at that size, and the same test); the strip-order arrays are
// filled only for a receiver with a piece over more. With at most 512 samples and many
// edges to come (ReceiverIntegrator::expect_edges) the picked points are instead sorted
// by their own v per receiver, so a piece tests exactly the samples in its v-range
// (DepthCounter::use_sorted_order): the same test per sample, so the same counts.
//
// Active triangles. R_T is empty for a triangle with no vertex strictly above the light
// plane (entirely below it, lying in it, or touching it from below): such a triangle
// gets facing 0 and adds no piece, so a triangle lying in the light plane (grid-snapped
// scenes) does not count the samples it contains, whose open segments never reach it.
// A triangle with a vertex above adds every clipped edge, including an edge lying in the
// light plane (it projects onto itself), so its boundary stays closed.
//
// Precision. Clipping and projection run in double on unrounded frame coordinates; the
// projected pieces are rounded once to float, like the samples, and counted in float.
//
// Guarantee: float32 counts with these failure modes, all near-degenerate: a sample within
// float rounding of a projected edge line (the segment passes near the edge; exactly on
// it the segment touches the edge and the relation itself is degenerate, and such a
// sample is never used as the reference, see clearance below); a receiver
// within rounding of a triangle's plane (the triangle projects to a sliver, whose sign
// may be wrong: only samples inside the sliver are affected); pieces whose projection
// touches the boundary of L' (rule 2 thresholds v_Q, v_P carry rounding: samples whose v
// lies within rounding of such a threshold may be miscounted). An edge passing through
// (within rounding of) the receiver has no projection: the receiver is marked doubtful
// and answered by rays.
#pragma once

#include <algorithm>
#include <cstdint>
#include <utility>
#include <vector>

#include "lib/mesh/prepare.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

// The strips of a light's samples (see "Sub-linear integration"), built once per light.
struct SampleStrips {
  int n = 0;                               // samples
  std::vector<float> u_hi, v_lo;           // per sample: its box's u_hi and v_lo
  double max_width = 0.0;                  // largest box extent in u (exact)
  std::vector<int> vorder, vrank;          // samples sorted by v_lo; position of each
  std::vector<float> vlo_sorted;           // v_lo in that order
  // The largest v_hi of positions 0..k of the v_lo order (nondecreasing): the samples
  // before the first position whose value reaches x all have v < x.
  std::vector<float> vhi_prefix;
  std::vector<int> strip_start;            // strips: ranges of the v_lo order; strips + 1
  std::vector<float> strip_vmin, strip_vmax;  // per strip: min v_lo, max v_hi
  std::vector<int> sorder, srank;          // per strip, its samples sorted by u_hi
  std::vector<float> uhi_sorted;           // u_hi in that order
  // Bucket index over v_lo for O(1) searches: bucket b starts at vlo_sorted[0] + b / scale;
  // bucket_first[b] is the first position whose v_lo is not below that start.
  double bucket_scale = 0.0;
  std::vector<int> bucket_first;
  // The same bucket index over vhi_prefix.
  double vhi_bucket_scale = 0.0;
  std::vector<int> vhi_bucket_first;
  // Position of the first v_lo not less than x (std::lower_bound on vlo_sorted). Inline:
  // two calls per piece, about a tenth of the integration on scenes of short pieces.
  int vlo_lower_bound(double x) const { return bucket_lower_bound(vlo_sorted, bucket_first, bucket_scale, x); }
  // Position of the first vhi_prefix value not less than x.
  int vhi_lower_bound(double x) const { return bucket_lower_bound(vhi_prefix, vhi_bucket_first, vhi_bucket_scale, x); }
  // std::lower_bound on the ascending `a` through its bucket index (`first`, `scale`).
  static int bucket_lower_bound(const std::vector<float>& a, const std::vector<int>& first, double scale, double x);
};
inline int SampleStrips::bucket_lower_bound(const std::vector<float>& a, const std::vector<int>& first, double scale,
                                            double x) {
  const int n = int(a.size());
  if (n == 0 || !(x > double(a.front()))) return 0;
  if (x > double(a.back())) return n;
  // The bucket of x, from a rounded product: count over it and its two neighbours, which
  // holds the answer even if the rounding picked the neighbour of the right bucket.
  const int buckets = int(first.size()) - 1;
  const int b = std::clamp(int((x - double(a.front())) * scale), 0, buckets - 1);
  const int k0 = first[size_t(std::max(b - 1, 0))], k1 = first[size_t(std::min(b + 2, buckets))];
  int k = k0;
  for (int i = k0; i < k1; ++i) k += double(a[size_t(i)]) < x;
  return k;
}

// Sample j's box is the box of jitter points j*K .. j*K+K-1 of `jitter_uv`.
SampleStrips make_sample_strips(const std::vector<Vec2f>& jitter_uv, int samples, int jitter);

// The picked jitter point of every sample of one receiver (DESIGN section 3,
// sample_position): pick[j] = j K + relation_hash_step(prefix, j) mod K, with `prefix` =
// relation_hash_prefix(receiver, light seed). For a power-of-two K four hashes at a time
// with AVX2 where the processor has it (64-bit products from 32-bit ones: the same
// integers); otherwise one by one.
void jitter_picks(uint64_t prefix, int samples, int jitter, std::vector<uint32_t>& pick);

// Per-sample relative depth-complexity counters with the strip structure above.
class DepthCounter {
 public:
  // Samples in frame (u, v), one point each (their own strips are built: sorting);
  // `extent` the light's size (for the bulk-test margin).
  void reset(const std::vector<Vec2f>& uv, double extent);
  // Samples of a light with its strips: sample j is jitter point pick[j], which lies in
  // sample j's box.
  void reset(const SampleStrips& strips, const std::vector<Vec2f>& jitter_uv, const std::vector<uint32_t>& pick,
             double extent);
  // Rule 1 for the piece P -> Q with weight w.
  void add_piece(const Vec2f& P, const Vec2f& Q, int w);
  // After use_sorted_order() returned true: the position of the first picked point with
  // v >= x in their own v order (a sample's v is in [lo.v, hi.v) iff its position is in
  // [rank(lo.v), rank(hi.v))). The same for the same x until the next reset.
  int rank(float x) const;
  // add_piece with kP = rank(P.v) and kQ = rank(Q.v) given (after use_sorted_order()
  // returned true): the same counts and flags. Pieces sharing an endpoint share its rank.
  void add_piece_ranked(const Vec2f& P, const Vec2f& Q, int w, int kP, int kQ);
  // Rule 2: +w to every sample with v >= vc.
  void add_step(float vc, int w);
  // The counters per sample (index as given to reset), and optionally per sample whether
  // it lies within the margin of some piece's line in that piece's v-range (unclear: its
  // count may be off by that piece's weight).
  void finish(std::vector<int32_t>& depth, std::vector<uint8_t>* unclear = nullptr);
  // The same as finish(depth, &unclear) followed by replacing the depth of every unclear
  // sample by `unclear_value`, in one pass, with the classes: the lowest and second-lowest
  // value of `depth` (unclear_value when absent) and the number of unclear samples.
  // Results identical to that sequence (min and count do not depend on the order). Like
  // finish, ends the receiver: the counters are only valid again after reset.
  struct Classes {
    int32_t dmin, second;
    size_t unclear;
  };
  Classes finish_classes(std::vector<int32_t>& depth, int32_t unclear_value);
  size_t size() const { return uv_.size(); }
  // After the strips form of reset and before any piece or step: keeps the picked
  // points in their own v order instead of their boxes' v_lo order when there are few
  // (at most 512). The same counts and flags per sample, with exactly the samples in a
  // piece's v-range tested; the sort costs thousands of instructions per receiver, so
  // it pays only with many pieces per sample. Returns whether the order is in use.
  bool use_sorted_order();
  const Vec2f& sample_uv(size_t j) const { return uv_[j]; }

 private:
  void clear_counters();
  void zero_counters();  // counters, flags and steps to zero (uv_, vu_, vv_ filled)
  void fold_steps();     // rule 2's difference array into dv_
  void use_strip_order();
  int sorted_lower_bound(float x) const;  // first position with v >= x (sorted_)

  const SampleStrips* strips_ = nullptr;
  SampleStrips own_;  // for reset(uv, extent)
  std::vector<Vec2f> uv_;
  double extent_ = 0.0;
  std::vector<float> vu_, vv_, su_, sv_;  // picked points in v_lo order and in strip u_hi order
  std::vector<int32_t> dv_, ds_;          // one-by-one counts per position of those orders
  std::vector<int32_t> fv_, fs_;          // unclear flags (0 or -1) per position
  bool strip_order_ = false;              // su_, sv_, ds_, fs_ in use since the last reset
  bool steps_ = false;                    // some add_step since the last reset (diffv_ not all 0)
  std::vector<int32_t> diffv_;            // rule 2 steps: a difference array over v_lo positions
  // The steps' (position, weight) since the last reset: diffv_ is zero elsewhere, so
  // clearing these entries clears it, and the AVX2 class scan adds them per block.
  std::vector<std::pair<int32_t, int32_t>> step_list_;
  // The sample at each position of vu_, vv_, dv_, fv_: strips_->vorder, or order_ when
  // sorted_ (positions in the picked points' own v order, never with the strip order).
  const int* ord_ = nullptr;
  std::vector<int> order_;
  bool sorted_ = false;
  std::vector<int> vb_first_;  // sorted_: first position of each of n buckets over v
  double vb_scale_ = 0.0;      // buckets per unit of v (0: all v equal)
};

// The prepared mesh's vertices in a light's frame coordinates (double, not rounded:
// LightFrame::to_local): from an array over every vertex (the wedge indexes read most of
// them per light), or computed on use and kept in a direct-mapped cache (the edge index
// reads only its candidates' vertices, and a full array is a linear pass and 24 bytes a
// vertex of fresh memory per light). The same doubles either way. One per thread: the
// cache is not shared.
class FramePositions {
 public:
  explicit FramePositions(const std::vector<Vec3d>& all) : all_(&all) {}
  FramePositions(const std::vector<Vec3f>& vertices, const LightFrame& frame) : vertices_(&vertices), frame_(&frame) {}
  Vec3d operator[](uint32_t v) const {
    if (all_) return (*all_)[v];
    const size_t slot = v & (kCache - 1);
    if (!keys_.empty() && keys_[slot] == v) return cache_[slot];
    return fill(v);
  }
  const std::vector<Vec3d>* array() const { return all_; }  // null: computed on use
  // Its height over the light plane alone (the activity and crossing tests).
  double h(uint32_t v) const { return all_ ? (*all_)[v].z : (*this)[v].z; }

 private:
  [[gnu::noinline]] Vec3d fill(uint32_t v) const;  // computes v's position into its slot (off the hot path)
  static constexpr size_t kCache = 8192;  // entries (224 KiB)
  const std::vector<Vec3d>* all_ = nullptr;
  const std::vector<Vec3f>* vertices_ = nullptr;
  const LightFrame* frame_ = nullptr;
  mutable std::vector<uint32_t> keys_;
  mutable std::vector<Vec3d> cache_;
};

// The point where the edge between vertices i and j (frame coordinates `fp`: a vector or
// FramePositions) crosses h = 0, computed from the pair in index order so every user gets
// the same point.
template <class Positions>
Vec3d light_plane_point(const Positions& fp, uint32_t i, uint32_t j) {
  const Vec3d p0 = fp[i], q0 = fp[j];
  if (p0.z == 0.0) return p0;
  if (q0.z == 0.0) return q0;
  const Vec3d& p = i > j ? q0 : p0;
  const Vec3d& q = i > j ? p0 : q0;
  const double t = p.z / (p.z - q.z);
  Vec3d x = p + (q - p) * t;
  x.z = 0.0;
  return x;
}

// The triangles crossing the light plane whose cut segment may meet L': the candidates
// for ReceiverIntegrator::add_cut. A cut segment lies in the light plane, so its
// projection from every receiver is itself, and one that misses L' adds nothing for any
// receiver (rooms: the walls of every room of a storey cross the plane of each of its
// ceiling lights, far from it).
std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const std::vector<Vec3d>& fp, const LightFrame& f);
// The same among `candidates` (ascending; a superset of the triangles with vertices
// strictly on both sides of the light plane, EdgeTree::crossing_triangles): the same list.
std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const std::vector<Vec3d>& fp, const LightFrame& f,
                                       const std::vector<uint32_t>& candidates);
std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const FramePositions& fp, const LightFrame& f,
                                       const std::vector<uint32_t>& candidates);

// Everything the integration of one receiver against one light needs.
class ReceiverIntegrator {
 public:
  // `frame_pos`: the prepared mesh's vertices in frame coordinates (double, not rounded).
  ReceiverIntegrator(const mesh::PreparedMesh& m, const std::vector<Vec3d>& frame_pos, const LightFrame& frame)
      : m_(m), planes_{&m, nullptr}, fp_(frame_pos), frame_(frame) {}
  // The same with the triangle planes computed once by the caller.
  ReceiverIntegrator(const mesh::PreparedMesh& m, const TrianglePlanes& planes,
                     const std::vector<Vec3d>& frame_pos, const LightFrame& frame)
      : m_(m), planes_{&m, &planes}, fp_(frame_pos), frame_(frame) {
    set_arrays();
  }
  // The same with the planes from `planes` (an array, or the mesh on each call).
  ReceiverIntegrator(const mesh::PreparedMesh& m, PlaneSource planes, FramePositions frame_pos,
                     const LightFrame& frame)
      : m_(m), planes_(planes), fp_(std::move(frame_pos)), frame_(frame) {
    set_arrays();
  }
  // The vertices' frame coordinates it reads (and caches, when computed on use).
  const FramePositions& positions() const { return fp_; }

  // Starts a receiver (world position; its frame height must be > 0) with its samples.
  void begin(const Vec3f& receiver, const std::vector<Vec2f>& samples_uv);
  // The same with samples given as picked jitter points of a light with its strips
  // (DepthCounter::reset).
  void begin(const Vec3f& receiver, const SampleStrips& strips, const std::vector<uint32_t>& pick);
  // The number of edges about to be added (add_edge) since begin(): with enough of
  // them the counter sorts its samples by v first (DepthCounter::use_sorted_order; the
  // same counts). Optional; before the first add_edge.
  void expect_edges(size_t edges);
  // sign(orient3d(T, r)) in double: +1 when r is on T's front side; 0 as well for a
  // triangle with no vertex strictly above the light plane (h > 0): it meets no open
  // segment from r to the light plane, so R_T is empty (a triangle lying in the light
  // plane, or touching it from below, adds nothing).
  int facing(size_t t) const;
  // Triangle t's plane record (the same doubles as triangle_planes'). Computed from the
  // mesh when no array was given, then kept in a small direct-mapped cache: the
  // receivers of a batch validate mostly the same edges.
  // The reference is valid until the next call.
  const TrianglePlane& plane(size_t t) const {
    if (planes_.planes) return (*planes_.planes)[t];
    const size_t slot = t & (kPlaneCache - 1);
    if (!plane_keys_.empty() && plane_keys_[slot] == int64_t(t)) return plane_cache_[slot];
    return fill_plane(t);
  }
  // Edge weight of section "Side of a projected edge" (0: not a silhouette from r).
  int edge_weight(const Edge& e) const;
  // Whether add_edge may project each vertex once per receiver (default on): after
  // expect_edges put the counter in its sorted order, a vertex strictly inside every
  // side plane with h >= 0 keeps its projection and its rank (DepthCounter::rank), and
  // an edge between two such vertices needs no clipping (add_segment would keep both
  // ends as they are). The same pieces and counts either way; off for the test of that.
  void set_vertex_reuse(bool on) { vertex_reuse_on_ = on; }
  // Edges added through the reused projections since begin().
  size_t reused_edges() const { return reused_edges_; }
  // Clips the edge to h >= 0 and to the pyramid from r over L', projects and integrates
  // it with weight w. Returns false when nothing of it projects into L'.
  bool add_edge(const Edge& e, int w);
  // The cut segment of triangle t with the light plane, if t crosses it (weight from its
  // facing). Returns false when t does not cross the plane or misses L'.
  bool add_cut(size_t t);
  void finish(std::vector<int32_t>& depth, std::vector<uint8_t>* unclear = nullptr) { counter_.finish(depth, unclear); }
  DepthCounter::Classes finish_classes(std::vector<int32_t>& depth, int32_t unclear_value) {
    return counter_.finish_classes(depth, unclear_value);
  }
  // True when, since begin(), some piece inside the pyramid could not be projected (an
  // edge through, or within rounding of, the receiver) or some triangle was nearly
  // edge-on (facing). Its counters are unreliable and the receiver must be answered by
  // rays.
  bool doubtful() const { return doubtful_; }

  // Reference-sample clearance. The counters are exact only for samples away from every
  // projected piece, and the reference ray decides a whole class from one sample: a
  // sample on a projected silhouette edge (its segment touches the edge: grid-snapped
  // scenes, far-origin coordinates rounded onto a common line) has a counter of either
  // side and an Embree answer of either side. `clearance` is the distance in the light
  // plane from sample j to the nearest piece integrated since begin() (edges and cut
  // segments after clipping), computed in double from the float pieces;
  // `clearance_threshold` the distance below which a sample is not trusted as a
  // reference (derivation at its definition).
  double clearance(size_t j) const;
  // clearance(j) >= clearance_threshold(), faster (early exit, box test per piece).
  bool clear(size_t j) const;
  double clearance_threshold() const { return clear_min_; }

  // The point where the edge between prepared vertices i and j crosses h = 0, computed
  // from the pair in index order so every user gets the same float point.
  Vec3d cut_point(uint32_t i, uint32_t j) const;

 private:
  bool add_segment(const Vec3d& a, const Vec3d& b, int w);
  // Central projection from r onto h = 0 (false: x at or above r's height, or the result
  // not finite).
  bool project(const Vec3d& x, Vec2f& out) const;
  // Every side plane has x strictly inside (dot(side_i, x - r) > 0, the values
  // add_segment computes).
  bool inside_sides(const Vec3d& x) const;
  // Vertex v's projection and rank for this receiver (set_vertex_reuse): `ok` when v has
  // h >= 0, lies strictly inside every side plane and projects; otherwise its edges take
  // add_segment. Direct-mapped by v, keyed by v and the receiver's stamp.
  struct VertexProjection {
    uint64_t key = 0;  // stamp << 32 | v (stamp 0: empty)
    Vec2f p{};
    int32_t rank = 0;
    int32_t ok = 0;
  };
  VertexProjection vertex_projection(uint32_t v) {
    const VertexProjection& slot = vertex_slots_[v & (kVertexSlots - 1)];
    return slot.key == (stamp_ << 32 | v) ? slot : fill_vertex(v);
  }
  [[gnu::noinline]] VertexProjection fill_vertex(uint32_t v);  // into v's slot
  static constexpr size_t kVertexSlots = 4096;
  std::vector<VertexProjection> vertex_slots_;
  uint64_t stamp_ = 0;           // this receiver's (set_receiver)
  bool vertex_reuse_ = false;    // in use for this receiver (expect_edges)
  bool vertex_reuse_on_ = true;  // set_vertex_reuse
  size_t reused_edges_ = 0;
  void set_receiver(const Vec3f& receiver);
  // facing with both sources arrays (kArrays: the wedge indexes, read directly) or not.
  template <bool kArrays>
  [[gnu::always_inline]] inline int facing_from(size_t t) const;
  // Both sources arrays: their data, read in place by facing_from<true> (the arrays are
  // not resized while the integrator lives: the solver fills them before).
  void set_arrays() {
    if (planes_.planes && fp_.array()) {
      plane_data_ = planes_.planes->data();
      fp_data_ = fp_.array()->data();
    }
  }
  bool arrays() const { return plane_data_ != nullptr; }
  const TrianglePlane* plane_data_ = nullptr;
  const Vec3d* fp_data_ = nullptr;

  const mesh::PreparedMesh& m_;
  PlaneSource planes_;
  FramePositions fp_;
  const LightFrame& frame_;
  Vec3d r_world_{};
  Vec3d r_{};                    // frame coordinates (double, not rounded)
  std::vector<Vec3d> side_;      // normals of the planes (r, L'_i, L'_i+1), inside positive
  double sx_[4] = {}, sy_[4] = {}, sz_[4] = {};  // the same by coordinate (side_lanes_)
  bool side_lanes_ = false;      // at most four planes and AVX2: add_segment tests them at once
  mutable bool doubtful_ = false;  // set by add_segment and by facing (nearly edge-on)
  [[gnu::noinline]] const TrianglePlane& fill_plane(size_t t) const;  // into its slot (off the hot path)
  static constexpr size_t kPlaneCache = 8192;        // entries of plane()'s cache (512 KiB)
  mutable std::vector<int64_t> plane_keys_;
  mutable std::vector<TrianglePlane> plane_cache_;
  std::vector<Vec2f> pieces_;    // projected pieces P, Q of this receiver (pairs)
  double clear_min_ = 0.0;
  DepthCounter counter_;
};

}  // namespace visgate::ssv
