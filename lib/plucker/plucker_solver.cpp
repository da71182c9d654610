// `plucker-bsp`: paper 002 Algorithm 2 around the lazy BSP; see plucker_solver.h.
#include "lib/plucker/plucker_solver.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>

#include "lib/base/check.h"
#include "lib/geom/expansion.h"
#include "lib/geom/float_mode.h"
#include "lib/plucker/bsp.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/fragment.h"
#include "lib/plucker/lines.h"
#include "lib/plucker/shaft.h"
#include "lib/plucker/triangle_tree.h"
#include "lib/scene/rng.h"

namespace visgate::plucker {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Error bound of h(x) = n . (x - p0) in float: 1 rounding in the difference, 1 per
// product, 2 in the sum: (1 + u)^4 - 1 < 4.01 u of |n|_1 |x - p0|_1; doubled.
constexpr float kDotErr = 8.0f * kUnitRoundoff;

// A light in its local frame (plucker_solver.h "Local frame"): every point below is
// relative to `origin`, the light's first vertex.
struct LightFrame {
  const Light* light = nullptr;
  Vec3f origin{};          // world position of the local origin (a light vertex)
  std::vector<Vec3d> poly;  // local (double: exact x - origin for float x, see to_local_d)
  Vec3f n{}, p0{};
  LightBounds bounds;       // of poly, centroid included: every fragment is a piece of it (node_plane)
  float plane_tol = 0.0f;  // max |h| of the light's own vertices plus the h error bound
  AABB box;                // local
  float extent = 0.0f;     // largest side of box
  PlaneFrame frame;
  LightPlane plane;        // n, plane_tol, extent, frame: for shadow boxes (fragment.h)
  // The plane in double (LightPlane::nd, h0): h(x) = nd . x - h0 in the slab tests.
  Vec3d nd{};
  double h0 = 0.0;
  // Exactly planar light (every vertex exactly on the plane of vertices 0, p1, p2, which
  // are not collinear; true of every axis-aligned light): the side of a point is then
  // decided exactly, as the region oracle decides it. emit_sign: the sign of
  // orient3d(v0, v_p1, v_p2, x) for x on the emitting side.
  bool planar = false;
  int p1 = 1, p2 = 2, emit_sign = 1;
  std::vector<Vec3d> samples;     // local jitter points, parallel to light.jitter_points
  std::vector<uint8_t> on_light;  // per jitter point: on the light polygon (fragment test)
  // The region oracle's exact light plane over the frame's (u, v) axes, for the exact
  // path's plane values at fragment vertices (exact_orient.h LiftedLight).
  LiftedLight lift;
};

Vec3f to_local(const Vec3f& x, const Vec3f& origin) { return x - origin; }
// The same in double: exact whenever the exponents of x and origin differ by at most 29
// (the difference of two floats then fits in 53 bits), else rounded once at u_d.
Vec3d to_local_d(const Vec3f& x, const Vec3f& origin) { return to_double(x) - to_double(origin); }

// True when to_local_d(x, origin) is exact: every coordinate difference of the two
// floats fits a double (always, unless their exponents differ by more than 29; Two-Sum's
// error term is then 0).
bool translates_exactly(const Vec3f& x, const Vec3f& origin) {
  for (int k = 0; k < 3; ++k) {
    double d, e;
    expansion::two_sum(double(x[k]), -double(origin[k]), d, e);
    if (e != 0.0) return false;
  }
  return true;
}

// The origin: the light vertex nearest to `focus` (the centre of the receivers' box).
// Fragments are float points relative to it, resolved to u times their distance from it:
// the light part the receivers look at should be near it (fuzz_plucker f71e1b21...: a
// light 4e5 long whose far tip was vertex 0; its fragments where the receivers and
// occluders are had a float spacing of 0.03 and lost a shadow band 0.017 wide).
LightFrame make_frame(const Light& light, const Vec3d& focus) {
  LightFrame f;
  f.light = &light;
  f.origin = light.polygon[0];
  double best = std::numeric_limits<double>::infinity();
  for (const Vec3f& v : light.polygon) {
    double d = max_component(vabs(to_double(v) - focus));
    if (d < best) best = d, f.origin = v;
  }
  f.poly.reserve(light.polygon.size());
  for (const Vec3f& v : light.polygon) f.poly.push_back(to_local_d(v, f.origin));
  f.n = light.normal;
  f.p0 = Vec3f(0, 0, 0);  // the origin vertex, on the light
  for (const Vec3f& v : light.polygon) {
    Vec3f d = to_local(v, f.origin);
    f.box.extend(d);
    float h = std::abs(dot(f.n, d)) + kDotErr * norm1(f.n) * norm1(d);
    f.plane_tol = std::max(f.plane_tol, h);
  }
  f.frame = PlaneFrame::from_normal(f.n);
  f.extent = max_component(f.box.extent());
  {
    // The vertex pair spanning the largest float area with vertex 0, then exactness.
    const auto& v = light.polygon;
    float widest = 0.0f;
    for (size_t a = 1; a < v.size(); ++a)
      for (size_t b = a + 1; b < v.size(); ++b) {
        float ar = norm1(cross(v[a] - v[0], v[b] - v[0]));
        if (ar > widest) widest = ar, f.p1 = int(a), f.p2 = int(b);
      }
    Vec3f c = cross(v[size_t(f.p1)] - v[0], v[size_t(f.p2)] - v[0]);
    float cn = dot(c, f.n), bound = 16.0f * kUnitRoundoff * norm1(v[size_t(f.p1)] - v[0]) * norm1(v[size_t(f.p2)] - v[0]);
    f.planar = std::abs(cn) > bound;
    f.emit_sign = cn > 0.0f ? 1 : -1;
    for (size_t k = 0; k < v.size() && f.planar; ++k)
      f.planar = orient3d_exact_sign(v[0], v[size_t(f.p1)], v[size_t(f.p2)], v[k]) == 0;
  }
  if (!f.planar) {
    // The lifted polygon (below) depends on the dropped axis: the region oracle's,
    // decided on the exact Newell normal (exact_orient.h newell_dominant_axis), not the
    // float normal's largest component.
    const int axis = newell_dominant_axis(light.polygon.data(), int(light.polygon.size()));
    if (axis != 3 - f.frame.u - f.frame.v) {
      f.frame.u = (axis + 1) % 3;
      f.frame.v = (axis + 2) % 3;
      f.frame.flip = f.n[axis] < 0.0f;
    }
    // A light whose float vertices are not coplanar (DESIGN allows 1e-5 of its extent)
    // is, for the region oracle, the polygon of its vertices' (u, v) coordinates lifted
    // along the dropped axis onto the plane of its Newell normal through its centroid
    // (oracle/region_oracle.h "Exact frame"). The fragments start from that polygon (in
    // double), not from the float vertices, and the light plane every slab test uses
    // (h(x) = n . (x - p0)) passes through the lifted origin vertex p0: fuzz_plucker
    // crash-d5cc89fd... (a light 0.003 wide whose vertices are 0.0015 off that plane) and
    // crash-ac8bb51f... (a light 2.6e5 long, vertices 0.84 off it, receivers 0.4 to 1.6
    // away, a blocker between the two planes culled as "beyond the light") lost 1.5e-4
    // and 3e-3 of the fraction. The (u, v) coordinates, hence point-in-fragment of the
    // samples, are unchanged. The Newell normal is translation invariant, so it is taken
    // on the local coordinates.
    Vec3d nn(0, 0, 0), cc(0, 0, 0);
    const size_t m = f.poly.size();
    for (size_t k = 0; k < m; ++k) {
      nn += cross(f.poly[k], f.poly[(k + 1) % m]);
      cc += f.poly[k];
    }
    cc = cc / double(m);
    const int u = f.frame.u, v = f.frame.v, w = 3 - u - v;
    if (nn[w] != 0.0) {
      for (Vec3d& p : f.poly) p[w] = cc[w] - (nn[u] * (p[u] - cc[u]) + nn[v] * (p[v] - cc[v])) / nn[w];
      Vec3d p0d(0, 0, 0);
      for (size_t k = 0; k < m; ++k)
        if (light.polygon[k] == f.origin) p0d = f.poly[k];
      f.p0 = Vec3f(p0d);
      // The slab tests in double against the lifted plane: the float normal's rounding
      // (u |x| over the light) would be 0.3 at the far end of a light 4e5 long, more
      // than the receivers' heights in crash-ac8bb51f.... The lifted vertices are on it
      // to double rounding; plane_tol bounds that (4 u_d |nd|_1 |p - p0|_1, doubled)
      // and the float evaluation of the receivers' and samples' sides (kDotErr terms).
      f.nd = nn / length(nn);
      f.h0 = dot(f.nd, p0d);
      double tol = 0.0;
      for (const Vec3d& p : f.poly) {
        f.box.extend(Vec3f(p));
        Vec3d d = p - p0d;
        tol = std::max(tol, std::abs(dot(f.nd, d)) + 8.0 * 0x1p-53 * norm1(f.nd) * norm1(d));
      }
      f.plane_tol = float(tol) * 2.0f;
      f.extent = max_component(f.box.extent());
    }
  }
  if (f.planar || f.nd == Vec3d(0, 0, 0)) f.nd = to_double(f.n);
  f.lift = LiftedLight(light.polygon.data(), int(light.polygon.size()), f.frame.u, f.frame.v);
  f.plane = LightPlane{f.n, f.plane_tol, f.extent, f.frame, f.nd, f.h0};
  f.bounds = LightBounds::of(f.poly.data(), int(f.poly.size()));
  // Light points (DESIGN section 6 allows explicit samples anywhere): a point on the
  // light's plane (|h| within the rounding bound used for receivers) and inside the
  // light polygon (point_in_fragment's boundary bound) is decided by point-in-fragment;
  // any other point by segment tests (plucker_solver.h "Light points").
  f.samples.resize(light.jitter_points.size());
  f.on_light.resize(light.jitter_points.size());
  for (size_t k = 0; k < light.jitter_points.size(); ++k) {
    f.samples[k] = to_local_d(light.jitter_points[k], f.origin);
    Vec3f d = to_local(light.jitter_points[k], f.origin) - f.p0;
    float h = dot(f.n, d);
    float tol = f.plane_tol + kDotErr * norm1(f.n) * norm1(d);
    f.on_light[k] = std::abs(h) <= tol && point_in_fragment(f.frame, f.poly.data(), int(f.poly.size()), f.samples[k]);
  }
  return f;
}

// Index of sample_position(light, j, i) in light.jitter_points (and LightFrame::samples).
size_t sample_index(const Light& light, int j, size_t i) {
  return size_t(&sample_position(light, j, i) - light.jitter_points.data());
}

// The open segment r -> s (local) against every triangle of the scene, each translated
// to the local frame as it is tested (lines.h segment_blocked).
bool segment_blocked_by_scene(const Scene& scene, const Vec3f& origin, const Vec3f& r, const Vec3f& s) {
  for (size_t t = 0; t < scene.mesh.size(); ++t)
    if (segment_blocked(r, s, to_local(scene.mesh.corner(t, 0), origin), to_local(scene.mesh.corner(t, 1), origin),
                        to_local(scene.mesh.corner(t, 2), origin)))
      return true;
  return false;
}

// True when a polygon clipped at the light plane has a clip point and a neighbour that
// rounding cannot tell apart: two consecutive vertices at most eps apart, one of them
// on the plane, eps = 2^-36 of the two points' own coordinates (local frame; a clip
// point is interpolated from its edge's near end, fragment.h, so its rounding is
// relative to its own magnitude: a polygon-wide eps reaching 2^108, fuzz_plucker seed
// 'pouch-12850', would have caught every vertex near the light). Such an edge's
// direction is rounding noise: a vertex within rounding of the light plane but beyond
// it (h = -1.7e-21, fuzz_plucker 09bd12dc...: a grid vertex on the float plane z = 2 of
// a light whose lifted plane passes just above it) was clipped into two points 1e-21
// apart on a triangle of size 1, and the plane through a receiver and their edge cut the
// shadow wedge at the vertex in half (fraction 0.75 for 0.62). Merging the two points
// instead (the rule until stop 26) moves the shadow by eps at the light plane, which is
// harmless unless a receiver sees the triangle nearly edge-on: then the shadow's wedge
// angle is the triangle's width at the plane over the receiver's distance from its
// plane, and a sliver 2^-37 wide at the light plane, 1.6e-34 beside a receiver, lost
// its only distinct vertex and was dropped although it hides a quarter of the light
// (fuzz_plucker 2d069e89..., fraction 1 for 0.75). Such triangles are subtracted exactly
// per receiver (subtract_triangle_exact, which needs no clipping at the light plane),
// as those within rounding of the plane (`plane_point_triangles`).
// `poly` has at least 3 vertices.
bool close_plane_points(const std::vector<Vec3d>& poly, const std::vector<uint8_t>& on_plane) {
  auto close = [](const Vec3d& a, const Vec3d& b) {
    const double eps = 0x1p-36 * std::max(max_component(vabs(a)), max_component(vabs(b)));
    return max_component(vabs(a - b)) <= eps;
  };
  const size_t n = poly.size();
  for (size_t k = 0; k < n; ++k) {
    const size_t k1 = (k + 1) % n;
    if ((on_plane[k] || on_plane[k1]) && close(poly[k], poly[k1])) return true;
  }
  return false;
}

// Side of the 8 corners of the receivers' box against the plane of the triangle t
// (world coordinates, the inputs as given: the local frame's rounding moves points by
// u |x - o|, which is enough to put a receiver 6e-9 below a face above it, fuzz_plucker
// 68d82337...): per corner x the sign of det[t1 - t0, t2 - t0, x - t0] =
// orient3d(t0, t1, t2, x), in float as (x - base) . N with N = edge_plane_normal_err(t0,
// t1, t2) (the cross product of its two shortest edges) and base the vertex nearest to x
// (lines.h nearest_base), decided against dot_err; undecided counts for neither side.
// The textbook (t1 - t0) x (t2 - t0) . (x - t0) loses the plane of a sliver with a vertex
// 6e5 away (fuzz_plucker dfb33fdd...: both long edges, their cross product's rounding
// larger than the triangle's area) and called receivers beside it "on the plane".
// +1 when every corner is strictly on the positive side, -1 when every one is strictly
// negative, else 0; the normal and its bound are computed once and the loop stops at the
// first corner that breaks the common sign (measured, rooms 1024 receivers and 27 lights:
// the former per-corner side test, normal included, was 12.5% of the solve).
int box_side(const Vec3f t[3], const Vec3f corners[8]) {
  Vec3f err;
  const Vec3f nrm = edge_plane_normal_err(t[0], t[1], t[2], err);
  int side = 0;
  for (int c = 0; c < 8; ++c) {
    const Vec3f d = corners[c] - nearest_base(t[0], t[1], t[2], corners[c]);
    const float s = dot(d, nrm), bound = dot_err(d, nrm, err);
    const int sd = s > bound ? 1 : (s < -bound ? -1 : 0);
    if (sd == 0 || (c > 0 && sd != side)) return 0;
    side = sd;
  }
  return side;
}

// A triangle part handled per receiver (plucker_solver.h "near" polygons).
struct NearPoly {
  uint32_t triangle;  // the scene triangle whose part this is (its plane, world coordinates)
  uint32_t begin, count;
  // Group-level data for the per-receiver tests: the polygon's box, and its triangle in
  // double local coordinates with the plane normal N = edge_plane_normal_err(t0, t1, t2)
  // (and N's error bound) and the 1-norms of two edges (near_side).
  Vec3d lo, hi;
  Vec3d t[3], n, err;
  double e1 = 0, e2 = 0, tmax = 0;
  // A part of a coplanar convex patch (shade_group shade_patch; `triangle` is its first):
  // the patch, all of whose triangles the exact paths subtract. Else -1.
  int32_t patch = -1;
};

// Side of the (local, double) point r against a near polygon's triangle plane: +1, -1, or
// 0 when undecided. Decided against dot_err plus the rounding of the local frame: every
// local point is within u_d |x|_inf of its exact translation (to_local_d), which moves
// det[t1 - t0, t2 - t0, r - t0] by at most 2 delta (|e1|_1 |e2|_1 + (|e1|_1 + |e2|_1)
// |r - base|_1) with delta = 2 u_d max |coordinate|, so a decided sign is the sign of
// the exact world configuration (the inputs as given).
int near_side(const NearPoly& np, const Vec3d& r, double rmax) {
  const Vec3d& base = nearest_base(np.t[0], np.t[1], np.t[2], r);
  Vec3d d = r - base;
  double s = dot(d, np.n);
  double d1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  double delta = 2.0 * 0x1p-53 * std::max(rmax, np.tmax);
  double bound = dot_err(d, np.n, np.err) + 2.0 * delta * (np.e1 * np.e2 + (np.e1 + np.e2) * d1);
  return s > bound ? 1 : (s < -bound ? -1 : 0);
}

struct Totals {
  double select_s = 0, init_s = 0, query_s = 0, bsp_query_s = 0, tree_s = 0, irradiance = 0;
  uint64_t trees = 0, queries = 0, occluders = 0, near = 0, fragments = 0, fallback = 0, segment_relations = 0;
  uint64_t exact_triangles = 0, exact_receivers = 0, undecided_receivers = 0, unreported_slivers = 0;
  uint64_t far_triangles = 0, band_triangles = 0, rounded_triangles = 0, close_triangles = 0, level_triangles = 0;
  uint64_t plane_point_triangles = 0, patches = 0, patch_triangles = 0;
  uint64_t bsp_nodes_max = 0;
  BspCounters bsp;
  void merge(const Totals& o) {
    select_s += o.select_s; init_s += o.init_s; query_s += o.query_s; bsp_query_s += o.bsp_query_s; tree_s += o.tree_s;
    irradiance += o.irradiance;
    trees += o.trees; queries += o.queries; occluders += o.occluders; near += o.near;
    fragments += o.fragments; fallback += o.fallback; segment_relations += o.segment_relations;
    exact_triangles += o.exact_triangles;
    far_triangles += o.far_triangles;
    band_triangles += o.band_triangles;
    rounded_triangles += o.rounded_triangles;
    close_triangles += o.close_triangles;
    level_triangles += o.level_triangles;
    plane_point_triangles += o.plane_point_triangles;
    patches += o.patches;
    patch_triangles += o.patch_triangles;
    exact_receivers += o.exact_receivers;
    undecided_receivers += o.undecided_receivers;
    unreported_slivers += o.unreported_slivers;
    bsp_nodes_max = std::max(bsp_nodes_max, o.bsp_nodes_max);
    bsp.nodes_created += o.bsp.nodes_created; bsp.developments += o.bsp.developments;
    bsp.insert_tests += o.bsp.insert_tests; bsp.splits += o.bsp.splits;
    bsp.occlusion_tests += o.bsp.occlusion_tests; bsp.lazy_visible += o.bsp.lazy_visible;
    bsp.on_line += o.bsp.on_line; bsp.zero_area += o.bsp.zero_area; bsp.merged += o.bsp.merged; bsp.visits += o.bsp.visits;
  }
};

// Live bytes of the trees shaded at the same time, and their maximum (Figure 8 "MS").
struct MemoryMeter {
  std::atomic<int64_t> current{0};
  std::atomic<int64_t> peak{0};
  MemoryBudget* budget = nullptr;  // SolveOptions::memory_budget_mb, counted by the trees
  void change(int64_t delta) {
    int64_t now = current.fetch_add(delta) + delta;
    int64_t p = peak.load();
    while (now > p && !peak.compare_exchange_weak(p, now)) {
    }
  }
};

struct Context {
  const Scene* scene;
  SolveResult* result;
  std::vector<double>* irradiance;
  bool coherence;
  LazyBsp::Choice choice;
  const TriangleTree* tree;
  uint64_t seed;
  MemoryMeter* memory;
};

// Keeps fragment f of `in` whole in `out` (box `box` in `out_boxes`), after taking back
// the pieces `out` received from index `first` on: a subtraction that split the fragment
// and then found nothing of it hidden returns the fragment instead of its pieces (a
// shadow beside a fragment still cuts it along the planes through its edges). With
// first == out.size() it only keeps the fragment.
void keep_whole(const FragmentList& in, size_t f, const Box2& box, size_t first, FragmentList& out,
                std::vector<Box2>& out_boxes) {
  out.truncate(first);
  out_boxes.resize(first);
  out.add(in.data(f), size_t(in.count(f)));
  out_boxes.push_back(box);
}

// Subtracts the near polygon q (oriented: the receiver on its negative side) from the
// fragments: bsp(q) walked once (Algorithm 1 lines 17-29 on a tree that is never stored).
// `qbox` bounds q's shadow on the light (shadow_box); a fragment whose box misses it
// is disjoint from the shadow and kept whole. `boxes` is parallel to `in`, `out_boxes`
// to `out`.
// Edges with skip[m] set (from q[m] to q[m+1]) are not tested: the caller knows every
// light line from r is on their inner side (the edge q has at r's own level, see the
// near-polygon loop in shade_group).
// Returns false, with `out` and `out_boxes` untouched, when q's shadow misses every
// fragment (box or edge plane): the fragments stay as they are and nothing is copied.
// Measured on columns 4096 x 16: about half of the 44,081 calls change nothing; not
// copying the fragments for them saves 1% of the solve's instructions.
bool subtract_polygon(const Vec3d& r, const Vec3d* q, int nq, const uint8_t* skip, const Box2& qbox,
                      const PlaneFrame& frame, const LightBounds& light, const FragmentList& in,
                      const std::vector<Box2>& boxes, FragmentList& out, std::vector<Box2>& out_boxes,
                      std::vector<Vec3d>& cur, std::vector<Vec3d>& pos, std::vector<Vec3d>& neg, BspCounters& c) {
  // The planes through r and q's edges, once for every fragment (fragment.h node_plane),
  // each written before it is read. Per thread rather than per call: 22 planes
  // default-constructed in every call were 0.7% of the instructions of a columns solve.
  static thread_local NodePlane planes[2 * kMaxOccluderVertices + 2];
  VG_CHECK(nq <= int(std::size(planes)));
  bool have_planes = false;
  auto plane = [&](int m) -> const NodePlane& {
    if (!have_planes) {
      for (int k = 0; k < nq; ++k)
        if (!skip[k]) planes[k] = node_plane(r, q[k], q[(k + 1) % nq], light);
      have_planes = true;
    }
    return planes[m];
  };
  auto keep = [&](const Vec3d* p, size_t n) {
    out.add(p, n);
    out_boxes.push_back(Box2::of(frame, p, int(n)));
  };
  int hint = 0;
  // A fragment entirely on the negative side of one edge plane misses q: kept whole,
  // without the splits the walk below would make before reaching that edge. Tried
  // from the edge that separated the previous fragment (neighbours mostly share it).
  auto misses = [&](size_t f) {
    if (!qbox.overlaps(boxes[f])) return true;
    for (int mi = 0; mi < nq; ++mi) {
      const int m = hint + mi < nq ? hint + mi : hint + mi - nq;
      if (skip[m]) continue;
      SplitResult s = classify_fragment(plane(m), in.data(f), in.count(f));
      if (s == SplitResult::OnLine) ++c.on_line;  // undecided: the caller re-shades r exactly
      if (s == SplitResult::Negative || s == SplitResult::OnLine) {
        hint = m;
        return true;
      }
    }
    return false;
  };
  // The first fragment q's shadow may meet; none: nothing changes.
  size_t first = 0;
  while (first < in.size() && misses(first)) ++first;
  if (first == in.size()) return false;
  out.clear();
  out_boxes.clear();
  for (size_t f = 0; f < first; ++f) keep_whole(in, f, boxes[f], out.size(), out, out_boxes);
  for (size_t f = first; f < in.size(); ++f) {
    if (f > first && misses(f)) {
      keep_whole(in, f, boxes[f], out.size(), out, out_boxes);
      continue;
    }
    cur.assign(in.data(f), in.data(f) + in.count(f));
    const size_t first_piece = out.size();
    bool alive = true;
    for (int m = 0; m < nq && alive; ++m) {
      if (skip[m]) continue;
      SplitResult s = split_fragment(plane(m), cur.data(), int(cur.size()), pos, neg);
      switch (s) {
        case SplitResult::Positive: break;
        case SplitResult::OnLine: ++c.on_line; [[fallthrough]];
        case SplitResult::Negative:  // what is left misses q: nothing of the fragment is hidden
          keep_whole(in, f, boxes[f], first_piece, out, out_boxes);
          alive = false;
          break;
        case SplitResult::ZeroArea: ++c.zero_area; alive = false; break;
        case SplitResult::Both:
          ++c.splits;
          if (!neg.empty()) keep(neg.data(), neg.size());
          if (pos.empty()) alive = false;
          else cur.swap(pos);
          break;
      }
    }
    // A piece positive against every edge stabs q: blocked, dropped.
  }
  return true;
}

// The exact near-plane path: removes from the fragments (local coordinates relative to
// `origin`) the light points x whose open segment from rw crosses the triangle tw
// properly (DESIGN section 3), with rw on side sigma (exact, nonzero) of tw's plane:
// x strictly on the other side of the plane, and the line rw -> x strictly on the
// stabbing side of every edge line (lines.h: side(rw -> x, t_e -> t_e+1) has the sign
// -sigma for lines crossing from side sigma). Then the crossing point lies strictly
// inside the triangle and strictly between rw and x, so no slab clipping is needed.
// Every sign is exact, taken at the region oracle's own light point of x: the exact
// lift onto the light's plane of x's (u, v) coordinates (origin + local, summed
// exactly; exact_orient.h LiftedLight); new vertices are interpolated in double from
// values accurate to 2^-30, so only points within rounding of a plane can be
// misjudged. Used where float cannot tell which way the planes through rw and the
// edges lean: receivers within rounding of a triangle's plane, extreme and undecided
// receivers, and triangles reaching far away or lying within rounding of the light's
// plane (shade_group).
void subtract_triangle_exact(const Vec3f& rw, const Vec3f tw[3], int sigma, const Vec3f& origin,
                             const PlaneFrame& frame, const LiftedLight& lift, const FragmentList& in, FragmentList& out,
                             std::vector<Box2>& out_boxes, std::vector<Vec3d>& cur) {
  out.clear();
  out_boxes.clear();
  // Scratch reused across calls (one set per thread): the exact path runs once per
  // candidate triangle and fragment list, and these three allocations were a visible
  // part of fuzz_plucker's ASan allocator time.
  thread_local std::vector<double> w;
  thread_local std::vector<Vec3d> inside, outside;
  // w > 0 inside plane k's half-space of the blocked set. The planes: the triangle's
  // (orient3d(t0, t1, t2, x)) and those through rw and each edge (det[x - rw, t_e - rw,
  // t_e+1 - rw] = orient3d(rw, t_e, t_e+1, x), cyclic columns), evaluated at the exact
  // lifted light point of x's (u, v) (LiftedLight: a vertex kept in 3D lies its rounding
  // off the light's plane, which decides the side for a receiver that close to the
  // plane), with accurate values: the clip below interpolates with them.
  LiftedLight::Plane planes[4] = {lift.plane(tw[0], tw[1], tw[2]), lift.plane(rw, tw[0], tw[1]),
                                  lift.plane(rw, tw[1], tw[2]), lift.plane(rw, tw[2], tw[0])};
  const int lu = lift.u(), lv = lift.v();
  // accurate: within 2^-30 (clip interpolation); else only the sign is exact.
  auto value = [&](int k, const Vec3d& x, bool accurate) {
    ExactOrient o = accurate ? lift.value(planes[k], origin[lu], x[lu], origin[lv], x[lv])
                             : lift.sign(planes[k], origin[lu], x[lu], origin[lv], x[lv]);
    if (o.sign == 0) return 0.0;
    double v = std::abs(o.value);
    if (!(v > 0.0)) v = std::numeric_limits<double>::min();
    return -double(sigma) * double(o.sign) * v;
  };
  for (size_t f = 0; f < in.size(); ++f) {
    cur.assign(in.data(f), in.data(f) + in.count(f));
    // The pieces split off this fragment start here; when nothing of it turns out hidden
    // they are taken back and the fragment kept whole (below).
    const size_t first_piece = out.size();
    bool blocked = true;
    for (int k = 0; k < 4; ++k) {
      w.resize(cur.size());
      bool pos = false, neg = false;
      for (size_t j = 0; j < cur.size(); ++j) {
        w[j] = value(k, cur[j], false);
        pos |= w[j] > 0.0;
        neg |= w[j] < 0.0;
      }
      if (!pos) {  // all of it outside this half-space: not hidden
        blocked = false;
        break;
      }
      if (!neg) continue;
      // A split interpolates with the values: those within 2^-30 (signs unchanged).
      for (size_t j = 0; j < cur.size(); ++j) w[j] = value(k, cur[j], true);
      // Split: the outside part is kept, the inside part goes on to the next plane.
      clip_by_values(cur.data(), w.data(), int(cur.size()), false, outside);
      clip_by_values(cur.data(), w.data(), int(cur.size()), true, inside);
      if (!outside.empty()) {
        out.add(outside.data(), outside.size());
        out_boxes.push_back(Box2::of(frame, outside.data(), int(outside.size())));
      }
      cur.swap(inside);
      if (cur.empty()) break;
    }
    if (!blocked || cur.empty()) {
      // Nothing of the fragment is hidden: the pieces split off it (outside one plane or
      // another) make up the whole fragment, which is kept instead, unsplit. Splitting it
      // anyway multiplied the fragments for nothing: a triangle whose shadow misses a
      // fragment still cuts it along the planes through its edges, and a fragment list
      // grew 1.8x per triangle to 145,369 fragments after 18 triangles, none hidden
      // (fuzz_plucker 82d969b1..., corpus/fuzz/slow: a light 2e-3 wide and 4e36 long).
      keep_whole(in, f, Box2::of(frame, in.data(f), in.count(f)), first_piece, out, out_boxes);
    }
    // Otherwise what is left is inside all four half-spaces: hidden, dropped.
  }
}

// One receiver on the light plane: float segment tests in the local frame
// (plucker_solver.h, degenerate).
void shade_fallback(const Context& ctx, size_t li, const LightFrame& lf, size_t i, Totals& tot) {
  const Scene& scene = *ctx.scene;
  const Light& light = scene.lights[li];
  ReceiverResult& rr = ctx.result->receivers[i];
  size_t off = scene.light_offset(li);
  const Vec3f r = to_local(scene.receivers[i].p, lf.origin);
  int vis = 0;
  for (int j = 0; j < light.samples; ++j) {
    bool blocked = segment_blocked_by_scene(scene, lf.origin, r, Vec3f(lf.samples[sample_index(light, j, i)]));
    rr.set_visible(off + size_t(j), !blocked);
    vis += !blocked;
  }
  tot.segment_relations += size_t(light.samples);
  rr.visible_fraction[li] = float(double(vis) / double(light.samples));
  rr.fragments[li].clear();
  ++tot.fallback;
}

// shade_group's working lists and its tree, one set per thread of a solve, kept from
// group to group: a group starts them empty (the tree rebuilt, LazyBsp::rebuild) but
// with the capacity earlier groups of the solve gave them, and the solve frees them when
// it returns (a thread-local set outlived the solve: after a light 100x larger, a
// 2-light solve in the same process reported the 41 MB the larger one had left behind).
// Allocated per group, their growth was about a fifth of plucker-bsp's samples in
// fuzz_plucker (ASan's allocator, perf 2026-12-04), where every scene is a few small
// groups. shade_group runs no parallel work of its own, so a thread never enters it
// twice at once.
struct GroupScratch {
  std::vector<Vec3d> rloc, near_verts, poly0, lower, upper, region, pyramid, pyramid_err, cur, pos, neg, q, patch;
  std::vector<NearPoly> near, near_sorted;
  std::vector<std::pair<double, uint32_t>> near_key;
  std::vector<Occluder> occluders;
  std::vector<uint8_t> on_plane0, on_level, skip, merged;
  std::vector<double> vals;
  std::vector<uint32_t> exact_tris, cand, exact_done, cell_start, cell_items, cell_fill, patch_at;
  FragmentList frags, tmp;
  std::vector<Box2> boxes, tmp_boxes;

