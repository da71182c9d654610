// Projection and depth-complexity integration (see integrate.h for the derivation).
#include "lib/ssv/integrate.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <numeric>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "lib/base/check.h"
#include "lib/base/cpu_features.h"

namespace visgate::ssv {

namespace {

// Slack positions at the end of the one-by-one arrays (picked points, counts, flags):
// the AVX2 test reads and writes its last step of eight whole, masked (count_run_avx2).
constexpr size_t kRunPad = 8;

// Pieces whose v-range reaches at most this many positions test them one by one.
constexpr int kOneByOne = 512;

// Index of the first element of a[0, n) (ascending) that is not less than x, like
// std::lower_bound, written so that the compiler emits conditional moves: the searches
// of add_piece and add_step on sample coordinates are data-dependent and would
// otherwise mispredict about half their branches (callgrind, columns: 1.5M of the 3.4M
// mispredicted branches of a solve were in add_piece).
template <class T, class X>
int branchless_lower_bound(const T* a, int n, X x) {
  if (n <= 0) return 0;
  const T* base = a;
  int len = n;
  while (len > 1) {
    const int half = len / 2;
    base += half & -int(base[half - 1] < x);  // arithmetic select: no branch
    len -= half;
  }
  return int(base - a) + (*base < x ? 1 : 0);
}

// n buckets over [a min, a max] of the ascending `a` (about one value each when evenly
// spread): first[b] is the first position whose value is not below the start of bucket
// b, a.front() + b / scale. Returns the scale (0: all values equal).
double bucket_index(const std::vector<float>& a, std::vector<int>& first) {
  const int n = int(a.size());
  const double span = n > 0 ? double(a.back()) - a.front() : 0.0;
  const int buckets = std::max(1, n);
  const double scale = span > 0.0 ? double(buckets) / span : 0.0;
  first.assign(size_t(buckets) + 1, n);
  if (scale > 0.0)
    for (int b = 0, k = 0; b <= buckets; ++b) {
      const double start = double(a.front()) + double(b) / scale;
      while (k < n && double(a[size_t(k)]) < start) ++k;
      first[size_t(b)] = k;
    }
  return scale;
}

// Strips of samples with boxes [u_lo, u_hi] x [v_lo, v_hi] (see integrate.h).
SampleStrips strips_from_boxes(const std::vector<std::array<float, 4>>& box) {
  SampleStrips o;
  const int n = int(box.size());
  o.n = n;
  o.u_hi.resize(size_t(n));
  o.v_lo.resize(size_t(n));
  for (int j = 0; j < n; ++j) {
    const auto& b = box[size_t(j)];
    o.u_hi[size_t(j)] = b[1];
    o.v_lo[size_t(j)] = b[2];
    o.max_width = std::max(o.max_width, double(b[1]) - double(b[0]));
  }
  o.vorder.resize(size_t(n));
  std::iota(o.vorder.begin(), o.vorder.end(), 0);
  std::sort(o.vorder.begin(), o.vorder.end(), [&](int a, int b) {
    return o.v_lo[size_t(a)] < o.v_lo[size_t(b)] || (o.v_lo[size_t(a)] == o.v_lo[size_t(b)] && a < b);
  });
  o.vrank.resize(size_t(n));
  o.vlo_sorted.resize(size_t(n));
  o.vhi_prefix.resize(size_t(n));
  float vhi = -std::numeric_limits<float>::infinity();
  for (int k = 0; k < n; ++k) {
    o.vrank[size_t(o.vorder[size_t(k)])] = k;
    o.vlo_sorted[size_t(k)] = o.v_lo[size_t(o.vorder[size_t(k)])];
    vhi = std::max(vhi, box[size_t(o.vorder[size_t(k)])][3]);
    o.vhi_prefix[size_t(k)] = vhi;
  }
  // ceil(sqrt(N)) strips of equal count.
  const int strips = std::max(1, std::min(n, int(std::ceil(std::sqrt(double(n))))));
  for (int t = 0; t <= strips; ++t) o.strip_start.push_back(int(int64_t(n) * t / strips));
  o.sorder = o.vorder;
  for (size_t t = 0; t + 1 < o.strip_start.size(); ++t) {
    const int start = o.strip_start[t], end = o.strip_start[t + 1];
    float vmin = std::numeric_limits<float>::infinity(), vmax = -std::numeric_limits<float>::infinity();
    for (int k = start; k < end; ++k) {
      const auto& b = box[size_t(o.vorder[size_t(k)])];
      vmin = std::min(vmin, b[2]);
      vmax = std::max(vmax, b[3]);
    }
    o.strip_vmin.push_back(vmin);
    o.strip_vmax.push_back(vmax);
    std::sort(o.sorder.begin() + start, o.sorder.begin() + end, [&](int a, int b) {
      return o.u_hi[size_t(a)] < o.u_hi[size_t(b)] || (o.u_hi[size_t(a)] == o.u_hi[size_t(b)] && a < b);
    });
  }
  o.srank.resize(size_t(n));
  o.uhi_sorted.resize(size_t(n));
  for (int k = 0; k < n; ++k) {
    o.srank[size_t(o.sorder[size_t(k)])] = k;
    o.uhi_sorted[size_t(k)] = o.u_hi[size_t(o.sorder[size_t(k)])];
  }
  o.bucket_scale = bucket_index(o.vlo_sorted, o.bucket_first);
  o.vhi_bucket_scale = bucket_index(o.vhi_prefix, o.vhi_bucket_first);
  return o;
}

#if defined(__GNUC__) && defined(__x86_64__)
#define VG_SSV_AVX2 1
#endif

bool use_avx2() {
#if defined(VG_SSV_AVX2)
  static const bool avx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
  return avx2;
#else
  return false;
#endif
}

#if defined(VG_SSV_AVX2)
// DepthCounter::reset's copies with AVX2 gathers: uv[j] = jit[pick[j]] four at a time
// (one 64-bit gather), and the picked points in the order `vorder` as separate u and v
// arrays eight at a time. Requires 2 pick[j] + 1 < 2^31. Returns the positions done
// (a multiple of eight, at most n); the caller copies the rest.
__attribute__((target("avx2"))) size_t gather_picks_avx2(const Vec2f* jit, const uint32_t* pick, const int* vorder,
                                                          size_t n, Vec2f* uv, float* vu, float* vv) {
  static_assert(sizeof(Vec2f) == 2 * sizeof(float));
  const float* base = &jit[0].u;
  const auto* base64 = reinterpret_cast<const long long*>(jit);
  size_t k = 0;
  for (; k + 8 <= n; k += 8) {
    const __m128i p0 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pick + k));
    const __m128i p1 = _mm_loadu_si128(reinterpret_cast<const __m128i*>(pick + k + 4));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(uv + k), _mm256_i32gather_epi64(base64, p0, 8));
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(uv + k + 4), _mm256_i32gather_epi64(base64, p1, 8));
    const __m256i j = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(vorder + k));
    const __m256i p = _mm256_i32gather_epi32(reinterpret_cast<const int*>(pick), j, 4);
    const __m256i f = _mm256_add_epi32(p, p);  // float index of jit[p].u
    _mm256_storeu_ps(vu + k, _mm256_i32gather_ps(base, f, 4));
    _mm256_storeu_ps(vv + k, _mm256_i32gather_ps(base + 1, f, 4));
  }
  return k;
}
#endif

}  // namespace

