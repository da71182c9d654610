// Candidate silhouette edges from the edge hierarchy (see edge_tree.h).
#include "lib/ssv/edge_tree.h"

#include "lib/base/cpu_features.h"
#include "lib/geom/lanes.h"
#include "lib/geom/morton.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>

#include <cstdlib>
#include <cstring>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define VISGATE_EDGE_TREE_AVX2 1
#endif

namespace visgate::ssv {

EdgeFrustum::EdgeFrustum(const LightFrame& frame, const Vec3f& receiver)
    : rlo(to_double(receiver)), rhi(to_double(receiver)) {
  const Vec3d r = rlo;
  const auto& L = frame.poly_world;
  n[count] = frame.N;  // the light plane, h >= 0
  d[count] = dot(frame.N, frame.origin);
  ++count;
  box.extend(r);
  for (const Vec3d& p : L) box.extend(p);
  // The side planes, oriented with the frame origin (L's vertex average, inside L') on
  // the positive side.
  for (size_t i = 0; i < L.size() && count < kMaxPlanes; ++i) {
    const Vec3d a = L[i] - r, b = L[(i + 1) % L.size()] - r;
    Vec3d nrm = cross(a, b);
    const double len = length(nrm);
    if (!(len > 1e-12 * length(a) * length(b))) continue;
    nrm = nrm / len;
    if (dot(nrm, frame.origin - r) < 0.0) nrm = -nrm;
    n[count] = nrm;
    d[count] = dot(nrm, r);
    ++count;
  }
}

EdgeFrustum::EdgeFrustum(const LightFrame& frame, const AABBd& receivers) : rlo(receivers.lo), rhi(receivers.hi) {
  const auto& L = frame.poly_world;
  n[count] = frame.N;  // the light plane, h >= 0
  d[count] = dot(frame.N, frame.origin);
  ++count;
  box = receivers;
  for (const Vec3d& p : L) box.extend(p);
  Vec3d corner[8];
  for (int k = 0; k < 8; ++k)
    corner[k] = Vec3d(k & 1 ? rhi.x : rlo.x, k & 2 ? rhi.y : rlo.y, k & 4 ? rhi.z : rlo.z);
  // Per edge of L', the plane through it and the corner that has every other corner on
  // its inner side (the hull's face at that edge), up to 1e-9 of the distances (the
  // corner itself evaluates to rounding noise; far below the tests' eps); none found:
  // no plane.
  for (size_t i = 0; i < L.size() && count < kMaxPlanes; ++i) {
    const Vec3d& a = L[i];
    const Vec3d ab = L[(i + 1) % L.size()] - a;
    for (const Vec3d& c : corner) {
      Vec3d nrm = cross(ab, c - a);
      const double len = length(nrm);
      if (!(len > 1e-12 * length(ab) * length(c - a))) continue;
      nrm = nrm / len;
      if (dot(nrm, frame.origin - a) < 0.0) nrm = -nrm;
      const double slack = 1e-9 * (length(ab) + length(c - a));
      bool supports = true;
      for (const Vec3d& o : corner) supports &= dot(nrm, o - a) >= -slack;
      if (!supports) continue;
      n[count] = nrm;
      d[count] = dot(nrm, a);
      ++count;
      break;
    }
  }
}

namespace {

// The unit normal n times 32767, to nearest (half away from zero; |n| <= 1: no
// overflow), 0 without a plane, into q[0..3) (q[3] is written too): the scalar
// v >= 0 ? v + 0.5 : v - 0.5 truncated, four lanes at once.
// n in lanes 0-2 (lane 3 goes to q[3], which no test reads).
inline void quantize_normal(Lanes n, bool has_plane, int16_t* q) {
#if defined(__SSE2__)
  const __m128 zero = _mm_setzero_ps();
  const __m128 v = has_plane ? _mm_mul_ps(n, _mm_set1_ps(32767.0f)) : zero;
  const __m128 ge = _mm_cmpge_ps(v, zero);
  const __m128 half = _mm_or_ps(_mm_and_ps(ge, _mm_set1_ps(0.5f)), _mm_andnot_ps(ge, _mm_set1_ps(-0.5f)));
  const __m128i r = _mm_cvttps_epi32(_mm_add_ps(v, half));
  _mm_storel_epi64(reinterpret_cast<__m128i*>(q), _mm_packs_epi32(r, r));
#else
  for (int c = 0; c < 3; ++c) {
    const float v = has_plane ? n.v[c] * 32767.0f : 0.0f;
    q[c] = int16_t(v >= 0.0f ? v + 0.5f : v - 0.5f);
  }
  q[3] = 0;
#endif
}

// triangle_plane(m, t).unit() rounded to float, lane 3 zero, from the corners c (lanes
// of triangle t's corners in order); has_plane: its nn > 0. SSE2 computes the same double
// operations in the same order (differences, cross product, the sum of squares x, y then
// z, sqrt, division, rounding to float), two lanes at a time: the same floats, bit for
// bit (IEEE arithmetic, no contraction).
inline Lanes unit_normal(const Lanes* c, bool& has_plane) {
#if defined(__SSE2__)
  const __m128d axy = _mm_cvtps_pd(c[0]), az = _mm_cvtps_pd(_mm_movehl_ps(c[0], c[0]));
  const __m128d uxy = _mm_sub_pd(_mm_cvtps_pd(c[1]), axy), uz = _mm_sub_sd(_mm_cvtps_pd(_mm_movehl_ps(c[1], c[1])), az);
  const __m128d wxy = _mm_sub_pd(_mm_cvtps_pd(c[2]), axy), wz = _mm_sub_sd(_mm_cvtps_pd(_mm_movehl_ps(c[2], c[2])), az);
  // (n.x, n.y) = (u.y w.z - u.z w.y, u.z w.x - u.x w.z); n.z = u.x w.y - u.y w.x.
  const __m128d nxy = _mm_sub_pd(_mm_mul_pd(_mm_shuffle_pd(uxy, uz, 1), _mm_shuffle_pd(wz, wxy, 0)),
                                 _mm_mul_pd(_mm_shuffle_pd(uz, uxy, 0), _mm_shuffle_pd(wxy, wz, 1)));
  const __m128d r = _mm_mul_pd(uxy, _mm_shuffle_pd(wxy, wxy, 1));
  const __m128d nz = _mm_sub_sd(r, _mm_unpackhi_pd(r, r));
  const __m128d sq = _mm_mul_pd(nxy, nxy);
  const __m128d nn = _mm_add_sd(_mm_add_sd(sq, _mm_unpackhi_pd(sq, sq)), _mm_mul_sd(nz, nz));
  has_plane = _mm_cvtsd_f64(nn) > 0.0;
  if (!has_plane) return _mm_setzero_ps();
  const __m128d len = _mm_sqrt_sd(nn, nn);
  const __m128d len2 = _mm_unpacklo_pd(len, len);
  return _mm_movelh_ps(_mm_cvtpd_ps(_mm_div_pd(nxy, len2)), _mm_cvtsd_ss(_mm_setzero_ps(), _mm_div_sd(nz, len)));
#else
  alignas(16) float f[3][4];
  for (int v = 0; v < 3; ++v) lanes_store(c[v], f[v]);
  const Vec3d a(f[0][0], f[0][1], f[0][2]), b(f[1][0], f[1][1], f[1][2]), cc(f[2][0], f[2][1], f[2][2]);
  TrianglePlane p;
  p.n = cross(b - a, cc - a);
  p.nn = dot(p.n, p.n);
  has_plane = p.nn > 0.0;
  return lanes_load(Vec3f(p.unit()));
#endif
}

// morton_spread10 of every 10-bit value (4 KiB): one load per coordinate.
constexpr auto kSpread10 = [] {
  std::array<uint32_t, 1024> t{};
  for (uint32_t i = 0; i < 1024; ++i) t[i] = morton_spread10(i);
  return t;
}();

}  // namespace

// A node's six float triples (lo, hi, tlo, thi, nlo, nhi: 18 consecutive floats, then
// `child`) as lanes. SSE2 loads four floats at each triple (lane 3 reads the next field,
// don't-care: lanes_min/max and the stores below keep lanes 0-2 only) and stores four at
// each of the first five, each store's lane 3 overwritten by the next triple's store,
// the last triple three floats: the same 18 floats as lanes_load/lanes_store, fewer
// operations.
template <class Node>
inline void load_bounds(const Node& nd, Lanes* v) {
  static_assert(offsetof(Node, nhi) == offsetof(Node, lo) + 15 * sizeof(float));
  const float* const f[6] = {nd.lo, nd.hi, nd.tlo, nd.thi, nd.nlo, nd.nhi};  // each member: no subscript past one
#if defined(__SSE2__)
  for (int i = 0; i < 6; ++i) v[i] = _mm_loadu_ps(f[i]);
#else
  for (int i = 0; i < 6; ++i) v[i] = lanes_load(f[i]);
#endif
}
template <class Node>
inline void store_bounds(Node& nd, const Lanes* v) {
  float* const f[6] = {nd.lo, nd.hi, nd.tlo, nd.thi, nd.nlo, nd.nhi};
#if defined(__SSE2__)
  for (int i = 0; i < 5; ++i) _mm_storeu_ps(f[i], v[i]);
  _mm_storel_pi(reinterpret_cast<__m64*>(f[5]), v[5]);
  _mm_store_ss(f[5] + 2, _mm_movehl_ps(v[5], v[5]));
#else
  for (int i = 0; i < 6; ++i) lanes_store(v[i], f[i]);
#endif
}

Vec3f tree_unit_normal(const Vec3f& a, const Vec3f& b, const Vec3f& c, bool& has_plane) {
  const Lanes corners[3] = {lanes_load(a), lanes_load(b), lanes_load(c)};
  Vec3f n;
  lanes_store(unit_normal(corners, has_plane), &n.x);
  return n;
}

namespace {

// The leaves read the edges in Morton order: a gather from `edges` (16 bytes an edge) and,
// for each triangle not in the build's cache, from the mesh's triangles (40 bytes), arrays
// past the private caches on large meshes (scan 300k: 7 MB and 12 MB). Fetching them some
// edges ahead hides the misses; only timing changes (a prefetch reads no value and cannot
// fault). `order` has kEdgeAhead positions past the end, each the last edge: no clamp.
constexpr size_t kEdgeAhead = 16, kTriangleAhead = 8;
// Inlined: GCC 12 otherwise finds the function free of side effects and drops the call.
#if defined(__GNUC__)
__attribute__((always_inline))
#endif
inline void prefetch_ahead(const std::vector<Edge>& edges, const mesh::PreparedMesh& m, const uint32_t* order,
                           size_t k) {
#if defined(__GNUC__)
  __builtin_prefetch(&edges[order[k + kEdgeAhead]]);
  const Edge& f = edges[order[k + kTriangleAhead]];
  __builtin_prefetch(&m.triangles[size_t(f.t1 >= 0 ? f.t1 : 0)]);
  __builtin_prefetch(&m.triangles[size_t(f.t2 >= 0 ? f.t2 : f.t1 >= 0 ? f.t1 : 0)]);
#else
  (void)edges, (void)m, (void)order, (void)k;
#endif
}

}  // namespace

EdgeTree::EdgeTree(const std::vector<Edge>& edges, const mesh::PreparedMesh& m, double M)
    : M_(M) {
  const size_t E = edges.size();
  if (E == 0) return;
  // Morton order of the edges' midpoints (the sums of their float endpoints), by a
  // stable LSD radix sort of two 15-bit digits (counts of 128 KiB each, in cache): ties
  // stay in index order.
  // The same floats as AABB::extend point by point (lanes.h), a third of the operations.
  LanesBox vbox;
  for (const Vec3f& v : m.vertex_pos) vbox.add(v);
  const AABB bounds = vbox.box();
  const Vec3f ext = bounds.extent();
  float scale[3];
  for (int c = 0; c < 3; ++c) scale[c] = ext[c] > 0.0f ? 1023.0f / (2.0f * ext[c]) : 0.0f;
  // Fresh memory is what this build costs (populated.h): the codes and the sort's second
  // buffer share one block, which then holds the leaves' endpoints.
  PopulatedArray<uint32_t> scratch(2 * E), a(E + kEdgeAhead);  // a: the order, padded for prefetch_ahead
  uint32_t* code = scratch.data();
  uint32_t* b = scratch.data() + E;
  uint32_t* src = a.data();
  constexpr int kDigit = 15;
  constexpr uint32_t kBuckets = 1u << kDigit, kMask = kBuckets - 1;
  std::vector<uint32_t> count(2 * (kBuckets + 1));  // zeroed
#if defined(__SSE2__)
  // The scalar cells below three lanes at a time: the same sums, differences and
  // products; min(t, 1023) then truncation where t > 0 (NaN: 0), 0 elsewhere.
  const __m128 lo2 = _mm_mul_ps(_mm_set1_ps(2.0f), lanes_load(bounds.lo)), sc = lanes_load(scale);
  const __m128 cell_max = _mm_set1_ps(1023.0f);
#endif
  for (size_t e = 0; e < E; ++e) {
    alignas(16) uint32_t q[4];
#if defined(__SSE2__)
    const Lanes s = _mm_add_ps(lanes_load(m.vertex_pos[edges[e].a]), lanes_load(m.vertex_pos[edges[e].b]));
    const __m128 t = _mm_mul_ps(_mm_sub_ps(s, lo2), sc);
    const __m128i cell = _mm_cvttps_epi32(_mm_min_ps(t, cell_max));
    _mm_store_si128(reinterpret_cast<__m128i*>(q), _mm_and_si128(cell, _mm_castps_si128(_mm_cmpgt_ps(t, _mm_setzero_ps()))));
#else
    const Vec3f s = m.vertex_pos[edges[e].a] + m.vertex_pos[edges[e].b];
    for (int c = 0; c < 3; ++c) {  // NaN (an extent or sum overflowed to infinity) goes to 0
      const float t = (s[c] - 2.0f * bounds.lo[c]) * scale[c];
      q[c] = t > 0.0f ? uint32_t(std::min(t, 1023.0f)) : 0u;
    }
#endif
    const uint32_t cd = kSpread10[q[0]] | (kSpread10[q[1]] << 1) | (kSpread10[q[2]] << 2);
    code[e] = cd;
    src[e] = uint32_t(e);
    // Both passes' digit counts in this one pass (a pass permutes the codes, not their
    // digits).
    ++count[(cd & kMask) + 1];
    ++count[kBuckets + 1 + (cd >> kDigit) + 1];
  }
  uint32_t* dst = b;
  for (int pass = 0; pass < 2; ++pass) {  // the second pass writes back into a
    uint32_t* cnt = count.data() + pass * (kBuckets + 1);
    const int shift = kDigit * pass;
    for (size_t k = 1; k <= kBuckets; ++k) cnt[k] += cnt[k - 1];
    for (size_t k = 0; k < E; ++k) dst[cnt[(code[src[k]] >> shift) & kMask]++] = src[k];
    std::swap(src, dst);
  }
  for (size_t k = E; k < E + kEdgeAhead; ++k) src[k] = src[E - 1];  // src is a again
  order_ = std::move(a);
  vertices_ = &m.vertex_pos;
  ends_ = std::move(scratch);  // the codes and b are dead; written with the leaves
  normals_ = PopulatedArray<int16_t>(6 * E);
  // Leaves, then each level above, bottom-up.
  const size_t leaves = (E + kLeaf - 1) / kLeaf;
  size_t total = 0;
  for (size_t n = leaves;; n = (n + 1) / 2) {
    total += n;
    if (n == 1) break;
  }
  nodes_ = PopulatedArray<Node>(total);
  const Lanes inf = lanes_set(INFINITY), ninf = lanes_set(-INFINITY);
  // Each triangle is in about two leaves, mostly near each other in the Morton order: a
  // direct-mapped cache of what a leaf reads of a triangle (its corners, float normal,
  // quantized normal and whether it has a plane), keyed by the triangle, spares the
  // second triangle_plane. An entry holds the very values computed on its first use, and
  // the last leaf that folded them into its bounds.
  // The corners enter a leaf's bounds as their box (blo, bhi): lanes_min and lanes_max
  // keep the first of equal values, so folding the box gives the floats, signed zeros
  // included, that folding the corners one by one in order gives.
  struct Met {
    Lanes blo, bhi, n;
    int32_t t;
    uint32_t leaf;
    uint8_t no_plane;
    int16_t q[4];
  };
  std::vector<Met> met(kMetEntries);
  for (Met& e : met) e.t = -1;
  // Locals: the stores through ends and nrm could otherwise alias the members.
  const uint32_t* const order = order_.data();
  uint32_t* const ends = ends_.data();
  int16_t* const nrm = normals_.data();
  const Vec3f* const vpos = m.vertex_pos.data();
  for (size_t j = 0; j < leaves; ++j) {
    Node& nd = nodes_[j];
    nd.leaf = 1;
    nd.child = uint32_t(j * kLeaf);
    nd.n = uint8_t(std::min<size_t>(kLeaf, E - j * kLeaf));
    nd.edges = nd.n;
    Lanes lo = inf, hi = ninf, tlo = inf, thi = ninf, nlo = inf, nhi = ninf;
    const uint32_t leaf_end = nd.child + nd.n;  // a local: the stores below may alias nd
    uint8_t single = 0;                          // likewise, stored after the loop
    for (uint32_t k = nd.child; k < leaf_end; ++k) {
      prefetch_ahead(edges, m, order, k);
      const Edge ed = edges[order[k]];  // a copy: the stores below may alias edges
      ends[2 * size_t(k)] = ed.a;
      ends[2 * size_t(k) + 1] = ed.b;
      const Lanes va = lanes_load(vpos[ed.a]), vb = lanes_load(vpos[ed.b]);
      lo = lanes_min(lo, lanes_min(va, vb));
      hi = lanes_max(hi, lanes_max(va, vb));
      if (ed.t2 < 0) single = 1;
      // The edge's two unit normals for the leaf's per-edge facing test, times 32767 and
      // rounded to integers (12 bytes an edge: fresh memory is what the build costs); 0
      // (never proven weight 0) for a single edge or a triangle without a plane.
      int16_t* en = nrm + 6 * size_t(k);  // zero from the PopulatedArray
      for (int side = 0; side < 2; ++side) {
        const int32_t t = side == 0 ? ed.t1 : ed.t2;
        if (t < 0) continue;
        Met& e = met[uint32_t(t) & (kMetEntries - 1)];
        if (e.t != t) {  // from its corners: no fresh per-triangle array
          const mesh::PreparedTriangle& tri = m.triangles[size_t(t)];
          Lanes c[3];
          for (int v = 0; v < 3; ++v) c[v] = lanes_load(vpos[tri.v[v]]);
          e.blo = lanes_min(lanes_min(c[0], c[1]), c[2]);
          e.bhi = lanes_max(lanes_max(c[0], c[1]), c[2]);
          e.t = t;
          e.leaf = uint32_t(-1);
          bool has_plane = false;
          e.n = unit_normal(c, has_plane);
          e.no_plane = uint8_t(!has_plane);  // no plane: never proven weight 0
          quantize_normal(e.n, has_plane, e.q);
        }
        // A leaf's edges share triangles (about half of its 16 references repeat): each
        // triangle's corners and normal enter its bounds at their first reference, in
        // reference order. One evicted and met again in the same leaf is folded again,
        // which changes nothing: after x is folded, acc <= x, and lanes_min keeps acc on
        // ties (lanes_max likewise).
        if (e.leaf != uint32_t(j)) {
          e.leaf = uint32_t(j);
          single |= e.no_plane;
          tlo = lanes_min(tlo, e.blo);
          thi = lanes_max(thi, e.bhi);
          nlo = lanes_min(nlo, e.n);
          nhi = lanes_max(nhi, e.n);
        }
        if (ed.t2 >= 0) std::memcpy(en + 3 * side, e.q, 3 * sizeof(int16_t));
      }
    }
    nd.single = single;
    const Lanes leaf_bounds[6] = {lo, hi, tlo, thi, nlo, nhi};
    store_bounds(nd, leaf_bounds);
  }
  for (size_t first = 0, n = leaves; n > 1; first += n, n = (n + 1) / 2) {
    const size_t up = first + n;
    for (size_t j = 0; j < (n + 1) / 2; ++j) {
      Node& nd = nodes_[up + j];
      nd.child = uint32_t(first + 2 * j);
      nd.n = uint8_t(2 * j + 1 < n ? 2 : 1);
      // Lows by lanes_min, highs by lanes_max, the children in order.
      Lanes acc[6] = {inf, ninf, inf, ninf, inf, ninf};
      for (uint32_t k = nd.child; k < nd.child + nd.n; ++k) {
        const Node& o = nodes_[k];
        Lanes c[6];
        load_bounds(o, c);
        for (int i = 0; i < 6; i += 2) {
          acc[i] = lanes_min(acc[i], c[i]);
          acc[i + 1] = lanes_max(acc[i + 1], c[i + 1]);
        }
        nd.single |= o.single;
        nd.edges += o.edges;
      }
      store_bounds(nd, acc);
    }
  }
}

namespace {

// The frustum in float for the node tests: its box grown by eps, and its planes four at a
// time (SSE2; the same float products and sums per plane as the scalar form).
struct FloatFrustum {
  static constexpr int kGroups = (EdgeFrustum::kMaxPlanes + 3) / 4;
  float blo[3], bhi[3];
  float rlo[3], rhi[3];
  float rlo4[4], rhi4[4];  // the same with a fourth lane (0) for the SSE2 loads
  int groups = 0;
#if defined(__SSE2__)
  __m128 nx[kGroups], ny[kGroups], nz[kGroups], d[kGroups], px[kGroups], py[kGroups], pz[kGroups];
#else
  float n[EdgeFrustum::kMaxPlanes][3], dd[EdgeFrustum::kMaxPlanes];
  int count = 0;
#endif
#if defined(__SSE2__)
  __m128 neps_;
#endif
  FloatFrustum(const EdgeFrustum& f, float eps) {
    for (int c = 0; c < 3; ++c) {
      blo[c] = float(f.box.lo[c]) - eps;
      bhi[c] = float(f.box.hi[c]) + eps;
      rlo[c] = float(f.rlo[c]);  // receivers are float points: exact
      rhi[c] = float(f.rhi[c]);
      rlo4[c] = rlo[c];
      rhi4[c] = rhi[c];
    }
    rlo4[3] = rhi4[3] = 0.0f;
#if defined(__SSE2__)
    groups = (f.count + 3) / 4;
    alignas(16) float v[7][4];
    for (int g = 0; g < groups; ++g) {
      for (int l = 0; l < 4; ++l) {
        const int i = 4 * g + l;
        // Padding lanes: n = 0, d = -inf, never outside.
        const bool real = i < f.count;
        for (int c = 0; c < 3; ++c) {
          v[c][l] = real ? float(f.n[i][c]) : 0.0f;
          v[4 + c][l] = (v[c][l] >= 0.0f) ? 1.0f : 0.0f;
        }
        v[3][l] = real ? float(f.d[i]) : -INFINITY;
      }
      nx[g] = _mm_load_ps(v[0]);
      ny[g] = _mm_load_ps(v[1]);
      nz[g] = _mm_load_ps(v[2]);
      d[g] = _mm_load_ps(v[3]);
      const __m128 one = _mm_set1_ps(1.0f);
      px[g] = _mm_cmpeq_ps(_mm_load_ps(v[4]), one);  // take hi where n >= 0
      py[g] = _mm_cmpeq_ps(_mm_load_ps(v[5]), one);
      pz[g] = _mm_cmpeq_ps(_mm_load_ps(v[6]), one);
    }
    neps_ = _mm_set1_ps(-eps);
#else
    count = f.count;
    for (int i = 0; i < count; ++i) {
      for (int c = 0; c < 3; ++c) n[i][c] = float(f.n[i][c]);
      dd[i] = float(f.d[i]);
    }
#endif
  }
  // The box lies more than eps outside the frustum's box or one of its planes.
  bool outside(const float* lo, const float* hi, float eps) const {
    for (int c = 0; c < 3; ++c)
      if (hi[c] < blo[c] || lo[c] > bhi[c]) return true;
#if defined(__SSE2__)
    (void)eps;
    const __m128 lx = _mm_set1_ps(lo[0]), ly = _mm_set1_ps(lo[1]), lz = _mm_set1_ps(lo[2]);
    const __m128 hx = _mm_set1_ps(hi[0]), hy = _mm_set1_ps(hi[1]), hz = _mm_set1_ps(hi[2]);
    for (int g = 0; g < groups; ++g) {
      const __m128 x = _mm_or_ps(_mm_and_ps(px[g], hx), _mm_andnot_ps(px[g], lx));
      const __m128 y = _mm_or_ps(_mm_and_ps(py[g], hy), _mm_andnot_ps(py[g], ly));
      const __m128 z = _mm_or_ps(_mm_and_ps(pz[g], hz), _mm_andnot_ps(pz[g], lz));
      __m128 s = _mm_sub_ps(_mm_setzero_ps(), d[g]);
      s = _mm_add_ps(s, _mm_mul_ps(nx[g], x));
      s = _mm_add_ps(s, _mm_mul_ps(ny[g], y));
      s = _mm_add_ps(s, _mm_mul_ps(nz[g], z));
      if (_mm_movemask_ps(_mm_cmplt_ps(s, neps_))) return true;
    }
#else
    for (int i = 0; i < count; ++i) {
      float s = -dd[i];
      for (int c = 0; c < 3; ++c) s += n[i][c] * (n[i][c] >= 0.0f ? hi[c] : lo[c]);
      if (s < -eps) return true;
    }
#endif
    return false;
  }
  // The segment a b lies more than eps outside the frustum's box or one of its planes
  // (both ends outside the same plane: tighter than the segment's box for a diagonal
  // edge).
  bool outside(const Vec3f& a, const Vec3f& b, float eps) const {
    for (int c = 0; c < 3; ++c)
      if (std::max(a[c], b[c]) < blo[c] || std::min(a[c], b[c]) > bhi[c]) return true;
#if defined(__SSE2__)
    (void)eps;
    const __m128 ax = _mm_set1_ps(a.x), ay = _mm_set1_ps(a.y), az = _mm_set1_ps(a.z);
    const __m128 bx = _mm_set1_ps(b.x), by = _mm_set1_ps(b.y), bz = _mm_set1_ps(b.z);
    for (int g = 0; g < groups; ++g) {
      __m128 sa = _mm_sub_ps(_mm_setzero_ps(), d[g]), sb = sa;
      sa = _mm_add_ps(sa, _mm_mul_ps(nx[g], ax));
      sa = _mm_add_ps(sa, _mm_mul_ps(ny[g], ay));
      sa = _mm_add_ps(sa, _mm_mul_ps(nz[g], az));
      sb = _mm_add_ps(sb, _mm_mul_ps(nx[g], bx));
      sb = _mm_add_ps(sb, _mm_mul_ps(ny[g], by));
      sb = _mm_add_ps(sb, _mm_mul_ps(nz[g], bz));
      if (_mm_movemask_ps(_mm_and_ps(_mm_cmplt_ps(sa, neps_), _mm_cmplt_ps(sb, neps_)))) return true;
    }
#else
    for (int i = 0; i < count; ++i) {
      float sa = -dd[i], sb = -dd[i];
      for (int c = 0; c < 3; ++c) {
        sa += n[i][c] * a[c];
        sb += n[i][c] * b[c];
      }
      if (sa < -eps && sb < -eps) return true;
    }
#endif
    return false;
  }
};

// Every triangle below `nd` active and every receiver of `ff` on one side of all their
// planes, beyond the margin (edge_tree.h): the node's edges all have weight 0.
template <class Node>
inline bool facing_prunes(const FloatFrustum& ff, const Node& nd, const float* N, float h0, float active_margin,
                          float abs_margin) {
  float hmin = -h0;
  for (int c = 0; c < 3; ++c) hmin += N[c] * (N[c] >= 0.0f ? nd.tlo[c] : nd.thi[c]);
  if (!(hmin > active_margin)) return false;
#if defined(__SSE2__)
  // Lanes x, y, z (the fourth is masked to 0): the same products, sums in another order
  // (the bound's slack covers any order, edge_tree.h).
  static_assert(offsetof(Node, thi) == offsetof(Node, tlo) + 3 * sizeof(float) &&
                offsetof(Node, nlo) == offsetof(Node, thi) + 3 * sizeof(float) &&
                offsetof(Node, nhi) == offsetof(Node, nlo) + 3 * sizeof(float) &&
                offsetof(Node, child) == offsetof(Node, nhi) + 3 * sizeof(float));
  const __m128 keep = _mm_castsi128_ps(_mm_set_epi32(0, -1, -1, -1));
  const __m128 tlo = _mm_loadu_ps(nd.tlo), thi = _mm_loadu_ps(nd.thi);
  const __m128 nlo = _mm_loadu_ps(nd.nlo), nhi = _mm_loadu_ps(nd.nhi);
  const __m128 dlo = _mm_sub_ps(_mm_loadu_ps(ff.rlo4), thi), dhi = _mm_sub_ps(_mm_loadu_ps(ff.rhi4), tlo);
  const __m128 p0 = _mm_mul_ps(nlo, dlo), p1 = _mm_mul_ps(nlo, dhi), p2 = _mm_mul_ps(nhi, dlo), p3 = _mm_mul_ps(nhi, dhi);
  __m128 lo = _mm_and_ps(keep, _mm_min_ps(_mm_min_ps(p0, p1), _mm_min_ps(p2, p3)));
  __m128 hi = _mm_and_ps(keep, _mm_max_ps(_mm_max_ps(p0, p1), _mm_max_ps(p2, p3)));
  const __m128 sign = _mm_set1_ps(-0.0f);
  __m128 far = _mm_and_ps(keep, _mm_max_ps(_mm_andnot_ps(sign, dlo), _mm_andnot_ps(sign, dhi)));
  // Horizontal sums of lo, hi and far.
  auto hsum = [](__m128 v) {
    const __m128 t = _mm_add_ps(v, _mm_movehl_ps(v, v));
    return _mm_cvtss_f32(_mm_add_ss(t, _mm_shuffle_ps(t, t, 1)));
  };
  const float flo = hsum(lo), fhi = hsum(hi), fr = hsum(far);
#else
  float flo = 0.0f, fhi = 0.0f, fr = 0.0f;
  for (int c = 0; c < 3; ++c) {
    // n_c (r_c - a_c) with n_c in [nlo, nhi], r_c - a_c in [dlo, dhi].
    const float dlo = ff.rlo[c] - nd.thi[c], dhi = ff.rhi[c] - nd.tlo[c];
    const float p0 = nd.nlo[c] * dlo, p1 = nd.nlo[c] * dhi, p2 = nd.nhi[c] * dlo, p3 = nd.nhi[c] * dhi;
    flo += std::min(std::min(p0, p1), std::min(p2, p3));
    fhi += std::max(std::max(p0, p1), std::max(p2, p3));
    fr += std::max(std::abs(dlo), std::abs(dhi));
  }
#endif
  const float margin = 0x1p-18f * fr + abs_margin;
  return flo > margin || fhi < -margin;
}

// The leaf's per-edge facing test for one receiver r (edge_tree.h): both triangles of the
// edge (q[0..3) and q[3..6): unit normals times S = 32767, rounded; 0 when it has no
// pair) have r on one side, beyond the margin, measured from the edge's endpoint a,
// which lies in both planes. `ext` is the L1 extent of the leaf's triangle box: every
// vertex v of the two triangles has |r - v| <= |r - a|_1 + ext. With f = q.(r - a) / S
// the unit normal's value is f within (1/(2S) + 2^-21) |r - a|_1 (rounding of q and of
// the float sums), so f > 2 (|r - a|_1 + ext) / S + abs_margin (about 2^-14) puts it
// above 2^-20 (|r - a|_1 + ext) with room to spare: the doubt threshold of
// ReceiverIntegrator::facing. The same float operations as the lanes' form.
// Returns 1 when the edge has weight 0 (leave it); 2 or 3 when its weight is proven +2 or
// -2 (r in front of one triangle and behind the other, both beyond the margin: handed
// out with EdgeTree::kWeightPlus2 or kWeightMinus2); else 0 (the solver computes it).
inline int edge_facing_class(const float* r, const Vec3f& a, const int16_t* q, float ext, float abs_margin) {
  const float dx = r[0] - a.x, dy = r[1] - a.y, dz = r[2] - a.z;
  const float f1 = (float(q[0]) * dx + float(q[2]) * dz) + float(q[1]) * dy;
  const float f2 = (float(q[3]) * dx + float(q[5]) * dz) + float(q[4]) * dy;
  const float l1 = (std::abs(dx) + std::abs(dz)) + std::abs(dy);
  const float margin = 2.0f * (l1 + ext) + 32767.0f * abs_margin;
  if ((f1 > margin && f2 > margin) || (f1 < -margin && f2 < -margin)) return 1;
  if (f1 > margin && f2 < -margin) return 2;
  if (f1 < -margin && f2 > margin) return 3;
  return 0;
}

// The leaf's triangles all active (their box more than active_margin above the light
// plane): facing_prunes' light-plane test.
template <class Node>
inline bool all_active(const Node& nd, const float* N, float h0, float active_margin) {
  float hmin = -h0;
  for (int c = 0; c < 3; ++c) hmin += N[c] * (N[c] >= 0.0f ? nd.tlo[c] : nd.thi[c]);
  return hmin > active_margin;
}

template <class Node>
inline float l1_extent(const Node& nd) {
  return ((nd.thi[0] - nd.tlo[0]) + (nd.thi[2] - nd.tlo[2])) + (nd.thi[1] - nd.tlo[1]);
}

}  // namespace

void EdgeTree::walk(const EdgeFrustum& f, const LightFrame& frame, float eps, const uint32_t* starts,
                    size_t n_starts, uint32_t max_edges, std::vector<uint32_t>* edges,
                    std::vector<uint32_t>* nodes, uint32_t cap) const {
  const size_t limit = cap > 0 ? size_t(cap) : SIZE_MAX;
  const FloatFrustum ff(f, eps);
  // Light plane in float: min height over a box > 2e-6 M means every vertex's frame
  // height (to_local in double) is positive.
  const float N[3] = {float(frame.N.x), float(frame.N.y), float(frame.N.z)};
  const float h0 = float(dot(frame.N, frame.origin));
  const float active_margin = float(2e-6 * M_), abs_margin = float(1e-9 * M_);
  // Depth first; the tree's height is below 40 for any uint32 edge count.
  uint32_t stack[64];
  for (size_t s = 0; s < n_starts; ++s) {
    size_t top = 0;
    stack[top++] = starts[s];
    while (top > 0) {
      const Node& nd = nodes_[stack[--top]];
      if (ff.outside(nd.lo, nd.hi, eps)) continue;
      if (!nd.single && facing_prunes(ff, nd, N, h0, active_margin, abs_margin)) continue;
      if (nodes && (nd.edges <= max_edges || nd.leaf)) {
        nodes->push_back(uint32_t(&nd - nodes_.data()));
        continue;
      }
      if (nd.leaf) {
        const bool active = all_active(nd, N, h0, active_margin);
        const float ext = l1_extent(nd);
        for (uint32_t k = nd.child; k < nd.child + nd.n; ++k) {
          // The facing test first: on a noisy surface it leaves most edges (the result is
          // the same in either order).
          const Vec3f& a = (*vertices_)[ends_[2 * k]];
          const int cls = active ? edge_facing_class(ff.rlo, a, &normals_[6 * size_t(k)], ext, abs_margin) : 0;
          if (cls == 1) continue;
          if (ff.outside(a, (*vertices_)[ends_[2 * k + 1]], eps)) continue;
          edges->push_back(order_[k] | (cls == 2 ? kWeightPlus2 : cls == 3 ? kWeightMinus2 : 0u));
        }
        if (edges->size() > limit) return;
        continue;
      }
      for (uint32_t k = nd.child + nd.n; k-- > nd.child;) stack[top++] = k;
    }
  }
}

#if defined(VISGATE_EDGE_TREE_AVX2) && defined(__SSE2__)
namespace {

// Up to eight receivers' FloatFrustum in lanes (lane k = receiver k): the same float
// values, padding planes as there (n = 0, d = -inf: never outside).
struct LaneFrusta {
  static constexpr int P = EdgeFrustum::kMaxPlanes;
  int planes = 0;
  float nx[P][8], ny[P][8], nz[P][8], d[P][8];
  int32_t px[P][8], py[P][8], pz[P][8];  // -1 where n >= 0: take the box's hi
  float blo[3][8], bhi[3][8], r[3][8];
  LaneFrusta(const EdgeFrustum* fs, size_t n, float eps) {
    for (size_t k = 0; k < n; ++k) planes = std::max(planes, fs[k].count);
    for (int k = 0; k < 8; ++k) {
      const EdgeFrustum& f = fs[size_t(k) < n ? size_t(k) : 0];  // unused lanes: a copy of lane 0, masked off
      for (int c = 0; c < 3; ++c) {
        blo[c][k] = float(f.box.lo[c]) - eps;
        bhi[c][k] = float(f.box.hi[c]) + eps;
        r[c][k] = float(f.rlo[c]);
      }
      for (int i = 0; i < planes; ++i) {
        const bool real = i < f.count;
        const float v[3] = {real ? float(f.n[i][0]) : 0.0f, real ? float(f.n[i][1]) : 0.0f,
                            real ? float(f.n[i][2]) : 0.0f};
        nx[i][k] = v[0];
        ny[i][k] = v[1];
        nz[i][k] = v[2];
        d[i][k] = real ? float(f.d[i]) : -INFINITY;
        px[i][k] = v[0] >= 0.0f ? -1 : 0;
        py[i][k] = v[1] >= 0.0f ? -1 : 0;
        pz[i][k] = v[2] >= 0.0f ? -1 : 0;
      }
    }
  }
};

// Lanes whose receiver has the box (lo, hi) more than eps outside its frustum's box or
// a plane: FloatFrustum::outside(lo, hi) per lane, the same products and sums in the
// same order (no fused multiply-add: target avx2 only).
__attribute__((target("avx2"))) inline int box_outside8(const LaneFrusta& L, const float* lo, const float* hi,
                                                        __m256 neps) {
  __m256 out = _mm256_setzero_ps();
  __m256 l[3], h[3];
  for (int c = 0; c < 3; ++c) {
    l[c] = _mm256_set1_ps(lo[c]);
    h[c] = _mm256_set1_ps(hi[c]);
    out = _mm256_or_ps(out, _mm256_cmp_ps(h[c], _mm256_loadu_ps(L.blo[c]), _CMP_LT_OQ));
    out = _mm256_or_ps(out, _mm256_cmp_ps(l[c], _mm256_loadu_ps(L.bhi[c]), _CMP_GT_OQ));
  }
  for (int i = 0; i < L.planes; ++i) {
    const __m256 x = _mm256_blendv_ps(l[0], h[0], _mm256_loadu_ps(reinterpret_cast<const float*>(L.px[i])));
    const __m256 y = _mm256_blendv_ps(l[1], h[1], _mm256_loadu_ps(reinterpret_cast<const float*>(L.py[i])));
    const __m256 z = _mm256_blendv_ps(l[2], h[2], _mm256_loadu_ps(reinterpret_cast<const float*>(L.pz[i])));
    __m256 sum = _mm256_sub_ps(_mm256_setzero_ps(), _mm256_loadu_ps(L.d[i]));
    sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_loadu_ps(L.nx[i]), x));
    sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_loadu_ps(L.ny[i]), y));
    sum = _mm256_add_ps(sum, _mm256_mul_ps(_mm256_loadu_ps(L.nz[i]), z));
    out = _mm256_or_ps(out, _mm256_cmp_ps(sum, neps, _CMP_LT_OQ));
  }
  return _mm256_movemask_ps(out);
}

