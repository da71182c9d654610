// Potential silhouette edges, penumbra wedges and wedge/box tests (see wedge.h).
#include "lib/ssv/wedge.h"

#include <cmath>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lib/base/check.h"

namespace visgate::ssv {

TrianglePlanes triangle_planes(const mesh::PreparedMesh& m) {
  TrianglePlanes out(m.triangles.size());
  for (size_t t = 0; t < m.triangles.size(); ++t) out[t] = triangle_plane(m, t);
  return out;
}

std::vector<Edge> mesh_edges(const mesh::PreparedMesh& m) {
  // Each label is taken at its first incidence in triangle order: a single edge's label
  // has one incidence, a double edge's two, in the triangle and its neighbour across it
  // (prepare.h), so the first is in the lower-numbered of the two: no flag per label.
  std::vector<Edge> edges(m.edge_count());
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    for (int k = 0; k < 3; ++k) {
      const uint32_t label = tri.edge_labels[k];
      const bool twin = m.is_double_edge[label];
      if (twin && tri.neighbors[k] < int32_t(t)) continue;
      Edge& e = edges[label];
      e.a = tri.v[k];
      e.b = tri.v[k == 2 ? 0 : k + 1];
      e.t1 = int32_t(t);
      e.t2 = twin ? tri.neighbors[k] : -1;
    }
  }
  return edges;
}

namespace {

// A plane in point-normal form, evaluated as n.(x - p) rather than as Planed's n.x - d:
// the rounding is relative to |x - p|, not to |x| (a wedge far from the origin).
struct PointNormalPlane {
  Vec3d n;  // unit
  Vec3d p;  // a point on the plane
  double eval(const Vec3d& x) const { return dot(n, x - p); }
};

Plane to_float(const PointNormalPlane& pl) {
  Plane f;
  f.n = Vec3f(pl.n);
  f.d = float(dot(pl.n, pl.p));
  return f;
}

// Orients a candidate plane so that L' lies on its closed negative side; false when L'
// straddles it (not a separating plane) or lies in it within tol. The latter happens for
// an edge touching or lying in the light plane (grid-snapped scenes): every candidate
// through it and a light vertex or edge is the light plane itself, and either orientation
// of it would be arbitrary (the wrong one excludes every receiver). The light plane is
// added once, oriented, by build_wedges; dropping a candidate only enlarges the wedge.
// "Negative side" allows L' only `rtol` (rounding) beyond the plane, not tol: a point x
// reached through the edge point p from the light point l is x = p + t (p - l), where
// f(x) = (1 + t) f(p) - t f(l), and t = |x - p| / |p - l| is unbounded for an edge that
// passes next to L' (corpus/ssv/sliver/b582982b...).
bool orient_against_light(PointNormalPlane& pl, const std::vector<Vec3d>& light, double tol, double rtol) {
  double lo = 0.0, hi = 0.0;
  for (const auto& l : light) {
    double f = pl.eval(l);
    lo = std::min(lo, f);
    hi = std::max(hi, f);
  }
  if (hi <= tol && lo >= -tol) return false;
  if (hi <= rtol) return true;
  if (lo >= -rtol) {
    pl.n = -pl.n;
    return true;
  }
  return false;
}

// Unit plane with normal n through p, or false when n is negligible relative to `scale2`
// (the product of the two spanning lengths): 1e-12 relative leaves the direction of a
// double cross product of float-derived vectors meaningful to about 1e-4.
bool make_plane(const Vec3d& n, const Vec3d& p, double scale2, PointNormalPlane& out) {
  double len = length(n);
  if (!(len > 1e-12 * scale2)) return false;
  out = {n / len, p};
  return true;
}

// The range [lo, hi] of the plane's value n.x - d over the box: the corners that
// minimise and maximise it, evaluated as dot(n, corner) - d. The SSE2 form computes the
// same products and sums in the same order, so the same floats, without the three
// data-dependent branches on the normal's signs (the scatter's hot loop).
inline void box_range(const Plane& p, const AABB& box, float& lo, float& hi) {
#if defined(__SSE2__)
  static_assert(sizeof(Plane) == 4 * sizeof(float) && sizeof(AABB) == 6 * sizeof(float));
  const __m128 n = _mm_loadu_ps(&p.n.x);                   // nx ny nz d
  const __m128 blo = _mm_loadu_ps(&box.lo.x);               // lo.x lo.y lo.z hi.x
  const __m128 t = _mm_loadu_ps(&box.lo.z);                 // lo.z hi.x hi.y hi.z (within the box)
  const __m128 bhi = _mm_shuffle_ps(t, t, _MM_SHUFFLE(3, 3, 2, 1));  // hi.x hi.y hi.z hi.z
  const __m128 m = _mm_cmpge_ps(n, _mm_setzero_ps());       // n[k] >= 0: lo is the minimising corner
  const __m128 pmin = _mm_or_ps(_mm_and_ps(m, blo), _mm_andnot_ps(m, bhi));
  const __m128 pmax = _mm_or_ps(_mm_and_ps(m, bhi), _mm_andnot_ps(m, blo));
  const __m128 pl = _mm_mul_ps(n, pmin), ph = _mm_mul_ps(n, pmax);
  const __m128 a = _mm_unpacklo_ps(pl, ph);                 // pl0 ph0 pl1 ph1
  const __m128 b = _mm_unpackhi_ps(pl, ph);                 // pl2 ph2 . .
  __m128 s = _mm_add_ps(a, _mm_movehl_ps(a, a));            // (x + y) for lo and hi
  s = _mm_add_ps(s, b);                                     // + z
  s = _mm_sub_ps(s, _mm_shuffle_ps(n, n, _MM_SHUFFLE(3, 3, 3, 3)));  // - d
  lo = _mm_cvtss_f32(s);
  hi = _mm_cvtss_f32(_mm_shuffle_ps(s, s, _MM_SHUFFLE(1, 1, 1, 1)));
#else
  Vec3f pmin, pmax;
  for (int k = 0; k < 3; ++k) {
    if (p.n[k] >= 0.0f) {
      pmin[k] = box.lo[k];
      pmax[k] = box.hi[k];
    } else {
      pmin[k] = box.hi[k];
      pmax[k] = box.lo[k];
    }
  }
  lo = dot(p.n, pmin) - p.d;
  hi = dot(p.n, pmax) - p.d;
#endif
}

// Both triangle planes have the box at least eps on their front side, or both on their
// back side: the edge is a silhouette from no point of the box (classify_box's Outside).
bool region_excludes(const Plane& t1, const Plane& t2, const AABB& box, float eps) {
  float lo1, hi1, lo2, hi2;
  box_range(t1, box, lo1, hi1);
  box_range(t2, box, lo2, hi2);
  return (lo1 >= eps && lo2 >= eps) || (hi1 <= -eps && hi2 <= -eps);
}

}  // namespace