SampleStrips make_sample_strips(const std::vector<Vec2f>& jitter_uv, int samples, int jitter) {
  VG_CHECK(jitter_uv.size() == size_t(samples) * size_t(jitter));
  std::vector<std::array<float, 4>> box(static_cast<size_t>(samples));
  for (int j = 0; j < samples; ++j) {
    auto& b = box[size_t(j)];
    b = {std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
         std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
    for (int k = 0; k < jitter; ++k) {
      const Vec2f& p = jitter_uv[size_t(j) * size_t(jitter) + size_t(k)];
      b[0] = std::min(b[0], p.u);
      b[1] = std::max(b[1], p.u);
      b[2] = std::min(b[2], p.v);
      b[3] = std::max(b[3], p.v);
    }
  }
  return strips_from_boxes(box);
}

void DepthCounter::reset(const std::vector<Vec2f>& uv, double extent) {
  std::vector<std::array<float, 4>> box(uv.size());
  for (size_t j = 0; j < uv.size(); ++j) box[j] = {uv[j].u, uv[j].u, uv[j].v, uv[j].v};
  own_ = strips_from_boxes(box);
  strips_ = &own_;
  uv_ = uv;
  extent_ = extent;
  clear_counters();
}

void DepthCounter::reset(const SampleStrips& strips, const std::vector<Vec2f>& jitter_uv, const std::vector<uint32_t>& pick,
                         double extent) {
  VG_CHECK(pick.size() == size_t(strips.n));
  strips_ = &strips;
  // The picked points in sample order and in v_lo order (what clear_counters would
  // gather from uv_).
  const size_t n = pick.size();
  uv_.resize(n);
  vu_.resize(n + kRunPad);
  vv_.resize(n + kRunPad);
  size_t k = 0;
#if defined(VG_SSV_AVX2)
  // Eight picked points per step with AVX2 gathers (copies only: the same floats).
  // The float index 2 pick of a jitter point must fit an int32.
  if (use_avx2() && jitter_uv.size() < (size_t(1) << 30))
    k = gather_picks_avx2(jitter_uv.data(), pick.data(), strips.vorder.data(), n, uv_.data(), vu_.data(), vv_.data());
#endif
  for (size_t j = k; j < n; ++j) uv_[j] = jitter_uv[pick[j]];
  for (; k < n; ++k) {
    const Vec2f a = jitter_uv[pick[size_t(strips.vorder[k])]];
    vu_[k] = a.u;
    vv_[k] = a.v;
  }
  ord_ = strips.vorder.data();
  sorted_ = false;
  extent_ = extent;
  zero_counters();
}

bool DepthCounter::use_sorted_order() {
  VG_CHECK(step_list_.empty() && !strip_order_);
  const size_t n = uv_.size();
  if (sorted_ || n > size_t(kOneByOne) || strips_ == &own_) return sorted_;
  {
    // Few samples: no piece ever uses the strips (add_piece tests at most kOneByOne
    // positions one by one), so order the picked points by their own v instead of their
    // boxes' v_lo. A piece's v-range is then exactly a range of positions, without the
    // slack of boxes reaching above their v_lo neighbours (vhi_prefix). Insertion sort from the v_lo order: each point lies in its
    // box, so only samples with overlapping boxes are out of order.
    order_.assign(strips_->vorder.begin(), strips_->vorder.end());
    for (size_t k = 1; k < n; ++k) {
      const float u = vu_[k], v = vv_[k];
      const int j = order_[k];
      size_t q = k;
      for (; q > 0 && vv_[q - 1] > v; --q) {
        vu_[q] = vu_[q - 1];
        vv_[q] = vv_[q - 1];
        order_[q] = order_[q - 1];
      }
      vu_[q] = u;
      vv_[q] = v;
      order_[q] = j;
    }
    ord_ = order_.data();
    sorted_ = true;
    // n buckets over [v_0, v_n-1] of the sorted points for sorted_lower_bound (any
    // bucket starts do: its start is checked).
    const double span = n > 0 ? double(vv_[n - 1]) - double(vv_[0]) : 0.0;
    vb_scale_ = span > 0.0 ? double(n) / span : 0.0;
    const double width = span / double(std::max<size_t>(n, 1));
    vb_first_.resize(n + 1);
    for (size_t b = 0, k = 0; b <= n; ++b) {
      const double start = double(vv_[0]) + double(b) * width;
      while (k < n && double(vv_[k]) < start) ++k;
      vb_first_[b] = int(k);
    }
  }
  return true;
}

void DepthCounter::clear_counters() {
  // The picked points in the two orders, as separate u and v arrays: the one-by-one
  // loops below then read consecutive memory and the compiler vectorises them.
  const SampleStrips& S = *strips_;
  const size_t n = uv_.size();
  ord_ = S.vorder.data();
  sorted_ = false;
  vu_.resize(n + kRunPad);
  vv_.resize(n + kRunPad);
  for (size_t k = 0; k < n; ++k) {
    const Vec2f& a = uv_[size_t(S.vorder[k])];
    vu_[k] = a.u;
    vv_[k] = a.v;
  }
  zero_counters();
}

void DepthCounter::zero_counters() {
  const size_t n = uv_.size();
  dv_.assign(n + kRunPad, 0);
  fv_.assign(n + kRunPad, 0);
  if (diffv_.size() != n + 1) {
    diffv_.assign(n + 1, 0);
  } else {
    for (const auto& st : step_list_) diffv_[size_t(st.first)] = 0;  // zero elsewhere
  }
  step_list_.clear();
  strip_order_ = false;
  steps_ = false;
}

void DepthCounter::use_strip_order() {
  // The strip-order arrays, filled on the first piece that uses the strips (pieces over
  // a few hundred samples): a receiver whose pieces all go one by one never pays for them.
  if (strip_order_) return;
  const SampleStrips& S = *strips_;
  const size_t n = uv_.size();
  su_.resize(n + kRunPad);
  sv_.resize(n + kRunPad);
  for (size_t k = 0; k < n; ++k) {
    const Vec2f& b = uv_[size_t(S.sorder[k])];
    su_[k] = b.u;
    sv_[k] = b.v;
  }
  ds_.assign(n + kRunPad, 0);
  fs_.assign(n + kRunPad, 0);
  strip_order_ = true;
}

namespace {

// One piece's one-by-one test (DepthCounter::add_piece): the line from (lou, lov) with
// direction (du, dv), its v-range [lov, hiv), the weight c of a sample strictly left and
// the |cross| below which a sample is unclear.
struct PieceTest {
  float lou, lov, hiv, du, dv, near;
  int32_t c;
};

// The test, cross2(hi - lo, s - lo) > 0 (strictly left of the line), over positions
// [k0, k1) of one order; with the v-range test where the position's box may lie partly
// outside it. Four positions at a time with SSE2: the same float operations in the same
// order as the scalar tail (no contraction: -ffp-contract=off), so identical results.
void count_run_sse2(const PieceTest& t, const float* u, const float* v, int32_t* out, int32_t* flag, int k0, int k1,
                    bool v_range) {
  int k = k0;
#if defined(__SSE2__)
  const __m128 lou = _mm_set1_ps(t.lou), lov = _mm_set1_ps(t.lov), hiv = _mm_set1_ps(t.hiv);
  const __m128 vdu = _mm_set1_ps(t.du), vdv = _mm_set1_ps(t.dv), zero = _mm_setzero_ps();
  const __m128 near = _mm_set1_ps(t.near), sign = _mm_set1_ps(-0.0f);
  const __m128i vc = _mm_set1_epi32(t.c);
  const __m128 all = _mm_castsi128_ps(_mm_set1_epi32(-1));
  for (; k + 4 <= k1; k += 4) {
    const __m128 uu = _mm_loadu_ps(u + k), vv = _mm_loadu_ps(v + k);
    const __m128 cr = _mm_sub_ps(_mm_mul_ps(vdu, _mm_sub_ps(vv, lov)), _mm_mul_ps(vdv, _mm_sub_ps(uu, lou)));
    const __m128 in = v_range ? _mm_and_ps(_mm_cmpge_ps(vv, lov), _mm_cmplt_ps(vv, hiv)) : all;
    const __m128 m = _mm_and_ps(_mm_cmpgt_ps(cr, zero), in);
    const __m128 f = _mm_and_ps(_mm_cmple_ps(_mm_andnot_ps(sign, cr), near), in);
    __m128i* o = reinterpret_cast<__m128i*>(out + k);
    _mm_storeu_si128(o, _mm_add_epi32(_mm_loadu_si128(o), _mm_and_si128(_mm_castps_si128(m), vc)));
    __m128i* g = reinterpret_cast<__m128i*>(flag + k);
    _mm_storeu_si128(g, _mm_or_si128(_mm_loadu_si128(g), _mm_castps_si128(f)));
  }
#endif
  for (; k < k1; ++k) {
    const bool in = !v_range || ((v[k] >= t.lov) & (v[k] < t.hiv));
    const float cr = t.du * (v[k] - t.lov) - t.dv * (u[k] - t.lou);
    out[k] += (in & (cr > 0.0f)) ? t.c : 0;
    flag[k] |= (in & (std::abs(cr) <= t.near)) ? -1 : 0;
  }
}

#if defined(VG_SSV_AVX2)
// The same test eight positions at a time (AVX2, chosen at run time): the same float
// operations in the same order, and AVX2 alone has no fused multiply-add, so the
// results are those of count_run_sse2.
__attribute__((target("avx2"))) void count_run_avx2(const PieceTest& t, const float* u, const float* v,
                                                     int32_t* out, int32_t* flag, int k0, int k1, bool v_range) {
  int k = k0;
  const __m256 lou = _mm256_set1_ps(t.lou), lov = _mm256_set1_ps(t.lov), hiv = _mm256_set1_ps(t.hiv);
  const __m256 vdu = _mm256_set1_ps(t.du), vdv = _mm256_set1_ps(t.dv), zero = _mm256_setzero_ps();
  const __m256 near = _mm256_set1_ps(t.near), sign = _mm256_set1_ps(-0.0f);
  const __m256i vc = _mm256_set1_epi32(t.c);
  const __m256 all = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
  for (; k + 8 <= k1; k += 8) {
    const __m256 uu = _mm256_loadu_ps(u + k), vv = _mm256_loadu_ps(v + k);
    const __m256 cr =
        _mm256_sub_ps(_mm256_mul_ps(vdu, _mm256_sub_ps(vv, lov)), _mm256_mul_ps(vdv, _mm256_sub_ps(uu, lou)));
    const __m256 in =
        v_range ? _mm256_and_ps(_mm256_cmp_ps(vv, lov, _CMP_GE_OQ), _mm256_cmp_ps(vv, hiv, _CMP_LT_OQ)) : all;
    const __m256 m = _mm256_and_ps(_mm256_cmp_ps(cr, zero, _CMP_GT_OQ), in);
    const __m256 f = _mm256_and_ps(_mm256_cmp_ps(_mm256_andnot_ps(sign, cr), near, _CMP_LE_OQ), in);
    __m256i* o = reinterpret_cast<__m256i*>(out + k);
    _mm256_storeu_si256(o, _mm256_add_epi32(_mm256_loadu_si256(o), _mm256_and_si256(_mm256_castps_si256(m), vc)));
    __m256i* g = reinterpret_cast<__m256i*>(flag + k);
    _mm256_storeu_si256(g, _mm256_or_si256(_mm256_loadu_si256(g), _mm256_castps_si256(f)));
  }
  if (k < k1) {
    // The tail: one more step with the lanes at or beyond k1 masked out (they add 0 and
    // keep their values; the arrays have kRunPad positions of slack). The same test.
    const __m256i live = _mm256_cmpgt_epi32(_mm256_set1_epi32(k1 - k), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256 uu = _mm256_loadu_ps(u + k), vv = _mm256_loadu_ps(v + k);
    const __m256 cr =
        _mm256_sub_ps(_mm256_mul_ps(vdu, _mm256_sub_ps(vv, lov)), _mm256_mul_ps(vdv, _mm256_sub_ps(uu, lou)));
    const __m256 in = _mm256_and_ps(
        _mm256_castsi256_ps(live),
        v_range ? _mm256_and_ps(_mm256_cmp_ps(vv, lov, _CMP_GE_OQ), _mm256_cmp_ps(vv, hiv, _CMP_LT_OQ)) : all);
    const __m256 m = _mm256_and_ps(_mm256_cmp_ps(cr, zero, _CMP_GT_OQ), in);
    const __m256 f = _mm256_and_ps(_mm256_cmp_ps(_mm256_andnot_ps(sign, cr), near, _CMP_LE_OQ), in);
    __m256i* o = reinterpret_cast<__m256i*>(out + k);
    _mm256_storeu_si256(o, _mm256_add_epi32(_mm256_loadu_si256(o), _mm256_and_si256(_mm256_castps_si256(m), vc)));
    __m256i* g = reinterpret_cast<__m256i*>(flag + k);
    _mm256_storeu_si256(g, _mm256_or_si256(_mm256_loadu_si256(g), _mm256_castps_si256(f)));
  }
}
#endif

#if defined(VG_SSV_AVX2)
// a * b mod 2^64 per 64-bit lane from 32-bit products: lo(a) lo(b) + (hi(a) lo(b) +
// lo(a) hi(b)) 2^32.
__attribute__((target("avx2"))) inline __m256i mul64(__m256i a, __m256i b) {
  const __m256i ll = _mm256_mul_epu32(a, b);
  const __m256i hl = _mm256_mul_epu32(_mm256_srli_epi64(a, 32), b);
  const __m256i lh = _mm256_mul_epu32(a, _mm256_srli_epi64(b, 32));
  return _mm256_add_epi64(ll, _mm256_slli_epi64(_mm256_add_epi64(hl, lh), 32));
}

// jitter_picks for K a power of two, four samples per step: splitmix64 (lib/scene/rng.h)
// of prefix ^ j * 0xD1B54A32D192ED03 (relation_hash_step) lane by lane.
__attribute__((target("avx2"))) int jitter_picks_avx2(uint64_t prefix, int samples, uint32_t K, uint32_t* out) {
  const __m256i pre = _mm256_set1_epi64x(int64_t(prefix));
  const __m256i step = _mm256_set1_epi64x(int64_t(0xD1B54A32D192ED03ull * 4ull));
  const __m256i golden = _mm256_set1_epi64x(int64_t(0x9E3779B97F4A7C15ull));
  const __m256i c1 = _mm256_set1_epi64x(int64_t(0xBF58476D1CE4E5B9ull));
  const __m256i c2 = _mm256_set1_epi64x(int64_t(0x94D049BB133111EBull));
  const __m256i mask = _mm256_set1_epi64x(int64_t(K - 1));
  const __m256i kstep = _mm256_set1_epi64x(int64_t(4ull * K));
  __m256i jc = _mm256_set_epi64x(int64_t(0xD1B54A32D192ED03ull * 3ull), int64_t(0xD1B54A32D192ED03ull * 2ull),
                                 int64_t(0xD1B54A32D192ED03ull), 0);
  __m256i base = _mm256_set_epi64x(int64_t(3ull * K), int64_t(2ull * K), int64_t(K), 0);
  // The low 32 bits of lanes 0, 2, 4, 6 (the four 64-bit results) into the low half.
  const __m256i low32 = _mm256_set_epi32(0, 0, 0, 0, 6, 4, 2, 0);
  int j = 0;
  for (; j + 4 <= samples; j += 4) {
    __m256i x = _mm256_add_epi64(_mm256_xor_si256(pre, jc), golden);
    x = mul64(_mm256_xor_si256(x, _mm256_srli_epi64(x, 30)), c1);
    x = mul64(_mm256_xor_si256(x, _mm256_srli_epi64(x, 27)), c2);
    x = _mm256_xor_si256(x, _mm256_srli_epi64(x, 31));
    const __m256i p = _mm256_add_epi64(base, _mm256_and_si256(x, mask));
    _mm_storeu_si128(reinterpret_cast<__m128i*>(out + j),
                     _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(p, low32)));
    jc = _mm256_add_epi64(jc, step);
    base = _mm256_add_epi64(base, kstep);
  }
  return j;
}
#endif

#if defined(VG_SSV_AVX2)
// DepthCounter::finish_classes without the strip order, eight positions per step: each
// lane keeps the lowest value it saw and the lowest value above that (the order of the
// values does not matter for either), then into sample order (a gather through `vrank`,
// the inverse of `vorder`, when given). Integer operations only: the same values, the
// same two lowest classes and the same unclear count as the SSE2 and scalar form.
// Rule 2's steps (at most kMaxLaneSteps) are added here per block, instead of by the
// prefix sum of DepthCounter::fold_steps: +w at every position >= the step's.
constexpr size_t kMaxLaneSteps = 4;
__attribute__((target("avx2"))) DepthCounter::Classes classes_avx2(int32_t* x, const int32_t* f, size_t n,
                                                                   int32_t unclear_value, const int* vorder,
                                                                   const int* vrank, int32_t* out,
                                                                   const std::pair<int32_t, int32_t>* steps,
                                                                   size_t n_steps) {
  const __m256i vu = _mm256_set1_epi32(unclear_value);
  __m256i m1 = vu, m2 = vu, cnt = _mm256_setzero_si256();
  __m256i sk[kMaxLaneSteps], sw[kMaxLaneSteps];
  for (size_t s = 0; s < n_steps; ++s) {
    sk[s] = _mm256_set1_epi32(steps[s].first - 1);  // position > first - 1
    sw[s] = _mm256_set1_epi32(steps[s].second);
  }
  __m256i pos = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
  const __m256i eight = _mm256_set1_epi32(8);
  size_t k = 0;
  for (; k + 8 <= n; k += 8) {
    const __m256i fk = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(f + k));
    __m256i dk = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(x + k));
    for (size_t s = 0; s < n_steps; ++s)
      dk = _mm256_add_epi32(dk, _mm256_and_si256(_mm256_cmpgt_epi32(pos, sk[s]), sw[s]));
    pos = _mm256_add_epi32(pos, eight);
    const __m256i xk = _mm256_blendv_epi8(dk, vu, fk);  // flags are 0 or -1
    _mm256_storeu_si256(reinterpret_cast<__m256i*>(x + k), xk);
    // m2: m1 when xk < m1, min(m2, xk) when xk > m1, else unchanged.
    const __m256i below = _mm256_cmpgt_epi32(m1, xk), above = _mm256_cmpgt_epi32(xk, m1);
    m2 = _mm256_blendv_epi8(m2, _mm256_min_epi32(m2, xk), above);
    m2 = _mm256_blendv_epi8(m2, m1, below);
    m1 = _mm256_min_epi32(m1, xk);
    cnt = _mm256_sub_epi32(cnt, fk);
  }
  alignas(32) int32_t l1[8], l2[8], counts[8];
  _mm256_store_si256(reinterpret_cast<__m256i*>(l1), m1);
  _mm256_store_si256(reinterpret_cast<__m256i*>(l2), m2);
  _mm256_store_si256(reinterpret_cast<__m256i*>(counts), cnt);
  DepthCounter::Classes c{unclear_value, unclear_value, 0};
  int64_t unclear = 0;
  for (int l = 0; l < 8; ++l) unclear += counts[l];
  for (; k < n; ++k) {
    for (size_t s = 0; s < n_steps; ++s) x[k] += int(k) >= steps[s].first ? steps[s].second : 0;
    x[k] = f[k] != 0 ? unclear_value : x[k];
    unclear -= f[k];
    // The tail as one more lane.
    c.second = x[k] < c.dmin ? c.dmin : (x[k] > c.dmin ? std::min(c.second, x[k]) : c.second);
    c.dmin = std::min(c.dmin, x[k]);
  }
  // Merge the lanes: the lowest of all, then the lowest value above it (a lane whose
  // lowest equals it offers its second).
  int32_t dmin = c.dmin;
  for (int l = 0; l < 8; ++l) dmin = std::min(dmin, l1[l]);
  int32_t second = c.dmin > dmin ? c.dmin : c.second;
  for (int l = 0; l < 8; ++l) second = std::min(second, l1[l] > dmin ? l1[l] : l2[l]);
  size_t q = 0;
  if (vrank) {
    // The values into sample order by a gather through the inverse order (AVX2 has no
    // scatter): out[j] = x[vrank[j]], the same integers.
    for (; q + 8 <= n; q += 8) {
      const __m256i r = _mm256_loadu_si256(reinterpret_cast<const __m256i*>(vrank + q));
      _mm256_storeu_si256(reinterpret_cast<__m256i*>(out + q), _mm256_i32gather_epi32(x, r, 4));
    }
    for (; q < n; ++q) out[q] = x[vrank[q]];
  } else {
    for (; q < n; ++q) out[vorder[q]] = x[q];
  }
  c.dmin = dmin;
  c.second = second;
  c.unclear = size_t(unclear);
  return c;
}
#endif