  void clear() {
    for (auto* v : {&rloc, &near_verts, &poly0, &lower, &upper, &region, &pyramid, &pyramid_err, &cur, &pos, &neg, &q, &patch})
      v->clear();
    near.clear();
    near_sorted.clear();
    near_key.clear();
    occluders.clear();
    for (auto* v : {&on_plane0, &on_level, &skip, &merged}) v->clear();
    vals.clear();
    for (auto* v : {&exact_tris, &cand, &exact_done, &cell_start, &cell_items, &cell_fill, &patch_at}) v->clear();
    frags.clear();
    tmp.clear();
    boxes.clear();
    tmp_boxes.clear();
  }
};
struct ThreadWork {
  GroupScratch scratch;
  std::unique_ptr<LazyBsp> tree;  // made at the thread's first group
};

// Algorithm 2 for one group of receivers (all strictly on the side `sigma` of the light
// plane) and one light.
//
// Slab (DESIGN section 3): let g point towards the light with g . x > g . r for every
// light point x and receiver r. A point p on the line r -> x lies strictly between r
// and x iff g . p > g . r and h(p) > 0 (h: distance from the light plane, positive on
// the receivers' side): along the line g grows from r to x and h falls to 0 at x. With
// gmax the largest g . r of the group, a triangle part with g . p >= gmax + delta and
// h >= 0 is between every receiver of the group and the light (tree occluders); the
// band g . p <= gmax + delta is clipped per receiver (near polygons). g is the receiver
// grid's normal when the light lies beyond the group's grid plane (flat tiles: a band
// of rounding width), else the light's normal (the band spans the group's depth).
void shade_group(const Context& ctx, size_t li, const LightFrame& lf, const std::vector<uint32_t>& group, float sigma,
                 uint64_t tree_seed, ThreadWork& work, Totals& tot) {
  GroupScratch& sc = work.scratch;
  sc.clear();
  const Scene& scene = *ctx.scene;
  const Light& light = scene.lights[li];

  // --- Occluder selection (Figure 8 "SC") ---
  Clock::time_point t0 = Clock::now();
  // Everything below is in the light's local frame (plucker_solver.h): the group's
  // receivers are translated here, the triangles as they are selected.
  std::vector<Vec3d>& rloc = sc.rloc;
  rloc.resize(group.size());
  AABB rbox;  // float box for the shaft (its margin covers the rounding)
  Vec3d dlo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity());
  Vec3d dhi = -dlo;
  for (size_t k = 0; k < group.size(); ++k) {
    rloc[k] = to_local_d(scene.receivers[group[k]].p, lf.origin);
    rbox.extend(Vec3f(rloc[k]));
    dlo = vmin(dlo, rloc[k]);
    dhi = vmax(dhi, rloc[k]);
  }
  // g-values are taken relative to a reference receiver (g . p keeps the digits of the
  // differences, not those of the local coordinates).
  const Vec3d ref = rloc[0];
  AABB both = rbox;
  both.extend(lf.box);
  double coord_max = max_component(vmax(vabs(to_double(both.lo) - ref), vabs(to_double(both.hi) - ref)));
  auto gval = [&](const Vec3d& g, const Vec3d& p) { return dot(g, p - ref); };
  auto group_plane = [&](const Vec3d& g, double& gmin, double& gmax) {
    gmin = std::numeric_limits<double>::infinity();
    gmax = -gmin;
    for (const Vec3d& p : rloc) {
      double v = gval(g, p);
      gmin = std::min(gmin, v);
      gmax = std::max(gmax, v);
    }
  };
  // delta: a separation of the tree occluders from every receiver's g-plane far above
  // the rounding of g . (p - ref) (in float it had error < 5.01 u |g|_1 |p - ref|_1;
  // now in double, the float-sized delta is kept as a wide, conservative band): with
  // |p - ref|_inf <= coord_max inside the shaft, 16 u |g|_1 3 coord_max.
  Vec3d g = lf.nd * double(-sigma);
  double gmin = 0, gmax = 0;
  group_plane(g, gmin, gmax);
  if (scene.grid) {
    Vec3d gn = to_double(normalize(scene.grid->normal));
    double nmin = 0, nmax = 0;
    group_plane(gn, nmin, nmax);
    double dlt = 16.0 * double(kUnitRoundoff) * (std::abs(gn.x) + std::abs(gn.y) + std::abs(gn.z)) * 3.0 * coord_max;
    bool beyond = true, below = true;
    for (const Vec3d& v : lf.poly) {
      double gv = gval(gn, v);
      beyond &= gv > nmax + 2 * dlt;
      below &= gv < nmin - 2 * dlt;
    }
    if (below) {
      gn = -gn;
      group_plane(gn, nmin, nmax);
    }
    if (beyond || below) {
      g = gn;
      gmin = nmin;
      gmax = nmax;
    }
  }
  const double delta = 16.0 * double(kUnitRoundoff) * (std::abs(g.x) + std::abs(g.y) + std::abs(g.z)) * 3.0 * coord_max;
  // World corners of the receivers' box, for the one-sided test (box_side).
  AABB wbox;
  for (uint32_t i : group) wbox.extend(scene.receivers[i].p);
  Vec3f wcorners[8];
  for (int c = 0; c < 8; ++c)
    wcorners[c] = Vec3f((c & 1) ? wbox.hi.x : wbox.lo.x, (c & 2) ? wbox.hi.y : wbox.lo.y, (c & 4) ? wbox.hi.z : wbox.lo.z);
  Vec3d corners[8];
  for (int c = 0; c < 8; ++c)
    corners[c] = Vec3d((c & 1) ? dhi.x : dlo.x, (c & 2) ? dhi.y : dlo.y, (c & 4) ? dhi.z : dlo.z);
  Shaft shaft(rbox, lf.box);
  std::vector<Occluder>& occluders = sc.occluders;
  std::vector<NearPoly>& near = sc.near;
  std::vector<Vec3d>& near_verts = sc.near_verts;
  std::vector<Vec3d>&poly0 = sc.poly0, &lower = sc.lower, &upper = sc.upper;
  std::vector<uint8_t>& on_plane0 = sc.on_plane0;
  std::vector<double>& vals = sc.vals;
  const Vec3d nd = lf.nd, gd = g, refd = ref;
  const double gcut = gmax + delta;
  // tmax: the largest |local coordinate| of the triangle (the selection loop's).
  auto make_near = [&](uint32_t t, const Vec3d tri[3], double tmax, const std::vector<Vec3d>& part) {
    NearPoly np;
    np.triangle = t;
    np.begin = uint32_t(near_verts.size());
    np.count = uint32_t(part.size());
    np.lo = np.hi = part[0];
    for (const Vec3d& v : part) np.lo = vmin(np.lo, v), np.hi = vmax(np.hi, v);
    for (int k = 0; k < 3; ++k) np.t[k] = tri[k];
    np.n = edge_plane_normal_err(tri[0], tri[1], tri[2], np.err);
    Vec3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
    np.e1 = std::abs(e1.x) + std::abs(e1.y) + std::abs(e1.z);
    np.e2 = std::abs(e2.x) + std::abs(e2.y) + std::abs(e2.z);
    np.tmax = tmax;
    return np;
  };
  // Triangles reaching far beyond the group's working scale (the light's extent and
  // the receivers' distance from it): every double quantity of their clipping carries
  // an absolute rounding of about 2^-53 of their coordinates (and the translation to the
  // local frame one of u_d |x| when exponents differ by more than 29). Up to 2^20 times
  // the working scale that stays below 2^-33 of it, the level the far-receiver bound
  // below accepts; beyond, the light-plane crossing of an edge 4e18 long was 480 off
  // (fuzz_plucker 1cb7edfb...: a wall reaching 8.2e22 away, entirely beyond the tilted
  // light inside the slab, clipped into a sliver that hid 40% of a unit light, fraction
  // 0.60 for 1). Such triangles are subtracted exactly per receiver
  // (subtract_triangle_exact on the float inputs), never clipped in double.
  // The receivers that set the scale are those the float path shades: one more than
  // 2^20 light widths from the light is extreme and shaded exactly (below). Letting it
  // count kept a wall reaching 2^104 away on the float path for the group's other
  // receivers, where the merging of close plane points (now close_plane_points, whose
  // tolerance is relative to the points' magnitudes, 2^68 there) merged its clip points
  // at the light plane with the vertices 0.78 below them and dropped the wall
  // (fuzz_plucker 96d10f7c...: receiver 0 at 2^99, fractions 0.885, 0.817, 0.555 for
  // 0.767, 0.789, 0.527).
  // The light's width: its longest side, or its area over that side when that is smaller.
  const double light_width = std::min(double(lf.extent), double(scene.lights[li].area) / double(lf.extent));
  double work_scale = double(lf.extent);
  for (const Vec3d& rl : rloc) {
    const double d = max_component(vabs(rl - lf.bounds.centroid));
    if (std::max(d, double(lf.extent)) <= 0x1p20 * light_width) work_scale = std::max(work_scale, d);
  }
  // A coplanar convex patch (triangle_tree.h; its triangles tris, the first of them t with
  // local coordinates tt) shaded as one polygon: only when each triangle would take the
  // plain float path of the loop below without a clip at the light plane (kept by the
  // shaft, translated exactly, not far reaching, every vertex before the light plane
  // beyond its rounding, not behind every receiver). Then the polygon's parts beyond and
  // below gcut are the unions of the triangles' parts: beyond gcut one occluder (bsp.h)
  // when the receivers lie strictly on one side of the plane, else one near polygon, and
  // below gcut one near polygon; a near polygon of a patch names it for the exact paths,
  // which subtract all its triangles (NearPoly::patch). Else false, having added nothing.
  static_assert(TriangleTree::kMaxPatchVertices + 1 <= kMaxOccluderVertices, "a patch clipped once is an occluder");
  auto shade_patch = [&](int32_t pid, std::span<const uint32_t> tris, const Vec3d tt[3]) {
    double tmax = 0.0;
    Vec3d tri0[3];
    for (size_t j = 0; j < tris.size(); ++j) {
      Vec3d loc[3];
      for (int k = 0; k < 3; ++k) {
        const Vec3f& w = scene.mesh.corner(tris[j], k);
        if (!translates_exactly(w, lf.origin)) return false;
        loc[k] = j == 0 ? tt[k] : to_local_d(w, lf.origin);
      }
      if (j == 0) std::copy(loc, loc + 3, tri0);
      if (j > 0 && shaft.culls(Vec3f(loc[0]), Vec3f(loc[1]), Vec3f(loc[2]))) return false;
      const double tm = std::max({max_component(vabs(loc[0])), max_component(vabs(loc[1])), max_component(vabs(loc[2]))});
      if (!(tm <= 0x1p20 * work_scale)) return false;
      tmax = std::max(tmax, tm);
      double gmx = -std::numeric_limits<double>::infinity();
      for (int k = 0; k < 3; ++k) {
        if (!(double(sigma) * (dot(nd, loc[k]) - lf.h0) > double(lf.plane_tol))) return false;
        gmx = std::max(gmx, dot(gd, loc[k] - refd));
      }
      if (gmx <= gmin - delta) return false;
    }
    const std::span<const Vec3f> wq = ctx.tree->patch_polygon(pid);
    const int bside = box_side(wq.data(), wcorners);  // three corners of the polygon: its plane, in its orientation
    std::vector<Vec3d>& q = sc.patch;
    q.resize(wq.size());
    vals.resize(wq.size());
    for (size_t k = 0; k < wq.size(); ++k) {
      q[k] = to_local_d(wq[k], lf.origin);
      vals[k] = dot(gd, q[k] - refd) - gcut;
    }
    auto add_near = [&](const std::vector<Vec3d>& part) {
      NearPoly np = make_near(tris[0], tri0, tmax, part);
      np.patch = pid;
      near.push_back(np);
      near_verts.insert(near_verts.end(), part.begin(), part.end());
    };
    clip_by_values(q.data(), vals.data(), int(q.size()), true, lower);
    if (!lower.empty()) {
      if (bside != 0) {
        VG_CHECK(lower.size() <= size_t(kMaxOccluderVertices));
        Occluder o;
        o.n = int(lower.size());
        for (int k = 0; k < o.n; ++k) o.v[k] = lower[size_t(bside > 0 ? o.n - 1 - k : k)];
        occluders.push_back(o);
      } else {
        add_near(lower);
      }
    }
    clip_by_values(q.data(), vals.data(), int(q.size()), false, upper);
    if (!upper.empty()) add_near(upper);
    ++tot.patches;
    tot.patch_triangles += tris.size();
    return true;
  };
  // Triangles subtracted exactly per receiver: the far-reaching ones (above) and those
  // within rounding of the light plane (below).
  std::vector<uint32_t>& exact_tris = sc.exact_tris;
  std::vector<uint32_t>& cand = sc.cand;
  ctx.tree->candidates(shaft, lf.origin, cand);
  std::vector<uint8_t>& merged = sc.merged;  // per candidate: shaded as part of a patch
  merged.assign(cand.size(), 0);
  for (size_t ci = 0; ci < cand.size(); ++ci) {
    const uint32_t t = cand[ci];
    if (merged[ci]) continue;
    Vec3d tri[3] = {to_local_d(scene.mesh.corner(t, 0), lf.origin), to_local_d(scene.mesh.corner(t, 1), lf.origin),
                    to_local_d(scene.mesh.corner(t, 2), lf.origin)};
    if (shaft.culls(Vec3f(tri[0]), Vec3f(tri[1]), Vec3f(tri[2]))) continue;
    // A coplanar convex patch from its first triangle, all of its triangles candidates:
    // one polygon (shade_patch).
    if (const int32_t pid = ctx.tree->patch(t); pid >= 0 && ctx.tree->patch_triangles(pid)[0] == t) {
      const std::span<const uint32_t> tris = ctx.tree->patch_triangles(pid);
      std::vector<uint32_t>& at = sc.patch_at;  // positions of tris[1..] in cand
      at.clear();
      for (size_t j = 1; j < tris.size(); ++j) {
        const auto it = std::lower_bound(cand.begin() + ptrdiff_t(ci) + 1, cand.end(), tris[j]);
        if (it == cand.end() || *it != tris[j]) break;
        at.push_back(uint32_t(it - cand.begin()));
      }
      if (at.size() + 1 == tris.size() && shade_patch(pid, tris, tri)) {
        for (uint32_t k : at) merged[k] = 1;
        continue;
      }
    }
    // Far reaching (above): exact, per receiver, before the double rejections below
    // (their values carry the same rounding).
    const double tmax = std::max({max_component(vabs(tri[0])), max_component(vabs(tri[1])), max_component(vabs(tri[2]))});
    if (!(tmax <= 0x1p20 * work_scale)) {
      exact_tris.push_back(t);
      ++tot.far_triangles;
      continue;
    }
    // A triangle whose translation to the local frame was rounded (a coordinate below
    // 2^-29 of the light origin's, or far above it) may have lost its shape there: a
    // sliver 2^-147 wide next to the origin became a segment in the frame of a light at
    // z = 2 and was dropped, while a receiver at the origin, 2^-149 from its plane, has
    // 5/32 of the light behind it (fuzz_plucker eb250d24...: fraction 1 for 0.84375).
    // The rounding moves a vertex by at most 2^-53 of its largest local coordinate; a
    // rounded triangle whose height (twice its area over its longest edge) is not above
    // 2^-32 of that coordinate is subtracted exactly per receiver from its float
    // inputs, as the far-reaching ones. Fatter ones keep their shape to 2^-20 and stay
    // on the float path, whose bounds count the translation's rounding (foliage's trunk:
    // vertices at 3.7e-18 next to a light at 0.2, 60 triangles, answers unchanged).
    if (!(translates_exactly(scene.mesh.corner(t, 0), lf.origin) &&
          translates_exactly(scene.mesh.corner(t, 1), lf.origin) &&
          translates_exactly(scene.mesh.corner(t, 2), lf.origin))) {
      const Vec3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0], e3 = tri[2] - tri[1];
      const double longest = std::max({length(e1), length(e2), length(e3)});
      if (!(length(cross(e1, e2)) > 0x1p-32 * tmax * longest)) {
        exact_tris.push_back(t);
        ++tot.rounded_triangles;
        continue;
      }
    }
    // Heights over the light plane and g-values in double on the float vertices (the
    // clipping below interpolates in double, fragment.h clip_by_values).
    double h[3], gv[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3d& x = tri[k];
      h[k] = double(sigma) * (dot(nd, x) - lf.h0);
      gv[k] = dot(gd, x - refd);
    }
    // Beyond, or lying in, the light plane: it never meets an open segment (occluders
    // touching the light plane with a vertex or an edge are kept). Within the plane's
    // rounding bound h cannot tell: a vertex 5.7e-7 before a light at z = 2 (plane_tol
    // 7e-7, the float normal's bound over a light 2 wide) made a triangle hiding 1/8 of
    // the light count as lying in its plane (fuzz_plucker a77807ad, fraction 1 for
    // 0.875). There the exact side of each such vertex against the light's plane (the
    // region oracle's Newell plane, exact_orient.h newell_side_exact) decides: a triangle
    // with a vertex strictly before it is subtracted exactly per receiver, which needs
    // no clipping at the light plane (subtract_triangle_exact hides a light point only
    // beyond the triangle's plane as seen from r).
    if (const double hmax = std::max(h[0], std::max(h[1], h[2])); hmax <= double(lf.plane_tol)) {
      if (hmax < -double(lf.plane_tol)) continue;
      bool before = false;
      for (int k = 0; k < 3 && !before; ++k)
        before = h[k] >= -double(lf.plane_tol) &&
                 double(sigma) * newell_side_exact(light.polygon.data(), int(light.polygon.size()),
                                                   scene.mesh.corner(t, k)) > 0.0;
      if (before) {
        exact_tris.push_back(t);
        ++tot.band_triangles;
      }
      continue;
    }
    // Behind every receiver's g-plane.
    if (std::max(gv[0], std::max(gv[1], gv[2])) <= gmin - delta) continue;
    // Clip to the light side h >= 0.
    clip_by_values(tri, h, 3, true, poly0, &on_plane0);
    if (poly0.size() < 3) continue;
    if (close_plane_points(poly0, on_plane0)) {
      exact_tris.push_back(t);
      ++tot.plane_point_triangles;
      continue;
    }
    // Split at gmax + delta: beyond it, between every receiver and the light (tree);
    // the rest per receiver.
    vals.resize(poly0.size());
    for (size_t k = 0; k < poly0.size(); ++k) vals[k] = dot(gd, poly0[k] - refd) - gcut;
    clip_by_values(poly0.data(), vals.data(), int(poly0.size()), true, lower);
    clip_by_values(poly0.data(), vals.data(), int(poly0.size()), false, upper);
    if (!lower.empty()) {
      // Orientation (bsp.h Occluder): receivers strictly on one side of the triangle's
      // plane (decided in float on the corners of their box; undecided counts for
      // neither) give a one-sided occluder, else two-sided.
      const Vec3f wtri[3] = {scene.mesh.corner(t, 0), scene.mesh.corner(t, 1), scene.mesh.corner(t, 2)};
      const int bside = box_side(wtri, wcorners);
      VG_CHECK(lower.size() <= size_t(kMaxOccluderVertices));
      Occluder o;
      o.n = int(lower.size());
      o.two_sided = bside == 0;
      for (int k = 0; k < o.n; ++k) o.v[k] = lower[size_t(bside > 0 ? o.n - 1 - k : k)];
      if (o.two_sided) {
        // Measured on columns (1024 receivers, 64 samples): two-sided occluders in the
        // tree are mixed against most hyperplanes and multiply the developments by ~25;
        // per receiver they cost one subtraction. So they go to the near list.
        near.push_back(make_near(t, tri, tmax, lower));
        near_verts.insert(near_verts.end(), lower.begin(), lower.end());
      } else {
        occluders.push_back(o);
      }
    }
    if (!upper.empty()) {
      near.push_back(make_near(t, tri, tmax, upper));
      near_verts.insert(near_verts.end(), upper.begin(), upper.end());
    }
  }
  // The near polygons in decreasing size over distance from the receivers' box centre
  // (box diagonal squared over the squared distance of the box centres): per receiver
  // they are subtracted in this order, and the big, close ones first leave fewer and
  // larger fragments to cut for the others. Measured (callgrind, columns 4096 x 16):
  // splits 234,842 -> 224,130, instructions -3%; nearest first -2.6%, largest first and
  // largest solid angle first worse than the selection order; rooms -0.4%. The visible
  // set does not depend on the order (each subtraction removes exactly its shadow).
  {
    const Vec3d cen = (dlo + dhi) * 0.5;
    std::vector<std::pair<double, uint32_t>>& key = sc.near_key;
    key.resize(near.size());
    for (size_t k = 0; k < near.size(); ++k) {
      const Vec3d d = near[k].hi - near[k].lo, m = (near[k].hi + near[k].lo) * 0.5 - cen;
      double q = dot(d, d) / std::max(dot(m, m), std::numeric_limits<double>::min());
      if (!(q >= 0.0)) q = 0.0;  // inf / inf: any place, but a strict weak order
      key[k] = {-q, uint32_t(k)};
    }
    std::sort(key.begin(), key.end());
    std::vector<NearPoly>& sorted = sc.near_sorted;
    sorted.resize(near.size());
    for (size_t k = 0; k < near.size(); ++k) sorted[k] = near[key[k].second];
    near.swap(sorted);
  }
  tot.select_s += seconds_since(t0);

  // --- Tree initialisation (Figure 8 "I"): vvsets and the root leaf ---
  t0 = Clock::now();
  tot.occluders += occluders.size();
  tot.near += near.size();
  // The receiver region for the second vvset (bsp.h): the distinct corners of the box.
  std::vector<Vec3d>& region = sc.region;
  for (const Vec3d& c : corners)
    if (std::find(region.begin(), region.end(), c) == region.end()) region.push_back(c);
  if (!work.tree) work.tree = std::make_unique<LazyBsp>(nullptr, 0, std::vector<Occluder>{}, 0);
  LazyBsp& bsp = *work.tree;  // the thread's tree, rebuilt per group (GroupScratch)
  bsp.rebuild(lf.poly.data(), int(lf.poly.size()), occluders, tree_seed, region.data(), int(region.size()));
  bsp.set_memory_budget(ctx.memory->budget);
  bsp.set_choice(ctx.choice);
  bsp.set_light_plane(lf.plane);
  ++tot.trees;
  tot.init_s += seconds_since(t0);
  int64_t reported = int64_t(bsp.memory_bytes() + near_verts.capacity() * sizeof(Vec3d) + near.capacity() * sizeof(NearPoly));
  ctx.memory->change(reported);

  // --- Queries (Figure 8 "Q"): every receiver of the group, in grid order ---
  FragmentList &frags = sc.frags, &tmp = sc.tmp;
  std::vector<Box2>&boxes = sc.boxes, &tmp_boxes = sc.tmp_boxes;
  std::vector<Vec3d>&pyramid = sc.pyramid, &pyramid_err = sc.pyramid_err;
  std::vector<Vec3d>&cur = sc.cur, &pos = sc.pos, &neg = sc.neg;
  std::vector<Vec3d>& q = sc.q;
  std::vector<uint8_t>&on_level = sc.on_level, &skip = sc.skip;
  std::vector<uint32_t>& exact_done = sc.exact_done;  // triangles subtracted exactly for this receiver
  std::vector<uint32_t>&cell_start = sc.cell_start, &cell_items = sc.cell_items,
                        &cell_fill = sc.cell_fill;  // the samples' fragment grid
  BspCounters near_counters;
  size_t off = scene.light_offset(li);
  size_t nlights = scene.lights.size();
  // Subtracts triangle t exactly from frags (boxes follow); false, subtracting nothing,
  // when rec lies in its plane.
  auto subtract_exact = [&](uint32_t t, const Receiver& rec) {
    const Vec3f wtri[3] = {scene.mesh.corner(t, 0), scene.mesh.corner(t, 1), scene.mesh.corner(t, 2)};
    const int side_exact = orient3d_exact_sign(wtri[0], wtri[1], wtri[2], rec.p);
    if (side_exact == 0) return false;
    ++tot.exact_triangles;
    subtract_triangle_exact(rec.p, wtri, side_exact, lf.origin, lf.frame, lf.lift, frags, tmp, tmp_boxes, cur);
    std::swap(frags, tmp);
    std::swap(boxes, tmp_boxes);
    return true;
  };
  for (size_t gk = 0; gk < group.size(); ++gk) {
    const uint32_t i = group[gk];
    const Receiver& rec = scene.receivers[i];
    const Vec3d& r = rloc[gk];
    Clock::time_point tq = Clock::now();
    // Extreme receivers: seen from r the light is at a grazing angle (r 2^20 times farther
    // from the light than from its plane, fuzz_plucker 0108e691...: 4.5e28 along the
    // light's plane and 2 below it), where even double planes through r move shadow edges
    // by more than the tolerance (a clipped vertex rounded by 1e-17 in height, seen from
    // 4.5e28, shifts a line on the light by 1e11 times that). Such a receiver is shaded
    // by the exact path alone: every candidate triangle of the group subtracted exactly
    // (subtract_triangle_exact), no tree and no near polygons.
    const double hr = double(sigma) * (dot(nd, r) - lf.h0);
    // Far receivers too (fuzz_plucker c02d4e53...: r = (0, 5e22, 7.8e26) above a unit
    // light, a pouch between): every double quantity through r (r + t (v - r), planes
    // through r) carries an absolute rounding of about 2^-53 |r - origin|, which stays
    // below 2^-33 of the light's extent, far under the fraction tolerance, only while r
    // is within 2^20 extents of the light. Beyond that the exact path answers. The
    // extent that counts is the light's width (area over its longest side) when that
    // is smaller: a sliver light 5.4e8 long and 6e-4 wide seen from 1.07e8 below
    // (fuzz_plucker e49b6000...) was answered fully visible, exactly hidden.
    // For a long light the grazing bound is tighter by its aspect (extent over width):
    // a shadow line running along the long axis meets the light's long edge at an angle
    // of about width / extent, so a lateral error moves where it ends by extent / width
    // times that (fuzz_plucker 685e5d6f...: a light 288k long and 0.66 wide seen from
    // 6.25e5 away and 0.8 below its plane, 2^19.6 times its height; a sliver occluder
    // lying along the light left a shadow line whose end on the long edge was 2400 off,
    // fraction 0.1845 for 0.1825).
    const double far = std::max(max_component(vabs(r - lf.bounds.centroid)), double(lf.extent));
    const double aspect = std::max(1.0, double(lf.extent) / light_width);
    const bool extreme = !(far * aspect <= 0x1p20 * hr) || !(far <= 0x1p20 * light_width);
    auto shade_exact = [&]() {
      ++tot.exact_receivers;
      frags.clear();
      frags.add(lf.poly.data(), lf.poly.size());
      boxes.assign(1, Box2::of(lf.frame, lf.poly.data(), int(lf.poly.size())));
      for (uint32_t t : cand) {
        if (frags.size() == 0) break;
        subtract_exact(t, rec);
      }
    };
    // Plane tests this receiver's float path could not decide (on_line: r within rounding
    // of the line of an occluder's or near polygon's edge) before and after it.
    const uint64_t undecided0 = bsp.counters().on_line + near_counters.on_line;
    if (extreme) {
      shade_exact();
    } else {
      // A light the tree hides as a whole from r needs nothing else (LazyBsp::hides_all:
      // a walk without splits). Otherwise the near polygons first, subtracted from the
      // whole light: they are the closest to r, so their shadows are the largest, and the
      // BSP is then walked (and developed) only for what they leave visible. Measured
      // (callgrind, 1024 receivers): columns 1.90e9 instructions against 2.75e9 with the
      // BSP first; rooms needs the hides_all walk (lights on other storeys).
      frags.clear();
      Clock::time_point th = Clock::now();
      const bool hidden = bsp.hides_all(r);
      tot.tree_s += seconds_since(th);
      if (!hidden) frags.add(lf.poly.data(), lf.poly.size());
      // Side planes of the pyramid (r, light), oriented so the light's centroid is
      // positive: a near polygon entirely on the negative side of one misses every
      // segment from r to the light. Each plane through r and light edge (l_j, l_j+1)
      // has N = edge_plane_normal (its two shortest of l_j - r, l_j+1 - r, l_j+1 - l_j:
      // for a receiver far from a small light the textbook (l_j - r) x (l_j+1 - r) is
      // the cross product of two nearly parallel long vectors: its rounding u |l - r|^2
      // against |N| ~ |l - r| |l_j+1 - l_j| is 1% for a receiver 1e5 light sizes away, as
      // in fuzz_plucker seed-mode07-1) and is evaluated through l_j: (x - l_j) . N,
      // rejected only below -16 dot_err (16 times its error bound).
      size_t m = lf.poly.size();
      pyramid.resize(m);
      pyramid_err.resize(m);
      // A plane only culls when the whole light is on its positive side (then it
      // supports the pyramid, whatever edge it came from). An edge far shorter than the
      // rounding of its lifted ends has no direction: fuzz_plucker 2f79b58a..., a
      // non-planar light with two vertices 2^-64 apart, lifted onto its Newell plane to
      // 1e-16; the plane through r and that edge turned about r and the light vertex,
      // cut through the light, and culled a polygon hiding 2% of it. Such a plane is
      // dropped (a zero normal culls nothing).
      for (size_t j = 0; j < m; ++j) {
        Vec3d err;
        Vec3d nrm = edge_plane_normal_err(r, lf.poly[j], lf.poly[(j + 1) % m], err);
        if (dot(nrm, lf.bounds.centroid - lf.poly[j]) < 0.0) nrm = -nrm;
        for (size_t k = 0; k < m; ++k) {
          const Vec3d d = lf.poly[k] - lf.poly[j];
          if (dot(nrm, d) < -16.0 * dot_err(d, nrm, err)) {
            nrm = Vec3d(0, 0, 0);
            err = Vec3d(0, 0, 0);
            break;
          }
        }
        pyramid[j] = nrm;
        pyramid_err[j] = err;
      }
      boxes.clear();
      for (size_t f = 0; f < frags.size(); ++f) boxes.push_back(Box2::of(lf.frame, frags.data(f), frags.count(f)));
      // The union of the fragments' boxes, again after every subtraction that changed them.
      Box2 all;
      auto bound_all = [&]() {
        all = Box2{};
        for (const Box2& b : boxes) all.extend(b);
      };
      bound_all();
      exact_done.clear();
      // A near polygon's whole triangle, exactly, once for this receiver; true when it
      // was subtracted (false: already done, or r lies in its plane).
      auto exact_once = [&](uint32_t t) {
        if (std::find(exact_done.begin(), exact_done.end(), t) != exact_done.end()) return false;
        exact_done.push_back(t);
        if (!subtract_exact(t, rec)) return false;
        bound_all();
        return true;
      };
      // A near polygon's triangles (all of a patch), exactly.
      auto exact_near = [&](const NearPoly& np) {
        if (np.patch < 0) return exact_once(np.triangle);
        bool done = false;
        for (uint32_t pt : ctx.tree->patch_triangles(np.patch)) done = exact_once(pt) || done;
        return done;
      };
      // Far-reaching triangles and those within rounding of the light plane (occluder
      // selection above), exactly.
      for (uint32_t t : exact_tris) {
        if (frags.size() == 0) break;
        if (!subtract_exact(t, rec)) continue;
        bound_all();
      }
      const Vec3d& rd = r;
      const double rmax = max_component(vabs(r));
      // The box of this receiver's pyramid (r and the light), grown by 2^-20 of its
      // size: a near polygon whose box misses it misses every segment from r to the light.
      Vec3d plo = vmin(r, to_double(lf.box.lo)), phi = vmax(r, to_double(lf.box.hi));
      {
        const double grow_p = 0x1p-20 * (max_component(phi - plo) + max_component(vmax(vabs(plo), vabs(phi))));
        plo = plo - Vec3d(grow_p, grow_p, grow_p);
        phi = phi + Vec3d(grow_p, grow_p, grow_p);
      }
      for (const NearPoly& np : near) {
        if (frags.size() == 0) break;
        if (np.hi.x < plo.x || np.lo.x > phi.x || np.hi.y < plo.y || np.lo.y > phi.y || np.hi.z < plo.z ||
            np.lo.z > phi.z)
          continue;
        const Vec3d* pv = near_verts.data() + np.begin;
        // Cheap rejections first, conservative also against the rounding of the local
        // frame (a point moves by u |x| when translated; see the exact path below):
        // this receiver's slab (g . p > g . r somewhere, else the polygon is at or behind
        // its g-plane), then the side planes of its pyramid.
        vals.resize(np.count);
        double maxv = -1.0, pmax = 0.0;
        for (uint32_t k = 0; k < np.count; ++k) {
          vals[k] = dot(gd, pv[k] - rd);
          maxv = std::max(maxv, vals[k]);
          pmax = std::max(pmax, max_component(vabs(pv[k])));
        }
        // The translation to the local frame is exact in double unless exponents differ by
        // more than 29, else rounded at u_d: 4 u_d of the coordinates is far above it.
        constexpr double kUd = 0x1p-53;
        const double gn1 = std::abs(g.x) + std::abs(g.y) + std::abs(g.z);
        if (maxv < -4.0 * kUd * gn1 * (pmax + rmax)) continue;
        bool outside = false;
        for (size_t j = 0; j < m && !outside; ++j) {
          outside = true;
          const Vec3d& pn = pyramid[j];
          const double shift = 4.0 * kUd * (std::abs(pn.x) + std::abs(pn.y) + std::abs(pn.z)) *
                               (pmax + double(lf.extent) + rmax);
          const Vec3d& lj = lf.poly[j];
          for (uint32_t k = 0; k < np.count && outside; ++k) {
            Vec3d d = pv[k] - lj;
            outside = dot(pn, d) < -16.0 * dot_err(d, pn, pyramid_err[j]) - shift;
          }
        }
        if (outside) continue;
        // The side of r against the triangle's plane (near_side: decided on the local
        // double coordinates with a bound that covers their rounding, so it is the side
        // in the inputs as given). A receiver within rounding of the plane (but not on
        // it) sees the triangle across a sliver of space that rounding cannot resolve,
        // and what the triangle hides can be the whole light (fuzz_plucker 68d82337...,
        // f95fbc59...: a receiver 6e-9 and 2^-148 below a face): such a triangle is
        // subtracted exactly, whole, once per receiver (subtract_triangle_exact). Exactly
        // on the plane the triangle cannot meet an open segment from r properly (it only
        // touches or contains it): skipped.
        int side_r = near_side(np, r, rmax);
        if (side_r == 0) {
          exact_near(np);
          continue;
        }
        // Vertices within the rounding of r's level count as on it. Just above it, a
        // vertex next to one below made a clip point within rounding of itself: the
        // plane through r and that edge of ulps took any direction about the line from
        // r (fuzz_plucker fbf561ee...: a pouch vertex 2^-63 behind r's level, computed
        // 1.3e-43 before it, 0.5 from r; its clip points 1e-42 away, and the plane
        // through them halved the light: fraction 0.5 for 1). On the level such a
        // vertex starts or ends only edges along the level (skipped below) or edges to
        // well-separated points. A vertex further above the level but still close to it
        // (within 2^-24 of the coordinates) has clip points whose rounding turns their
        // planes about a point far beyond the light by an angle the light can see; and
        // a triangle whose only part above the level is within its rounding may still
        // hide much of the light from a receiver right under it (fuzz_plucker 50cf10d2:
        // a vertex 2^-49 above a receiver, exactly the rounding bound there, hides a
        // quarter of the light). Both go to the exact path (`level_triangles`; none on
        // the built-in families, whose vertices are at a receiver's level exactly or far
        // from it).
        {
          const double on_tol = 4.0 * kUd * gn1 * (pmax + rmax), near_tol = 0x1p-24 * gn1 * (pmax + rmax);
          const bool above = maxv > 0.0;
          bool near_level = false;
          maxv = 0.0;
          for (double& v : vals) {
            if (std::abs(v) <= on_tol) v = 0.0;
            near_level |= v > 0.0 && v <= near_tol;
            maxv = std::max(maxv, v);
          }
          if (maxv <= 0.0 && !above) continue;  // float path: at or behind r's g-plane
          if (maxv <= 0.0 || near_level) {  // above it only by rounding, or close to it
            if (exact_near(np)) ++tot.level_triangles;
            continue;
          }
        }
        clip_by_values(pv, vals.data(), int(np.count), true, q, &on_level);
        if (q.empty()) continue;
        // Oriented so that r is on the negative side (bsp.h Occluder).
        if (side_r > 0) {
          std::reverse(q.begin(), q.end());
          std::reverse(on_level.begin(), on_level.end());
        }
        // An edge of q at r's own level (both ends on the clip plane g . p = g . r) lies
        // in the level plane through r, so the plane through r and that edge is the
        // level plane itself, and every light point is strictly beyond it, on q's side:
        // the edge cannot cut a light line away and is skipped. Testing it would be
        // wrong near degeneracy: when r is within rounding of the triangle's plane, the
        // edge passes within rounding of r, float calls r "on its line" and the whole
        // polygon was dropped (fuzz_plucker 68d82337...: a receiver 6e-9 below a face,
        // fraction 1 instead of 0).
        skip.assign(q.size(), 0);
        for (size_t k = 0; k < q.size(); ++k) skip[k] = on_level[k] && on_level[(k + 1) % q.size()];
        // The planes through r and q's edges are only as good as q's vertices: a vertex
        // rounded by u of its coordinates, at a distance d from r, turns such a plane by
        // up to u |q| / d. A vertex that close to r (the clip at r's level of an edge
        // passing within 2^-24 of the coordinates of r) sends the triangle to the exact
        // path: fuzz_plucker 88259d77, a receiver 1.8e-12 above a triangle's vertex in a
        // frame whose coordinates are about 3 (ulp 4e-16), its level clip point 1e-13
        // from r, whose plane turned by 7e-4 and left a shadow sliver 1.3e-4 of the light
        // visible.
        bool too_close = false;
        for (size_t k = 0; k < q.size() && !too_close; ++k) {
          if (skip[k] && skip[(k + q.size() - 1) % q.size()]) continue;  // starts and ends no tested edge
          const double d = max_component(vabs(q[k] - r)), scale = std::max(max_component(vabs(q[k])), rmax);
          too_close = !(d > 0x1p-24 * scale);
        }
        if (too_close) {
          if (exact_near(np)) ++tot.close_triangles;
          continue;
        }
        // Its shadow's box against the fragments' boxes: disjoint boxes, nothing to cut.
        Box2 qbox = shadow_box(lf.plane, r, q.data(), q.size());
        if (!qbox.overlaps(all)) continue;
        if (!subtract_polygon(r, q.data(), int(q.size()), skip.data(), qbox, lf.frame, lf.bounds, frags, boxes, tmp,
                              tmp_boxes, cur, pos, neg, near_counters))
          continue;
        std::swap(frags, tmp);
        std::swap(boxes, tmp_boxes);
        bound_all();
      }
      // Algorithm 1 on the pieces the near polygons left visible.
      Clock::time_point tb = Clock::now();
      if (frags.size() > 0) {
        bsp.query(r, frags, tmp);
        std::swap(frags, tmp);
      }
      const double tbs = seconds_since(tb);
      tot.bsp_query_s += tbs;
      tot.tree_s += tbs;
      // An undecided plane was taken as "outside that edge" (bsp.cpp, subtract_polygon):
      // right when r is exactly on the edge's line (the line lies in the triangle's
      // plane, so r does too and the triangle is edge-on to it, hiding nothing), but a
      // guess within rounding of it. fuzz_plucker 944ae82f...: a triangle reaching 2^78
      // from a light 3 units wide, clipped at the receivers' level far out, left an
      // occluder edge 2^78 away whose plane through r float could not orient; the
      // fragment it shadows was returned visible (fraction 1.0 against 0.955). Such a
      // receiver is shaded again by the exact path (rare: for tree occluders the group's
      // receivers are strictly on one side of the plane, so only rounding gets here).
      if (bsp.counters().on_line + near_counters.on_line != undecided0) {
        ++tot.undecided_receivers;
        shade_exact();
      }
    }
    boxes.clear();
    for (size_t f = 0; f < frags.size(); ++f) boxes.push_back(Box2::of(lf.frame, frags.data(f), frags.count(f)));
    // Fragments, fraction, bits by point-in-fragment, irradiance.
    ReceiverResult& rr = ctx.result->receivers[i];
    auto& out = rr.fragments[li];
    out.clear();
    out.reserve(frags.size());
    double area = 0.0, irr = 0.0;
    const Vec3d od = to_double(lf.origin);
    const double h_r = dot(lf.nd, r) - lf.h0;  // r's height over the light's plane (below)
    for (size_t f = 0; f < frags.size(); ++f) {
      area += polygon_area(frags.data(f), frags.count(f));
      irr += lambert_irradiance(r, rec.n, frags.data(f), frags.count(f));
      // Reported in world coordinates: one float rounding per vertex (plucker_solver.h).
      // A fragment thinner than the float spacing there is not reported when its rounded
      // polygon no longer holds its own interior point (the centroid of its largest fan
      // triangle, as the comparator takes it): measured on far-origin scenes (spacing
      // 1/16 at 6.8e5), rounded slivers put that point up to 0.03 into blocked space,
      // far beyond tau (fuzz_plucker 719086e3...). The fraction and the bits use the
      // double fragments and are unaffected.
      Polygon3f wf;
      wf.reserve(size_t(frags.count(f)));
      for (int k = 0; k < frags.count(f); ++k) wf.push_back(Vec3f(frags.data(f)[k] + od));
      double best = 0.0;
      Vec3d inside{};
      for (size_t k = 1; k + 1 < wf.size(); ++k) {
        Vec3d a = to_double(wf[0]), b = to_double(wf[k]), c = to_double(wf[k + 1]);
        double ar = length(cross(b - a, c - a));
        if (ar > best) best = ar, inside = to_double(Vec3f((a + b + c) / 3.0));
      }
      // The comparator's segment runs from r to that rounded point, which rounding also
      // moved off the light's plane (by up to half the spacing): its test is the point
      // where the segment meets the plane, the central projection from r, not the point
      // with an axis dropped. fuzz_plucker c4e40475...: a light 4 across at 4.7e5 tilted
      // by 1/64 (spacing 1/32), a sliver fragment 1/64 wide whose rounded point lay 1/64
      // below the plane and, seen from a receiver 1.84 below it and 3 aside, behind a
      // shadow edge (blocked at margin 8e-5) while its dropped-axis point was inside.
      Vec3d pl = inside - od;
      const double h_p = dot(lf.nd, pl) - lf.h0;
      if (h_r != h_p) pl = r + (pl - r) * (h_r / (h_r - h_p));
      if (best > 0.0 && point_in_fragment(lf.frame, frags.data(f), frags.count(f), pl)) {
        out.push_back(std::move(wf));
      } else {
        ++tot.unreported_slivers;
      }
    }
    rr.visible_fraction[li] = float(std::min(1.0, area / light.area));
    // A sample is visible when it lies in the box of a fragment grown by 2^-38 of the
    // light's extent and in the fragment by point_in_fragment with a vertex slack of
    // 2^-40 of the extent (fragment.h: the fragments are double, so this is about 2^13
    // ulps of the coordinates, far above the rounding of the interpolated vertices and
    // far below tau; with float fragments it was 2^-20 and 2^-18). The box bounds what the
    // slack accepts near short edges; together they accept exactly the points within
    // about 2^-38 of the extent of a fragment.
    const double grow = double(lf.extent) * 0x1p-38;
    const double slack = double(lf.extent) * 0x1p-40;
    for (Box2& b : boxes) b = Box2{b.ulo - grow, b.uhi + grow, b.vlo - grow, b.vhi + grow};
    // Many samples and fragments: the fragments bucketed by a G x G grid over their
    // boxes, so a sample tests only the fragments whose (grown) box overlaps its cell
    // (measured, columns 4096 receivers at 1024 samples, ~50 fragments per receiver,
    // CPU: the solve 0.78 s before, 0.69 s after; bits and fractions bit-identical on
    // columns and foliage). The same test on a subset that contains every fragment whose
    // box holds the sample: cell indices floor((x - x0) / w), clamped, are monotone in x,
    // so a point inside a box falls in a cell of the box's cell range.
    const size_t nf = frags.size();
    int grid = 0;
    double gu0 = 0, gv0 = 0, gwu = 0, gwv = 0;
    if (nf > 8 && light.samples > 32) {
      Box2 gb;
      for (const Box2& b : boxes) gb.extend(b);
      grid = std::clamp(int(std::sqrt(double(nf))), 2, 16);
      gu0 = gb.ulo, gv0 = gb.vlo;
      gwu = (gb.uhi - gb.ulo) / grid, gwv = (gb.vhi - gb.vlo) / grid;
      if (!(gwu > 0.0) || !(gwv > 0.0)) grid = 0;
    }
    auto cell = [](double x, double x0, double w, int n) {
      double c = std::floor((x - x0) / w);
      return c < 0.0 ? 0 : (c >= double(n - 1) ? n - 1 : int(c));
    };
    if (grid > 0) {
      cell_start.assign(size_t(grid) * size_t(grid) + 1, 0u);
      for (int pass = 0; pass < 2; ++pass) {
        for (size_t f = 0; f < nf; ++f) {
          const Box2& b = boxes[f];
          int u0 = cell(b.ulo, gu0, gwu, grid), u1 = cell(b.uhi, gu0, gwu, grid);
          int v0 = cell(b.vlo, gv0, gwv, grid), v1 = cell(b.vhi, gv0, gwv, grid);
          for (int cv = v0; cv <= v1; ++cv)
            for (int cu = u0; cu <= u1; ++cu) {
              size_t c = size_t(cv) * size_t(grid) + size_t(cu);
              if (pass == 0) ++cell_start[c + 1];
              else cell_items[cell_fill[c]++] = uint32_t(f);
            }
        }
        if (pass == 0) {
          for (size_t c = 1; c < cell_start.size(); ++c) cell_start[c] += cell_start[c - 1];
          cell_items.resize(cell_start.back());
          cell_fill.assign(cell_start.begin(), cell_start.end() - 1);
        }
      }
    }
    for (int j = 0; j < light.samples; ++j) {
      size_t k = sample_index(light, j, i);
      bool vis = false;
      if (lf.on_light[k]) {
        const Vec3d& sp = lf.samples[k];
        const double su = sp[lf.frame.u], sv = sp[lf.frame.v];
        if (grid > 0) {
          size_t c = size_t(cell(sv, gv0, gwv, grid)) * size_t(grid) + size_t(cell(su, gu0, gwu, grid));
          for (uint32_t e = cell_start[c]; e < cell_start[c + 1] && !vis; ++e) {
            uint32_t f = cell_items[e];
            vis = boxes[f].contains(su, sv) && point_in_fragment(lf.frame, frags.data(f), frags.count(f), sp, slack);
          }
        } else {
          for (size_t f = 0; f < nf && !vis; ++f)
            vis = boxes[f].contains(su, sv) && point_in_fragment(lf.frame, frags.data(f), frags.count(f), sp, slack);
        }
      } else {
        // Off the light polygon (explicit samples): the segment r -> sample itself.
        vis = !segment_blocked_by_scene(scene, lf.origin, to_local(rec.p, lf.origin), Vec3f(lf.samples[k]));
        ++tot.segment_relations;
      }
      rr.set_visible(off + size_t(j), vis);
    }
    if (ctx.irradiance) (*ctx.irradiance)[size_t(i) * nlights + li] = irr;
    tot.irradiance += irr;
    tot.fragments += frags.size();
    ++tot.queries;
    tot.query_s += seconds_since(tq);
    int64_t now = int64_t(bsp.memory_bytes() + near_verts.capacity() * sizeof(Vec3d) + near.capacity() * sizeof(NearPoly));
    ctx.memory->change(now - reported);
    reported = now;
    // The paper's modified version: reset between queries, excluded from the timings.
    if (!ctx.coherence) bsp.reset();
  }
  ctx.memory->change(-reported);
  tot.bsp_nodes_max = std::max<uint64_t>(tot.bsp_nodes_max, bsp.node_count());
  const BspCounters& c = bsp.counters();
  tot.bsp.nodes_created += c.nodes_created;
  tot.bsp.developments += c.developments;
  tot.bsp.insert_tests += c.insert_tests;
  tot.bsp.occlusion_tests += c.occlusion_tests;
  tot.bsp.lazy_visible += c.lazy_visible;
  tot.bsp.merged += c.merged;
  tot.bsp.visits += c.visits;
  tot.bsp.splits += c.splits + near_counters.splits;
  tot.bsp.on_line += c.on_line + near_counters.on_line;
  tot.bsp.zero_area += c.zero_area + near_counters.zero_area;
}