BoxClass classify_box(const Wedge& w, WedgeState& s, const AABB& box, float eps, bool use_region) {
  bool region_contains = true;
  if (use_region && w.has_region) {
    // Silhouette region (section 4.2): settled bits are never re-tested.
    for (int k = 0; k < 2; ++k) {
      uint8_t pos = k == 0 ? kPos1 : kPos2, neg = k == 0 ? kNeg1 : kNeg2;
      if (s.region & (pos | neg)) continue;
      float lo, hi;
      box_range(w.tri[k], box, lo, hi);
      if (lo >= eps) s.region |= pos;
      else if (hi <= -eps) s.region |= neg;
    }
    if (((s.region & kPos1) && (s.region & kPos2)) || ((s.region & kNeg1) && (s.region & kNeg2)))
      return BoxClass::Outside;
    region_contains = ((s.region & kPos1) && (s.region & kNeg2)) || ((s.region & kNeg1) && (s.region & kPos2));
  }
  uint32_t mask = s.mask;
  while (mask) {
    int i = __builtin_ctz(mask);
    mask &= mask - 1;
    float lo, hi;
    box_range(w.planes[size_t(i)], box, lo, hi);
    if (hi < -eps) return BoxClass::Outside;
    if (lo >= -eps) s.mask = uint16_t(s.mask & ~(1u << i));
  }
  return (s.mask == 0 && region_contains) ? BoxClass::Contains : BoxClass::Partial;
}