// Lanes whose receiver has the segment a b more than eps outside (FloatFrustum::outside
// for a segment, per lane).
__attribute__((target("avx2"))) inline int segment_outside8(const LaneFrusta& L, const Vec3f& a, const Vec3f& b,
                                                            __m256 neps) {
  __m256 out = _mm256_setzero_ps();
  for (int c = 0; c < 3; ++c) {
    out = _mm256_or_ps(out, _mm256_cmp_ps(_mm256_set1_ps(std::max(a[c], b[c])), _mm256_loadu_ps(L.blo[c]), _CMP_LT_OQ));
    out = _mm256_or_ps(out, _mm256_cmp_ps(_mm256_set1_ps(std::min(a[c], b[c])), _mm256_loadu_ps(L.bhi[c]), _CMP_GT_OQ));
  }
  const __m256 ax = _mm256_set1_ps(a.x), ay = _mm256_set1_ps(a.y), az = _mm256_set1_ps(a.z);
  const __m256 bx = _mm256_set1_ps(b.x), by = _mm256_set1_ps(b.y), bz = _mm256_set1_ps(b.z);
  for (int i = 0; i < L.planes; ++i) {
    const __m256 nx = _mm256_loadu_ps(L.nx[i]), ny = _mm256_loadu_ps(L.ny[i]), nz = _mm256_loadu_ps(L.nz[i]);
    __m256 sa = _mm256_sub_ps(_mm256_setzero_ps(), _mm256_loadu_ps(L.d[i])), sb = sa;
    sa = _mm256_add_ps(sa, _mm256_mul_ps(nx, ax));
    sa = _mm256_add_ps(sa, _mm256_mul_ps(ny, ay));
    sa = _mm256_add_ps(sa, _mm256_mul_ps(nz, az));
    sb = _mm256_add_ps(sb, _mm256_mul_ps(nx, bx));
    sb = _mm256_add_ps(sb, _mm256_mul_ps(ny, by));
    sb = _mm256_add_ps(sb, _mm256_mul_ps(nz, bz));
    out = _mm256_or_ps(out, _mm256_and_ps(_mm256_cmp_ps(sa, neps, _CMP_LT_OQ), _mm256_cmp_ps(sb, neps, _CMP_LT_OQ)));
  }
  return _mm256_movemask_ps(out);
}