uint64_t morton_spread(uint32_t x) {
  uint64_t v = x & 0x3FF;
  v = (v | (v << 16)) & 0x030000FF;
  v = (v | (v << 8)) & 0x0300F00F;
  v = (v | (v << 4)) & 0x030C30C3;
  v = (v | (v << 2)) & 0x09249249;
  return v;
}

}  // namespace

std::vector<std::vector<uint32_t>> receiver_groups(const Scene& scene, int tile) {
  tile = std::max(1, tile);
  std::vector<std::vector<uint32_t>> groups;
  size_t n = scene.receivers.size();
  if (scene.grid && size_t(scene.grid->nu) * size_t(scene.grid->nv) == n) {
    // Tiles of the receiver grid, row-major inside each tile (scanline order).
    int nu = scene.grid->nu, nv = scene.grid->nv;
    for (int tb = 0; tb < nv; tb += tile)
      for (int ta = 0; ta < nu; ta += tile) {
        std::vector<uint32_t> g;
        for (int b = tb; b < std::min(nv, tb + tile); ++b)
          for (int a = ta; a < std::min(nu, ta + tile); ++a) g.push_back(uint32_t(size_t(b) * size_t(nu) + size_t(a)));
        groups.push_back(std::move(g));
      }
    return groups;
  }
  // Spatial clustering: Morton order of the receivers, runs of tile^2.
  AABB box;
  for (const auto& r : scene.receivers) box.extend(r.p);
  Vec3d lo = to_double(box.lo), ext = to_double(box.hi) - lo;
  std::vector<std::pair<uint64_t, uint32_t>> keys(n);
  for (size_t i = 0; i < n; ++i) {
    Vec3d p = to_double(scene.receivers[i].p) - lo;
    uint32_t c[3];
    for (int a = 0; a < 3; ++a) c[a] = ext[a] > 0 ? uint32_t(std::min(1023.0, std::max(0.0, p[a] / ext[a] * 1023.0))) : 0u;
    keys[i] = {morton_spread(c[0]) | (morton_spread(c[1]) << 1) | (morton_spread(c[2]) << 2), uint32_t(i)};
  }
  std::sort(keys.begin(), keys.end());
  size_t run = size_t(tile) * size_t(tile);
  for (size_t k = 0; k < n; k += run) {
    std::vector<uint32_t> g;
    for (size_t m = k; m < std::min(n, k + run); ++m) g.push_back(keys[m].second);
    groups.push_back(std::move(g));
  }
  return groups;
}

