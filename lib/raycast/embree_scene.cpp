// The verified Embree scene that ISS and SSV cast their rays with (see embree_scene.h).
#include "lib/raycast/embree_scene.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "lib/base/cpu_features.h"
#include "lib/geom/error_bounds.h"
#include "lib/geom/float_mode.h"
#include "lib/geom/predicates.h"

namespace visgate::raycast {

namespace {

// The process-wide Embree device (see EmbreeScene): created once, thread-safe by the
// C++ static initialisation guarantee; never released (reachable through the static, so
// leak checkers do not count it), which avoids tearing Embree down after TBB at exit.
// VISGATE_EMBREE_CONFIG, when set, is appended to the device configuration (e.g.
// "max_isa=avx" or "isa=sse4.2"): Embree picks its BVH and intersection kernels by the
// CPU at run time, so a finding of another machine (AVX-512) may need another ISA's
// kernels to show, and this is the way to run a target on them.
RTCDevice shared_device() {
  static RTCDevice device = [] {
    std::string config = "verbose=0";
    if (const char* extra = std::getenv("VISGATE_EMBREE_CONFIG"); extra && *extra) config += std::string(",") + extra;
    RTCDevice d = rtcNewDevice(config.c_str());
    VG_CHECK(d != nullptr);
    return d;
  }();
  return device;
}

// Sign of a double as -1, 0, +1.
int sign_of(double v) { return (v > 0.0) - (v < 0.0); }

// The ranged test of fallback_occluded(soup, from, to, t0, t1) for one triangle.
bool line_range_hits_triangle(const Vec3f& fa, const Vec3f& fb, const Vec3f& fc, const Vec3f& from, const Vec3f& to,
                              double t0, double t1) {
  const Vec3d p = to_double(from), q = to_double(to);
  const Vec3d a = to_double(fa), b = to_double(fb), c = to_double(fc);
  // The line's crossing parameter t = dp / (dp - dq) (from the triangle's own normal,
  // as in segment_hits_triangle); a line in or parallel to the plane is a miss.
  const Vec3d n = cross(b - a, c - a);
  const double dp = dot(n, p - a), dq = dot(n, q - a);
  if (dp == dq) return false;
  const double tc = dp / (dp - dq);
  if (!(tc >= t0 && tc <= t1)) return false;
  const Vec3d x = tc == 1.0 ? q : p + (q - p) * tc;
  return point_in_triangle_closed(a, b, c, n, x);
}

}  // namespace

bool within_embree_bound(const Vec3f& p) {
  return std::abs(p.x) <= kEmbreeCoordinateBound && std::abs(p.y) <= kEmbreeCoordinateBound &&
         std::abs(p.z) <= kEmbreeCoordinateBound;
}

bool segment_hits_triangle(const Vec3f& fa, const Vec3f& fb, const Vec3f& fc, const Vec3f& from, const Vec3f& to) {
  const Vec3d p = to_double(from), q = to_double(to);
  const Vec3d a = to_double(fa), b = to_double(fb), c = to_double(fc);
  // Signed distances (times |n|) of the endpoints from the triangle's plane; the
  // receiver end strictly off the plane, the light end on the other side or on it
  // (t in (0, 1]). n comes from the triangle alone, so its relative error is 1e-16
  // whatever the endpoints' magnitude.
  const Vec3d n = cross(b - a, c - a);
  const double dp = dot(n, p - a), dq = dot(n, q - a);
  const int sp = sign_of(dp), sq = sign_of(dq);
  if (sp == 0 || sp == sq) return false;
  // The crossing point, computed from the endpoint nearer to the plane so that its
  // error is 1e-16 of that endpoint's distance, not of the segment's length (a far
  // receiver, 1e22 away, must not blur a unit triangle).
  Vec3d x;
  if (sq == 0) x = q;
  else if (std::abs(dq) <= std::abs(dp)) x = q + (p - q) * (dq / (dq - dp));
  else x = p + (q - p) * (dp / (dp - dq));
  return point_in_triangle_closed(a, b, c, n, x);
}

// Proof of a hit without the double-precision test (embree_scene.h).
namespace {

// The query-independent half of certainly_crosses_interior for one origin p and one
// triangle: the origin-relative corners' cross products, their triple product and the
// largest coordinate. A fan's lanes share p, and neighbouring lanes mostly hit the same
// triangle, so the verification filter keeps the terms per origin (TermsCache; perf, columns:
// the setup was two thirds of the 185 instructions of a proof). Splitting the function
// changes no rounding: every product is the expression of the single-call form.
// The cross products are kept as rows, row r holding coordinate r of B x C, C x A and
// A x B in lanes 0-2 (lane 3 is 0), so that the AVX2 build forms w_a, w_b, w_c of a
// query with three vector products; both builds evaluate every term with the same
// operations in the same order, so their results are the same bits.
struct CrossingTerms {
  double x[4] = {}, y[4] = {}, z[4] = {};  // unaligned loads and stores
  double det = 0.0, m = 0.0;
};

CrossingTerms crossing_terms(const Vec3d& p, const Vec3f& fa, const Vec3f& fb, const Vec3f& fc) {
  const Vec3d A = to_double(fa) - p, B = to_double(fb) - p, C = to_double(fc) - p;
  const Vec3d bc = cross(B, C), ca = cross(C, A), ab = cross(A, B);
  CrossingTerms t;
  t.x[0] = bc.x, t.y[0] = bc.y, t.z[0] = bc.z;
  t.x[1] = ca.x, t.y[1] = ca.y, t.z[1] = ca.z;
  t.x[2] = ab.x, t.y[2] = ab.y, t.z[2] = ab.z;
  t.det = dot(A, bc);
  t.m = max_component(vmax(vabs(A), vmax(vabs(B), vabs(C))));
  return t;
}

// The decision of certainly_crosses from the three triple products w = (w_a, w_b, w_c)
// and n, the largest |coordinate| of d (the same in both builds).
__attribute__((always_inline)) inline bool crossing_certain(const CrossingTerms& t, double wa, double wb, double wc, double n) {
  // One bound for all four products: with m the largest |coordinate| of A, B, C and
  // n that of d, each permanent is at most 6 n m^2 (det's: 6 m^3), so 8 eps of it is
  // below 48 eps n m^2.
  const double m = t.m;
  const double e = 48.0 * kUnitRoundoffD * n * m * m, edet = 48.0 * kUnitRoundoffD * m * m * m;
  const bool pos = wa > e && wb > e && wc > e, neg = wa < -e && wb < -e && wc < -e;
  if (!pos && !neg) return false;
  if (pos ? !(t.det > edet) : !(t.det < -edet)) return false;  // t > 0
  // t < 1: |det| < |w_a + w_b + w_c| (one sign), which is at least the sum of the
  // |w_i| less 3 e, less the rounding of the two additions (2 eps of the sum; 4 allowed).
  const double sum = std::abs(wa) + std::abs(wb) + std::abs(wc);
  return std::abs(t.det) + edet < sum - 3.0 * e - 4.0 * kUnitRoundoffD * sum;
}

bool certainly_crosses(const CrossingTerms& t, const Vec3d& d) {
  // w_a = dot(d, B x C), w_b = dot(d, C x A), w_c = dot(d, A x B).
  const double wa = d.x * t.x[0] + d.y * t.y[0] + d.z * t.z[0];
  const double wb = d.x * t.x[1] + d.y * t.y[1] + d.z * t.z[1];
  const double wc = d.x * t.x[2] + d.y * t.y[2] + d.z * t.z[2];
  return crossing_certain(t, wa, wb, wc, max_component(vabs(d)));
}

#if defined(__GNUC__) && defined(__x86_64__)
// The AVX2 build of crossing_terms and certainly_crosses: the same products, sums,
// differences and maxima lane by lane (AVX2 alone has no fused multiply-add, and the
// build has -ffp-contract=off), so the same bits; the three cross products and the three
// triple products take one vector operation per coordinate instead of three.
// Writes the terms into t (the filter's cache slot: no copy of the returned struct).
__attribute__((target("avx2"))) void crossing_terms_avx2(const Vec3d& p, const Vec3f& fa,
                                                                                const Vec3f& fb, const Vec3f& fc,
                                                                                CrossingTerms& t) {
  // Rows of A, B, C: lane i of xs is coordinate x of corner i less p.x (exact float to
  // double conversion, one rounded subtraction, as to_double(fa) - p); lane 3 is 0.
  // (Lane 3 is cleared by a blend: a (p, p, p, 0) constant hoisted by GCC becomes a
  // register vmovq that valgrind 3.19 cannot decode, and callgrind measures this code.)
  const __m256d zero = _mm256_setzero_pd();
  const __m256d xs = _mm256_blend_pd(
      _mm256_sub_pd(_mm256_cvtps_pd(_mm_setr_ps(fa.x, fb.x, fc.x, 0.0f)), _mm256_set1_pd(p.x)), zero, 0x8);
  const __m256d ys = _mm256_blend_pd(
      _mm256_sub_pd(_mm256_cvtps_pd(_mm_setr_ps(fa.y, fb.y, fc.y, 0.0f)), _mm256_set1_pd(p.y)), zero, 0x8);
  const __m256d zs = _mm256_blend_pd(
      _mm256_sub_pd(_mm256_cvtps_pd(_mm_setr_ps(fa.z, fb.z, fc.z, 0.0f)), _mm256_set1_pd(p.z)), zero, 0x8);
  // U = (B, C, A, 0) and V = (C, A, B, 0) per coordinate: U x V is (B x C, C x A, A x B).
  constexpr int kU = _MM_SHUFFLE(3, 0, 2, 1), kV = _MM_SHUFFLE(3, 1, 0, 2);
  const __m256d ux = _mm256_permute4x64_pd(xs, kU), uy = _mm256_permute4x64_pd(ys, kU), uz = _mm256_permute4x64_pd(zs, kU);
  const __m256d vx = _mm256_permute4x64_pd(xs, kV), vy = _mm256_permute4x64_pd(ys, kV), vz = _mm256_permute4x64_pd(zs, kV);
  const __m256d X = _mm256_sub_pd(_mm256_mul_pd(uy, vz), _mm256_mul_pd(uz, vy));
  const __m256d Y = _mm256_sub_pd(_mm256_mul_pd(uz, vx), _mm256_mul_pd(ux, vz));
  const __m256d Z = _mm256_sub_pd(_mm256_mul_pd(ux, vy), _mm256_mul_pd(uy, vx));
  _mm256_storeu_pd(t.x, X);
  _mm256_storeu_pd(t.y, Y);
  _mm256_storeu_pd(t.z, Z);
  // det = dot(A, B x C): lane 0 of (xs X + ys Y) + zs Z.
  t.det = _mm256_cvtsd_f64(
      _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(xs, X), _mm256_mul_pd(ys, Y)), _mm256_mul_pd(zs, Z)));
  // m: the largest |coordinate| of A, B, C (lane 3's 0 cannot exceed it; no NaN here).
  const __m256d magnitude = _mm256_castsi256_pd(_mm256_set1_epi64x(0x7FFFFFFFFFFFFFFF));
  __m256d mx = _mm256_max_pd(_mm256_max_pd(_mm256_and_pd(xs, magnitude), _mm256_and_pd(ys, magnitude)),
                             _mm256_and_pd(zs, magnitude));
  mx = _mm256_max_pd(mx, _mm256_permute4x64_pd(mx, _MM_SHUFFLE(1, 0, 3, 2)));
  mx = _mm256_max_pd(mx, _mm256_permute4x64_pd(mx, _MM_SHUFFLE(2, 3, 0, 1)));
  t.m = _mm256_cvtsd_f64(mx);
}