#if defined(VG_SSV_AVX2)
// The four side planes of L' (add_segment) at both ends of a segment in AVX2 lanes:
// each lane the same products and sums as dot(side, a - r) in double (no fused
// multiply-add), so the same values. 0: some plane has both ends outside (<= 0), 1:
// every plane has both inside (> 0), 2: otherwise.
__attribute__((target("avx2"))) int side_class_avx2(const double* sx, const double* sy, const double* sz,
                                                    const Vec3d& da, const Vec3d& db, double* fa_out,
                                                    double* fb_out) {
  const __m256d nx = _mm256_loadu_pd(sx), ny = _mm256_loadu_pd(sy), nz = _mm256_loadu_pd(sz);
  const __m256d fa = _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(nx, _mm256_set1_pd(da.x)), _mm256_mul_pd(ny, _mm256_set1_pd(da.y))),
      _mm256_mul_pd(nz, _mm256_set1_pd(da.z)));
  const __m256d fb = _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(nx, _mm256_set1_pd(db.x)), _mm256_mul_pd(ny, _mm256_set1_pd(db.y))),
      _mm256_mul_pd(nz, _mm256_set1_pd(db.z)));
  _mm256_storeu_pd(fa_out, fa);
  _mm256_storeu_pd(fb_out, fb);
  const __m256d zero = _mm256_setzero_pd();
  const int out = _mm256_movemask_pd(
      _mm256_and_pd(_mm256_cmp_pd(fa, zero, _CMP_LE_OQ), _mm256_cmp_pd(fb, zero, _CMP_LE_OQ)));
  if (out != 0) return 0;
  const int in = _mm256_movemask_pd(
      _mm256_and_pd(_mm256_cmp_pd(fa, zero, _CMP_GT_OQ), _mm256_cmp_pd(fb, zero, _CMP_GT_OQ)));
  return in == 15 ? 1 : 2;
}