// Lanes facing_prunes would prune (its receiver-independent light-plane test is done by
// the caller): the same per-lane products, minima, maxima and sums in the order of the
// SSE2 form ((x + z) + y).
template <class Node>
__attribute__((target("avx2"))) inline int facing_prunes8(const LaneFrusta& L, const Node& nd, float abs_margin) {
  __m256 lo[3], hi[3], far[3];
  const __m256 sign = _mm256_set1_ps(-0.0f);
  for (int c = 0; c < 3; ++c) {
    const __m256 r = _mm256_loadu_ps(L.r[c]);
    const __m256 dlo = _mm256_sub_ps(r, _mm256_set1_ps(nd.thi[c])), dhi = _mm256_sub_ps(r, _mm256_set1_ps(nd.tlo[c]));
    const __m256 nlo = _mm256_set1_ps(nd.nlo[c]), nhi = _mm256_set1_ps(nd.nhi[c]);
    const __m256 p0 = _mm256_mul_ps(nlo, dlo), p1 = _mm256_mul_ps(nlo, dhi), p2 = _mm256_mul_ps(nhi, dlo),
                 p3 = _mm256_mul_ps(nhi, dhi);
    lo[c] = _mm256_min_ps(_mm256_min_ps(p0, p1), _mm256_min_ps(p2, p3));
    hi[c] = _mm256_max_ps(_mm256_max_ps(p0, p1), _mm256_max_ps(p2, p3));
    far[c] = _mm256_max_ps(_mm256_andnot_ps(sign, dlo), _mm256_andnot_ps(sign, dhi));
  }
  const __m256 flo = _mm256_add_ps(_mm256_add_ps(lo[0], lo[2]), lo[1]);
  const __m256 fhi = _mm256_add_ps(_mm256_add_ps(hi[0], hi[2]), hi[1]);
  const __m256 fr = _mm256_add_ps(_mm256_add_ps(far[0], far[2]), far[1]);
  const __m256 margin = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(0x1p-18f), fr), _mm256_set1_ps(abs_margin));
  const __m256 nmargin = _mm256_sub_ps(_mm256_setzero_ps(), margin);
  return _mm256_movemask_ps(
      _mm256_or_ps(_mm256_cmp_ps(flo, margin, _CMP_GT_OQ), _mm256_cmp_ps(fhi, nmargin, _CMP_LT_OQ)));
}