__attribute__((target("avx2"))) bool certainly_crosses_avx2(const CrossingTerms& t, const Vec3d& d) {
  // Lane i: (d.x row_x[i] + d.y row_y[i]) + d.z row_z[i], the scalar build's w.
  const __m256d w = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(d.x), _mm256_loadu_pd(t.x)),
                                                _mm256_mul_pd(_mm256_set1_pd(d.y), _mm256_loadu_pd(t.y))),
                                  _mm256_mul_pd(_mm256_set1_pd(d.z), _mm256_loadu_pd(t.z)));
  const __m128d lo = _mm256_castpd256_pd128(w), hi = _mm256_extractf128_pd(w, 1);
  return crossing_certain(t, _mm_cvtsd_f64(lo), _mm_cvtsd_f64(_mm_unpackhi_pd(lo, lo)), _mm_cvtsd_f64(hi),
                          max_component(vabs(d)));
}

__attribute__((target("avx2"))) bool certainly_crosses_interior_avx2(const Vec3d& p, const Vec3d& q, const Vec3f& fa,
                                                                    const Vec3f& fb, const Vec3f& fc) {
  CrossingTerms t;
  crossing_terms_avx2(p, fa, fb, fc, t);
  return certainly_crosses_avx2(t, q - p);
}

// VISGATE_ISS_NO_AVX2 in the environment selects the default build here too (the
// verification filter serves ISS's leaf rays).
bool filter_avx2() {
  static const bool avx2 = avx2_enabled("VISGATE_ISS_NO_AVX2");
  return avx2;
}
#endif

}  // namespace

