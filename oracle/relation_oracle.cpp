// The relation oracle (DESIGN section 5; relation semantics of section 3, paper 000
// section 1.8: V(r, l) over the open segment). Exact classes from CGAL Epick predicates
// on exactly converted float32 inputs; margins estimated in double; a BVH over float
// triangle boxes with enlarged bounds prunes the exact tests. The case analysis and the
// margin formulas are documented in relation_oracle.h.
#include "oracle/relation_oracle.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>

#include "lib/geom/float_mode.h"
#include "lib/solver.h"

namespace visgate::oracle {

namespace {

using K = CGAL::Exact_predicates_inexact_constructions_kernel;
using P3 = K::Point_3;
using P2 = K::Point_2;

enum class Hit { Miss, Touch, Cross };

P3 to_p3(const Vec3f& v) { return P3(double(v.x), double(v.y), double(v.z)); }

// Drops coordinate k (the remaining two in cyclic order): an affine map that is a
// bijection on any plane whose normal has a non-zero k component.
P2 drop(const P3& x, int k) { return P2(x[(k + 1) % 3], x[(k + 2) % 3]); }

// Axis k whose drop keeps the triangle (a, b, c) non-degenerate (sign of normal_k != 0).
int projection_axis(const P3& a, const P3& b, const P3& c) {
  for (int k = 0; k < 3; ++k)
    if (CGAL::orientation(drop(a, k), drop(b, k), drop(c, k)) != CGAL::COLLINEAR) return k;
  return -1;
}

// 1D overlap of the open interval (p, q) with the closed interval [u, v] along a line
// on which coordinate `ax` of the given points is an affine parameter (p[ax] != q[ax]).
template <class P>
bool open_closed_overlap_1d(const P& p, const P& q, const P& u, const P& v, int ax) {
  double a = p[ax], b = q[ax], c = u[ax], d = v[ax];
  if (a > b) std::swap(a, b);
  if (c > d) std::swap(c, d);
  return c < b && d > a;
}

// Open 2D segment (p, q), p != q, against the closed segment [u, v].
bool open_seg_meets_closed_seg_2(const P2& p, const P2& q, const P2& u, const P2& v) {
  if (u == v) return CGAL::collinear(p, q, u) && CGAL::collinear_are_strictly_ordered_along_line(p, u, q);
  CGAL::Orientation o1 = CGAL::orientation(p, q, u), o2 = CGAL::orientation(p, q, v);
  if (o1 == CGAL::COLLINEAR && o2 == CGAL::COLLINEAR) return open_closed_overlap_1d(p, q, u, v, p.x() != q.x() ? 0 : 1);
  if (o1 == o2) return false;  // both strictly on one side
  // Lines cross in one point X, which lies in [u, v]; X is in the open (p, q) iff p, q are
  // strictly on opposite sides of line uv.
  CGAL::Orientation o3 = CGAL::orientation(u, v, p), o4 = CGAL::orientation(u, v, q);
  return o3 != CGAL::COLLINEAR && o4 != CGAL::COLLINEAR && o3 != o4;
}

// Open 3D segment (p, q), p != q, against the closed segment [u, v].
bool open_seg_meets_closed_seg_3(const P3& p, const P3& q, const P3& u, const P3& v) {
  if (u == v) return CGAL::collinear(p, q, u) && CGAL::collinear_are_strictly_ordered_along_line(p, u, q);
  if (CGAL::orientation(p, q, u, v) != CGAL::COPLANAR) return false;
  const P3* w = !CGAL::collinear(p, q, u) ? &u : (!CGAL::collinear(p, q, v) ? &v : nullptr);
  if (w) {
    // The four points span one plane; drop an axis along which it projects bijectively.
    int k = projection_axis(p, q, *w);
    VG_CHECK(k >= 0);
    return open_seg_meets_closed_seg_2(drop(p, k), drop(q, k), drop(u, k), drop(v, k));
  }
  // All four on one line: any coordinate in which p and q differ parametrises it.
  int ax = p.x() != q.x() ? 0 : (p.y() != q.y() ? 1 : 2);
  return open_closed_overlap_1d(p, q, u, v, ax);
}

// Closed 2D triangle (a, b, c) with orientation `s` contains x.
bool in_closed_triangle_2(const P2& a, const P2& b, const P2& c, CGAL::Orientation s, const P2& x) {
  CGAL::Orientation o1 = CGAL::orientation(a, b, x), o2 = CGAL::orientation(b, c, x), o3 = CGAL::orientation(c, a, x);
  return (o1 == s || o1 == CGAL::COLLINEAR) && (o2 == s || o2 == CGAL::COLLINEAR) && (o3 == s || o3 == CGAL::COLLINEAR);
}

// The exact case analysis of relation_oracle.h for one triangle; p != q. `flat` (when
// given) is set when the triangle has zero area or is coplanar with the segment.
Hit classify_exact(const P3& p, const P3& q, const P3& a, const P3& b, const P3& c, bool* flat = nullptr) {
  if (flat) *flat = true;
  if (CGAL::collinear(a, b, c)) {
    // Zero-area triangle: the union of its closed edges; it can touch, never cross.
    bool t = open_seg_meets_closed_seg_3(p, q, a, b) || open_seg_meets_closed_seg_3(p, q, b, c) ||
             open_seg_meets_closed_seg_3(p, q, c, a);
    return t ? Hit::Touch : Hit::Miss;
  }
  CGAL::Orientation op = CGAL::orientation(a, b, c, p), oq = CGAL::orientation(a, b, c, q);
  if (op == CGAL::COPLANAR && oq == CGAL::COPLANAR) {
    int k = projection_axis(a, b, c);
    VG_CHECK(k >= 0);
    P2 a2 = drop(a, k), b2 = drop(b, k), c2 = drop(c, k), p2 = drop(p, k), q2 = drop(q, k);
    CGAL::Orientation s = CGAL::orientation(a2, b2, c2);
    bool t = (in_closed_triangle_2(a2, b2, c2, s, p2) && in_closed_triangle_2(a2, b2, c2, s, q2)) ||
             open_seg_meets_closed_seg_2(p2, q2, a2, b2) || open_seg_meets_closed_seg_2(p2, q2, b2, c2) ||
             open_seg_meets_closed_seg_2(p2, q2, c2, a2);
    return t ? Hit::Touch : Hit::Miss;
  }
  if (flat) *flat = false;
  // The open segment reaches the plane only if its endpoints are strictly on opposite sides.
  if (op == CGAL::COPLANAR || oq == CGAL::COPLANAR || op == oq) return Hit::Miss;
  CGAL::Orientation s1 = CGAL::orientation(p, q, a, b), s2 = CGAL::orientation(p, q, b, c),
                    s3 = CGAL::orientation(p, q, c, a);
  int pos = (s1 == CGAL::POSITIVE) + (s2 == CGAL::POSITIVE) + (s3 == CGAL::POSITIVE);
  int neg = (s1 == CGAL::NEGATIVE) + (s2 == CGAL::NEGATIVE) + (s3 == CGAL::NEGATIVE);
  if (pos > 0 && neg > 0) return Hit::Miss;
  return (pos == 3 || neg == 3) ? Hit::Cross : Hit::Touch;
}

// ---- margins (double estimates, formulas in relation_oracle.h) ----

double det3(const Vec3d& u, const Vec3d& v, const Vec3d& w) { return dot(u, cross(v, w)); }

double dist_plane(const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& x) {
  Vec3d n = cross(b - a, c - a);
  double ln = length(n);
  return ln > 0 ? std::abs(dot(n, x - a)) / ln : length(x - a);
}

// Signed volume and distance between line pq and line uv.
double dist_line(const Vec3d& p, const Vec3d& q, const Vec3d& u, const Vec3d& v, double* signed_det) {
  Vec3d d = q - p;
  double det = det3(d, u - p, v - p);
  if (signed_det) *signed_det = det;
  double lc = length(cross(d, v - u));
  if (lc > 0) return std::abs(det) / lc;
  double ld = length(d);
  return ld > 0 ? length(cross(u - p, d)) / ld : length(u - p);
}

double dist_point_segment(const Vec3d& x, const Vec3d& a, const Vec3d& b) {
  Vec3d ab = b - a;
  double l2 = dot(ab, ab);
  double t = l2 > 0 ? std::clamp(dot(x - a, ab) / l2, 0.0, 1.0) : 0.0;
  return length(x - (a + ab * t));
}

// Distance between closed segments [p, q] and [u, v] (double): minimum over the
// endpoint-to-segment distances and, when the segments' lines cross between them, the
// line distance.
double dist_segment_segment(const Vec3d& p, const Vec3d& q, const Vec3d& u, const Vec3d& v) {
  double d = std::min({dist_point_segment(p, u, v), dist_point_segment(q, u, v), dist_point_segment(u, p, q),
                       dist_point_segment(v, p, q)});
  Vec3d d1 = q - p, d2 = v - u, r = p - u;
  double a = dot(d1, d1), e = dot(d2, d2), b = dot(d1, d2), c = dot(d1, r), f = dot(d2, r);
  double den = a * e - b * b;
  if (den > 0) {
    double s = (b * f - c * e) / den, t = (a * f - b * c) / den;
    if (s > 0 && s < 1 && t > 0 && t < 1) d = std::min(d, length((p + d1 * s) - (u + d2 * t)));
  }
  return d;
}

double blocked_distance(const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  return std::min({dist_plane(a, b, c, p), dist_plane(a, b, c, q), dist_line(p, q, a, b, nullptr),
                   dist_line(p, q, b, c, nullptr), dist_line(p, q, c, a, nullptr)});
}

double miss_distance(bool flat, const Vec3d& p, const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  if (flat)
    return std::min({dist_segment_segment(p, q, a, b), dist_segment_segment(p, q, b, c), dist_segment_segment(p, q, c, a)});
  Vec3d n = cross(b - a, c - a);
  double sp = dot(n, p - a), sq = dot(n, q - a);
  double w_plane = (sp > 0 && sq < 0) || (sp < 0 && sq > 0) ? 0.0 : std::min(dist_plane(a, b, c, p), dist_plane(a, b, c, q));
  double s[3], d[3];
  d[0] = dist_line(p, q, a, b, &s[0]);
  d[1] = dist_line(p, q, b, c, &s[1]);
  d[2] = dist_line(p, q, c, a, &s[2]);
  double max_pos = 0, max_neg = 0;
  for (int e = 0; e < 3; ++e) {
    if (s[e] > 0) max_pos = std::max(max_pos, d[e]);
    if (s[e] < 0) max_neg = std::max(max_neg, d[e]);
  }
  return std::max(w_plane, std::min(max_pos, max_neg));
}

// ---- segment / box test (double slab test on an enlarged float box) ----

struct Segment {
  Vec3f from, to;
  P3 P, Q;
  Vec3d p, q, dir;
  Vec3d inv;  // 1 / dir per axis (0 where dir is 0; those axes are tested separately)
  double len_sq = 0.0;
};

Segment make_segment(const Vec3f& from, const Vec3f& to) {
  Segment s;
  s.from = from;
  s.to = to;
  s.P = to_p3(from);
  s.Q = to_p3(to);
  s.p = to_double(from);
  s.q = to_double(to);
  s.dir = s.q - s.p;
  for (int k = 0; k < 3; ++k) s.inv[k] = s.dir[k] != 0.0 ? 1.0 / s.dir[k] : 0.0;
  s.len_sq = dot(s.dir, s.dir);
  return s;
}

// Closed segment meets the box [lo - e, hi + e] (double slab test with the rounded
// inverse direction). The parameters t carry relative errors of a few ulps, i.e. an
// absolute error below ~1e-15 (|lo| + |p|) / |dir_k| in t, while the enlargement e gives
// a slack of e / |dir_k|; with e >= 2^-34 M (see scene_scale) the test never rejects a
// box that the segment meets.
bool segment_meets_box(const Segment& s, const Vec3f& lo, const Vec3f& hi, double e) {
  double t0 = 0.0, t1 = 1.0;
  for (int k = 0; k < 3; ++k) {
    double l = double(lo[k]) - e, h = double(hi[k]) + e, o = s.p[k], d = s.dir[k];
    if (d == 0.0) {
      if (o < l || o > h) return false;
      continue;
    }
    double ta = (l - o) * s.inv[k], tb = (h - o) * s.inv[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// Prepared triangle data, in BVH order.
struct Tri {
  P3 A, B, C;
  Vec3d a, b, c;
  Vec3f lo, hi;
};

// Per-relation accumulator.
struct Accum {
  bool classes_only = false;  // run_relation_oracle_classes: no margins, stop at a crossing
  bool blocked = false, touched = false;
  double best_block = 0.0;                                      // max over blockers
  double min_miss = std::numeric_limits<double>::infinity();    // min over nearby misses
};

// Segments further than `cap` from a triangle's box do not visit it; the rounding of the
// slab test is far below cap (cap >= 2^-33 of the largest coordinate, see scale_of).
void test_triangle(const Segment& s, const Tri& t, double cap, Accum& acc) {
  if (!segment_meets_box(s, t.lo, t.hi, cap)) return;
  bool flat = false;
  Hit h = classify_exact(s.P, s.Q, t.A, t.B, t.C, &flat);
  if (h == Hit::Cross) {
    acc.blocked = true;
    if (!acc.classes_only) acc.best_block = std::max(acc.best_block, blocked_distance(s.p, s.q, t.a, t.b, t.c));
  } else if (h == Hit::Touch) {
    acc.touched = true;
  } else if (!acc.classes_only && !acc.blocked && !acc.touched) {
    acc.min_miss = std::min(acc.min_miss, miss_distance(flat, s.p, s.q, t.a, t.b, t.c));
  }
}

RelationAnswer finish(const Accum& acc, double diag, double cap) {
  RelationAnswer r;
  if (acc.classes_only) {
    r.cls = acc.blocked ? RelationClass::Blocked : acc.touched ? RelationClass::Degenerate : RelationClass::Visible;
    r.margin = std::numeric_limits<double>::quiet_NaN();
    return r;
  }
  if (acc.blocked) {
    r.cls = RelationClass::Blocked;
    r.margin = acc.best_block / diag;
  } else if (acc.touched) {
    r.cls = RelationClass::Degenerate;
    r.margin = 0.0;
  } else {
    r.cls = RelationClass::Visible;
    r.margin = std::min(cap, acc.min_miss) / diag;
  }
  return r;
}

Tri make_tri(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  Tri t;
  t.A = to_p3(a);
  t.B = to_p3(b);
  t.C = to_p3(c);
  t.a = to_double(a);
  t.b = to_double(b);
  t.c = to_double(c);
  t.lo = vmin(a, vmin(b, c));
  t.hi = vmax(a, vmax(b, c));
  return t;
}

// Scene diagonal D (1 when the scene is a single point) and the margin cap D / 1024.
// cap is also the box enlargement of the traversal; since float coordinates of a scene
// with diagonal D and largest magnitude M satisfy D >= 2^-24 M unless all points
// coincide, cap >= 2^-34 M, far above the double rounding of the slab test (~2^-50 M).
void scene_scale(const Scene& scene, double& diag, double& cap) {
  diag = scene.bounds().diagonal();
  if (!(diag > 0.0)) diag = 1.0;
  cap = diag * kMarginCap;
}

// ---- BVH over triangle boxes ----

struct Node {
  Vec3f lo, hi;
  uint32_t first = 0, count = 0;  // leaf: triangles [first, first + count); inner: count 0
  uint32_t right = 0;             // inner: right child (left child is this + 1)
};

class Bvh {
 public:
  explicit Bvh(const TriangleSoup& mesh) {
    size_t n = mesh.size();
    std::vector<uint32_t> order(n);
    std::iota(order.begin(), order.end(), 0u);
    std::vector<Vec3f> centre(n);
    std::vector<Tri> tris(n);
    for (size_t i = 0; i < n; ++i) {
      tris[i] = make_tri(mesh.corner(i, 0), mesh.corner(i, 1), mesh.corner(i, 2));
      // Halves first: lo + hi overflows to infinity for coordinates near FLT_MAX.
      centre[i] = tris[i].lo * 0.5f + tris[i].hi * 0.5f;
    }
    if (n > 0) {
      nodes_.reserve(2 * n / kLeaf + 2);
      build(order, centre, tris, 0, uint32_t(n));
    }
    tris_.resize(n);
    for (size_t i = 0; i < n; ++i) tris_[i] = tris[order[i]];
  }

  void query(const Segment& s, double cap, Accum& acc) const {
    if (nodes_.empty()) return;
    // Node boxes hold their triangles' boxes; grow the enlargement a little more than the
    // per-triangle test so that rounding in the slab test can never prune a triangle box
    // that test_triangle would accept.
    const double e = cap * (1.0 + 1.0 / 1024.0);
    uint32_t stack[128];
    int sp = 0;
    stack[sp++] = 0;
    while (sp > 0 && !(acc.classes_only && acc.blocked)) {  // a crossing decides the class
      const Node& nd = nodes_[stack[--sp]];
      if (!segment_meets_box(s, nd.lo, nd.hi, e)) continue;
      if (nd.count > 0) {
        for (uint32_t i = nd.first; i < nd.first + nd.count; ++i) test_triangle(s, tris_[i], cap, acc);
        continue;
      }
      uint32_t self = uint32_t(&nd - nodes_.data());
      VG_CHECK(sp + 2 <= 128);
      stack[sp++] = nd.right;
      stack[sp++] = self + 1;
    }
  }

 private:
  static constexpr uint32_t kLeaf = 4;

  uint32_t build(std::vector<uint32_t>& order, const std::vector<Vec3f>& centre, const std::vector<Tri>& tris,
                 uint32_t begin, uint32_t end) {
    uint32_t idx = uint32_t(nodes_.size());
    nodes_.emplace_back();
    AABB box, cbox;
    for (uint32_t i = begin; i < end; ++i) {
      box.extend(tris[order[i]].lo);
      box.extend(tris[order[i]].hi);
      cbox.extend(centre[order[i]]);
    }
    nodes_[idx].lo = box.lo;
    nodes_[idx].hi = box.hi;
    if (end - begin <= kLeaf || cbox.extent()[cbox.longest_axis()] == 0.0f) {
      nodes_[idx].first = begin;
      nodes_[idx].count = end - begin;
      return idx;
    }
    // Binned surface-area heuristic on the longest centroid axis; the split is clamped to
    // keep at least a quarter of the triangles on each side, so the depth stays below
    // log_{4/3}(n) + 1 (< 62 for 2^32 triangles) and the fixed stack of 128 suffices.
    int ax = cbox.longest_axis();
    constexpr int kBins = 16;
    // In double: the float extent overflows to infinity when the centroids span more
    // than FLT_MAX (coordinates near +-FLT_MAX), and inf / inf would be NaN. cw > 0 here.
    const double c0 = cbox.lo[ax], cw = double(cbox.hi[ax]) - double(cbox.lo[ax]);
    auto bin_of = [&](uint32_t t) {
      return std::min(kBins - 1, int(double(kBins) * ((double(centre[t][ax]) - c0) / cw)));
    };
    AABB bb[kBins];
    uint32_t bc[kBins] = {};
    for (uint32_t i = begin; i < end; ++i) {
      int b = bin_of(order[i]);
      bb[b].extend(tris[order[i]].lo);
      bb[b].extend(tris[order[i]].hi);
      ++bc[b];
    }
    float right_area[kBins] = {};
    AABB acc;
    for (int b = kBins - 1; b > 0; --b) {
      acc.extend(bb[b]);
      right_area[b] = acc.surface_area();
    }
    acc = AABB();
    uint32_t nl = 0, n = end - begin, best_left = n / 2;
    float best = std::numeric_limits<float>::infinity();
    for (int b = 0; b + 1 < kBins; ++b) {
      acc.extend(bb[b]);
      nl += bc[b];
      if (nl < n / 4 || n - nl < n / 4) continue;
      float cost = acc.surface_area() * float(nl) + right_area[b + 1] * float(n - nl);
      if (cost < best) {
        best = cost;
        best_left = nl;
      }
    }
    uint32_t mid = begin + best_left;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end, [&](uint32_t x, uint32_t y) {
      return centre[x][ax] < centre[y][ax] || (centre[x][ax] == centre[y][ax] && x < y);
    });
    build(order, centre, tris, begin, mid);
    uint32_t right = build(order, centre, tris, mid, end);
    nodes_[idx].right = right;
    return idx;
  }

  std::vector<Node> nodes_;
  std::vector<Tri> tris_;
};

void run_receiver(const Scene& scene, const Bvh& bvh, size_t i, double diag, double cap, bool classes_only,
                  std::string& cls, std::vector<double>& margins) {
  size_t n = scene.samples_per_receiver();
  cls.assign(n, 'v');
  margins.assign(n, 0.0);
  const Vec3f& r = scene.receivers[i].p;
  size_t b = 0;
  for (const Light& light : scene.lights) {
    for (int j = 0; j < light.samples; ++j, ++b) {
      const Vec3f& l = sample_position(light, j, i);
      if (r == l) continue;  // empty open segment: visible, margin 0
      Segment s = make_segment(r, l);
      Accum acc;
      acc.classes_only = classes_only;
      bvh.query(s, cap, acc);
      RelationAnswer a = finish(acc, diag, cap);
      cls[b] = char(a.cls);
      margins[b] = a.margin;
    }
  }
}

}  // namespace

RelationClass classify_segment_triangle(const Vec3f& p, const Vec3f& q, const Vec3f& a, const Vec3f& b,
                                        const Vec3f& c) {
  if (p == q) return RelationClass::Visible;
  switch (classify_exact(to_p3(p), to_p3(q), to_p3(a), to_p3(b), to_p3(c))) {
    case Hit::Cross: return RelationClass::Blocked;
    case Hit::Touch: return RelationClass::Degenerate;
    case Hit::Miss: break;
  }
  return RelationClass::Visible;
}

RelationAnswer classify_segment(const Scene& scene, const Vec3f& from, const Vec3f& to) {
  const IeeeFloatMode ieee;
  if (from == to) return RelationAnswer{RelationClass::Visible, 0.0};
  double diag, cap;
  scene_scale(scene, diag, cap);
  Segment s = make_segment(from, to);
  Accum acc;
  for (size_t t = 0; t < scene.mesh.size(); ++t)
    test_triangle(s, make_tri(scene.mesh.corner(t, 0), scene.mesh.corner(t, 1), scene.mesh.corner(t, 2)), cap, acc);
  return finish(acc, diag, cap);
}

struct BlockedSegmentTest::Impl {
  double diag = 1.0, cap = 0.0;
  std::vector<Tri> tris;
};

BlockedSegmentTest::BlockedSegmentTest(const Scene& scene) : impl_(std::make_unique<Impl>()) {
  const IeeeFloatMode ieee;
  scene_scale(scene, impl_->diag, impl_->cap);
  impl_->tris.reserve(scene.mesh.size());
  for (size_t t = 0; t < scene.mesh.size(); ++t)
    impl_->tris.push_back(make_tri(scene.mesh.corner(t, 0), scene.mesh.corner(t, 1), scene.mesh.corner(t, 2)));
}

BlockedSegmentTest::~BlockedSegmentTest() = default;

bool BlockedSegmentTest::blocked(const Vec3f& from, const Vec3f& to, double tau) const {
  const IeeeFloatMode ieee;
  if (from == to) return false;
  Segment s = make_segment(from, to);
  // classify_segment's margin is max over crossing triangles of blocked_distance / diag;
  // division by diag is monotone, so it reaches tau iff one triangle's quotient does.
  for (const Tri& t : impl_->tris) {
    if (!segment_meets_box(s, t.lo, t.hi, impl_->cap)) continue;
    bool flat = false;
    if (classify_exact(s.P, s.Q, t.A, t.B, t.C, &flat) != Hit::Cross) continue;
    if (blocked_distance(s.p, s.q, t.a, t.b, t.c) / impl_->diag >= tau) return true;
  }
  return false;
}

namespace {

RelationOracleResult run_oracle(const Scene& scene, const std::vector<size_t>& receivers, int threads,
                                bool classes_only) {
  auto t0 = std::chrono::steady_clock::now();
  RelationOracleResult res;
  res.classes.resize(scene.receivers.size());
  res.margins.resize(scene.receivers.size());
  double diag, cap;
  scene_scale(scene, diag, cap);
  ThreadLimit limit(threads);
  Bvh bvh(scene.mesh);
  tbb::parallel_for(tbb::blocked_range<size_t>(0, receivers.size(), 1), [&](const tbb::blocked_range<size_t>& rg) {
    const IeeeFloatMode ieee;  // Embree leaves FTZ/DAZ on in TBB workers (lib/geom/float_mode.h)
    for (size_t k = rg.begin(); k < rg.end(); ++k) {
      size_t i = receivers[k];
      VG_CHECK(i < scene.receivers.size());
      run_receiver(scene, bvh, i, diag, cap, classes_only, res.classes[i], res.margins[i]);
    }
  });
  res.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return res;
}

std::vector<size_t> all_receivers(const Scene& scene) {
  std::vector<size_t> all(scene.receivers.size());
  std::iota(all.begin(), all.end(), size_t(0));
  return all;
}

}  // namespace

RelationOracleResult run_relation_oracle(const Scene& scene, const std::vector<size_t>& receivers, int threads) {
  return run_oracle(scene, receivers, threads, false);
}

RelationOracleResult run_relation_oracle_classes(const Scene& scene, int threads) {
  return run_oracle(scene, all_receivers(scene), threads, true);
}

RelationOracleResult run_relation_oracle(const Scene& scene, int threads) {
  return run_oracle(scene, all_receivers(scene), threads, false);
}

}  // namespace visgate::oracle