// Lanes edge_facing_class gives 1 (returned), 2 (`plus`) and 3 (`minus`): the same
// per-lane operations in the same order.
__attribute__((target("avx2"))) inline int edge_facing_class8(const LaneFrusta& L, const Vec3f& a, const int16_t* q,
                                                              float ext, float abs_margin, int& plus, int& minus) {
  // The six components to float (exact) four and two at a time, reading no further than
  // q[5].
  alignas(16) float n[8];
  int32_t q45;
  std::memcpy(&q45, q + 4, sizeof(q45));
  _mm_store_ps(n, _mm_cvtepi32_ps(_mm_cvtepi16_epi32(_mm_loadl_epi64(reinterpret_cast<const __m128i*>(q)))));
  _mm_store_ps(n + 4, _mm_cvtepi32_ps(_mm_cvtepi16_epi32(_mm_cvtsi32_si128(q45))));
  const __m256 sign = _mm256_set1_ps(-0.0f);
  const __m256 dx = _mm256_sub_ps(_mm256_loadu_ps(L.r[0]), _mm256_set1_ps(a.x));
  const __m256 dy = _mm256_sub_ps(_mm256_loadu_ps(L.r[1]), _mm256_set1_ps(a.y));
  const __m256 dz = _mm256_sub_ps(_mm256_loadu_ps(L.r[2]), _mm256_set1_ps(a.z));
  const __m256 f1 = _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(n[0]), dx), _mm256_mul_ps(_mm256_set1_ps(n[2]), dz)),
      _mm256_mul_ps(_mm256_set1_ps(n[1]), dy));
  const __m256 f2 = _mm256_add_ps(
      _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(n[3]), dx), _mm256_mul_ps(_mm256_set1_ps(n[5]), dz)),
      _mm256_mul_ps(_mm256_set1_ps(n[4]), dy));
  const __m256 l1 = _mm256_add_ps(_mm256_add_ps(_mm256_andnot_ps(sign, dx), _mm256_andnot_ps(sign, dz)),
                                  _mm256_andnot_ps(sign, dy));
  const __m256 margin = _mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(2.0f), _mm256_add_ps(l1, _mm256_set1_ps(ext))),
                                      _mm256_set1_ps(32767.0f * abs_margin));
  const __m256 nmargin = _mm256_sub_ps(_mm256_setzero_ps(), margin);
  const int p1 = _mm256_movemask_ps(_mm256_cmp_ps(f1, margin, _CMP_GT_OQ));
  const int n1 = _mm256_movemask_ps(_mm256_cmp_ps(f1, nmargin, _CMP_LT_OQ));
  const int p2 = _mm256_movemask_ps(_mm256_cmp_ps(f2, margin, _CMP_GT_OQ));
  const int n2 = _mm256_movemask_ps(_mm256_cmp_ps(f2, nmargin, _CMP_LT_OQ));
  plus = p1 & n2;
  minus = n1 & p2;
  return (p1 & p2) | (n1 & n2);
}

}  // namespace