bool certainly_crosses_interior(const Vec3d& p, const Vec3d& q, const Vec3f& fa, const Vec3f& fb, const Vec3f& fc) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (filter_avx2()) return certainly_crosses_interior_avx2(p, q, fa, fb, fc);
#endif
  return certainly_crosses_interior_default(p, q, fa, fb, fc);
}

bool certainly_crosses_interior_default(const Vec3d& p, const Vec3d& q, const Vec3f& fa, const Vec3f& fb,
                                        const Vec3f& fc) {
  return certainly_crosses(crossing_terms(p, fa, fb, fc), q - p);
}

bool fallback_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to) {
  const IeeeFloatMode ieee;
  for (const auto& t : soup.triangles)
    if (segment_hits_triangle(soup.vertices[t[0]], soup.vertices[t[1]], soup.vertices[t[2]], from, to)) return true;
  return false;
}

bool fallback_occluded(const TriangleSoup& soup, const Vec3f& from, const Vec3f& to, double t0, double t1) {
  const IeeeFloatMode ieee;
  for (const auto& t : soup.triangles)
    if (line_range_hits_triangle(soup.vertices[t[0]], soup.vertices[t[1]], soup.vertices[t[2]], from, to, t0, t1))
      return true;
  return false;
}

namespace {

struct TermsCache;

// The intersect context of a verified query: Embree passes it to the filter, which
// needs the query's float endpoints (org + dir would be rounded again) and its range.
struct VerifyContext {
  RTCIntersectContext base;  // first member: Embree sees a plain RTCIntersectContext
  Vec3f from, to;
  double t0 = 0.0, t1 = 1.0;
  bool ranged = false;       // false: the segment test, t in (0, 1]
  const Vec3f* fan_to = nullptr;  // a packet from `from`: lane k (ray id k) ends at fan_to[k]
  const TriangleSoup* soup = nullptr;
  // Primitives::paired_quads: the soup triangles of the quads (EmbreeScene::quad_first_).
  const uint32_t* quad_first = nullptr;
  unsigned csr = IeeeFloatMode::current_csr();  // the querying thread's MXCSR (the filter runs on it)
  size_t rejected = 0;
  // Bit k: the filter let a hit of ray id k stand (fan ids are below 16, a single query's
  // id is 0). A query that comes back blocked without its bit was not verified
  // (EmbreeScene::unverified_hits).
  uint32_t accepted = 0;
  // Segment queries: this thread's crossing terms, bound to the scene and `from`.
  TermsCache* cache = nullptr;
};

// Segment queries: crossing_terms of recently hit triangles seen from one origin, per
// thread, kept across the queries of that origin (ISS casts a receiver's 256 leaf rays as
// 16 fans; with one remembered triangle per fan 58% of the filter's lanes recomputed the
// terms on columns, with this cache 19%). A hit on (scene id, origin bits, prim) returns
// the terms crossing_terms computed for exactly those inputs, so answers cannot change.
// Scene ids are never reused, so a destroyed scene's entries cannot match another's
// triangles. The query checks scene and origin once (bind), the filter only the slot.
struct TermsCache {
  static constexpr unsigned kSlots = 32;  // direct-mapped on the primitive id
  uint64_t scene_id = 0;                  // 0: nothing bound yet
  Vec3f origin{0.0f, 0.0f, 0.0f};
  unsigned tag[kSlots] = {};  // prim id + 1 of the slot's terms; 0: empty
  CrossingTerms terms[kSlots];
  // Makes the entries those of scene `id` and origin `from` (emptied when either differs).
  void bind(uint64_t id, const Vec3f& from) {
    if (id != scene_id || std::memcmp(&from, &origin, sizeof(Vec3f)) != 0) {
      scene_id = id;
      origin = from;
      std::fill(tag, tag + kSlots, 0u);
    }
  }
  // Terms of triangle `prim_id` (corners a, b, c) from the bound origin p (in double),
  // by crossing_terms or its AVX2 build (the same bits).
  template <bool kAvx2>
  const CrossingTerms& get(const Vec3d& p, unsigned prim_id, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
    const unsigned slot = prim_id % kSlots;
    if (tag[slot] != prim_id + 1u) {
#if defined(__GNUC__) && defined(__x86_64__)
      if constexpr (kAvx2) crossing_terms_avx2(p, a, b, c, terms[slot]);
      else
#endif
        terms[slot] = crossing_terms(p, a, b, c);
      tag[slot] = prim_id + 1u;
    }
    return terms[slot];
  }
};

// certainly_crosses, or its AVX2 build when kAvx2.
template <bool kAvx2>
__attribute__((always_inline)) inline bool proves_crossing(const CrossingTerms& t, const Vec3d& d) {
#if defined(__GNUC__) && defined(__x86_64__)
  if constexpr (kAvx2) return certainly_crosses_avx2(t, d);
#endif
  return certainly_crosses(t, d);
}

// This thread's cache bound to (scene id, from).
TermsCache* bound_terms_cache(uint64_t id, const Vec3f& from) {
  thread_local TermsCache cache;
  cache.bind(id, from);
  return &cache;
}

// The lanes of a filter call with a candidate hit (valid[i] == -1), as bits; n <= 32.
// Four lanes per compare where SSE2 is there: the lane-by-lane loop was a fifth of the
// filter's instructions on scan (packets of 8, mostly one candidate each).
uint32_t candidate_lanes(const int* valid, unsigned n) {
  uint32_t lanes = 0;
  unsigned i = 0;
#if defined(__SSE2__)
  const __m128i hit = _mm_set1_epi32(-1);
  for (; i + 4 <= n; i += 4) {
    const __m128i v = _mm_loadu_si128(reinterpret_cast<const __m128i*>(valid + i));
    lanes |= uint32_t(_mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(v, hit)))) << i;
  }