// Whether d = x - r has every lane's dot(side, d) > 0: side_class_avx2(d, d) == 1, with
// the same products and sums.
__attribute__((target("avx2"))) bool side_inside_avx2(const double* sx, const double* sy, const double* sz,
                                                      const Vec3d& d) {
  const __m256d nx = _mm256_loadu_pd(sx), ny = _mm256_loadu_pd(sy), nz = _mm256_loadu_pd(sz);
  const __m256d f = _mm256_add_pd(
      _mm256_add_pd(_mm256_mul_pd(nx, _mm256_set1_pd(d.x)), _mm256_mul_pd(ny, _mm256_set1_pd(d.y))),
      _mm256_mul_pd(nz, _mm256_set1_pd(d.z)));
  return _mm256_movemask_pd(_mm256_cmp_pd(f, _mm256_setzero_pd(), _CMP_GT_OQ)) == 15;
}

// Set once at start-up: count_run runs once per piece, a guarded local static cost a
// check per call.
const bool kCountRunAvx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
#endif

inline void count_run(const PieceTest& t, const float* u, const float* v, int32_t* out, int32_t* flag, int k0, int k1,
                      bool v_range) {
#if defined(VG_SSV_AVX2)
  if (kCountRunAvx2) return count_run_avx2(t, u, v, out, flag, k0, k1, v_range);
#endif
  count_run_sse2(t, u, v, out, flag, k0, k1, v_range);
}

}  // namespace

// Inline: fill_vertex ranks every vertex it projects (about a twentieth of the
// armadillo's integration in the call alone). Only this file calls it.
inline int DepthCounter::sorted_lower_bound(float x) const {
  // std::lower_bound on the sorted picked v's: start at x's bucket, step forward over
  // the points below x. The start is checked (the point before it lies below x), so a
  // bucket misjudged by rounding costs a search, never a wrong position.
  const int n = int(uv_.size());
  if (n == 0 || !(x > vv_[0])) return 0;
  if (x > vv_[size_t(n - 1)]) return n;
  const int b = std::clamp(int((double(x) - double(vv_[0])) * vb_scale_), 0, n - 1);
  int k = vb_first_[size_t(b)];
  if (k > 0 && !(vv_[size_t(k - 1)] < x)) return branchless_lower_bound(vv_.data(), n, x);
  while (k < n && vv_[size_t(k)] < x) ++k;
  return k;
}