// walk() for up to eight receivers at once: a node goes on with the lanes that did not
// leave it, so each lane visits exactly the nodes its own walk visits.
__attribute__((target("avx2"))) void EdgeTree::walk8(const EdgeFrustum* fs, size_t n, const LightFrame& frame,
                                                     float eps, const std::vector<uint32_t>& starts,
                                                     std::vector<uint32_t>* outs, uint32_t cap) const {
  const LaneFrusta L(fs, n, eps);
  const size_t limit = cap > 0 ? size_t(cap) : SIZE_MAX;
  const __m256 neps = _mm256_set1_ps(-eps);
  const float N[3] = {float(frame.N.x), float(frame.N.y), float(frame.N.z)};
  const float h0 = float(dot(frame.N, frame.origin));
  const float active_margin = float(2e-6 * M_), abs_margin = float(1e-9 * M_);
  int live = int((1u << n) - 1u);  // the lanes not yet past the cap
  struct Item {
    uint32_t node;
    int mask;
  };
  Item stack[64];
  for (uint32_t start : starts) {
    size_t top = 0;
    stack[top++] = {start, int((1u << n) - 1u)};
    while (top > 0) {
      const Item it = stack[--top];
      const Node& nd = nodes_[it.node];
      int m = it.mask & live & ~box_outside8(L, nd.lo, nd.hi, neps);
      if (m == 0) continue;
      if (!nd.single) {
        float hmin = -h0;  // facing_prunes' light-plane test: the same for every lane
        for (int c = 0; c < 3; ++c) hmin += N[c] * (N[c] >= 0.0f ? nd.tlo[c] : nd.thi[c]);
        if (hmin > active_margin) m &= ~facing_prunes8(L, nd, abs_margin);
        if (m == 0) continue;
      }
      if (nd.leaf) {
        const bool active = all_active(nd, N, h0, active_margin);
        const float ext = l1_extent(nd);
        int pushed = 0;
        for (uint32_t k = nd.child; k < nd.child + nd.n; ++k) {
          const Vec3f& a = (*vertices_)[ends_[2 * k]];
          int plus = 0, minus = 0;
          int keep = active ? m & ~edge_facing_class8(L, a, &normals_[6 * size_t(k)], ext, abs_margin, plus, minus) : m;
          if (keep) keep &= ~segment_outside8(L, a, (*vertices_)[ends_[2 * k + 1]], neps);
          pushed |= keep;
          while (keep) {
            const int lane = __builtin_ctz(unsigned(keep));
            keep &= keep - 1;
            outs[lane].push_back(order_[k] | ((plus >> lane) & 1 ? kWeightPlus2 : (minus >> lane) & 1 ? kWeightMinus2 : 0u));
          }
        }
        if (limit != SIZE_MAX) {
          for (int rest = pushed; rest; rest &= rest - 1) {
            const int lane = __builtin_ctz(unsigned(rest));
            if (outs[lane].size() > limit) live &= ~(1 << lane);
          }
          if (live == 0) return;
        }
        continue;
      }
      for (uint32_t k = nd.child + nd.n; k-- > nd.child;) stack[top++] = {k, m};
    }
  }
}
#endif

