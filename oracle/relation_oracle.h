// The relation oracle (DESIGN section 5): for every relation (receiver i, sample j of
// light l) the exact class of the open segment (r, sample_position(l, j, i)) against the
// blocker soup, decided with exact predicates on the float32 inputs converted exactly:
//   Blocked    some triangle crosses the open segment properly (the crossing point is
//              strictly inside the triangle and strictly inside the segment);
//   Degenerate no proper crossing, but some triangle touches the open segment or
//              contains part of it;
//   Visible    no triangle meets the open segment.
// Plus `margin`, a double-precision estimate (not exact) of how far the input is from
// changing the answer, relative to the scene's bounding-box diagonal; 0 for Degenerate.
//
// Guarantee: the class is exact. Every decision is a sign of CGAL's Epick predicates
// (orientation in 3D and 2D, collinearity, order along a line) evaluated on the float32
// coordinates converted to double (exact), which CGAL filters and falls back to exact
// rational arithmetic; nothing is constructed. Per triangle T = (a, b, c) and open
// segment (p, q), p != q:
//   - T collinear (zero area): never blocks; Degenerate iff the open segment meets one
//     of its three closed edges.
//   - op = orient(a,b,c,p), oq = orient(a,b,c,q) both 0 (coplanar): Degenerate iff the
//     open segment meets the closed triangle (tested in the axis plane where T projects
//     with non-zero area, an affine bijection of T's plane: both endpoints in T, or the
//     open segment meets a closed edge).
//   - one of op, oq is 0, or op == oq: the open segment never reaches T's plane: miss.
//     (So an endpoint on a face does not by itself touch the open segment.)
//   - op, oq strictly opposite: s1..s3 = orient(p,q,a,b), orient(p,q,b,c),
//     orient(p,q,c,a); all non-zero and equal: Blocked; the non-zero ones equal with some
//     zero: Degenerate (the crossing point is on an edge or a vertex); else miss.
// A segment with from == to is empty: Visible with margin 0.
//
// Margin (double estimate, DESIGN section 5). D = scene bounds diagonal (1 if 0).
//   dist_plane(x)  = |det(b-a, c-a, x-a)| / |(b-a) x (c-a)|   (distance of x from T's plane)
//   dist_line(u,v) = |det(q-p, u-p, v-p)| / |(q-p) x (v-u)|   (distance between the line pq
//                    and the edge line uv; for parallel lines |(u-p) x (q-p)| / |q-p|)
//   Blocked by T:  m(T) = min(dist_plane(p), dist_plane(q), dist_line(a,b),
//                  dist_line(b,c), dist_line(c,a)); relation margin = max over blocking
//                  T of m(T) / D (the best blocker).
//   T missed:      w_plane = 0 if p, q are strictly on opposite sides of T's plane, else
//                  min(dist_plane(p), dist_plane(q)); with d_e = dist_line of edge e and
//                  s_e the sign of its orientation (double estimate),
//                  w_edge = min(max_{s_e > 0} d_e, max_{s_e < 0} d_e) (max over none = 0:
//                  the cheaper group of edge lines to cross so that all signs agree);
//                  miss(T) = max(w_plane, w_edge). Coplanar and zero-area triangles:
//                  miss(T) = the double distance between the segment and T's edges.
//                  Visible margin = min(cap, min over nearby T of miss(T)) / D, where the
//                  nearby triangles are those whose float box, enlarged by cap, the closed
//                  segment meets (a double slab test), and cap = D / 1024 (kMarginCap):
//                  a visible margin equal to 2^-10 means "no triangle within cap".
//   Degenerate:    0.
// The margin is an estimate in double (rounding, and the distances are first-order
// proxies for "how far a vertex must move"), not a certified bound.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "lib/scene/scene.h"

namespace visgate::oracle {

enum class RelationClass : char { Visible = 'v', Blocked = 'b', Degenerate = 'd' };

// Relative cap of visible margins (see above): 2^-10 of the scene diagonal.
inline constexpr double kMarginCap = 1.0 / 1024.0;

struct RelationAnswer {
  RelationClass cls = RelationClass::Visible;
  double margin = 0.0;
};

// Exact class of the open segment (p, q) against one closed triangle (a, b, c), without
// margin. Visible here means "misses this triangle".
RelationClass classify_segment_triangle(const Vec3f& p, const Vec3f& q, const Vec3f& a, const Vec3f& b,
                                        const Vec3f& c);

// Exact classification of one open segment against the scene's blockers (no
// acceleration structure: every triangle). For tests, the minimiser and fuzzers.
// Gives the same class and margin as run_relation_oracle.
RelationAnswer classify_segment(const Scene& scene, const Vec3f& from, const Vec3f& to);

// The comparator's fragment test for many segments of one scene: blocked(from, to, tau)
// equals classify_segment(scene, from, to).cls == Blocked && margin >= tau, exactly (the
// same box and exact triangle tests on the same triangles), but prepares the scene's
// scale and triangles once, skips the visible margins the question does not need and
// stops at the first crossing triangle whose margin reaches tau. The scene must outlive
// the object.
class BlockedSegmentTest {
 public:
  explicit BlockedSegmentTest(const Scene& scene);
  ~BlockedSegmentTest();
  BlockedSegmentTest(const BlockedSegmentTest&) = delete;
  BlockedSegmentTest& operator=(const BlockedSegmentTest&) = delete;
  bool blocked(const Vec3f& from, const Vec3f& to, double tau) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct RelationOracleResult {
  // Per receiver: one character per relation, light-major then sample ('v', 'b', 'd'),
  // and the parallel margins.
  std::vector<std::string> classes;
  std::vector<std::vector<double>> margins;
  double seconds = 0.0;
};

// Every relation of the scene, with a BVH over conservatively enlarged float boxes,
// exact tests at the leaves and TBB threads (0: all). The answers do not depend on the
// thread count.
RelationOracleResult run_relation_oracle(const Scene& scene, int threads = 0);

// Only the listed receivers (rows of the other receivers stay empty).
RelationOracleResult run_relation_oracle(const Scene& scene, const std::vector<size_t>& receivers, int threads = 0);

// Every relation's class only, the same classes as run_relation_oracle (the same BVH,
// boxes and exact tests; a relation's class is Blocked as soon as one triangle crosses
// it, so its traversal stops there, and no distances are computed); every margin is
// NaN. For callers that need the margins of a few relations only (the fuzz targets: of
// the relations a method answers differently, from classify_segment, which gives the
// same margin).
RelationOracleResult run_relation_oracle_classes(const Scene& scene, int threads = 0);

}  // namespace visgate::oracle