namespace {

// The one-by-one test of the piece lo -> hi (lo.v < hi.v) with weight c (DepthCounter::
// add_piece), with its margin and the line's length.
PieceTest piece_test(const Vec2f& lo, const Vec2f& hi, int c, double extent, double& margin, double& dlen) {
  const float du = hi.u - lo.u, dv = hi.v - lo.v;
  // Margin. The float cross product below errs only for samples within a few float32
  // ulps (about 1e-7 relative to the coordinates' magnitude) of the line; `margin`, 1e-6
  // of the magnitudes (a distance), is well beyond that band. Samples within `margin` of
  // the line are marked unclear (answered by their own ray: their count may be off by
  // the piece's weight, and the relation may still be decided, far from degenerate, by
  // another triangle). Every sample
  // classified in bulk lies further than `margin` from the line.
  margin = 1e-6 * (extent + std::abs(lo.u) + std::abs(lo.v) + std::abs(hi.u) + std::abs(hi.v));
  dlen = std::sqrt(double(du) * du + double(dv) * dv);
  const float near_cross = float(margin * dlen);  // |cross| below it: within margin of the line
  return PieceTest{lo.u, lo.v, hi.v, du, dv, near_cross, c};
}

}  // namespace

int DepthCounter::rank(float x) const { return sorted_lower_bound(x); }

void DepthCounter::add_piece_ranked(const Vec2f& P, const Vec2f& Q, int w, int kP, int kQ) {
  if (P.v == Q.v || w == 0) return;
  const bool up = Q.v > P.v;
  // Positions [kb, ke): the samples with v in [lo.v, hi.v), as in add_piece.
  const int kb = up ? kP : kQ, ke = up ? kQ : kP;
  if (kb >= ke) return;
  double margin, dlen;
  const PieceTest pt = piece_test(up ? P : Q, up ? Q : P, up ? w : -w, extent_, margin, dlen);
  count_run(pt, vu_.data(), vv_.data(), dv_.data(), fv_.data(), kb, ke, true);
}

void DepthCounter::add_piece(const Vec2f& P, const Vec2f& Q, int w) {
  if (P.v == Q.v || w == 0) return;
  const SampleStrips& S = *strips_;
  const bool up = Q.v > P.v;
  const Vec2f lo = up ? P : Q, hi = up ? Q : P;
  const int c = up ? w : -w;
  // Positions [kb, ke) of the picked points' own v order (sorted_): exactly the samples
  // with v in [lo.v, hi.v). A piece that reaches none (most pieces of small triangles
  // over few samples) ends here, before its margin and line are set up.
  int kb = 0, ke = 0;
  if (sorted_) {
    const int n = int(uv_.size());
    kb = sorted_lower_bound(lo.v);
    ke = kb;  // a piece reaches few samples: a forward scan finds the same end
    while (ke < n && vv_[size_t(ke)] < hi.v) ++ke;
    if (kb >= ke) return;
  }
  // The one-by-one test, cross2(hi - lo, s - lo) > 0 (strictly left of the line), over
  // positions [k0, k1) of one order; with the v-range [lo.v, hi.v) where the position's
  // box may lie partly outside it. Four positions at a time with SSE2 (the same float
  // operations in the same order as the scalar tail: identical results).
  double margin, dlen;
  const PieceTest pt = piece_test(lo, hi, c, extent_, margin, dlen);
  const float du = pt.du, dv = pt.dv;
  auto run = [&pt](const float* u, const float* v, int32_t* out, int32_t* flag, int k0, int k1, bool v_range) {
    count_run(pt, u, v, out, flag, k0, k1, v_range);
  };
  if (sorted_) {
    // The same one-by-one test over exactly the samples in the v-range.
    run(vu_.data(), vv_.data(), dv_.data(), fv_.data(), kb, ke, true);
    return;
  }
  const double slope = double(du) / double(dv);
  // Only samples with v_lo < hi.v and v_hi >= lo.v can have v in [lo.v, hi.v): a range
  // [kb, ke) of the v_lo order (kb the first position whose v_hi prefix maximum reaches
  // lo.v), met by a run of consecutive strips.
  kb = S.vhi_lower_bound(lo.v);
  ke = S.vlo_lower_bound(hi.v);
  if (kb >= ke) return;
  // Up to a few hundred samples in range, testing each one by one (four per SSE2 step)
  // costs less than the strips' searches: the same test, so the same counts.
  if (ke - kb <= kOneByOne) {
    run(vu_.data(), vv_.data(), dv_.data(), fv_.data(), kb, ke, true);
    return;
  }
  use_strip_order();
  const int strips = int(S.strip_start.size()) - 1;
  // The strip holding position kb: the last strip start <= kb.
  int t = branchless_lower_bound(S.strip_start.data(), strips + 1, kb + 1) - 1;
  for (; t < strips && S.strip_start[size_t(t)] < ke; ++t) {
    const float vmin = S.strip_vmin[size_t(t)], vmax = S.strip_vmax[size_t(t)];
    const int start = S.strip_start[size_t(t)], end = S.strip_start[size_t(t) + 1];
    if (vmin >= lo.v && vmax < hi.v) {
      // Every sample of the strip is in the v-range: the line's u-range over the strip,
      // widened so that a sample outside it is further than `margin` from the line (a
      // horizontal offset x is a distance x |dv| / |d|).
      const double xa = lo.u + (double(vmin) - lo.v) * slope;
      const double xb = lo.u + (double(vmax) - lo.v) * slope;
      const double mu = margin * dlen / std::abs(double(dv)) * (1.0 + 0x1p-20);
      const float x0 = float(std::min(xa, xb) - mu);
      const double x1 = std::max(xa, xb) + mu + S.max_width;
      // Boxes with u_hi < x0 are surely left (prefix); those with u_hi > x1 are surely
      // right (their u_lo >= u_hi - max_width exceeds the line's u-range): only the
      // positions between are tested.
      const float* uh = S.uhi_sorted.data() + start;
      const int ia = start + branchless_lower_bound(uh, end - start, x0);
      const int ib = start + branchless_lower_bound(uh, end - start, std::nextafter(float(x1), INFINITY));
      int32_t* out = ds_.data();
      for (int k = start; k < ia; ++k) out[k] += c;  // the surely-left prefix
      run(su_.data(), sv_.data(), out, fs_.data(), ia, std::max(ia, ib), false);
    } else {
      run(vu_.data(), vv_.data(), dv_.data(), fv_.data(), std::max(start, kb), std::min(end, ke), true);
    }
  }
}

void DepthCounter::add_step(float vc, int w) {
  if (sorted_) {
    // Every sample with v >= vc: a suffix of the picked points' v order.
    const int kb = sorted_lower_bound(vc);
    diffv_[size_t(kb)] += w;
    step_list_.emplace_back(kb, w);
    steps_ = true;
    return;
  }
  const SampleStrips& S = *strips_;
  // Boxes with v_lo >= vc: a suffix of the v_lo order. Boxes below it from the first
  // position whose v_hi prefix maximum reaches vc may reach it: tested one by one.
  const int kb = S.vlo_lower_bound(vc);
  diffv_[size_t(kb)] += w;
  step_list_.emplace_back(kb, w);
  steps_ = true;
  const int kr = S.vhi_lower_bound(vc);
  for (int k = kr; k < kb; ++k) dv_[size_t(k)] += vv_[size_t(k)] >= vc ? w : 0;
}

void DepthCounter::finish(std::vector<int32_t>& depth, std::vector<uint8_t>* unclear) {
  const SampleStrips& S = *strips_;
  const size_t n = uv_.size();
  fold_steps();
  depth.resize(n);
  if (sorted_) {
    for (size_t k = 0; k < n; ++k) depth[size_t(ord_[k])] = dv_[k];
    if (unclear) {
      unclear->resize(n);
      for (size_t k = 0; k < n; ++k) (*unclear)[size_t(ord_[k])] = uint8_t(fv_[k] != 0);
    }
    return;
  }
  if (strip_order_) {
    for (size_t j = 0; j < n; ++j) depth[j] = dv_[size_t(S.vrank[j])] + ds_[size_t(S.srank[j])];
  } else {
    for (size_t j = 0; j < n; ++j) depth[j] = dv_[size_t(S.vrank[j])];
  }
  if (unclear) {
    unclear->resize(n);
    if (strip_order_) {
      for (size_t j = 0; j < n; ++j) (*unclear)[j] = uint8_t((fv_[size_t(S.vrank[j])] | fs_[size_t(S.srank[j])]) != 0);
    } else {
      for (size_t j = 0; j < n; ++j) (*unclear)[j] = uint8_t(fv_[size_t(S.vrank[j])] != 0);
    }
  }
}