#endif
  for (; i < n; ++i) lanes |= uint32_t(valid[i] == -1) << i;
  return lanes;
}

// What a filter's primitive ids are: the soup's triangles (Primitives::triangles) or the
// quads of Primitives::paired_quads (quad_first).
enum class PrimKind { triangle, quad };
// EmbreeScene::quad_first_'s mark of a quad holding one triangle.
constexpr uint32_t kSingleQuad = 0x80000000u;

// Occlusion filter of a verified scene: a candidate hit stands only when the double-
// precision test of the same query agrees (see embree_scene.h, "Hit verification"),
// or, for segment queries, when certainly_crosses_interior proves it first (kAvx2: its
// AVX2 build, the same answers). A quad's candidate stands when either of its two
// triangles is confirmed.
template <bool kAvx2, PrimKind kKind>
__attribute__((always_inline)) inline void verify_hit_filter_body(const RTCFilterFunctionNArguments* args) {
  // The filter runs on the querying thread, which may be a TBB worker with FTZ/DAZ on.
  auto* vc = reinterpret_cast<VerifyContext*>(args->context);
  const IeeeFloatMode ieee(vc->csr);
  const Vec3d p = to_double(vc->from);
  // Lanes with a candidate hit, as bits (packets of 8 or 16 mostly carry one or two);
  // queries are single rays or packets of at most 16.
  VG_CHECK(args->N <= 32);
  for (uint32_t lanes = candidate_lanes(args->valid, args->N); lanes; lanes &= lanes - 1) {
    const unsigned i = unsigned(__builtin_ctz(lanes));
    const unsigned prim = RTCHitN_primID(args->hit, args->N, i);
    const unsigned id = vc->fan_to ? RTCRayN_id(args->ray, args->N, i) : 0u;
    const Vec3f& to = vc->fan_to ? vc->fan_to[id] : vc->to;
    auto confirms = [&](unsigned tri) {
      const auto& t = vc->soup->triangles[tri];
      const Vec3f &a = vc->soup->vertices[t[0]], &b = vc->soup->vertices[t[1]], &c = vc->soup->vertices[t[2]];
      return (!vc->ranged && proves_crossing<kAvx2>(vc->cache->get<kAvx2>(p, tri, a, b, c), to_double(to) - p)) ||
             (vc->ranged ? line_range_hits_triangle(a, b, c, vc->from, to, vc->t0, vc->t1)
                         : segment_hits_triangle(a, b, c, vc->from, to));
    };
    bool confirmed;
    if constexpr (kKind == PrimKind::quad) {
      const uint32_t q = vc->quad_first[prim], first = q & ~kSingleQuad;
      confirmed = confirms(first) || (!(q & kSingleQuad) && confirms(first + 1u));
    } else {
      confirmed = confirms(prim);
    }
    if (confirmed) {
      vc->accepted |= 1u << (id & 31u);
    } else {
      args->valid[i] = 0;
      ++vc->rejected;
    }
  }
}