void EdgeTree::query_batch(const EdgeFrustum* fs, size_t n, const LightFrame& frame, float eps,
                           const std::vector<uint32_t>& starts, std::vector<uint32_t>* outs, uint32_t cap) const {
#if defined(VISGATE_EDGE_TREE_AVX2) && defined(__SSE2__)
  static const bool avx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
  if (avx2) {
    for (size_t k = 0; k < n; ++k) outs[k].clear();
    if (empty()) return;
    for (size_t first = 0; first < n; first += 8) walk8(fs + first, std::min<size_t>(8, n - first), frame, eps, starts, outs + first, cap);
    return;
  }
#endif
  for (size_t k = 0; k < n; ++k) query(fs[k], frame, eps, starts, outs[k], cap);
}

void EdgeTree::query(const EdgeFrustum& f, const LightFrame& frame, float eps, const std::vector<uint32_t>& starts,
                     std::vector<uint32_t>& out, uint32_t cap) const {
  out.clear();
  if (!empty()) walk(f, frame, eps, starts.data(), starts.size(), 0, &out, nullptr, cap);
}

void EdgeTree::frontier(const EdgeFrustum& f, const LightFrame& frame, float eps, uint32_t max_edges,
                        std::vector<uint32_t>& out) const {
  out.clear();
  const uint32_t root = uint32_t(nodes_.size() - 1);
  if (!empty()) walk(f, frame, eps, &root, 1, max_edges, nullptr, &out);
}