void DepthCounter::fold_steps() {
  if (!steps_) return;  // diffv_ all zero: the prefix sums add nothing
  int32_t run = 0;  // rule 2: prefix sums of the steps, folded into the v-order counts
  for (size_t k = 0; k < uv_.size(); ++k) {
    run += diffv_[k];
    dv_[k] += run;
  }
  for (const auto& st : step_list_) diffv_[size_t(st.first)] = 0;
  step_list_.clear();
  steps_ = false;
}

DepthCounter::Classes DepthCounter::finish_classes(std::vector<int32_t>& depth, int32_t unclear_value) {
  const SampleStrips& S = *strips_;
  const size_t n = uv_.size();
  depth.resize(n);
  const int* vorder = ord_;  // the order of the positions (strip_order_ only with S.vorder)
#if defined(VG_SSV_AVX2)
  if (!strip_order_ && use_avx2()) {
    if (step_list_.size() > kMaxLaneSteps) fold_steps();
    const size_t n_steps = steps_ ? step_list_.size() : 0;
    const Classes lanes =
        classes_avx2(dv_.data(), fv_.data(), n, unclear_value, vorder, sorted_ ? nullptr : S.vrank.data(),
                     depth.data(), step_list_.data(), n_steps);
    for (const auto& st : step_list_) diffv_[size_t(st.first)] = 0;
    step_list_.clear();
    steps_ = false;
    return lanes;
  }
#endif
  fold_steps();
  Classes c{unclear_value, unclear_value, 0};
  if (!strip_order_) {
    // Every sample's count and flag sit at its v_lo position: the values, their two
    // lowest and the unclear count from consecutive memory (four per SSE2 step, no
    // loop-carried chain of selects), then one scatter into sample order. The flags
    // are 0 or -1 (add_piece), so the count is minus their sum.
    int32_t* x = dv_.data();
    const int32_t* f = fv_.data();
    size_t k = 0;
    int32_t dmin = unclear_value;
    int64_t flags = 0;
#if defined(__SSE2__)
    const __m128i vu = _mm_set1_epi32(unclear_value);
    __m128i mn = vu, cnt = _mm_setzero_si128();
    for (; k + 4 <= n; k += 4) {
      const __m128i fk = _mm_loadu_si128(reinterpret_cast<const __m128i*>(f + k));
      const __m128i dk = _mm_loadu_si128(reinterpret_cast<const __m128i*>(x + k));
      const __m128i xk = _mm_or_si128(_mm_andnot_si128(fk, dk), _mm_and_si128(fk, vu));
      _mm_storeu_si128(reinterpret_cast<__m128i*>(x + k), xk);
      const __m128i gt = _mm_cmpgt_epi32(mn, xk);
      mn = _mm_or_si128(_mm_and_si128(gt, xk), _mm_andnot_si128(gt, mn));
      cnt = _mm_sub_epi32(cnt, fk);
    }
    alignas(16) int32_t lanes[4], counts[4];
    _mm_store_si128(reinterpret_cast<__m128i*>(lanes), mn);
    _mm_store_si128(reinterpret_cast<__m128i*>(counts), cnt);
    for (int l = 0; l < 4; ++l) {
      dmin = std::min(dmin, lanes[l]);
      flags -= counts[l];
    }
#endif
    for (; k < n; ++k) {
      x[k] = f[k] != 0 ? unclear_value : x[k];
      dmin = std::min(dmin, x[k]);
      flags += f[k];
    }
    int32_t second = unclear_value;
    for (size_t q = 0; q < n; ++q) second = std::min(second, x[q] > dmin ? x[q] : unclear_value);
    int32_t* out = depth.data();
    for (size_t q = 0; q < n; ++q) out[vorder[q]] = x[q];
    c.dmin = dmin;
    c.second = second;
    c.unclear = size_t(-flags);
    return c;
  }
  const int* srank = S.srank.data();
  for (size_t k = 0; k < n; ++k) {
    const size_t j = size_t(vorder[k]);
    const int32_t f = strip_order_ ? (fv_[k] | fs_[size_t(srank[j])]) : fv_[k];
    const int32_t d = strip_order_ ? dv_[k] + ds_[size_t(srank[j])] : dv_[k];
    const bool u = f != 0;
    c.unclear += u;
    const int32_t x = u ? unclear_value : d;
    depth[j] = x;
    // The running lowest and second-lowest distinct value: independent of the order.
    c.second = x < c.dmin ? c.dmin : (x > c.dmin ? std::min(c.second, x) : c.second);
    c.dmin = std::min(c.dmin, x);
  }
  return c;
}

void ReceiverIntegrator::begin(const Vec3f& receiver, const std::vector<Vec2f>& samples_uv) {
  set_receiver(receiver);
  counter_.reset(samples_uv, frame_.extent);
}

void ReceiverIntegrator::begin(const Vec3f& receiver, const SampleStrips& strips, const std::vector<uint32_t>& pick) {
  set_receiver(receiver);
  counter_.reset(strips, frame_.jitter_uv, pick, frame_.extent);
}

void ReceiverIntegrator::expect_edges(size_t edges) {
  // The sort and its buckets cost about 5,000 instructions at 64 samples and more than
  // 20,000 at 256 (many boxes overlap), an exact v-range saves about 100-200 per piece
  // (callgrind on foliage, scan, rooms and columns): sort from two edges per sample.
  if (edges >= 16 && edges >= 2 * counter_.size()) vertex_reuse_ = counter_.use_sorted_order() && vertex_reuse_on_;
}

void ReceiverIntegrator::set_receiver(const Vec3f& receiver) {
  r_world_ = to_double(receiver);
  r_ = frame_.to_local(receiver);
  VG_CHECK(r_.z > 0.0);
  pieces_.clear();
  doubtful_ = false;
  vertex_reuse_ = false;
  reused_edges_ = 0;
  // A new stamp empties every vertex slot (a stamp that no longer fits 32 bits restarts
  // from 1 with the slots cleared).
  if (++stamp_ >= (uint64_t(1) << 32) || vertex_slots_.empty()) {
    vertex_slots_.assign(kVertexSlots, VertexProjection{});
    stamp_ = 1;
  }
  // Clearance threshold. The pieces are clipped and projected in double from unrounded
  // frame coordinates and rounded once to float, like the samples' (u, v): with |u|, |v|
  // below 2E on L' (E the light's extent) each is within 2^-23 E of its exact value, and
  // the counter's float cross products add a few 2^-23 E more. Embree's robust test
  // decides the reference segment in float relative to its origin r, an angular error
  // of a few ulps: a few 2^-23 |q - r| in the light plane, and |q - r| <= S = E + |r_u| +
  // |r_v| + h_r. 2^-16 S is above both by a factor of 32 and far below the spacing of
  // any sample pattern that matters (256 samples on a light of extent E are about E / 16
  // apart; a light 1e-3 wide seen from 3 away still has samples 2.5e-4 apart against a
  // threshold of 4.6e-5).
  clear_min_ = 0x1p-16 * (frame_.extent + std::abs(r_.x) + std::abs(r_.y) + r_.z);
  const size_t n = frame_.poly.size();
  side_.resize(n);
  // Plane through r and the edge (L'_i, L'_i+1), oriented with L's interior positive:
  // the frame origin (vertex average) is inside L'.
  for (size_t i = 0; i < n; ++i) {
    const Vec2f& p = frame_.poly[i];
    const Vec2f& q = frame_.poly[(i + 1) % n];
    const Vec3d a(p.u, p.v, 0.0), b(q.u, q.v, 0.0);
    Vec3d nrm = cross(a - r_, b - r_);
    if (dot(nrm, Vec3d(0, 0, 0) - r_) < 0.0) nrm = -nrm;
    // A receiver so far away (beyond about 1e10 light extents) that the edge's two
    // directions from it agree to double precision has no usable side plane.
    if (!(length(nrm) > 1e-12 * length(a - r_) * length(b - r_))) doubtful_ = true;
    side_[i] = nrm;
  }
  // The planes in AVX2 lanes for add_segment; lanes beyond n repeat plane 0, which
  // changes neither "some plane rejects" nor "every plane keeps".
  side_lanes_ = false;
#if defined(VG_SSV_AVX2)
  if (kCountRunAvx2 && n >= 1 && n <= 4) {
    for (size_t i = 0; i < 4; ++i) {
      const Vec3d& nrm = side_[i < n ? i : 0];
      sx_[i] = nrm.x;
      sy_[i] = nrm.y;
      sz_[i] = nrm.z;
    }
    side_lanes_ = true;
  }
#endif
}