template <PrimKind kKind>
void verify_hit_filter(const RTCFilterFunctionNArguments* args) {
  verify_hit_filter_body<false, kKind>(args);
}
#if defined(__GNUC__) && defined(__x86_64__)
template <PrimKind kKind>
__attribute__((target("avx2"))) void verify_hit_filter_avx2(const RTCFilterFunctionNArguments* args) {
  verify_hit_filter_body<true, kKind>(args);
}
#endif

// The filter of this CPU (filter_avx2) for primitives of kind kKind.
template <PrimKind kKind>
RTCFilterFunctionN verify_hit_filter_for_cpu() {
#if defined(__GNUC__) && defined(__x86_64__)
  if (filter_avx2()) return verify_hit_filter_avx2<kKind>;
#endif
  return verify_hit_filter<kKind>;
}

// Primitives::paired_quads: triangles a and b pair when they share an edge in opposite
// orientations. Writes the quad (v0, v1, v2, v3) whose triangles (v0, v1, v3) and
// (v2, v3, v1) are a and b, each listed from another corner (repeated corners
// included: the two triangles are a's and b's corners whatever they are).
__attribute__((always_inline)) inline bool pair_quad(const std::array<uint32_t, 3>& a,
                                                     const std::array<uint32_t, 3>& b, uint32_t* quad) {
  const uint32_t b0 = b[0], b1 = b[1], b2 = b[2];
  // a listed as (p, q, r) pairs when b is a rotation of (s, r, q): its edge r -> q.
  auto from = [&](uint32_t p, uint32_t q, uint32_t r) {
    uint32_t s;
    if (b1 == r && b2 == q) s = b0;
    else if (b0 == r && b1 == q) s = b2;
    else if (b2 == r && b0 == q) s = b1;
    else return false;
    quad[0] = p, quad[1] = q, quad[2] = s, quad[3] = r;
    return true;
  };
  const uint32_t a0 = a[0], a1 = a[1], a2 = a[2];
  return from(a0, a1, a2) || from(a1, a2, a0) || from(a2, a0, a1);
}

}  // namespace

// Scene ids for TermsCache: distinct for every scene of the process, never 0.
std::atomic<uint64_t> next_scene_id{1};