SplitBoxes split_boxes(const AABB& box, int axis, float mid) {
  AABB lb = box, rb = box;
  lb.hi[axis] = mid;
  rb.lo[axis] = mid;
  SplitBoxes b;
  b.c_left = (lb.lo + lb.hi) * 0.5f;
  b.c_right = (rb.lo + rb.hi) * 0.5f;
  const Vec3f el = (lb.hi - lb.lo) * 0.5f, er = (rb.hi - rb.lo) * 0.5f;
  b.half = Vec3f(std::max(el.x, er.x), std::max(el.y, er.y), std::max(el.z, er.z));
  return b;
}

void classify_split(const Wedge& w, const WedgeState& s, const SplitBoxes& b, float eps, bool use_region,
                    WedgeState& left, BoxClass& left_class, WedgeState& right, BoxClass& right_class) {
  // Written without data-dependent branches except the loop over active planes: the
  // outcomes are close to random per wedge, and mispredictions were a third of the
  // cost of a split (callgrind --branch-sim, columns).
  left = s;
  right = s;
  // Range of plane p over each half: [dist - rad, dist + rad].
  auto ranges = [&](const Plane& p, float& lo_l, float& hi_l, float& lo_r, float& hi_r) {
    const float rad = dot(vabs(p.n), b.half);
    const float dl = dot(p.n, b.c_left) - p.d, dr = dot(p.n, b.c_right) - p.d;
    lo_l = dl - rad;
    hi_l = dl + rad;
    lo_r = dr - rad;
    hi_r = dr + rad;
  };
  bool out_l = false, out_r = false, contains_l = true, contains_r = true;
  if (use_region && w.has_region) {
    // Silhouette region (section 4.2): settled bits are never re-tested.
    uint8_t rl = s.region, rr = s.region;
    for (int k = 0; k < 2; ++k) {
      const uint8_t pos = k == 0 ? kPos1 : kPos2, neg = k == 0 ? kNeg1 : kNeg2;
      if (s.region & (pos | neg)) continue;
      float lo_l, hi_l, lo_r, hi_r;
      ranges(w.tri[k], lo_l, hi_l, lo_r, hi_r);
      rl |= uint8_t((lo_l >= eps ? pos : 0) | (hi_l <= -eps ? neg : 0));
      rr |= uint8_t((lo_r >= eps ? pos : 0) | (hi_r <= -eps ? neg : 0));
    }
    // Outside: on the front side of both triangles or on the back side of both.
    // Contains: on the front side of exactly one (the silhouette region, "XOR").
    auto both = [](uint8_t r, uint8_t x, uint8_t y) { return (r & x) && (r & y); };
    out_l = both(rl, kPos1, kPos2) || both(rl, kNeg1, kNeg2);
    out_r = both(rr, kPos1, kPos2) || both(rr, kNeg1, kNeg2);
    contains_l = both(rl, kPos1, kNeg2) || both(rl, kNeg1, kPos2);
    contains_r = both(rr, kPos1, kNeg2) || both(rr, kNeg1, kPos2);
    left.region = rl;
    right.region = rr;
  }
  uint32_t mask = s.mask, keep_l = s.mask, keep_r = s.mask;
  while (mask) {
    const int i = __builtin_ctz(mask);
    mask &= mask - 1;
    float lo_l, hi_l, lo_r, hi_r;
    ranges(w.planes[size_t(i)], lo_l, hi_l, lo_r, hi_r);
    out_l |= hi_l < -eps;
    out_r |= hi_r < -eps;
    keep_l &= ~((lo_l >= -eps ? 1u : 0u) << i);  // the plane contains the half
    keep_r &= ~((lo_r >= -eps ? 1u : 0u) << i);
  }
  left.mask = uint16_t(keep_l);
  right.mask = uint16_t(keep_r);
  left_class = out_l ? BoxClass::Outside : (keep_l == 0 && contains_l) ? BoxClass::Contains : BoxClass::Partial;
  right_class = out_r ? BoxClass::Outside : (keep_r == 0 && contains_r) ? BoxClass::Contains : BoxClass::Partial;
}

bool point_in_wedge(const Wedge& w, uint32_t mask, const Vec3f& p, float eps) {
  while (mask) {
    const int i = __builtin_ctz(mask);
    mask &= mask - 1;
    if (w.planes[size_t(i)].eval(p) < -eps) return false;
  }
  return true;
}