SolveResult solve_plucker(const Scene& scene, const SolveOptions& opt, std::vector<double>* irradiance) {
  ThreadLimit limit(opt.threads);
  Clock::time_point start = Clock::now();
  SolveResult result = make_empty_result(scene);
  for (auto& rr : result.receivers) rr.fragments.assign(scene.lights.size(), {});
  if (irradiance) irradiance->assign(scene.receivers.size() * scene.lights.size(), 0.0);
  bool coherence = opt.get_bool("coherence", true);
  int tile = int(opt.get_int("tile", 8));
  LazyBsp::Choice choice = opt.get("choice", "relevant") == "random" ? LazyBsp::Choice::Random : LazyBsp::Choice::Relevant;
  MemoryMeter memory;
  MemoryBudget budget("plucker-bsp", opt.memory_budget_mb);  // outlives the trees in thread_work
  memory.budget = &budget;
  // The triangle hierarchy for occluder selection, built once (counted as selection).
  Clock::time_point tt = Clock::now();
  TriangleTree tree(scene.mesh);
  double tree_s = seconds_since(tt);
  memory.change(int64_t(tree.memory_bytes()));
  Context ctx{&scene, &result, irradiance, coherence, choice, &tree, opt.seed, &memory};
  auto groups = receiver_groups(scene, tile);
  AABB rbox_all;
  for (const auto& rcv : scene.receivers) rbox_all.extend(rcv.p);
  const Vec3d focus = scene.receivers.empty() ? Vec3d(0, 0, 0) : (to_double(rbox_all.lo) + to_double(rbox_all.hi)) * 0.5;
  Totals totals;
  std::mutex merge_mutex;
  tbb::enumerable_thread_specific<ThreadWork> thread_work;  // freed when the solve returns

  // Multiple lights in turn (Algorithm 2 line 2); groups of one light in parallel.
  for (size_t li = 0; li < scene.lights.size(); ++li) {
    LightFrame lf = make_frame(scene.lights[li], focus);
    tbb::parallel_for(size_t(0), groups.size(), [&](size_t g) {
      const IeeeFloatMode ieee;  // TBB workers run with FTZ/DAZ once Embree exists (lib/geom/float_mode.h)
      Totals tot;
      // Split the group by the side of the light plane; receivers on it fall back.
      std::vector<uint32_t> side[2];
      for (uint32_t i : groups[g]) {
        Vec3f d = to_local(scene.receivers[i].p, lf.origin) - lf.p0;
        float h = dot(lf.n, d);
        float tol = lf.plane_tol + kDotErr * norm1(lf.n) * norm1(d);
        int sd = h > tol ? 1 : (h < -tol ? -1 : 0);
        // Undecided in float: exactly, for an exactly planar light (a receiver far away
        // at a grazing height, fuzz_plucker 0108e691...: 4.5e28 along the light's plane
        // and 2 below it, is not on the plane), else against the region oracle's exact
        // plane of the light (Newell normal through the exact centroid): a light 5.5e6
        // long has a float bound above 2 near its base, and receivers 2 below it were
        // shaded by the fallback's sample counts (fuzz_plucker crash-61c69374...:
        // fraction 1 for a receiver 2^-149 under a face, exact 0). Only a receiver
        // exactly on that plane, where the oracle defines no region, falls back.
        if (sd == 0) {
          const auto& v = scene.lights[li].polygon;
          sd = lf.planar ? lf.emit_sign * orient3d_exact_sign(v[0], v[size_t(lf.p1)], v[size_t(lf.p2)],
                                                              scene.receivers[i].p)
                         : newell_side_exact(v.data(), int(v.size()), scene.receivers[i].p);
        }
        if (sd > 0) side[0].push_back(i);
        else if (sd < 0) side[1].push_back(i);
        else shade_fallback(ctx, li, lf, i, tot);
      }
      for (int s = 0; s < 2; ++s) {
        if (side[s].empty()) continue;
        // One tree per group, light and side; its random stream depends only on them.
        uint64_t seed = splitmix64(opt.seed ^ splitmix64((uint64_t(g) << 1 | uint64_t(s)) ^ splitmix64(li + 0x9E37)));
        shade_group(ctx, li, lf, side[s], s == 0 ? 1.0f : -1.0f, seed, thread_work.local(), tot);
      }
      std::lock_guard<std::mutex> lock(merge_mutex);
      totals.merge(tot);
    });
  }

  totals.select_s += tree_s;
  result.seconds = seconds_since(start);
  Stats& st = result.stats;
  st.set("relations", double(scene.relation_count()));
  st.set("groups", double(groups.size()));
  st.set("trees", double(totals.trees));
  st.set("queries", double(totals.queries));
  st.set("occluders", double(totals.occluders));
  st.set("near_polygons", double(totals.near));
  st.set("fragments", double(totals.fragments));
  st.set("bsp_nodes", double(totals.bsp.nodes_created));
  st.set("bsp_nodes_max", double(totals.bsp_nodes_max));
  st.set("developments", double(totals.bsp.developments));
  st.set("insert_tests", double(totals.bsp.insert_tests));
  st.set("occlusion_tests", double(totals.bsp.occlusion_tests));
  st.set("lazy_visible", double(totals.bsp.lazy_visible));
  st.set("merged_splits", double(totals.bsp.merged));
  st.set("splits", double(totals.bsp.splits));
  st.set("node_visits", double(totals.bsp.visits));
  st.set("degenerate_on_line", double(totals.bsp.on_line));
  st.set("degenerate_zero_area", double(totals.bsp.zero_area));
  st.set("fallback_receivers", double(totals.fallback));
  st.set("segment_relations", double(totals.segment_relations));
  st.set("exact_triangles", double(totals.exact_triangles));
  st.set("far_triangles", double(totals.far_triangles));
  st.set("band_triangles", double(totals.band_triangles));
  st.set("rounded_triangles", double(totals.rounded_triangles));
  st.set("close_triangles", double(totals.close_triangles));
  st.set("level_triangles", double(totals.level_triangles));
  st.set("plane_point_triangles", double(totals.plane_point_triangles));
  st.set("patches", double(totals.patches));
  st.set("patch_triangles", double(totals.patch_triangles));
  st.set("exact_receivers", double(totals.exact_receivers));
  st.set("undecided_receivers", double(totals.undecided_receivers));
  st.set("unreported_slivers", double(totals.unreported_slivers));
  st.set("peak_memory_bytes", double(memory.peak.load()));
  st.set("peak_memory_kb", double(memory.peak.load()) / 1024.0);
  st.set("occluder_selection_seconds", totals.select_s);
  st.set("tree_init_seconds", totals.init_s);
  st.set("query_seconds", totals.query_s);
  st.set("bsp_query_seconds", totals.bsp_query_s);
  st.set("tree_seconds", totals.tree_s);
  double sum = totals.select_s + totals.init_s + totals.query_s;
  if (sum > 0) {
    st.set("occluder_selection_percent", 100.0 * totals.select_s / sum);
    st.set("tree_init_percent", 100.0 * totals.init_s / sum);
    st.set("query_percent", 100.0 * totals.query_s / sum);
  }
  st.set("irradiance_sum", totals.irradiance);
  st.set("coherence", coherence ? 1.0 : 0.0);
  return result;
}

std::vector<OptionSpec> PluckerSolver::options() const {
  return {{"coherence", "on: queries reuse the tree; off: reset between queries (paper 002 section 5.1)", {"on", "off"}},
          {"tile", "receivers per group side (grid tiles, or tile^2 receivers in Morton order)", {}},
          {"choice", "relevant: develop with an occluder the query sees (bsp.h); random: the paper's random occluder",
           {"relevant", "random"}}};
}

SolveResult PluckerSolver::solve_scene(const Scene& scene, const SolveOptions& opt) { return solve_plucker(scene, opt, nullptr); }

}  // namespace visgate::plucker