EmbreeScene::EmbreeScene(const TriangleSoup& soup, bool robust, bool verify_hits, BuildQuality quality,
                         Primitives primitives)
    : soup_(&soup), verify_(verify_hits), id_(next_scene_id.fetch_add(1, std::memory_order_relaxed)) {
  for (const Vec3f& v : soup.vertices)
    if (!within_embree_bound(v)) {
      mesh_in_bound_ = false;  // every query goes to the fallback; no Embree scene
      return;
    }
  RTCDevice device = shared_device();
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneFlags(scene, robust ? RTC_SCENE_FLAG_ROBUST : RTC_SCENE_FLAG_NONE);
  const RTCBuildQuality q = quality == BuildQuality::low    ? RTC_BUILD_QUALITY_LOW
                            : quality == BuildQuality::high ? RTC_BUILD_QUALITY_HIGH
                                                            : RTC_BUILD_QUALITY_MEDIUM;
  rtcSetSceneBuildQuality(scene, q);
  // A geometry of `type` over the soup's vertices (Embree-allocated buffers have the
  // tail padding its SIMD loads need); the caller sets its index buffer and attaches it.
  auto geometry = [&](RTCGeometryType type, RTCFilterFunctionN filter) {
    RTCGeometry geom = rtcNewGeometry(device, type);
    auto* vb = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                           3 * sizeof(float), soup.vertices.size()));
    std::memcpy(vb, soup.vertices.data(), soup.vertices.size() * 3 * sizeof(float));
    rtcSetGeometryBuildQuality(geom, q);
    if (verify_) rtcSetGeometryOccludedFilterFunction(geom, filter);
    return geom;
  };
  auto triangle_index = [&](RTCGeometry geom, size_t count) {
    return static_cast<uint32_t*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                          3 * sizeof(uint32_t), count));
  };
  auto attach = [&](RTCGeometry geom, unsigned geom_id) {
    rtcCommitGeometry(geom);
    rtcAttachGeometryByID(scene, geom, geom_id);
    rtcReleaseGeometry(geom);
  };
  if (primitives == Primitives::paired_quads && soup.size() > 1 && soup.size() < kSingleQuad) {
    // One geometry of quads (one BVH for every ray to traverse): a triangle left unpaired
    // is the quad (a, b, c, c), Embree's encoding of a triangle as a quad, whose second
    // half (c, c, b) has no area and is never hit. The corners are written in place into
    // the index buffer Embree shares.
    const size_t n = soup.size();
    quad_index_.reset(new uint32_t[4 * n]);  // the first 4 x quads entries are written
    quad_first_.reserve(n);
    uint32_t* quad = quad_index_.get();
    for (size_t k = 0; k < n; quad += 4) {
      if (k + 1 < n && pair_quad(soup.triangles[k], soup.triangles[k + 1], quad)) {
        quad_first_.push_back(uint32_t(k));
        ++pairs_;
        k += 2;
      } else {
        const auto& t = soup.triangles[k];
        quad[0] = t[0], quad[1] = t[1], quad[2] = t[2], quad[3] = t[2];
        quad_first_.push_back(uint32_t(k) | kSingleQuad);
        ++k;
      }
    }
    if (pairs_ == 0) {
      quad_first_ = {};
      quad_index_.reset();
    }
  }
  if (pairs_ > 0) {
    RTCGeometry geom = geometry(RTC_GEOMETRY_TYPE_QUAD, verify_hit_filter_for_cpu<PrimKind::quad>());
    rtcSetSharedGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT4, quad_index_.get(), 0,
                               4 * sizeof(uint32_t), quad_first_.size());
    attach(geom, 0);
  } else if (soup.size() > 0) {
    RTCGeometry geom = geometry(RTC_GEOMETRY_TYPE_TRIANGLE, verify_hit_filter_for_cpu<PrimKind::triangle>());
    std::memcpy(triangle_index(geom, soup.size()), soup.triangles.data(), soup.triangles.size() * 3 * sizeof(uint32_t));
    attach(geom, 0);
  }
  rtcCommitScene(scene);
  // A build Embree refused (out of memory, an unsupported VISGATE_EMBREE_CONFIG) would
  // otherwise answer every ray from an empty or partial scene.
  if (const RTCError err = rtcGetDeviceError(device); err != RTC_ERROR_NONE) {
    rtcReleaseScene(scene);
    throw InternalError("Embree could not build the scene of " + std::to_string(soup.size()) +
                        " triangles (RTCError " + std::to_string(int(err)) + ")");
  }
  scene_ = scene;
}

EmbreeScene::~EmbreeScene() {
  if (scene_) rtcReleaseScene(static_cast<RTCScene>(scene_));
}

bool EmbreeScene::occluded(const Vec3f& from, const Vec3f& to) const {
  if (!mesh_in_bound_ || !within_embree_bound(from) || !within_embree_bound(to)) {
    fallback_rays_.fetch_add(1, std::memory_order_relaxed);
    return fallback_occluded(*soup_, from, to);
  }
  return occluded_embree(from, to, 0.0f, 1.0f, false);
}

bool EmbreeScene::occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar) const {
  VG_CHECK(tnear >= 0.0f && tnear <= tfar);
  if (!mesh_in_bound_ || !within_embree_bound(from) || !within_embree_bound(to)) {
    fallback_rays_.fetch_add(1, std::memory_order_relaxed);
    return fallback_occluded(*soup_, from, to, tnear, tfar);
  }
  return occluded_embree(from, to, tnear, tfar, true);
}

bool EmbreeScene::occluded(const Vec3f& from, const Vec3f& to, float tnear, float tfar, bool& disputed) const {
  VG_CHECK(tnear >= 0.0f && tnear <= tfar);
  disputed = false;
  if (!mesh_in_bound_ || !within_embree_bound(from) || !within_embree_bound(to)) {
    fallback_rays_.fetch_add(1, std::memory_order_relaxed);
    return fallback_occluded(*soup_, from, to, tnear, tfar);
  }
  size_t rejected = 0;
  const bool hit = occluded_embree(from, to, tnear, tfar, true, &rejected);
  disputed = rejected > 0;
  return hit;
}