Vec3d FramePositions::fill(uint32_t v) const {
  if (keys_.empty()) {
    keys_.assign(kCache, UINT32_MAX);
    cache_.resize(kCache);
  }
  const size_t slot = v & (kCache - 1);
  cache_[slot] = frame_->to_local((*vertices_)[v]);
  keys_[slot] = v;
  return cache_[slot];
}

const TrianglePlane& ReceiverIntegrator::fill_plane(size_t t) const {
  if (plane_keys_.empty()) {
    plane_keys_.assign(kPlaneCache, -1);
    plane_cache_.resize(kPlaneCache);
  }
  const size_t slot = t & (kPlaneCache - 1);
  plane_cache_[slot] = triangle_plane(m_, t);
  plane_keys_[slot] = int64_t(t);
  return plane_cache_[slot];
}

int ReceiverIntegrator::facing(size_t t) const { return arrays() ? facing_from<true>(t) : facing_from<false>(t); }

template <bool kArrays>
inline int ReceiverIntegrator::facing_from(size_t t) const {
  const auto& v = m_.triangles[t].v;
  auto h = [&](uint32_t i) { return kArrays ? fp_data_[i].z : fp_.h(i); };
  if (!(h(v[0]) > 0.0 || h(v[1]) > 0.0 || h(v[2]) > 0.0)) return 0;
  const TrianglePlane& p = kArrays ? plane_data_[t] : plane(t);  // used before the next plane() call
  const double f = dot(p.n, r_world_ - p.a);
  // Nearly edge-on. With r within 2^-20 (relative to its distance from the triangle) of
  // the triangle's plane, T projects to a sliver narrower than float resolution in the
  // light plane: its three pieces round onto one line and the strict-left tests of
  // samples on that line no longer agree between them. The sign itself is right (double error about 1e-16 of the same scale), but
  // the receiver is answered by rays. f = 0 exactly is harmless: T then adds no piece
  // at all, and no open segment from r crosses it properly. The test is f^2 <= 2^-40
  // |n|^2 max |r - v|^2; max |r - v|^2 <= 2 (|r - a|^2 + max |v - a|^2) rules most out
  // cheaply.
  if (f != 0.0) {
    const Vec3d ra0 = r_world_ - p.a;
    const double f2 = f * f, lim = 0x1p-40 * p.nn;
    if (f2 <= lim * 2.0 * (dot(ra0, ra0) + p.reach2)) {
      const Vec3d a = to_double(m_.corner(t, 0)), b = to_double(m_.corner(t, 1)), c = to_double(m_.corner(t, 2));
      const Vec3d ra = r_world_ - a, rb = r_world_ - b, rcc = r_world_ - c;
      const double reach2 = std::max(dot(ra, ra), std::max(dot(rb, rb), dot(rcc, rcc)));
      if (f2 <= lim * reach2) doubtful_ = true;
    }
  }
  return (f > 0.0) - (f < 0.0);
}

int ReceiverIntegrator::edge_weight(const Edge& e) const {
  if (arrays()) {
    int w = facing_from<true>(size_t(e.t1));
    if (e.t2 >= 0) w -= facing_from<true>(size_t(e.t2));
    return w;
  }
  int w = facing_from<false>(size_t(e.t1));
  if (e.t2 >= 0) w -= facing_from<false>(size_t(e.t2));
  return w;
}

void jitter_picks(uint64_t prefix, int samples, int jitter, std::vector<uint32_t>& pick) {
  pick.resize(size_t(std::max(samples, 0)));
  const uint64_t K = uint64_t(jitter);
  const bool pow2 = (K & (K - 1)) == 0;
  int j = 0;
#if defined(VG_SSV_AVX2)
  static const bool avx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
  if (avx2 && pow2 && K <= (uint64_t(1) << 24)) j = jitter_picks_avx2(prefix, samples, uint32_t(K), pick.data());
#endif
  for (; j < samples; ++j) {
    const uint64_t h = relation_hash_step(prefix, uint64_t(j));
    pick[size_t(j)] = uint32_t(uint64_t(j) * K + (pow2 ? h & (K - 1) : h % K));
  }
}


Vec3d ReceiverIntegrator::cut_point(uint32_t i, uint32_t j) const { return light_plane_point(fp_, i, j); }

std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const std::vector<Vec3d>& fp, const LightFrame& f) {
  std::vector<uint32_t> all(m.triangles.size());
  for (size_t t = 0; t < all.size(); ++t) all[t] = uint32_t(t);
  return light_plane_cuts(m, fp, f, all);
}

namespace {

template <class Positions>
std::vector<uint32_t> cuts_among(const mesh::PreparedMesh& m, const Positions& fp, const LightFrame& f,
                                 const std::vector<uint32_t>& candidates) {
  // L' in double, with its bounding box.
  const size_t nl = f.poly.size();
  double ulo = INFINITY, uhi = -INFINITY, vlo = INFINITY, vhi = -INFINITY;
  for (const Vec2f& p : f.poly) {
    ulo = std::min(ulo, double(p.u));
    uhi = std::max(uhi, double(p.u));
    vlo = std::min(vlo, double(p.v));
    vhi = std::max(vhi, double(p.v));
  }
  double area2 = 0.0;  // twice the signed area: L' is counter-clockwise, checked anyway
  for (size_t i = 0; i < nl; ++i) {
    const Vec2f& a = f.poly[i];
    const Vec2f& b = f.poly[(i + 1) % nl];
    area2 += double(a.u) * b.v - double(b.u) * a.v;
  }
  const double orient = area2 >= 0.0 ? 1.0 : -1.0;
  // A generous tolerance (1e-6 of the extent): keeping a segment that misses L' costs
  // one clipped-away piece per receiver; dropping one that meets it would be wrong.
  const double tol = 1e-6 * f.extent;
  std::vector<uint32_t> out;
  for (const uint32_t t : candidates) {
    const auto& v = m.triangles[t].v;
    bool pos = false, neg = false;
    for (uint32_t i : v) {
      pos |= fp[i].z > 0.0;
      neg |= fp[i].z < 0.0;
    }
    if (!pos || !neg) continue;
    // The cut segment E F exactly as add_cut computes it.
    Vec3d E{}, F{};
    for (int k = 0; k < 3; ++k) {
      const uint32_t p = v[size_t(k)], q = v[size_t((k + 1) % 3)];
      if (fp[p].z >= 0.0 && fp[q].z < 0.0) E = light_plane_point(fp, p, q);
      if (fp[p].z < 0.0 && fp[q].z >= 0.0) F = light_plane_point(fp, p, q);
    }
    // Misses L' when its box misses L''s box, or both ends lie outside one edge of L'
    // (L' is convex and counter-clockwise: inside is to the left of every edge).
    if (std::max(E.x, F.x) < ulo - tol || std::min(E.x, F.x) > uhi + tol || std::max(E.y, F.y) < vlo - tol ||
        std::min(E.y, F.y) > vhi + tol)
      continue;
    bool outside = false;
    for (size_t i = 0; i < nl && !outside; ++i) {
      const Vec2f& a = f.poly[i];
      const Vec2f& b = f.poly[(i + 1) % nl];
      const double eu = double(b.u) - a.u, ev = double(b.v) - a.v, len = std::hypot(eu, ev);
      auto side = [&](const Vec3d& x) { return orient * (eu * (x.y - a.v) - ev * (x.x - a.u)) / len; };
      outside = side(E) < -tol && side(F) < -tol;
    }
    if (!outside) out.push_back(uint32_t(t));
  }
  return out;
}

}  // namespace

std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const std::vector<Vec3d>& fp, const LightFrame& f,
                                       const std::vector<uint32_t>& candidates) {
  return cuts_among(m, fp, f, candidates);
}

std::vector<uint32_t> light_plane_cuts(const mesh::PreparedMesh& m, const FramePositions& fp, const LightFrame& f,
                                       const std::vector<uint32_t>& candidates) {
  return cuts_among(m, fp, f, candidates);
}