bool point_in_wedge(const Wedge& w, const Vec3f& p, float eps) {
  for (int i = 0; i < w.plane_count; ++i)
    if (w.planes[size_t(i)].eval(p) < -eps) return false;
  return true;
}

std::vector<Wedge> build_wedges(const mesh::PreparedMesh& m, const std::vector<Edge>& edges,
                                const std::vector<Vec3d>& frame_pos, const LightFrame& frame, double tol,
                                WedgeBuildCounts& counts, const TrianglePlanes* planes) {
  std::vector<Wedge> wedges;
  build_wedges(m, edges, frame_pos, frame, tol, counts, planes, wedges);
  return wedges;
}

void build_wedges(const mesh::PreparedMesh& m, const std::vector<Edge>& edges, const std::vector<Vec3d>& frame_pos,
                  const LightFrame& frame, double tol, WedgeBuildCounts& counts,
                  const TrianglePlanes* planes, std::vector<Wedge>& wedges,
                  const std::vector<uint32_t>* subset, const RegionBoxes* regions) {
  TrianglePlanes own;
  if (!planes) {
    own = triangle_planes(m);
    planes = &own;
  }
  // Unit plane of a triangle, front (normal) side positive.
  auto triangle_plane = [&](size_t t) { return PointNormalPlane{(*planes)[t].unit(), (*planes)[t].a}; };
  wedges.clear();
  const auto& L = frame.poly_world;
  const size_t nl = L.size();
  const size_t n_edges = subset ? subset->size() : edges.size();
  counts.edges += n_edges;
  std::vector<PointNormalPlane> cand;
  // The light's edges and their lengths, once per call (the same values per edge).
  std::vector<Vec3d> light_edge(nl);
  std::vector<double> light_edge_len(nl);
  for (size_t i = 0; i < nl; ++i) {
    light_edge[i] = L[(i + 1) % nl] - L[i];
    light_edge_len[i] = length(light_edge[i]);
  }
  // The rounding of a double plane test (unit normal, coordinates up to M, tol = 1e-9 M
  // in the solver): about 1e-15 M; rtol = 1e-13 M keeps a hundredfold margin.
  const double rtol = 1e-4 * tol;
  // Per triangle, once per light rather than once per incident edge, and only for the
  // triangles of the edges asked for: active (some vertex strictly above the light
  // plane, integrate.h) and its side of L' (+1: every vertex of L' more than tol in front
  // of its plane, -1: more than tol behind, 0: neither), by the same expressions the
  // per-edge tests used. `stamp` tells this call's entries from older ones.
  thread_local std::vector<uint32_t> stamp;
  thread_local std::vector<int8_t> tri_class;  // bit 0: active; value >> 1: the side
  thread_local uint32_t call = 0;
  const size_t T = m.triangles.size();
  if (stamp.size() < T || ++call == 0) {
    stamp.assign(std::max(stamp.size(), T), 0);
    tri_class.resize(stamp.size());
    call = 1;
  }
  auto classify_triangle = [&](size_t t) {
    if (stamp[t] == call) return tri_class[t];
    const auto& tv = m.triangles[t].v;
    const bool act = frame_pos[tv[0]].z > 0.0 || frame_pos[tv[1]].z > 0.0 || frame_pos[tv[2]].z > 0.0;
    stamp[t] = call;
    tri_class[t] = int8_t(light_side((*planes)[t], L, tol) * 2 | (act ? 1 : 0));
    return tri_class[t];
  };
  size_t last_part = 0;  // the region part that saw the last edge (regions only)
  for (size_t k = 0; k < n_edges; ++k) {
    const size_t ei = subset ? (*subset)[k] : k;
    const Edge& e = edges[ei];
    const int8_t c1 = e.t1 >= 0 ? classify_triangle(size_t(e.t1)) : int8_t(0);
    const int8_t c2 = e.t2 >= 0 ? classify_triangle(size_t(e.t2)) : int8_t(0);
    // Some incident triangle must reach above the light plane (be active, integrate.h),
    // and so must the edge.
    const bool act1 = (c1 & 1) != 0, act2 = (c2 & 1) != 0;
    if (!(act1 || act2) || (frame_pos[e.a].z < 0.0 && frame_pos[e.b].z < 0.0)) {
      ++counts.below_light;
      continue;
    }
    // A double edge with one inactive neighbour has the weight of a single edge of the
    // active one (its facing is 0, integrate.h): no silhouette region, no culling by the
    // pair's planes.
    const bool pair = act1 && act2;
    if (pair) {
      // Potential silhouette w.r.t. L' (section 2.1): some light point sees exactly one
      // of the two triangles front-facing.
      const int s1 = c1 >> 1;  // arithmetic shift: -1, 0 or +1
      if (s1 != 0 && s1 == (c2 >> 1)) {
        ++counts.not_silhouette;
        continue;
      }
    }
    // The planes only for the edges kept (most edges of a dense mesh stop above).
    const PointNormalPlane p1 = triangle_plane(size_t(act1 ? e.t1 : e.t2));
    const PointNormalPlane p2 = pair ? triangle_plane(size_t(e.t2)) : PointNormalPlane{};
    // Silhouette regions (section 4.2) against the receivers: a double edge whose two
    // planes have every receiver box at least eps on the same side is a silhouette from
    // none of them (classify_box would call each box Outside), and gets no wedge.
    if (pair && regions) {
      const Plane f1 = to_float(p1), f2 = to_float(p2);
      bool seen = !region_excludes(f1, f2, regions->all, regions->eps);
      if (seen) {
        // The part that saw the last edge first: edges in label order are neighbours,
        // and whether some part sees the edge does not depend on the order tried.
        const size_t np = regions->parts.size();
        seen = false;
        for (size_t j = 0; j < np && !seen; ++j) {
          const size_t q = j == 0 ? last_part : (j <= last_part ? j - 1 : j);
          if (!region_excludes(f1, f2, regions->parts[q], regions->eps)) {
            seen = true;
            last_part = q;
          }
        }
      }
      if (!seen) {
        ++counts.region_culled;
        continue;
      }
    }
    // The part of the edge on or above the light plane.
    Vec3d A = to_double(m.vertex_pos[e.a]), B = to_double(m.vertex_pos[e.b]);
    double ha = frame.height(A), hb = frame.height(B);
    if (ha < 0.0 && hb > 0.0) A = A + (B - A) * (ha / (ha - hb));
    if (hb < 0.0 && ha > 0.0) B = B + (A - B) * (hb / (hb - ha));

    // Separating planes of the edge and L'.
    cand.clear();
    cand.push_back({frame.N, frame.origin});  // the light plane: h >= 0
    const Vec3d AB = B - A;
    const double ab = length(AB);
    for (size_t i = 0; i < nl; ++i) {  // through the edge and a light vertex
      PointNormalPlane pl;
      if (!make_plane(cross(AB, L[i] - A), A, ab * length(L[i] - A), pl)) continue;
      if (orient_against_light(pl, L, tol, rtol)) cand.push_back(pl);
    }
    for (int end = 0; end < 2; ++end) {  // through an edge endpoint and a light edge
      const Vec3d& P = end == 0 ? A : B;
      const Vec3d& Q = end == 0 ? B : A;
      for (size_t i = 0; i < nl; ++i) {
        const Vec3d& l0 = L[i];
        PointNormalPlane pl;
        if (!make_plane(cross(light_edge[i], P - l0), l0, light_edge_len[i] * length(P - l0), pl)) continue;
        if (!orient_against_light(pl, L, tol, rtol)) continue;
        if (pl.eval(Q) < -rtol) continue;  // the edge must lie on the inner side (rtol: as above)
        cand.push_back(pl);
      }
    }
    Wedge w;
    w.edge = uint32_t(ei);
    for (const auto& pl : cand) {
      if (w.plane_count == kMaxWedgePlanes) {  // dropping a plane only enlarges the wedge
        ++counts.planes_dropped;
        continue;
      }
      w.planes[w.plane_count++] = to_float(pl);
    }
    w.tri[0] = to_float(p1);
    if (pair) {
      w.tri[1] = to_float(p2);
      w.has_region = true;
    }
    wedges.push_back(w);
  }
  counts.wedges += wedges.size();
}

}  // namespace visgate::ssv