bool EmbreeScene::occluded_embree(const Vec3f& from, const Vec3f& to, float tnear, float tfar, bool ranged,
                                  size_t* rejected) const {
  VerifyContext vc;
  rtcInitIntersectContext(&vc.base);
  vc.from = from;
  vc.to = to;
  vc.t0 = tnear;
  vc.t1 = tfar;
  vc.ranged = ranged;
  vc.soup = soup_;
  vc.quad_first = quad_first_.data();
  if (!ranged) vc.cache = bound_terms_cache(id_, from);
  RTCRay ray;
  ray.org_x = from.x;
  ray.org_y = from.y;
  ray.org_z = from.z;
  Vec3f d = to - from;
  ray.dir_x = d.x;
  ray.dir_y = d.y;
  ray.dir_z = d.z;
  ray.tnear = tnear;
  ray.tfar = tfar;
  ray.time = 0.0f;
  ray.mask = 0xFFFFFFFFu;
  ray.id = 0;
  ray.flags = 0;
  rtcOccluded1(static_cast<RTCScene>(scene_), &vc.base, &ray);
  if (vc.rejected) rejected_hits_.fetch_add(vc.rejected, std::memory_order_relaxed);
  if (rejected) *rejected = vc.rejected;
  const bool hit = ray.tfar == -std::numeric_limits<float>::infinity();
  if (hit && verify_ && !(vc.accepted & 1u)) {  // blocked, but no hit passed the filter
    unverified_hits_.fetch_add(1, std::memory_order_relaxed);
    return ranged ? fallback_occluded(*soup_, from, to, tnear, tfar) : fallback_occluded(*soup_, from, to);
  }
  return hit;
}

namespace {

// Width of the packets occluded_fan traces: 16 where Embree has a native 16-wide kernel
// (AVX-512), else 8. On AVX2 machines Embree answers rtcOccluded16 through its ray-
// stream path, which repacks the rays into 8-wide packets (measured on columns, ISS's
// leaf rays, 9 runs beside a compile: median 0.155 s with rtcOccluded16, 0.133 s with
// two rtcOccluded8; the minimum the same).
int native_packet_width() {
  static const int width = rtcGetDeviceProperty(shared_device(), RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) ? 16 : 8;
  return width;
}

// One packet of W rays from a common origin; the constant fields (tnear, time, mask,
// id, flags) are set once per thread, each trace writes origin, directions, tfar and
// the lane mask. Lane k of packet `base` is fan lane base + k (its ray id, which the
// verification filter maps to its end point).
template <int W, class Ray>
struct alignas(64) FanPacket {
  Ray ray;
  alignas(64) int valid[W];
  FanPacket() {
    for (int k = 0; k < W; ++k) {
      ray.tnear[k] = 0.0f;
      ray.time[k] = 0.0f;
      ray.mask[k] = 0xFFFFFFFFu;
      ray.flags[k] = 0;
      ray.dir_x[k] = ray.dir_y[k] = 0.0f;
      ray.dir_z[k] = 1.0f;  // inactive lanes keep a valid direction
    }
  }
  // Sets lanes [0, n) to the segments from `from` to to[0..n); lanes whose end point is
  // outside Embree's domain stay inactive (valid[k] == 0), as do lanes n..W-1. Returns
  // the active lanes as bits.
  uint32_t set(const Vec3f& from, const Vec3f* to, int n, unsigned base) {
    for (int k = 0; k < W; ++k) {
      ray.org_x[k] = from.x;
      ray.org_y[k] = from.y;
      ray.org_z[k] = from.z;
      ray.tfar[k] = 1.0f;
      ray.id[k] = base + unsigned(k);
      valid[k] = 0;
    }
    uint32_t active = 0;
    int k0 = 0;
#if defined(__SSE2__)
    // Four lanes at a time while they are whole (a fan's end points are AoS Vec3f, 12
    // bytes: three unaligned loads, transposed); the bound test and the float subtraction
    // are those of the lane loop below, so the rays are the same bits. A group with a
    // point outside the bound is left to the lane loop.
    const __m128 fx = _mm_set1_ps(from.x), fy = _mm_set1_ps(from.y), fz = _mm_set1_ps(from.z);
    const __m128 bound = _mm_set1_ps(kEmbreeCoordinateBound);
    const __m128 magnitude = _mm_castsi128_ps(_mm_set1_epi32(0x7FFFFFFF));
    for (; k0 + 4 <= n; k0 += 4) {
      const float* q = &to[k0].x;
      static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");
      const __m128 v0 = _mm_loadu_ps(q), v1 = _mm_loadu_ps(q + 4), v2 = _mm_loadu_ps(q + 8);
      const __m128 x = _mm_shuffle_ps(v0, _mm_shuffle_ps(v1, v2, _MM_SHUFFLE(1, 1, 2, 2)), _MM_SHUFFLE(2, 0, 3, 0));
      const __m128 y = _mm_shuffle_ps(_mm_shuffle_ps(v0, v1, _MM_SHUFFLE(0, 0, 1, 1)),
                                      _mm_shuffle_ps(v1, v2, _MM_SHUFFLE(2, 2, 3, 3)), _MM_SHUFFLE(2, 0, 2, 0));
      const __m128 z = _mm_shuffle_ps(_mm_shuffle_ps(v0, v1, _MM_SHUFFLE(1, 1, 2, 2)), v2, _MM_SHUFFLE(3, 0, 2, 0));
      // |c| <= bound, false for NaN (within_embree_bound's test).
      const __m128 in = _mm_and_ps(_mm_and_ps(_mm_cmple_ps(_mm_and_ps(x, magnitude), bound),
                                              _mm_cmple_ps(_mm_and_ps(y, magnitude), bound)),
                                   _mm_cmple_ps(_mm_and_ps(z, magnitude), bound));
      if (_mm_movemask_ps(in) != 0xF) break;
      _mm_storeu_ps(ray.dir_x + k0, _mm_sub_ps(x, fx));
      _mm_storeu_ps(ray.dir_y + k0, _mm_sub_ps(y, fy));
      _mm_storeu_ps(ray.dir_z + k0, _mm_sub_ps(z, fz));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(valid + k0), _mm_set1_epi32(-1));
      active |= 0xFu << k0;
    }
#endif
    for (int k = k0; k < n; ++k) {
      if (!within_embree_bound(to[k])) continue;
      valid[k] = -1;
      active |= 1u << k;
      const Vec3f d = to[k] - from;
      ray.dir_x[k] = d.x;
      ray.dir_y[k] = d.y;
      ray.dir_z[k] = d.z;
    }
    return active;
  }
  // Lanes [0, n) that came back blocked (tfar set to -inf; inactive lanes keep 1), as bits.
  uint32_t blocked(int n) const {
    constexpr float kHit = -std::numeric_limits<float>::infinity();
    uint32_t bits = 0;
#if defined(__SSE2__)
    static_assert(W % 4 == 0, "packets of whole SSE vectors");
    const __m128 hit = _mm_set1_ps(kHit);
    for (int k = 0; k < W; k += 4)
      bits |= uint32_t(_mm_movemask_ps(_mm_cmpeq_ps(_mm_loadu_ps(ray.tfar + k), hit))) << k;
    return n >= 32 ? bits : bits & ((1u << n) - 1u);
#else
    for (int k = 0; k < n; ++k) bits |= uint32_t(ray.tfar[k] == kHit) << k;
    return bits;
#endif
  }
};

}  // namespace