inline bool ReceiverIntegrator::project(const Vec3d& x, Vec2f& out) const {
  const double den = r_.z - x.z;
  if (!(den > 0.0)) return false;
  const double s = r_.z / den;
  out = {float(r_.x + (x.x - r_.x) * s), float(r_.y + (x.y - r_.y) * s)};
  return std::isfinite(out.u) && std::isfinite(out.v);
}

inline bool ReceiverIntegrator::inside_sides(const Vec3d& x) const {
#if defined(VG_SSV_AVX2)
  if (side_lanes_) return side_inside_avx2(sx_, sy_, sz_, x - r_);
#endif
  for (const Vec3d& n : side_) {
    if (!(dot(n, x - r_) > 0.0)) return false;
  }
  return true;
}

ReceiverIntegrator::VertexProjection ReceiverIntegrator::fill_vertex(uint32_t v) {
  VertexProjection& slot = vertex_slots_[v & (kVertexSlots - 1)];
  const Vec3d x = fp_[v];
  slot.key = stamp_ << 32 | v;
  slot.ok = x.z >= 0.0 && inside_sides(x) && project(x, slot.p);
  slot.rank = slot.ok ? counter_.rank(slot.p.v) : 0;
  return slot;
}

bool ReceiverIntegrator::add_edge(const Edge& e, int w) {
  if (vertex_reuse_) {
    // Both ends at h >= 0 and strictly inside every side plane: add_segment would keep
    // them unclipped and project each (the same doubles, the same floats), with no step.
    // The copy: both ends may share a slot.
    const VertexProjection a = vertex_projection(e.a), b = vertex_projection(e.b);
    if (a.ok && b.ok) {
      counter_.add_piece_ranked(a.p, b.p, w, a.rank, b.rank);
      pieces_.push_back(a.p);
      pieces_.push_back(b.p);
      ++reused_edges_;
      return true;
    }
  }
  auto from = [&](const auto& fp) {  // an array (read in place) or FramePositions
    const Vec3d& a = fp[e.a];
    const Vec3d& b = fp[e.b];
    if (a.z < 0.0 && b.z < 0.0) return false;
    const Vec3d A = a.z < 0.0 ? light_plane_point(fp, e.a, e.b) : a;
    const Vec3d B = b.z < 0.0 ? light_plane_point(fp, e.a, e.b) : b;
    return add_segment(A, B, w);
  };
  return fp_.array() ? from(*fp_.array()) : from(fp_);
}

bool ReceiverIntegrator::add_cut(size_t t) {
  const auto& v = m_.triangles[t].v;
  bool pos = false, neg = false;
  for (uint32_t i : v) {
    pos |= fp_[i].z > 0.0;
    neg |= fp_[i].z < 0.0;
  }
  if (!pos || !neg) return false;
  Vec3d E{}, F{};
  for (int k = 0; k < 3; ++k) {
    uint32_t p = v[size_t(k)], q = v[size_t((k + 1) % 3)];
    if (fp_[p].z >= 0.0 && fp_[q].z < 0.0) E = cut_point(p, q);
    if (fp_[p].z < 0.0 && fp_[q].z >= 0.0) F = cut_point(p, q);
  }
  int w = facing(t);
  if (w == 0) return false;
  return add_segment(E, F, w);
}

bool ReceiverIntegrator::add_segment(const Vec3d& a, const Vec3d& b, int w) {
  // Clip to the pyramid from r over L' (h >= 0 is already done): Liang-Barsky on the
  // side planes, remembering which plane cut each end. Double precision: the side
  // planes of a light that is small against its distance to the receiver are nearly
  // parallel, and a float normal cross(a - r, b - r) of two almost equal vectors loses
  // most of its bits (a 1e-3 light seen from distance 2 got a normal with relative error
  // 1e-4, which moved the clipped ends 15% of the light inwards and dropped counts). In
  // double every step below errs by about 1e-16 of the frame magnitudes, far below the
  // float rounding of the inputs. A point on a side plane (f = 0) counts as outside, so
  // a piece that starts or ends exactly on the boundary of L' records that plane (rule 2
  // needs the step of a right-chain contact).
  double t0 = 0.0, t1 = 1.0;
  int enter = -1, exit = -1;
  // Up to four planes in AVX2 lanes first: a plane with both ends outside rejects the
  // segment whatever the others (the loop below returns false there too), and with
  // both ends inside every plane the loop changes nothing; only a segment that crosses a
  // plane goes through the loop.
  // A crossing segment's loop reads the lanes' values (the same numbers).
  int sides = 2;
  double fav[4], fbv[4];
#if defined(VG_SSV_AVX2)
  if (side_lanes_) sides = side_class_avx2(sx_, sy_, sz_, a - r_, b - r_, fav, fbv);
#endif
  if (sides == 0) return false;
  for (size_t i = 0; i < (sides == 1 ? 0 : side_.size()); ++i) {
    const double fa = side_lanes_ ? fav[i] : dot(side_[i], a - r_), fb = side_lanes_ ? fbv[i] : dot(side_[i], b - r_);
    if (fa <= 0.0 && fb <= 0.0) return false;
    if (fa > 0.0 && fb > 0.0) continue;
    const double t = fa / (fa - fb);
    if (fa <= 0.0) {
      if (t >= t0) { t0 = t; enter = int(i); }
    } else {
      if (t <= t1) { t1 = t; exit = int(i); }
    }
  }
  if (!(t0 < t1)) return false;
  const Vec3d a2 = enter >= 0 ? a + (b - a) * t0 : a;
  const Vec3d b2 = exit >= 0 ? a + (b - a) * t1 : b;
  // Inside the pyramid only its apex r reaches the receiver's height, so a point at or
  // above it is an edge through (within rounding of) the receiver: the projection is
  // undefined and the receiver is marked doubtful.
  Vec2f P, Q;
  if (!project(a2, P) || !project(b2, Q)) {
    doubtful_ = true;
    return false;
  }
  counter_.add_piece(P, Q, w);
  pieces_.push_back(P);
  pieces_.push_back(Q);
  if (enter >= 0 && frame_.right_chain[size_t(enter)]) counter_.add_step(P.v, -w);
  if (exit >= 0 && frame_.right_chain[size_t(exit)]) counter_.add_step(Q.v, w);
  return true;
}

double ReceiverIntegrator::clearance(size_t j) const {
  const Vec2f& sf = counter_.sample_uv(j);
  const double su = sf.u, sv = sf.v;
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k + 1 < pieces_.size(); k += 2) {
    // Distance from the sample to the segment P Q.
    const double pu = pieces_[k].u, pv = pieces_[k].v;
    const double du = double(pieces_[k + 1].u) - pu, dv = double(pieces_[k + 1].v) - pv;
    const double len2 = du * du + dv * dv;
    double t = len2 > 0.0 ? ((su - pu) * du + (sv - pv) * dv) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double eu = su - (pu + t * du), ev = sv - (pv + t * dv);
    best = std::min(best, eu * eu + ev * ev);
  }
  return std::sqrt(best);
}

bool ReceiverIntegrator::clear(size_t j) const {
  // clearance(j) >= clearance_threshold(), with a box test first: a piece whose bounding
  // box, grown by the threshold, does not hold the sample is further away.
  const Vec2f& sf = counter_.sample_uv(j);
  const double su = sf.u, sv = sf.v, c = clear_min_, c2 = c * c;
  for (size_t k = 0; k + 1 < pieces_.size(); k += 2) {
    const double pu = pieces_[k].u, pv = pieces_[k].v, qu = pieces_[k + 1].u, qv = pieces_[k + 1].v;
    if (su < std::min(pu, qu) - c || su > std::max(pu, qu) + c || sv < std::min(pv, qv) - c ||
        sv > std::max(pv, qv) + c)
      continue;
    const double du = qu - pu, dv = qv - pv;
    const double len2 = du * du + dv * dv;
    double t = len2 > 0.0 ? ((su - pu) * du + (sv - pv) * dv) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double eu = su - (pu + t * du), ev = sv - (pv + t * dv);
    if (!(eu * eu + ev * ev >= c2)) return false;
  }
  return true;
}

}  // namespace visgate::ssv