void EdgeTree::crossing_triangles(const std::vector<Edge>& edges, const LightFrame& frame,
                                  std::vector<uint32_t>& out) const {
  out.clear();
  if (empty()) return;
  const float N[3] = {float(frame.N.x), float(frame.N.y), float(frame.N.z)};
  const float h0 = float(dot(frame.N, frame.origin));
  const float margin = float(2e-6 * M_);
  uint32_t stack[64];
  size_t top = 0;
  stack[top++] = uint32_t(nodes_.size() - 1);
  while (top > 0) {
    const Node& nd = nodes_[stack[--top]];
    float hmin = -h0, hmax = -h0;
    for (int c = 0; c < 3; ++c) {
      hmin += N[c] * (N[c] >= 0.0f ? nd.tlo[c] : nd.thi[c]);
      hmax += N[c] * (N[c] >= 0.0f ? nd.thi[c] : nd.tlo[c]);
    }
    if (hmin > margin || hmax < -margin) continue;  // every triangle below on one side
    if (nd.leaf) {
      for (uint32_t k = nd.child; k < nd.child + nd.n; ++k) {
        const Edge& e = edges[order_[k]];
        out.push_back(uint32_t(e.t1));
        if (e.t2 >= 0) out.push_back(uint32_t(e.t2));
      }
      continue;
    }
    for (uint32_t k = nd.child + nd.n; k-- > nd.child;) stack[top++] = k;
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
}

void EdgeTree::large_triangle_edges(double nn, std::vector<uint32_t>& out) const {
  out.clear();
  if (empty()) return;
  uint32_t stack[64];
  size_t top = 0;
  stack[top++] = uint32_t(nodes_.size() - 1);
  while (top > 0) {
    const Node& nd = nodes_[stack[--top]];
    // Exact but for the last bits of a double: the factor 2 covers them and the float
    // rounding of the caller's bound.
    double d2 = 0.0;
    for (int c = 0; c < 3; ++c) {
      const double ext = double(nd.thi[c]) - double(nd.tlo[c]);
      d2 += ext * ext;
    }
    if (2.0 * d2 * d2 < nn) continue;
    if (nd.leaf) {
      for (uint32_t k = nd.child; k < nd.child + nd.n; ++k) out.push_back(order_[k]);
      continue;
    }
    for (uint32_t k = nd.child + nd.n; k-- > nd.child;) stack[top++] = k;
  }
}

}  // namespace visgate::ssv