void EmbreeScene::finish_lanes(const Vec3f& from, const Vec3f* to, int n, uint32_t active, uint32_t blocked,
                               uint32_t accepted, bool* out) const {
  // Eight lanes' bits to eight bools at a time (a bool is one byte, 0 or 1).
  static constexpr auto kSpread = [] {
    std::array<uint64_t, 256> t{};
    for (unsigned b = 0; b < 256; ++b)
      for (unsigned k = 0; k < 8; ++k) t[b] |= uint64_t((b >> k) & 1u) << (8 * k);
    return t;
  }();
  static_assert(sizeof(bool) == 1, "bools of one byte");
  int lane = 0;
  for (; lane + 8 <= n; lane += 8) std::memcpy(out + lane, &kSpread[(blocked >> lane) & 0xFFu], 8);
  for (; lane < n; ++lane) out[lane] = (blocked >> lane) & 1u;
  // Lanes outside Embree's domain: the fallback, one by one (rare).
  for (uint32_t rest = ((1u << n) - 1u) & ~active; rest; rest &= rest - 1) {
    const int k = __builtin_ctz(rest);
    out[k] = occluded(from, to[k]);
  }
  if (!verify_) return;
  for (uint32_t rest = blocked & ~accepted; rest; rest &= rest - 1) {
    const int k = __builtin_ctz(rest);
    unverified_hits_.fetch_add(1, std::memory_order_relaxed);
    out[k] = fallback_occluded(*soup_, from, to[k]);
  }
}

void EmbreeScene::occluded_fan(const Vec3f& from, const Vec3f* to, int n, bool* out) const {
  if (n <= 0) return;
  if (n > 16) {
    occluded_fan(from, to, 16, out);
    occluded_fan(from, to + 16, n - 16, out + 16);
    return;
  }
  if (!mesh_in_bound_ || !within_embree_bound(from)) {
    for (int k = 0; k < n; ++k) out[k] = occluded(from, to[k]);
    return;
  }
  // The verification filter reads a VerifyContext (lane k's end point is to[ray id]).
  VerifyContext vc;
  rtcInitIntersectContext(&vc.base);
  vc.from = from;
  vc.fan_to = to;
  vc.soup = soup_;
  vc.quad_first = quad_first_.data();
  vc.cache = bound_terms_cache(id_, from);
  if (native_packet_width() == 16) {
    thread_local FanPacket<16, RTCRay16> pk;
    const uint32_t active = pk.set(from, to, n, 0);
    rtcOccluded16(pk.valid, static_cast<RTCScene>(scene_), &vc.base, &pk.ray);
    finish_lanes(from, to, n, active, pk.blocked(n) & active, vc.accepted, out);
  } else {
    thread_local FanPacket<8, RTCRay8> pk;
    for (int b = 0; b < n; b += 8) {
      const int m = std::min(8, n - b);
      const uint32_t active = pk.set(from, to + b, m, unsigned(b));
      rtcOccluded8(pk.valid, static_cast<RTCScene>(scene_), &vc.base, &pk.ray);
      finish_lanes(from, to + b, m, active, pk.blocked(m) & active, vc.accepted >> b, out + b);
    }
  }
  if (vc.rejected) rejected_hits_.fetch_add(vc.rejected, std::memory_order_relaxed);
}

}  // namespace visgate::raycast
