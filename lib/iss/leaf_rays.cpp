// Leaf relations (paper 000 section 4.10, CAST-SHADOW-RAYS): the direct test against
// the few triangles a leaf shaft holds, Embree leaf rays through the verified scene of
// lib/raycast/embree_scene.h, 16 per packet, or the custom ray caster over the shaft's
// blockers.
#include <algorithm>
#include <cstdlib>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#endif

#include "lib/base/cpu_features.h"
#include "lib/geom/predicates.h"
#include "lib/iss/iss_solver.h"
#include "lib/iss/traversal.h"

// The 32-byte vectors of the direct test stay inside this file's always-inline helpers
// and never cross a function boundary by value (see direct_classify), so GCC's note that
// passing them would change the ABI without AVX is moot (it is given at the file's end).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

namespace visgate::iss {

namespace {

// ---- the direct test ------------------------------------------------------------------
// Section 4.10's custom caster restricted to the triangles that may meet one shaft: a
// columns leaf shaft (64 receivers x 4 samples) meets 5 to 40 column faces, and testing
// each segment against those costs less than a traversal of the whole scene's BVH.
//
// Certification, per segment p q (receiver p, light sample q, float points in double)
// and triangle a b c, with A = a - p, B = b - p, C = c - p, d = q - p, the triple
// products w_a = d.(B x C), w_b = d.(C x A), w_c = d.(A x B) and det = A.(B x C), each a
// 3x3 orientation determinant of differences from p (raycast::certainly_crosses_interior
// states the bounds: with m the largest |coordinate| of A, B, C and n that of d, each w
// is within e = 48 eps n m^2 of its exact value and det within edet = 48 eps m^3):
//  - hit: the w share one strict sign beyond e, det the same sign beyond edet, and
//    |det| + edet < |w_a| + |w_b| + |w_c| - 3e - 4 eps (|w_a| + |w_b| + |w_c|): the segment
//    crosses the open triangle at a parameter strictly inside (0, 1), which blocks under
//    every endpoint and edge convention (certainly_crosses_interior's test);
//  - miss: two w of strictly opposite signs beyond e (the line misses the closed
//    triangle: a point x = alpha a + beta b + gamma c of it on the line gives w_a : w_b : w_c
//    = alpha : beta : gamma, all of one sign), or p and q strictly on one side of the
//    triangle's plane: det beyond edet and det_q = det - (w_a + w_b + w_c) beyond
//    edet + 3e + 4 eps (|w_a| + |w_b| + |w_c| + |det|) with det's sign (the sum's two
//    roundings and the subtraction's stay below that last term).
// A segment is blocked when some candidate certainly blocks it and visible when every
// candidate certainly misses it; any other segment is left to the verified Embree ray of
// the other path. A certified answer is the exact one, so it can differ from the Embree
// ray's only where that ray is wrong (a crossing within Embree's float rounding of an
// edge); everything else stays as it was.
constexpr double kEps = 0x1p-53;

typedef double V4 __attribute__((vector_size(32)));
typedef int64_t M4 __attribute__((vector_size(32)));
// Unaligned loads and stores of four doubles.
typedef double V4u __attribute__((vector_size(32), aligned(8)));

// Term arrays per candidate, each kp doubles (kp a multiple of 4).
enum DirectTerm { kBcx, kBcy, kBcz, kCax, kCay, kCaz, kAbx, kAby, kAbz, kDet, kEm, kEdet, kTermCount };
// Cell shafts also keep m (the largest |coordinate| of A, B, C) and A, B, C themselves.
enum CellTerm { kM = kTermCount, kVax, kVay, kVaz, kVbx, kVby, kVbz, kVcx, kVcy, kVcz, kCellTermCount };

__attribute__((always_inline)) inline V4 load4(const double* x) { return *reinterpret_cast<const V4u*>(x); }
__attribute__((always_inline)) inline void store4(double* x, V4 v) { *reinterpret_cast<V4u*>(x) = v; }
__attribute__((always_inline)) inline V4 abs4(V4 v) { return v < 0.0 ? -v : v; }
__attribute__((always_inline)) inline V4 max4(V4 a, V4 b) { return a > b ? a : b; }
__attribute__((always_inline)) inline V4 min4(V4 a, V4 b) { return a < b ? a : b; }

// The origin-dependent terms of every candidate (corners: 9 arrays ax..cz of kp each);
// with kCell the cell terms too.
template <bool kCell>
__attribute__((always_inline)) inline void direct_terms_body(const double* c, size_t kp, const double* p, double* t) {
  for (size_t k = 0; k < kp; k += 4) {
    const V4 Ax = load4(c + 0 * kp + k) - p[0], Ay = load4(c + 1 * kp + k) - p[1], Az = load4(c + 2 * kp + k) - p[2];
    const V4 Bx = load4(c + 3 * kp + k) - p[0], By = load4(c + 4 * kp + k) - p[1], Bz = load4(c + 5 * kp + k) - p[2];
    const V4 Cx = load4(c + 6 * kp + k) - p[0], Cy = load4(c + 7 * kp + k) - p[1], Cz = load4(c + 8 * kp + k) - p[2];
    const V4 bcx = By * Cz - Bz * Cy, bcy = Bz * Cx - Bx * Cz, bcz = Bx * Cy - By * Cx;
    store4(t + kBcx * kp + k, bcx);
    store4(t + kBcy * kp + k, bcy);
    store4(t + kBcz * kp + k, bcz);
    store4(t + kCax * kp + k, Cy * Az - Cz * Ay);
    store4(t + kCay * kp + k, Cz * Ax - Cx * Az);
    store4(t + kCaz * kp + k, Cx * Ay - Cy * Ax);
    store4(t + kAbx * kp + k, Ay * Bz - Az * By);
    store4(t + kAby * kp + k, Az * Bx - Ax * Bz);
    store4(t + kAbz * kp + k, Ax * By - Ay * Bx);
    store4(t + kDet * kp + k, Ax * bcx + Ay * bcy + Az * bcz);
    const V4 m = max4(max4(max4(abs4(Ax), abs4(Ay)), max4(abs4(Az), abs4(Bx))),
                      max4(max4(abs4(By), abs4(Bz)), max4(max4(abs4(Cx), abs4(Cy)), abs4(Cz))));
    const V4 em = (48.0 * kEps) * m * m;
    store4(t + kEm * kp + k, em);
    store4(t + kEdet * kp + k, em * m);
    if constexpr (kCell) {
      store4(t + kM * kp + k, m);
      store4(t + kVax * kp + k, Ax);
      store4(t + kVay * kp + k, Ay);
      store4(t + kVaz * kp + k, Az);
      store4(t + kVbx * kp + k, Bx);
      store4(t + kVby * kp + k, By);
      store4(t + kVbz * kp + k, Bz);
      store4(t + kVcx * kp + k, Cx);
      store4(t + kVcy * kp + k, Cy);
      store4(t + kVcz * kp + k, Cz);
    }
  }
}

// Term arrays are read at the stride of the current candidate count: a longer array
// serves a shorter list, so they only grow (resize would zero-fill again whatever a
// smaller list had given up).
inline void grow_to(std::vector<double>& v, size_t n) {
  if (v.size() < n) v.resize(n);
}

// "Every lane set" and "some lane set" of a lane mask, in the default build from the
// four lanes; in the AVX2 build by one movemask (the lane extraction was a fifth of the
// test's instructions). Only the test of the mask differs: the same answers. By
// reference: a 256-bit vector argument outside an AVX function changes the ABI (clang
// rejects it).
struct LanesDefault {
  static bool all(const M4& m) { return m[0] & m[1] & m[2] & m[3]; }
  static bool any(const M4& m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
};
#if defined(__GNUC__) && defined(__x86_64__)
struct LanesAvx2 {
  // Not always_inline: the AVX2 wrapper (flatten) inlines them, and only it may.
  __attribute__((target("avx2"))) static bool all(const M4& m) { return _mm256_movemask_pd(__m256d(m)) == 15; }
  __attribute__((target("avx2"))) static bool any(const M4& m) { return _mm256_movemask_pd(__m256d(m)) != 0; }
};
#endif

// The `count` segments of one origin (segment s: d[4s..4s+3] = dx, dy, dz and n = max
// |d_i|) against the candidates, four candidates per vector (the term arrays are SoA
// over the kp candidates; lanes past the candidates repeat the last one, which changes
// no answer): out[s] = 1 when some candidate certainly blocks segment s, 2 when every
// candidate certainly misses it, 0 otherwise. Each (segment, candidate) pair takes the
// operations of the tests above in the same order, so the same lane answers; a segment
// stops at its first blocking candidate (the answer is an OR of the blocks, an AND of
// the misses).
template <class Lanes>
__attribute__((always_inline)) inline void direct_classify_body(const double* t, size_t kp, const double* d,
                                                                size_t count, uint8_t* out) {
  for (size_t s = 0; s < count; ++s) {
    const double dx = d[4 * s], dy = d[4 * s + 1], dz = d[4 * s + 2], n = d[4 * s + 3];
    uint8_t res = 2;
    for (size_t k = 0; k < kp; k += 4) {
      const V4 wa = dx * load4(t + kBcx * kp + k) + dy * load4(t + kBcy * kp + k) + dz * load4(t + kBcz * kp + k);
      const V4 wb = dx * load4(t + kCax * kp + k) + dy * load4(t + kCay * kp + k) + dz * load4(t + kCaz * kp + k);
      const V4 wc = dx * load4(t + kAbx * kp + k) + dy * load4(t + kAby * kp + k) + dz * load4(t + kAbz * kp + k);
      const V4 e = n * load4(t + kEm * kp + k);
      const V4 wmax = max4(max4(wa, wb), wc), wmin = min4(min4(wa, wb), wc);
      M4 miss = (wmax > e) & (wmin < -e);
      // Lines passing beside the triangles (the common case) need nothing else.
      if (Lanes::all(miss)) continue;
      const V4 det = load4(t + kDet * kp + k), edet = load4(t + kEdet * kp + k);
      const M4 pos = det > edet, neg = det < -edet;
      const V4 sum_abs = abs4(wa) + abs4(wb) + abs4(wc);
      const M4 hit = (pos & (wmin > e) & ((det + edet) + 3.0 * e < sum_abs - (4.0 * kEps) * sum_abs)) |
                     (neg & (wmax < -e) & ((edet - det) + 3.0 * e < sum_abs - (4.0 * kEps) * sum_abs));
      if (Lanes::any(hit)) {
        res = 1;
        break;
      }
      const V4 dq = det - (wa + wb + wc);
      miss |= (pos & (dq > edet + 3.0 * e + (4.0 * kEps) * (sum_abs + det))) |
              (neg & (dq < -(edet + 3.0 * e + (4.0 * kEps) * (sum_abs - det))));
      if (!Lanes::all(miss)) res = 0;
    }
    out[s] = res;
  }
}

// Cell shafts (Traversal::cell_rays): the segments from one origin p to every point of
// a box Q of light points, against the candidates, by the tests above at Q's corners
// q_1..q_nc (corner c: d[4c..4c+3] = dx, dy, dz, n). Each w is linear in q and det does
// not depend on q, so a sign the test certifies at every corner holds exactly over Q,
// the corners' hull: a candidate certified to block every corner segment (every w of
// det's strict sign, and det - sum w of the opposite sign: the crossing parameter
// det / sum w inside (0, 1)) blocks every segment from p into Q; one with the same pair
// of strictly opposite w at every corner, or with det - sum w strictly of det's sign at
// every corner (Q strictly on p's side of its plane), misses every such segment.
// With pyr (four planes n_x, n_y, n_z, bound factor: Traversal::cell_descend), a
// candidate also misses all of Q when its three vertices (the cell terms) are certainly
// negative for one plane. Returns true when some candidate blocks all of Q (out is then
// incomplete); else bit k & 3 of out[k / 4] is set for the candidates k that miss all of Q.
// Four candidates' terms (lanes k..k+3) against the corners of a cell, shared by
// cell_classify and cell_patch_flags: at(c) sets the triple products w and their bound e
// at corner c and keeps which w had one strict sign at every corner so far.
struct CellLanes {
  V4 tbx, tby, tbz, tcx, tcy, tcz, tax, tay, taz, em, det, edet, wa, wb, wc, e;
  M4 pos, neg, apos, aneg, bpos, bneg, cpos, cneg;
  __attribute__((always_inline)) CellLanes(const double* t, size_t kp, size_t k) {
    tbx = load4(t + kBcx * kp + k), tby = load4(t + kBcy * kp + k), tbz = load4(t + kBcz * kp + k);
    tcx = load4(t + kCax * kp + k), tcy = load4(t + kCay * kp + k), tcz = load4(t + kCaz * kp + k);
    tax = load4(t + kAbx * kp + k), tay = load4(t + kAby * kp + k), taz = load4(t + kAbz * kp + k);
    em = load4(t + kEm * kp + k), det = load4(t + kDet * kp + k), edet = load4(t + kEdet * kp + k);
    pos = det > edet, neg = det < -edet;
    apos = pos | ~pos, aneg = apos, bpos = apos, bneg = apos, cpos = apos, cneg = apos;
  }
  __attribute__((always_inline)) void at(const double* d, int c) {
    const double dx = d[4 * c], dy = d[4 * c + 1], dz = d[4 * c + 2], n = d[4 * c + 3];
    wa = dx * tbx + dy * tby + dz * tbz;
    wb = dx * tcx + dy * tcy + dz * tcz;
    wc = dx * tax + dy * tay + dz * taz;
    e = n * em;
  }
  __attribute__((always_inline)) void keep_signs() {
    apos &= wa > e;
    aneg &= wa < -e;
    bpos &= wb > e;
    bneg &= wb < -e;
    cpos &= wc > e;
    cneg &= wc < -e;
  }
  // at(c) and keep_signs(), and corner c on p's side of the triangle's plane (same) or
  // strictly beyond it (beyond), certified.
  __attribute__((always_inline)) void step(const double* d, int c, M4& same, M4& beyond) {
    at(d, c);
    keep_signs();
    const V4 sum_abs = abs4(wa) + abs4(wb) + abs4(wc);
    const V4 dq = det - (wa + wb + wc);
    const V4 bp = edet + 3.0 * e + (4.0 * kEps) * (sum_abs + det), bn = edet + 3.0 * e + (4.0 * kEps) * (sum_abs - det);
    same = (pos & (dq > bp)) | (neg & (dq < -bn));
    beyond = (pos & (dq < -bp)) | (neg & (dq > bn));
  }
  // The corner's segment certainly crosses the open triangle strictly inside (0, 1).
  __attribute__((always_inline)) M4 hit() const {
    const V4 wmax = max4(max4(wa, wb), wc), wmin = min4(min4(wa, wb), wc);
    const V4 sum_abs = abs4(wa) + abs4(wb) + abs4(wc);
    return (pos & (wmin > e) & ((det + edet) + 3.0 * e < sum_abs - (4.0 * kEps) * sum_abs)) |
           (neg & (wmax < -e) & ((edet - det) + 3.0 * e < sum_abs - (4.0 * kEps) * sum_abs));
  }
};

// Lanes k..k+3 whose three vertices (the cell terms) are certainly negative for one side
// plane of the pyramid pyr (cell_pyramid): those candidates miss every segment into Q.
__attribute__((always_inline)) inline M4 pyramid_miss(const double* t, size_t kp, size_t k, const double* pyr) {
  const V4 m = load4(t + kM * kp + k);
  const V4 ax = load4(t + kVax * kp + k), ay = load4(t + kVay * kp + k), az = load4(t + kVaz * kp + k);
  const V4 bx = load4(t + kVbx * kp + k), by = load4(t + kVby * kp + k), bz = load4(t + kVbz * kp + k);
  const V4 cx = load4(t + kVcx * kp + k), cy = load4(t + kVcy * kp + k), cz = load4(t + kVcz * kp + k);
  M4 miss = {0, 0, 0, 0};
  for (int f = 0; f < 4; ++f) {
    const double* pl = pyr + 4 * f;
    const V4 ep = m * pl[3];
    miss |= ((ax * pl[0] + ay * pl[1] + az * pl[2]) < -ep) & ((bx * pl[0] + by * pl[1] + bz * pl[2]) < -ep) &
            ((cx * pl[0] + cy * pl[1] + cz * pl[2]) < -ep);
  }
  return miss;
}

// kSide false (cell_pairs): without the side-of-plane miss, only the w pairs and the
// block, for the sample groups of cell_group, where the side test decided nothing more
// on rooms and cost about half of the test.
template <class Lanes, bool kSide = true>
__attribute__((always_inline)) inline bool cell_classify_body(const double* t, size_t kp, const double* d, int nc,
                                                              const double* pyr, uint8_t* out) {
  for (size_t k = 0; k < kp; k += 4) {
    CellLanes L(t, kp, k);
    M4 side = kSide ? L.apos : ~L.apos;
    // First the misses (the common answer, and all that most candidates need).
    for (int c = 0; c < nc; ++c) {
      if constexpr (kSide) {
        M4 same, beyond;
        L.step(d, c, same, beyond);
        side &= same;
      } else {
        L.at(d, c);
        L.keep_signs();
      }
    }
    M4 miss = (L.apos & (L.bneg | L.cneg)) | (L.bpos & (L.aneg | L.cneg)) | (L.cpos & (L.aneg | L.bneg)) | side;
    if (pyr && !Lanes::all(miss)) miss |= pyramid_miss(t, kp, k, pyr);
    // A block needs only be certified where every w has det's strict sign at every corner.
    const M4 maybe = (L.pos & L.apos & L.bpos & L.cpos) | (L.neg & L.aneg & L.bneg & L.cneg);
    if (Lanes::any(maybe)) {
      M4 hit = maybe;
      for (int c = 0; c < nc; ++c) {
        L.at(d, c);
        hit &= L.hit();
      }
      if (Lanes::any(hit)) return true;
    }
    out[k >> 2] = uint8_t((miss[0] & 1) | (miss[1] & 2) | (miss[2] & 4) | (miss[3] & 8));
  }
  return false;
}
// The same certificates over a box Q from its centre and half extents rather than its
// corners (cell_box: bx = centre c, half extents h, both relative to p, and the bound
// factor k). Each w(q) = (q - p).N is affine in q, so over Q it lies within
// w(c) +- h.|N|: the exact range, the one the corners give, at about the cost of two
// corners instead of four or eight. Rounding: |w~(c) - w(c)| <= n_c em (the point test's
// bound, n_c = max |c_i|) and |N~_i - N_i| <= em / 4 (the 15th round's bound on the two
// products and the difference of N's components), so over Q
//   |w(q) - w~(c)| <= n_c em + sum_i h_i (|N~_i| + em / 4) = k em + h.|N~| =: th,
// with h and k inflated by 64 eps (cell_box), which covers the roundings of the
// differences that give h, of the three products and sums of th, and of the sums of
// th below. Miss: one pair of w strictly opposite over Q (w~ > th and w~ < -th); with
// kSide also Q strictly on p's side of the plane: det - sum w has det's strict sign
// over Q, certified as the corner test does with 3e replaced by T, the bound of sum w
// over Q from its gradient s = N_a + N_b + N_c: the computed s~ is within 3 em / 4 +
// 2.1 eps sum |N~| per component, so |sum w(q) - sum w~(c)| <= 3 k em + h.|s~| +
// 2.1 eps (th_a + th_b + th_c), taken with 8 eps. Block: every w of det's strict sign
// over Q and |det| + edet + T < sum |w~| (1 - 8 eps) (the crossing parameter inside
// (0, 1) at every q). The pyramid (pyr) as in cell_classify. Returns and out as
// cell_classify.
template <class Lanes, bool kSide>
__attribute__((always_inline)) inline bool cell_box_body(const double* t, size_t kp, const double* bx,
                                                         const double* pyr, uint8_t* out) {
  const double cx = bx[0], cy = bx[1], cz = bx[2], hx = bx[3], hy = bx[4], hz = bx[5], kk = bx[6];
  for (size_t k = 0; k < kp; k += 4) {
    const V4 tbx = load4(t + kBcx * kp + k), tby = load4(t + kBcy * kp + k), tbz = load4(t + kBcz * kp + k);
    const V4 tcx = load4(t + kCax * kp + k), tcy = load4(t + kCay * kp + k), tcz = load4(t + kCaz * kp + k);
    const V4 tax = load4(t + kAbx * kp + k), tay = load4(t + kAby * kp + k), taz = load4(t + kAbz * kp + k);
    const V4 wa = cx * tbx + cy * tby + cz * tbz;
    const V4 wb = cx * tcx + cy * tcy + cz * tcz;
    const V4 wc = cx * tax + cy * tay + cz * taz;
    const V4 e = kk * load4(t + kEm * kp + k);
    const V4 tha = e + (hx * abs4(tbx) + hy * abs4(tby) + hz * abs4(tbz));
    const V4 thb = e + (hx * abs4(tcx) + hy * abs4(tcy) + hz * abs4(tcz));
    const V4 thc = e + (hx * abs4(tax) + hy * abs4(tay) + hz * abs4(taz));
    const M4 apos = wa > tha, aneg = wa < -tha, bpos = wb > thb, bneg = wb < -thb, cpos = wc > thc,
             cneg = wc < -thc;
    M4 miss = (apos & (bneg | cneg)) | (bpos & (aneg | cneg)) | (cpos & (aneg | bneg));
    const V4 det = load4(t + kDet * kp + k), edet = load4(t + kEdet * kp + k);
    const M4 pos = det > edet, neg = det < -edet;
    // The bound of sum w over Q (the plane side and the block): its gradient s = sum N.
    auto sum_bound = [&]() {
      const V4 sx = tbx + tcx + tax, sy = tby + tcy + tay, sz = tbz + tcz + taz;
      return 3.0 * e + (hx * abs4(sx) + hy * abs4(sy) + hz * abs4(sz)) + (8.0 * kEps) * (tha + thb + thc);
    };
    if constexpr (kSide) {
      if (!Lanes::all(miss)) {
        const V4 sum_abs = abs4(wa) + abs4(wb) + abs4(wc), T = sum_bound();
        const V4 dq = det - (wa + wb + wc);
        miss |= (pos & (dq > edet + T + (4.0 * kEps) * (sum_abs + det))) |
                (neg & (dq < -(edet + T + (4.0 * kEps) * (sum_abs - det))));
      }
    }
    if (pyr && !Lanes::all(miss)) miss |= pyramid_miss(t, kp, k, pyr);
    const M4 maybe = (pos & apos & bpos & cpos) | (neg & aneg & bneg & cneg);
    if (Lanes::any(maybe)) {
      const V4 sum_abs = abs4(wa) + abs4(wb) + abs4(wc), T = sum_bound();
      const V4 lim = sum_abs - (8.0 * kEps) * sum_abs;
      const M4 hit = (pos & ((det + edet) + T < lim)) | (neg & ((edet - det) + T < lim));
      if (Lanes::any(maybe & hit)) return true;
    }
    out[k >> 2] = uint8_t((miss[0] & 1) | (miss[1] & 2) | (miss[2] & 4) | (miss[3] & 8));
  }
  return false;
}
bool cell_box_classify_default(const double* t, size_t kp, const double* bx, const double* pyr, uint8_t* out) {
  return cell_box_body<LanesDefault, true>(t, kp, bx, pyr, out);
}
bool cell_box_pairs_default(const double* t, size_t kp, const double* bx, uint8_t* out) {
  return cell_box_body<LanesDefault, false>(t, kp, bx, nullptr, out);
}

// The connected-surface certificate of a mixed cell (Traversal::cell_patch_blocks): per
// candidate k, out[k] has bit 0 when the candidate's plane certainly separates p from
// every corner of Q (det of one strict sign, det - sum w of the other at every corner);
// bit 1 + e (edge e from vertex e to e + 1: ab, bc, ca) when that closed edge certainly
// misses every segment from p into Q: the w of the plane through p and the edge (w_c, w_a,
// w_b) of one strict sign at every corner (Q strictly on one side of that plane, which the
// segments meet only at p, and p is off the edge when bit 0 is set); bit 4 when some
// corner segment certainly crosses the open triangle (the hit test of cell_classify).
// Linear signs again: what holds at the corners holds over Q. Only the first kTermCount
// term arrays are read.
__attribute__((always_inline)) inline void cell_patch_flags_body(const double* t, size_t kp, const double* d, int nc,
                                                                 uint8_t* out) {
  for (size_t k = 0; k < kp; k += 4) {
    CellLanes L(t, kp, k);
    M4 sep = L.apos, hit = ~L.apos;
    for (int c = 0; c < nc; ++c) {
      M4 same, beyond;
      L.step(d, c, same, beyond);
      sep &= beyond;
      hit |= L.hit();
    }
    const M4 eab = L.cpos | L.cneg, ebc = L.apos | L.aneg, eca = L.bpos | L.bneg;
    for (int j = 0; j < 4; ++j)
      out[k + size_t(j)] = uint8_t((sep[j] & 1) | (eab[j] & 2) | (ebc[j] & 4) | (eca[j] & 8) | (hit[j] & 16));
  }
}
void cell_patch_flags_default(const double* t, size_t kp, const double* d, int nc, uint8_t* out) {
  cell_patch_flags_body(t, kp, d, nc, out);
}
bool cell_classify_default(const double* t, size_t kp, const double* d, int nc, const double* pyr, uint8_t* out) {
  return cell_classify_body<LanesDefault>(t, kp, d, nc, pyr, out);
}
bool cell_pairs_default(const double* t, size_t kp, const double* d, int nc, uint8_t* out) {
  return cell_classify_body<LanesDefault, false>(t, kp, d, nc, nullptr, out);
}

void direct_terms_default(const double* c, size_t kp, const double* p, double* t) {
  direct_terms_body<false>(c, kp, p, t);
}
void cell_terms_default(const double* c, size_t kp, const double* p, double* t) { direct_terms_body<true>(c, kp, p, t); }
void direct_classify_default(const double* t, size_t kp, const double* d, size_t count, uint8_t* out) {
  direct_classify_body<LanesDefault>(t, kp, d, count, out);
}
#if defined(__GNUC__) && defined(__x86_64__)
// The same operations four candidates per instruction; AVX2 alone has no fused
// multiply-add (and the build has -ffp-contract=off), so the results are the default's.
__attribute__((target("avx2"))) void direct_terms_avx2(const double* c, size_t kp, const double* p, double* t) {
  direct_terms_body<false>(c, kp, p, t);
}
__attribute__((target("avx2"))) void cell_terms_avx2(const double* c, size_t kp, const double* p, double* t) {
  direct_terms_body<true>(c, kp, p, t);
}
// flatten: LanesAvx2::all is inlined here, where AVX2 is enabled.
__attribute__((target("avx2"), flatten)) void direct_classify_avx2(const double* t, size_t kp, const double* d,
                                                                   size_t count, uint8_t* out) {
  direct_classify_body<LanesAvx2>(t, kp, d, count, out);
}
__attribute__((target("avx2"), flatten)) bool cell_classify_avx2(const double* t, size_t kp, const double* d, int nc,
                                                                  const double* pyr, uint8_t* out) {
  return cell_classify_body<LanesAvx2>(t, kp, d, nc, pyr, out);
}
__attribute__((target("avx2"), flatten)) bool cell_pairs_avx2(const double* t, size_t kp, const double* d, int nc,
                                                               uint8_t* out) {
  return cell_classify_body<LanesAvx2, false>(t, kp, d, nc, nullptr, out);
}
__attribute__((target("avx2"))) void cell_patch_flags_avx2(const double* t, size_t kp, const double* d, int nc,
                                                            uint8_t* out) {
  cell_patch_flags_body(t, kp, d, nc, out);
}
__attribute__((target("avx2"), flatten)) bool cell_box_classify_avx2(const double* t, size_t kp, const double* bx,
                                                                      const double* pyr, uint8_t* out) {
  return cell_box_body<LanesAvx2, true>(t, kp, bx, pyr, out);
}
__attribute__((target("avx2"), flatten)) bool cell_box_pairs_avx2(const double* t, size_t kp, const double* bx,
                                                                   uint8_t* out) {
  return cell_box_body<LanesAvx2, false>(t, kp, bx, nullptr, out);
}
// VISGATE_ISS_NO_AVX2 in the environment selects the default build of the kernels (to
// check it against the AVX2 one on a machine that has both).
bool have_avx2() {
  static const bool avx2 = avx2_enabled("VISGATE_ISS_NO_AVX2");
  return avx2;
}
#endif

void direct_terms(const double* c, size_t kp, const double* p, double* t) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return direct_terms_avx2(c, kp, p, t);
#endif
  direct_terms_default(c, kp, p, t);
}
void cell_terms(const double* c, size_t kp, const double* p, double* t) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_terms_avx2(c, kp, p, t);
#endif
  cell_terms_default(c, kp, p, t);
}
// Arrays, not vector arguments: a 32-byte vector passed by value between the AVX2 and
// the default function would not travel in the same registers.
__attribute__((always_inline)) inline void direct_classify(const double* t, size_t kp, const double* d, size_t count,
                                                          uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return direct_classify_avx2(t, kp, d, count, out);
#endif
  direct_classify_default(t, kp, d, count, out);
}

bool cell_classify(const double* t, size_t kp, const double* d, int nc, const double* pyr, uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_classify_avx2(t, kp, d, nc, pyr, out);
#endif
  return cell_classify_default(t, kp, d, nc, pyr, out);
}

// cell_classify without the pyramid and the side-of-plane miss.
bool cell_pairs(const double* t, size_t kp, const double* d, int nc, uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_pairs_avx2(t, kp, d, nc, out);
#endif
  return cell_pairs_default(t, kp, d, nc, out);
}

// cell_classify and cell_pairs over a box from its centre (cell_box_body; bx: cell_box).
bool cell_box_classify(const double* t, size_t kp, const double* bx, const double* pyr, uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_box_classify_avx2(t, kp, bx, pyr, out);
#endif
  return cell_box_classify_default(t, kp, bx, pyr, out);
}
bool cell_box_pairs(const double* t, size_t kp, const double* bx, uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_box_pairs_avx2(t, kp, bx, out);
#endif
  return cell_box_pairs_default(t, kp, bx, out);
}

void cell_patch_flags(const double* t, size_t kp, const double* d, int nc, uint8_t* out) {
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return cell_patch_flags_avx2(t, kp, d, nc, out);
#endif
  cell_patch_flags_default(t, kp, d, nc, out);
}

// Box-against-plane culling of candidate boxes (SoA: lo x, y, z, hi x, y, z of kp each),
// four boxes per vector, plane after plane (one call for all of a shaft's planes): keep[k]
// stays -1 while box k is not beyond a plane, by the test and the arithmetic of
// ShaftGeometry::may_intersect_box (the box corner nearest to the plane's inside, eval =
// dot(n, q) - d against the plane's tolerance). pl: the plane arrays (plane_array).
__attribute__((always_inline)) inline void direct_cull_body(const double* box, size_t kp, const double* const* pl,
                                                            int count, int64_t* keep) {
  for (int i = 0; i < count; ++i) {
    const double nx = pl[0][i], ny = pl[1][i], nz = pl[2][i], d = pl[3][i], tol = pl[4][i];
    const double* X = box + (nx > 0 ? 0 : 3) * kp;
    const double* Y = box + (ny > 0 ? 1 : 4) * kp;
    const double* Z = box + (nz > 0 ? 2 : 5) * kp;
    for (size_t k = 0; k < kp; k += 4) {
      const V4 e = (nx * load4(X + k) + ny * load4(Y + k) + nz * load4(Z + k)) - d;
      M4 m;
      std::memcpy(&m, keep + k, sizeof m);
      m &= ~(e > tol);
      std::memcpy(keep + k, &m, sizeof m);
    }
  }
}
void direct_cull_default(const double* box, size_t kp, const double* const* pl, int count, int64_t* keep) {
  direct_cull_body(box, kp, pl, count, keep);
}
#if defined(__GNUC__) && defined(__x86_64__)
__attribute__((target("avx2"))) void direct_cull_avx2(const double* box, size_t kp, const double* const* pl,
                                                      int count, int64_t* keep) {
  direct_cull_body(box, kp, pl, count, keep);
}
#endif


// The distinct corners of a box into out (one value on an axis where the box is flat, so
// a flat box has 4); returns their count.
int distinct_box_corners(const AABB& box, Vec3f* out) {
  const int nx = box.lo.x < box.hi.x ? 2 : 1, ny = box.lo.y < box.hi.y ? 2 : 1, nz = box.lo.z < box.hi.z ? 2 : 1;
  int nc = 0;
  for (int x = 0; x < nx; ++x)
    for (int y = 0; y < ny; ++y)
      for (int z = 0; z < nz; ++z) out[nc++] = Vec3f(x ? box.hi.x : box.lo.x, y ? box.hi.y : box.lo.y, z ? box.hi.z : box.lo.z);
  return nc;
}

// The corners of a cell's box (distinct_box_corners, in its order) relative to the origin
// od into cd (dx, dy, dz, n = max |d_i| each); returns their count. The differences are
// taken once per axis, the same values as per corner.
int cell_corners(const AABB& box, const double* od, double* cd) {
  double v[3][2], a[3][2];
  int n[3];
  for (int x = 0; x < 3; ++x) {
    n[x] = box.lo[x] < box.hi[x] ? 2 : 1;
    v[x][0] = double(box.lo[x]) - od[x];
    v[x][1] = double(box.hi[x]) - od[x];
    a[x][0] = std::abs(v[x][0]);
    a[x][1] = std::abs(v[x][1]);
  }
  int nc = 0;
  for (int x = 0; x < n[0]; ++x)
    for (int y = 0; y < n[1]; ++y)
      for (int z = 0; z < n[2]; ++z) {
        double* d = cd + 4 * nc++;
        d[0] = v[0][x];
        d[1] = v[1][y];
        d[2] = v[2][z];
        d[3] = std::max(std::max(a[0][x], a[1][y]), a[2][z]);
      }
  return nc;
}

// cell_box_body's box terms of `box` from the origin od: bx[0..2] the centre c and
// bx[3..5] the half extents h, relative to od (the corners' differences as cell_corners
// takes them), h inflated so that |q_i - od_i - c_i| <= h_i for every q in the box
// (each difference rounded by at most eps of itself; the 2 eps max(|lo|, |hi|) term
// covers the box's differences from od should they round), and bx[6] = k = n_c +
// sum h_i / 4 (n_c = max |c_i|), both by a factor 1 + 64 eps that also covers the
// roundings of cell_box_body's th (section there).
void cell_box(const AABB& box, const double* od, double* bx) {
  constexpr double kUp = 1.0 + 64.0 * kEps;
  double n = 0.0, hs = 0.0;
  for (int x = 0; x < 3; ++x) {
    const double lo = double(box.lo[x]) - od[x], hi = double(box.hi[x]) - od[x];
    const double c = 0.5 * (lo + hi);
    const double h = std::max(c - lo, hi - c) * kUp + (2.0 * kEps) * std::max(std::abs(lo), std::abs(hi));
    bx[x] = c;
    bx[3 + x] = h;
    n = std::max(n, std::abs(c));
    hs += h;
  }
  bx[6] = (n + 0.25 * hs) * kUp;
}

// A box flat on one axis (nc == 4 corners cd): the pyramid from the origin p over its
// rectangle, side planes through p and each rectangle edge (corners in cyclic order 0,
// 1, 3, 2), the box's side positive. Each plane's value at a point v is the orientation
// determinant (v - p).((q_k - p) x (q_k+1 - p)), computed in the operations of the
// direct test's w = d.(B x C), so within the same bound 48 eps |v - p| M^2 (M the larger
// |coordinate| of the two corners' d; pyr[4f + 3] = 48 eps M^2); a plane is oriented by
// the determinant at the next corner, certified the same way. False (no plane to use)
// without that certificate. A point certainly negative for one side plane lies outside
// the pyramid, which holds every segment from p into the box.
bool cell_pyramid(const double* cd, int nc, double* pyr) {
  if (nc != 4) return false;
  for (int f = 0; f < 4; ++f) {
    static constexpr int kCyc[4] = {0, 1, 3, 2};
    const double* d1 = cd + 4 * kCyc[f];
    const double* d2 = cd + 4 * kCyc[(f + 1) & 3];
    const double* d3 = cd + 4 * kCyc[(f + 2) & 3];
    const double nx = d1[1] * d2[2] - d1[2] * d2[1], ny = d1[2] * d2[0] - d1[0] * d2[2],
                 nz = d1[0] * d2[1] - d1[1] * d2[0];
    const double m2 = std::max(d1[3], d2[3]) * std::max(d1[3], d2[3]);
    const double r = d3[0] * nx + d3[1] * ny + d3[2] * nz, er = (48.0 * kEps) * d3[3] * m2;
    const double sg = r > er ? 1.0 : r < -er ? -1.0 : 0.0;  // the next corner's side positive
    if (sg == 0.0) return false;
    pyr[4 * f] = sg * nx;
    pyr[4 * f + 1] = sg * ny;
    pyr[4 * f + 2] = sg * nz;
    pyr[4 * f + 3] = (48.0 * kEps) * m2;
  }
  return true;
}

// Every corner of box b certainly negative for one side plane of the pyramid pyr from
// od (cell_pyramid): the box, and every triangle inside it, misses every segment from
// od into the cell. The bound takes m, the largest |coordinate| of any corner's v - od.
bool box_outside_pyramid(const AABB& b, const double* od, const double* pyr) {
  double v[8][3], m = 0.0;
  for (int k = 0; k < 8; ++k) {
    v[k][0] = double(k & 1 ? b.hi.x : b.lo.x) - od[0];
    v[k][1] = double(k & 2 ? b.hi.y : b.lo.y) - od[1];
    v[k][2] = double(k & 4 ? b.hi.z : b.lo.z) - od[2];
    m = std::max({m, std::abs(v[k][0]), std::abs(v[k][1]), std::abs(v[k][2])});
  }
  for (int f = 0; f < 4; ++f) {
    const double* pl = pyr + 4 * f;
    const double ep = m * pl[3];
    bool out = true;
    for (int k = 0; k < 8 && out; ++k) out = v[k][0] * pl[0] + v[k][1] * pl[1] + v[k][2] * pl[2] < -ep;
    if (out) return true;
  }
  return false;
}

}  // namespace

int cell_certificate(const Vec3f tri[3], const Vec3f& p, const AABB& box, bool centre, bool side) {
  const size_t kp = 4;
  double c[9 * kp], t[kCellTermCount * kp], cd[4 * 8], bx[7];
  for (int v = 0; v < 3; ++v)
    for (int a = 0; a < 3; ++a)
      for (size_t k = 0; k < kp; ++k) c[size_t(3 * v + a) * kp + k] = double(tri[v][a]);
  const double od[3] = {double(p.x), double(p.y), double(p.z)};
  cell_terms(c, kp, od, t);
  uint8_t out[1] = {0};
  bool blocked;
  if (centre) {
    cell_box(box, od, bx);
    blocked = side ? cell_box_classify(t, kp, bx, nullptr, out) : cell_box_pairs(t, kp, bx, out);
  } else {
    const int nc = cell_corners(box, od, cd);
    blocked = side ? cell_classify(t, kp, cd, nc, nullptr, out) : cell_pairs(t, kp, cd, nc, out);
  }
  return blocked ? 1 : (out[0] & 1) ? 2 : 0;
}

void direct_cull(const double* box, size_t kp, const ShaftGeometry& g, int64_t* keep) {
  const double* const pl[5] = {g.plane_array(0), g.plane_array(1), g.plane_array(2), g.plane_array(3),
                               g.plane_array(4)};
#if defined(__GNUC__) && defined(__x86_64__)
  if (have_avx2()) return direct_cull_avx2(box, kp, pl, g.plane_count(), keep);
#endif
  direct_cull_default(box, kp, pl, g.plane_count(), keep);
}

// Candidates of a leaf shaft: the triangles whose box may meet it (a segment between the
// node boxes lies in their hull, so a triangle it meets has a box that meets the hull).
// A sub-shaft's hull lies in its parent's, so each shaft's list is filtered from its
// parent's: the lists of the shafts above the leaf (cand_stack_, pushed by
// shaft_subdivide) are made on first need, the highest one looked at, kCandUp levels
// up, by a query of the whole triangle hierarchy. Every list is complete for its shaft.
bool Traversal::direct_candidates(const ShaftGeometry& g, bool query_leaf) {
  // The triangles of `from` (boxes `from_box`, SoA of kp(from) each) that may meet
  // `sg`, with their boxes when `to_box` is given.
  auto padded = [](size_t n) { return std::max<size_t>(4, (n + 3) & ~size_t(3)); };
  auto filter = [&](const std::vector<uint32_t>& from, const std::vector<double>& from_box, const ShaftGeometry& sg,
                    std::vector<uint32_t>& to, std::vector<double>* to_box) {
    const size_t n = from.size(), kp = padded(n);
    direct_keep_.assign(kp, -1);
    direct_cull(from_box.data(), kp, sg, direct_keep_.data());
    to.clear();
    for (size_t k = 0; k < n; ++k)
      if (direct_keep_[k]) to.push_back(from[k]);
    if (!to_box) return;
    const size_t tp = padded(to.size());
    to_box->resize(6 * tp);
    for (size_t k = 0, o = 0; k < n; ++k) {
      if (!direct_keep_[k]) continue;
      for (int c = 0; c < 6; ++c) (*to_box)[size_t(c) * tp + o] = from_box[size_t(c) * kp + k];
      ++o;
    }
    for (size_t o = to.size(); o < tp; ++o)  // padding: copies of a kept box, or empty
      for (int c = 0; c < 6; ++c) (*to_box)[size_t(c) * tp + o] = to.empty() ? 0.0 : (*to_box)[size_t(c) * tp];
  };
  // The hierarchy's answer and its boxes, SoA; false when it exceeds kCandQueryMax (a
  // closed dense surface in the shaft: its leaves would exceed the test's candidates
  // too, so the traversal stops early rather than gather thousands of triangles).
  auto query = [&](const ShaftGeometry& sg) {
    direct_query_.clear();
    bool over = false;
    const accel::Bvh<float>& tree = bvh_->tree();
    tree.for_each_leaf([&](const AABB& b) { return !over && sg.may_intersect_box(to_double(b)); },
                       [&](const accel::Bvh<float>::Node& leaf) {
                         for (uint32_t t : tree.leaf_items(leaf)) direct_query_.push_back(t);
                         over = direct_query_.size() > kCandQueryMax;
                       });
    if (over) return false;
    std::sort(direct_query_.begin(), direct_query_.end());
    const size_t n = direct_query_.size(), kp = padded(n);
    direct_query_box_.resize(6 * kp);
    for (size_t k = 0; k < n; ++k) {
      const AABB& b = tri_boxes_[direct_query_[k]];
      for (int c = 0; c < 3; ++c) {
        direct_query_box_[size_t(c) * kp + k] = double(b.lo[c]);
        direct_query_box_[size_t(3 + c) * kp + k] = double(b.hi[c]);
      }
    }
    for (size_t k = n; k < kp; ++k)  // padding lanes: a box the filter reads and never keeps
      for (int c = 0; c < 6; ++c) direct_query_box_[size_t(c) * kp + k] = 0.0;
    return true;
  };
  const size_t top = cand_depth_;
  if (top == 0) {
    if (!query(g)) return false;
    filter(direct_query_, direct_query_box_, g, direct_cand_, nullptr);
    return true;
  }
  size_t src = top;  // nearest ready list at or above the leaf's parent
  const size_t lowest = top > kCandUp ? top - kCandUp : 0;
  for (size_t k = top; k-- > lowest;)
    if (cand_stack_[k].ready) {
      src = k;
      break;
    }
  if (src == top) {
    src = lowest;
    CandLevel& c = cand_stack_[src];
    c.ready = true;
    c.too_many = !query(*c.g);
    if (!c.too_many) filter(direct_query_, direct_query_box_, *c.g, c.tris, &c.box);
  }
  // Every leaf that looks up to this list gives up too (a deeper leaf, whose look-up
  // ends below it, may query again), unless it asks for its own query (cell_rays).
  if (cand_stack_[src].too_many) {
    if (!query_leaf || !query(g)) return false;
    filter(direct_query_, direct_query_box_, g, direct_cand_, nullptr);
    return true;
  }
  for (size_t k = src + 1; k < top; ++k) {
    filter(cand_stack_[k - 1].tris, cand_stack_[k - 1].box, *cand_stack_[k].g, cand_stack_[k].tris,
           &cand_stack_[k].box);
    cand_stack_[k].ready = true;
    cand_stack_[k].too_many = false;
  }
  filter(cand_stack_[top - 1].tris, cand_stack_[top - 1].box, g, direct_cand_, nullptr);
  return true;
}

// The corners of direct_cand_ into direct_corners_ (9 SoA arrays ax..cz of kp each);
// returns kp, the count padded to a multiple of 4 (at least 4). Lanes past the
// candidates repeat the last one: a repeated triangle changes no answer.
namespace {
// The corners of tris[min(first + k, count - 1)] for k < kp (count > 0) into out as 9 x kp
// doubles, coordinate a of corner v at (3 v + a) kp + k: the lanes past the list repeat
// its last triangle.
template <class Mesh>
void load_corner_lanes(const Mesh& mesh, const uint32_t* tris, size_t count, size_t first, size_t kp, double* out) {
  for (size_t k = 0; k < kp; ++k) {
    const uint32_t t = tris[std::min(first + k, count - 1)];
    for (int v = 0; v < 3; ++v) {
      const Vec3f& x = mesh.corner(t, v);
      for (int a = 0; a < 3; ++a) out[size_t(3 * v + a) * kp + k] = double(x[a]);
    }
  }
}
}  // namespace

size_t Traversal::direct_load_corners() {
  const size_t k_count = direct_cand_.size(), kp = std::max<size_t>(4, (k_count + 3) & ~size_t(3));
  direct_corners_.resize(9 * kp);
  if (k_count > 0) load_corner_lanes(mesh_, direct_cand_.data(), k_count, 0, kp, direct_corners_.data());
  return kp;
}

bool Traversal::direct_rays(int r, int l, const Shaft& sh) {
  return direct_candidates(sh.g) && direct_rays_cands(r, l);
}

bool Traversal::direct_rays_cands(int r, int l) {
  const size_t k_count = direct_cand_.size();
  if (k_count > size_t(p_.direct_max_candidates)) return false;
  const size_t kp = direct_load_corners();
  grow_to(direct_terms_, kTermCount * kp);
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  const auto& ro = rtree_->order();
  const auto& lo = ltree_->order();
  size_t blocked = 0, uncertain = 0;
  // One group: the segments from the origin o to the `count` end points end(k), one
  // test call for the group; done(k, hit, clear) records relation k.
  auto run_group = [&](const Vec3f& o, uint32_t count, auto&& end, auto&& done) {
    const double od[3] = {double(o.x), double(o.y), double(o.z)};
    if (k_count == 0) {  // no candidate: no triangle meets a segment (every one clear)
      for (uint32_t k = 0; k < count; ++k) done(k, false, true);
      return;
    }
    direct_terms(direct_corners_.data(), kp, od, direct_terms_.data());
    direct_d_.resize(4 * size_t(count));
    direct_out_.resize(count);
    for (uint32_t k = 0; k < count; ++k) {
      const Vec3f& e = end(k);
      double* d = direct_d_.data() + 4 * size_t(k);  // dx, dy, dz, n
      d[0] = double(e.x) - od[0];
      d[1] = double(e.y) - od[1];
      d[2] = double(e.z) - od[2];
      d[3] = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])});
    }
    direct_classify(direct_terms_.data(), kp, direct_d_.data(), count, direct_out_.data());
    for (uint32_t k = 0; k < count; ++k) done(k, direct_out_[k] == 1, direct_out_[k] == 2);
  };
  // Relation (receiver i at p, sample j, light point q) from the test's lane masks.
  auto record = [&](uint32_t i, const Vec3f& p, uint32_t j, const Vec3f* q, bool hit, bool clear) {
    bool occ = hit;
    if (!hit && !clear) {
      // Not certified: the verified Embree ray of the other path, from the receiver.
      leaf_caster(1).occluded_fan(p, q, 1, &occ);
      ++uncertain;
    }
    if (occ) ++blocked;  // bits start blocked: only visible ones are written
    else result_.receivers[i].set_visible(light_offset_ + size_t(j), true);
  };
  // The leaf's relations grouped by a shared origin of the test (its terms are computed
  // once per group): each receiver, or each light point (a sample's jitter point: at
  // most jitter per sample, whatever the receivers) when there are fewer of those. The
  // test is symmetric in the segment's ends. Receivers in chunks of about kDirectChunk
  // relations bound the scratch arrays (an automatic-ray shaft may hold millions of
  // relations). The groups go sample by sample, then by jitter point, each holding its
  // receivers in tree order.
  const uint32_t nl = L.size(), jit = uint32_t(std::max(1, light_->jitter));
  for (uint32_t c0 = R.begin, c1 = 0; c0 < R.end; c0 = c1) {
    c1 = std::min<uint32_t>(R.end, c0 + std::max<uint32_t>(1, uint32_t(kDirectChunk / nl)));
    const uint32_t nr = c1 - c0;
    if (size_t(nl) * jit >= nr) {  // by receiver: the group is the receiver's fan
      direct_q_.resize(nl);
      for (uint32_t a = c0; a < c1; ++a) {
        const uint32_t i = ro[a];
        const Vec3f& p = scene_.receivers[i].p;
        const uint64_t prefix = relation_hash_prefix(i, light_->seed);
        for (uint32_t b = 0; b < nl; ++b) direct_q_[b] = &leaf_sample_at(*light_, int(lo[L.begin + b]), prefix);
        run_group(
            p, nl, [&](uint32_t k) -> const Vec3f& { return *direct_q_[k]; },
            [&](uint32_t k, bool hit, bool clear) { record(i, p, lo[L.begin + k], direct_q_[k], hit, clear); });
      }
      continue;
    }
    // By light point: each sample's receivers sorted by the jitter point they take.
    direct_prefix_.resize(nr);
    direct_jp_.resize(nr);
    direct_members_.resize(nr);
    // The seed as a local: the stores below could alias light_->seed, which kept the
    // compiler from hoisting its half of relation_hash_prefix out of the loop.
    const uint64_t seed = light_->seed;
    for (uint32_t a = 0; a < nr; ++a) direct_prefix_[a] = relation_hash_prefix(ro[c0 + a], seed);
    for (uint32_t b = L.begin; b < L.end; ++b) {
      const uint32_t j = lo[b];
      direct_start_.assign(jit + 1, 0);
      for (uint32_t a = 0; a < nr; ++a) {
        const uint32_t jp = uint32_t(leaf_jitter_index(jit, int(j), direct_prefix_[a]));
        direct_jp_[a] = jp;
        ++direct_start_[jp + 1];
      }
      for (uint32_t g = 0; g < jit; ++g) direct_start_[g + 1] += direct_start_[g];
      direct_fill_.assign(direct_start_.begin(), direct_start_.end() - 1);
      for (uint32_t a = 0; a < nr; ++a) direct_members_[direct_fill_[direct_jp_[a]]++] = ro[c0 + a];
      for (uint32_t g = 0; g < jit; ++g) {
        const uint32_t g0 = direct_start_[g], g1 = direct_start_[g + 1];
        if (g0 == g1) continue;
        const Vec3f* q = &light_->jitter_point(int(j), int(g));
        const uint32_t* members = direct_members_.data() + g0;
        run_group(
            *q, g1 - g0, [&](uint32_t k) -> const Vec3f& { return scene_.receivers[members[k]].p; },
            [&](uint32_t k, bool hit, bool clear) {
              record(members[k], scene_.receivers[members[k]].p, j, q, hit, clear);
            });
      }
    }
  }
  const double rel = double(R.size()) * double(L.size());
  n_rays_ += rel;
  n_rays_blocked_ += double(blocked);
  n_direct_ += rel;
  n_direct_uncertain_ += double(uncertain);
  return true;
}

// Cell shafts: see traversal.h (cell_rays). Per receiver p of R, the candidates' terms
// from p once; then the light subtree of L from the top, each node Q a shaft from the
// point p to Q's box, decided by cell_classify against the candidates its parent left
// mixed (a candidate missing the parent's box misses Q's, a subset). Blocked: one
// candidate blocks every segment from p into the box (the relations' light points lie
// in it: each sample's jitter box is in its node's box); visible: every candidate
// misses every such segment, and the candidates are every triangle that may meet the
// shaft sh, which holds these segments. A light-tree leaf left mixed gets the direct
// test per relation against its mixed candidates (those its cells did not clear), and
// Embree for what that test cannot certify.
bool Traversal::cell_rays(int r, int l, const Shaft& sh) {
  if (!direct_candidates(sh.g, true)) return false;
  const size_t k_count = direct_cand_.size();
  const bool cull = k_count > size_t(p_.cell_max_candidates);
  if (cull && (!p_.cell_backfaces || k_count <= size_t(p_.direct_max_candidates))) return direct_rays_cands(r, l);
  if (cell_levels_.empty()) cell_levels_.emplace_back();
  if (p_.cell_patches && patch_of_.empty()) {
    patch_of_.assign(mesh_.triangles.size(), kPatchUnknown);
    patch_edges_.assign(mesh_.triangles.size(), 7);
  }
  const TreeNode& R = rn(r);
  if (cull) {
    // Too many candidates: without the faces of closed star-shaped surfaces turned
    // strictly away from every receiver (cull_back_faces at the receiver node box's
    // corners, one value on a flat axis), cells when few enough are left, else the
    // direct test or Embree rays as before. A segment from a receiver that meets a
    // dropped face also meets a kept candidate strictly inside it, so every certificate
    // over the kept candidates holds over all of them. A planar patch (cell_patch_blocks)
    // lies on one plane with one orientation and in one neighbour component: its
    // triangles are dropped all or none.
    cull_prepare();
    Vec3f corners[8];
    const int nc = distinct_box_corners(R.box, corners);
    direct_cand_ = cull_all_;
    cull_back_faces(corners, nc, R.box);
    if (direct_cand_.size() > size_t(p_.cell_max_candidates)) {
      if (!p_.cell_surfaces) return direct_rays_cands(r, l);
      cell_surface_receivers(r, l);
      return true;
    }
    n_cull_decided_ += double(R.size()) * double(ln(l).size());
  }
  const size_t kp = load_cell_top();
  const auto& ro = rtree_->order();
  for (uint32_t a = R.begin; a < R.end; ++a) cell_receiver(l, ro[a], kp);
  return true;
}

// direct_cand_'s corners loaded (direct_load_corners) and the candidates made the top
// cell level; returns its padded count.
size_t Traversal::load_cell_top() {
  const size_t kp = direct_load_corners();
  CellLevel& top = cell_levels_[0];
  grow_to(top.terms, kCellTermCount * kp);
  top.count = direct_cand_.size();
  top.kp = kp;
  top.tris = direct_cand_;
  return kp;
}

void Traversal::cell_receiver(int l, uint32_t i, size_t kp) {
  const Vec3f& p = scene_.receivers[i].p;
  const double od[3] = {double(p.x), double(p.y), double(p.z)};
  if (p_.cell_cache && cell_cache_ok_) {
    if (cell_cache_blocks(ln(l).box, od)) {
      const double n = double(ln(l).size());  // bits start blocked
      n_cells_ += 1;
      n_blocked_shaft_ += n;
      n_cell_decided_ += n;
      n_cell_cache_decided_ += n;
      return;
    }
    // Tried again only after a node cell blocks anew (cell_cache_store): a run of
    // receivers behind one wall ends at its first miss.
    cell_cache_ok_ = false;
  }
  if (cell_levels_[0].count > 0) cell_terms(direct_corners_.data(), kp, od, cell_levels_[0].terms.data());
  cell_uncertain_.clear();
  cell_descend(l, 0, i, od, relation_hash_prefix(i, light_->seed));
  if (!cell_uncertain_.empty()) fan_rays(i, cell_uncertain_.data(), cell_uncertain_.size());
}

// The leaf's candidates (direct_cand_) on closed star-shaped surfaces, with their
// planes, into cull_faces_; the others into cull_all_.
void Traversal::cull_prepare() {
  if (closed_of_.empty()) closed_of_.assign(mesh_.triangles.size(), kPatchUnknown);
  cull_all_.clear();
  cull_faces_.clear();
  for (uint32_t t : direct_cand_) {
    if (closed_of_[t] == kPatchUnknown) flood_closed_surface(t);
    if (closed_of_[t] == kNoPatch) {
      cull_all_.push_back(t);
      continue;
    }
    const Vec3d a = to_double(mesh_.corner(t, 0)), A = to_double(mesh_.corner(t, 1)) - a,
                C = to_double(mesh_.corner(t, 2)) - a;
    CullFace f;
    f.t = t;
    f.surface = closed_of_[t];
    f.a = a;
    f.n = cross(A, C);
    f.perm = Vec3d(std::abs(A.y * C.z) + std::abs(A.z * C.y), std::abs(A.z * C.x) + std::abs(A.x * C.z),
                   std::abs(A.x * C.y) + std::abs(A.y * C.x));
    cull_faces_.push_back(f);
  }
}

// Closed star-shaped surfaces: the triangles reached from t0 over neighbour pairs
// (mesh::PreparedTriangle::neighbors, each pair traversing its edge in opposite
// directions and naming each other) form one when every edge of every one of them has
// such a pair, so their sum is an oriented 2-cycle without boundary, and its vertices'
// centroid c (rounded to float) lies strictly behind every face's plane (exact
// orientation). Then the winding number w of the cycle is >= 0 off the surface: along
// a generic ray from a point y away from c every crossing leaves a face's plane on the
// side away from c, so each lowers w by one on the way to w = 0 far away, and w(y) is
// their count. Where it fails, the triangles get kNoPatch.
void Traversal::flood_closed_surface(uint32_t t0) {
  const uint32_t id = uint32_t(closed_.size());
  closed_stack_.assign(1, t0);
  cull_members_.clear();
  closed_of_[t0] = id;
  bool closed = true;
  AABB box;
  Vec3d sum(0, 0, 0);
  while (!closed_stack_.empty()) {
    const uint32_t t = closed_stack_.back();
    closed_stack_.pop_back();
    cull_members_.push_back(t);
    const mesh::PreparedTriangle& T = mesh_.triangles[t];
    for (int e = 0; e < 3; ++e) {
      box.extend(mesh_.corner(t, e));
      sum = sum + to_double(mesh_.corner(t, e));
      const int32_t u = T.neighbors[size_t(e)];
      bool paired = false;
      if (u >= 0) {
        const mesh::PreparedTriangle& U = mesh_.triangles[size_t(u)];
        const uint32_t va = T.v[size_t(e)], vb = T.v[size_t((e + 1) % 3)];
        for (int g = 0; g < 3; ++g)
          paired |= U.v[size_t(g)] == vb && U.v[size_t((g + 1) % 3)] == va && U.neighbors[size_t(g)] == int32_t(t);
      }
      if (!paired) {
        closed = false;
        continue;
      }
      if (closed_of_[size_t(u)] == kPatchUnknown) {
        closed_of_[size_t(u)] = id;
        closed_stack_.push_back(uint32_t(u));
      }
    }
  }
  const double n = 3.0 * double(cull_members_.size());
  const Vec3f c(float(sum.x / n), float(sum.y / n), float(sum.z / n));
  for (size_t k = 0; k < cull_members_.size() && closed; ++k) {
    const uint32_t t = cull_members_[k];
    const Vec3f &a = mesh_.corner(t, 0), &b = mesh_.corner(t, 1), &d = mesh_.corner(t, 2);
    Sign s = orient3d_filtered(a, b, d, SumPoint(c));
    if (s == Sign::Uncertain) s = orient3d_exact(a, b, d, c);
    closed = s == Sign::Negative;
  }
  if (!closed) {
    for (uint32_t t : cull_members_) closed_of_[t] = kNoPatch;
    return;
  }
  closed_.push_back(ClosedSurface{box});
}

// Appends to direct_cand_ the faces of cull_faces_ except those whose surface's box
// `box` lies strictly outside and whose plane every point of pts lies strictly behind
// (exact orientation), so every point p of the hull of pts. Why no answer changes for
// a segment from such a p: let a dropped face F
// meet the segment s = p q at a parameter t0 in (0, 1). p is strictly behind F's plane,
// so s crosses it transversally. Shift [p, p + t1 (q - p)] (t1 just above t0)
// slightly and generically: it still starts where the winding number w is 0 (outside
// the box), crosses F, and meets only faces that s meets transversally, each at an
// inner point, where w changes by one. As w >= 0, its first crossing raises w: p is
// strictly in front of that face. Faces s misses stay at a positive distance, so some
// face with p strictly in front meets s transversally at a parameter in (0, t0]: a kept
// candidate (its box meets the shaft) that blocks s whenever F does.
void Traversal::cull_back_faces(const Vec3f* pts, int np, const AABB& box) {
  cull_group_.clear();
  for (const CullFace& f : cull_faces_) {
    const AABB& b = closed_[f.surface].box;
    bool drop = box.hi.x < b.lo.x || box.lo.x > b.hi.x || box.hi.y < b.lo.y || box.lo.y > b.hi.y ||
                box.hi.z < b.lo.z || box.lo.z > b.hi.z;
    for (int k = 0; k < np && drop; ++k) {
      // orient3d(a, b, c, p) = n.(p - a) in Shewchuk's operations, within twice his
      // errboundA (7 + 56 eps) eps of the permanent; the exact sign where that is unsure.
      const Vec3d D = to_double(pts[k]) - f.a;
      const double v = dot(f.n, D);
      const double bound = 2.0 * (7.0 + 56.0 * kEps) * kEps *
                           (std::abs(D.x) * f.perm.x + std::abs(D.y) * f.perm.y + std::abs(D.z) * f.perm.z);
      drop = v < -bound || (v <= bound && orient3d_exact(mesh_.corner(f.t, 0), mesh_.corner(f.t, 1),
                                                         mesh_.corner(f.t, 2), pts[k]) == Sign::Negative);
    }
    if (drop) continue;
    direct_cand_.push_back(f.t);
    cull_group_.emplace_back(f.surface, f.t);
  }
}

// A culled leaf (cull_back_faces) still over cell_max_candidates, receiver by receiver:
// the kept faces of every closed surface whose box lies certainly outside the pyramid
// from the receiver p over the light node's box (box_outside_pyramid) are left out too.
// Such a box holds the whole surface, so each of its faces misses every segment from p
// into the box, and every certificate over the others holds over all of them. With at
// most cell_surface_candidates left, p's cells (cell_receiver); else p's relations by
// Embree rays, as the leaf's were.
void Traversal::cell_surface_receivers(int r, int l) {
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  const auto& ro = rtree_->order();
  const auto& lo = ltree_->order();
  // The kept faces grouped by surface (cull_surfaces_: the end of each one's run).
  std::sort(cull_group_.begin(), cull_group_.end());
  cull_surfaces_.clear();
  for (size_t g = 0; g < cull_group_.size(); ++g)
    if (g + 1 == cull_group_.size() || cull_group_[g + 1].first != cull_group_[g].first) cull_surfaces_.push_back(uint32_t(g + 1));
  for (uint32_t a = R.begin; a < R.end; ++a) {
    const uint32_t i = ro[a];
    const Vec3f& p = scene_.receivers[i].p;
    const double od[3] = {double(p.x), double(p.y), double(p.z)};
    double cd[4 * 8], pyr[16];
    const bool use_pyr = cell_pyramid(cd, cell_corners(L.box, od, cd), pyr);
    direct_cand_ = cull_all_;
    for (size_t g = 0, g0 = 0; g < cull_surfaces_.size(); g0 = cull_surfaces_[g++]) {
      const size_t g1 = cull_surfaces_[g];
      if (use_pyr && box_outside_pyramid(closed_[cull_group_[g0].first].box, od, pyr)) continue;
      for (size_t k = g0; k < g1; ++k) direct_cand_.push_back(cull_group_[k].second);
    }
    if (direct_cand_.size() > size_t(p_.cell_surface_candidates)) {
      fan_rays(i, lo.data() + L.begin, L.size());
      n_rays_ += double(L.size());
      continue;
    }
    cell_receiver(l, i, load_cell_top());
    n_surface_cull_decided_ += double(L.size());
  }
}

void Traversal::cell_descend(int c, size_t depth, uint32_t i, const double* od, uint64_t prefix) {
  const auto& lo = ltree_->order();
  CellLevel& lev = cell_levels_[depth];
  const size_t kc = lev.count, kp = lev.kp;
  // The node box's corners and, for a flat box, the pyramid over it (cell_pyramid: a
  // triangle whose three vertices are certainly negative for one side plane misses
  // every segment from p into the box; cell_classify's pyr).
  double cd[4 * 8], pyr[16], bx[7];
  const int nc = kc > 0 ? cell_corners(ln(c).box, od, cd) : 0;
  const bool use_pyr = kc > 0 && cell_pyramid(cd, nc, pyr);
  const TreeNode& Q = ln(c);
  n_cells_ += 1;
  cell_out_.resize(kp / 4);
  // The kernels write one byte of miss bits (at most 15) per vector they finish and
  // return at the first vector with a block: the first byte left at 0xff names it.
  const bool cache = depth == 0 && p_.cell_cache;
  if (cache) std::fill(cell_out_.begin(), cell_out_.end(), uint8_t(0xff));
  if (kc > 0 && p_.cell_centre) cell_box(Q.box, od, bx);
  if (kc > 0 && (p_.cell_centre ? cell_box_classify(lev.terms.data(), kp, bx, use_pyr ? pyr : nullptr, cell_out_.data())
                                : cell_classify(lev.terms.data(), kp, cd, nc, use_pyr ? pyr : nullptr, cell_out_.data()))) {
    n_blocked_shaft_ += double(Q.size());  // bits start blocked
    n_cell_decided_ += double(Q.size());
    if (cache) {
      const auto v = std::find(cell_out_.begin(), cell_out_.end(), uint8_t(0xff));
      if (v != cell_out_.end()) cell_cache_store(lev, size_t(v - cell_out_.begin()));
    }
    return;
  }
  auto is_mixed = [&](size_t k) { return ((cell_out_[k >> 2] >> (k & 3)) & 1) == 0; };
  size_t mixed = 0;
  for (size_t k = 0; k < kc; ++k) mixed += is_mixed(k);
  if (mixed == 0) {
    ReceiverResult& rr = result_.receivers[i];
    for (uint32_t b = Q.begin; b < Q.end; ++b) rr.set_visible(light_offset_ + size_t(lo[b]), true);
    n_empty_ += double(Q.size());
    n_cell_decided_ += double(Q.size());
    return;
  }
  // The mixed candidates' terms, compacted for the level below (padding lanes repeat
  // the last one): all of them for cells below, the direct test's alone for a leaf.
  const bool descend = int(depth) < p_.cell_depth;
  const size_t nterms = descend && !Q.is_leaf ? size_t(kCellTermCount) : size_t(kTermCount);
  if (cell_levels_.size() <= depth + 1) cell_levels_.emplace_back();
  CellLevel& next = cell_levels_[depth + 1];
  CellLevel& cur = cell_levels_[depth];  // emplace_back may have moved it
  const size_t np = (mixed + 3) & ~size_t(3);
  grow_to(next.terms, kCellTermCount * np);
  next.count = mixed;
  next.kp = np;
  next.tris.clear();
  for (size_t k = 0, o = 0; k < kc; ++k) {
    if (!is_mixed(k)) continue;
    next.tris.push_back(cur.tris[k]);
    for (size_t f = 0; f < nterms; ++f) next.terms[f * np + o] = cur.terms[f * kp + k];
    ++o;
  }
  for (size_t o = mixed; o < np; ++o)
    for (size_t f = 0; f < nterms; ++f) next.terms[f * np + o] = next.terms[f * np + mixed - 1];
  if (mixed > 1 && p_.cell_patches && cell_patch_blocks(next, cd, nc)) {
    n_blocked_shaft_ += double(Q.size());
    n_cell_decided_ += double(Q.size());
    n_cell_patch_decided_ += double(Q.size());
    return;
  }
  if (descend && !Q.is_leaf) {
    ScopedTimer t(times_[kTree]);
    ltree_->split(c);
  }
  if (descend && ln(c).split_done()) {
    const int left = ln(c).left, right = ln(c).right;
    cell_descend(left, depth + 1, i, od, prefix);
    cell_descend(right, depth + 1, i, od, prefix);
    return;
  }
  // A light-tree leaf left mixed: each relation by the direct test against the mixed
  // candidates (the others miss every segment into the leaf's box), Embree where the
  // test cannot certify. With cell_groups, a node of more than cell_group_samples
  // samples with at most cell_group_candidates mixed candidates first takes a cell at
  // each group of that many samples (cell_group).
  const TreeNode& QL = ln(c);
  if (!p_.cell_groups || QL.size() <= uint32_t(p_.cell_group_samples) ||
      mixed > size_t(p_.cell_group_candidates)) {
    cell_direct(next, lo.data() + QL.begin, QL.size(), od, prefix, i);
    return;
  }
  cell_samples_.clear();
  const uint32_t g = uint32_t(p_.cell_group_samples);
  const std::vector<AABB>& boxes = cell_group_boxes(c);
  const size_t h = cell_group_heap_size();
  for (uint32_t b = QL.begin, k = 0; b < QL.end; b += g, ++k)
    cell_group(next, b, std::min(QL.end, b + g), boxes.data() + k * h, 0, od, i);
  cell_direct(next, cell_samples_.data(), uint32_t(cell_samples_.size()), od, prefix, i);
}

// cell_cache: the candidate vector `vec` of lev (four lanes, those past its count
// repeating the last candidate, as load_cell_top pads them) as the light's cached
// blockers.
void Traversal::cell_cache_store(const CellLevel& lev, size_t vec) {
  load_corner_lanes(mesh_, lev.tris.data(), lev.count, 4 * vec, 4, cell_cache_c_);
  cell_cache_ok_ = true;
}

// The node cell's block certificate (cell_descend's, at the box's corners or from its
// centre) for the cached vector alone: a triangle that certainly crosses every segment
// from od into the box blocks every relation of the cell, whatever the other
// candidates are, so the cached triangles need not be among this leaf's.
bool Traversal::cell_cache_blocks(const AABB& box, const double* od) {
  double t[kCellTermCount * 4], cd[4 * 8], bx[7];
  uint8_t out[1];
  cell_terms(cell_cache_c_, 4, od, t);
  if (p_.cell_centre) {
    cell_box(box, od, bx);
    return cell_box_classify(t, 4, bx, nullptr, out);
  }
  return cell_classify(t, 4, cd, cell_corners(box, od, cd), nullptr, out);
}

// A group of a mixed cell's samples (cell_groups: light-tree order positions b..e of the
// cell's light node, at most cell_group_samples of them): a cell at the union of their
// jitter boxes (heap[node]), which holds every relation's light point, against the
// cell's mixed candidates lev by cell_pairs (cell_classify's certificates over the box:
// blocked when one candidate blocks every segment from p into the box, visible when
// each misses them all; the candidates lev leaves out miss every segment into the whole
// node box). Else, above cell_group_min samples, its two halves the same way (heap
// nodes 2 node + 1 and 2 node + 2), else its samples go to cell_samples_ for the direct
// test. A node's order below packet size is order_for_packets' (halves at multiples of 8
// on the longest axis), so groups of 8, 16 or 32 from the node's start are cells of the
// light's grid; any other grouping is as exact, only looser.
void Traversal::cell_group(const CellLevel& lev, uint32_t b, uint32_t e, const AABB* heap, size_t node,
                           const double* od, uint32_t i) {
  const auto& lo = ltree_->order();
  const AABB& box = heap[node];
  double cd[4 * 8];
  n_cells_ += 1;
  cell_out_.resize(lev.kp / 4);
  uint8_t* out = cell_out_.data();
  const double n = double(e - b);
  bool blocked;
  if (p_.cell_group_centre) {
    cell_box(box, od, cd);
    blocked = cell_box_pairs(lev.terms.data(), lev.kp, cd, out);
  } else {
    blocked = cell_pairs(lev.terms.data(), lev.kp, cd, cell_corners(box, od, cd), out);
  }
  if (blocked) {
    n_blocked_shaft_ += n;
    n_cell_decided_ += n;
    n_group_decided_ += n;
    return;
  }
  bool all_miss = true;
  for (size_t k = 0; k < lev.count && all_miss; ++k) all_miss = ((out[k >> 2] >> (k & 3)) & 1) != 0;
  if (all_miss) {
    ReceiverResult& rr = result_.receivers[i];
    for (uint32_t s = b; s < e; ++s) rr.set_visible(light_offset_ + size_t(lo[s]), true);
    n_empty_ += n;
    n_cell_decided_ += n;
    n_group_decided_ += n;
    return;
  }
  if (e - b > uint32_t(p_.cell_group_min)) {
    const uint32_t m = b + (e - b + 1) / 2;
    cell_group(lev, b, m, heap, 2 * node + 1, od, i);
    cell_group(lev, m, e, heap, 2 * node + 2, od, i);
    return;
  }
  cell_samples_.insert(cell_samples_.end(), lo.begin() + b, lo.begin() + e);
}

// The size of cell_group's box heap for groups of cell_group_samples samples down to
// halves of at most cell_group_min: node 0 the group, nodes 2 n + 1 and 2 n + 2 the
// halves of node n (the first half the larger, so the deepest).
size_t Traversal::cell_group_heap_size() const {
  size_t levels = 1;
  for (uint32_t s = uint32_t(p_.cell_group_samples); s > uint32_t(p_.cell_group_min); s = (s + 1) / 2) ++levels;
  return (size_t(1) << levels) - 1;
}

void Traversal::cell_group_fill(uint32_t b, uint32_t e, AABB* heap, size_t node) const {
  heap[node] = jitter_union(b, e);
  if (e - b <= uint32_t(p_.cell_group_min)) return;
  const uint32_t m = b + (e - b + 1) / 2;
  cell_group_fill(b, m, heap, 2 * node + 1);
  cell_group_fill(m, e, heap, 2 * node + 2);
}

// The box heaps (cell_group_heap_size each) of cell_group's first groups of light node c
// (cell_group_samples samples each from its start, in light-tree order), once per node:
// its order stays as it is until the node is split, and then they are taken anew each
// time.
const std::vector<AABB>& Traversal::cell_group_boxes(int c) {
  const TreeNode& Q = ln(c);
  const bool keep = !Q.split_done();
  if (keep) {
    auto it = group_boxes_.find(c);
    if (it != group_boxes_.end()) return it->second;
  }
  const uint32_t g = uint32_t(p_.cell_group_samples);
  const size_t h = cell_group_heap_size();
  std::vector<AABB>& out = keep ? group_boxes_[c] : group_scratch_;
  out.assign(h * ((Q.size() + g - 1) / g), AABB());
  for (uint32_t b = Q.begin, k = 0; b < Q.end; b += g, ++k)
    cell_group_fill(b, std::min(Q.end, b + g), out.data() + k * h, 0);
  return out;
}

// The union of the jitter boxes of the light samples at light-tree order positions b..e.
AABB Traversal::jitter_union(uint32_t b, uint32_t e) const {
  const auto& lo = ltree_->order();
  AABB box;
  for (uint32_t s = b; s < e; ++s) box.extend(light_->jitter_boxes[lo[s]]);
  return box;
}

// The direct test per relation of receiver i and the light samples js against the
// candidates of lev (their first kTermCount term arrays), Embree for what it cannot
// certify (cell_uncertain_).
void Traversal::cell_direct(const CellLevel& lev, const uint32_t* js, uint32_t count, const double* od,
                            uint64_t prefix, uint32_t i) {
  direct_d_.resize(4 * size_t(count));
  direct_out_.resize(count);
  for (uint32_t k = 0; k < count; ++k) {
    const Vec3f& e = leaf_sample_at(*light_, int(js[k]), prefix);
    double* d = direct_d_.data() + 4 * size_t(k);
    d[0] = double(e.x) - od[0];
    d[1] = double(e.y) - od[1];
    d[2] = double(e.z) - od[2];
    d[3] = std::max({std::abs(d[0]), std::abs(d[1]), std::abs(d[2])});
  }
  direct_classify(lev.terms.data(), lev.kp, direct_d_.data(), count, direct_out_.data());
  ReceiverResult& rr = result_.receivers[i];
  size_t blocked = 0;
  for (uint32_t k = 0; k < count; ++k) {
    const uint32_t j = js[k];
    if (direct_out_[k] == 1) ++blocked;
    else if (direct_out_[k] == 2) rr.set_visible(light_offset_ + size_t(j), true);
    else cell_uncertain_.push_back(j);  // fan_rays counts their blocked ones
    n_direct_uncertain_ += direct_out_[k] == 0;
  }
  n_rays_ += double(count);
  n_rays_blocked_ += double(blocked);
  n_direct_ += double(count);
}

// Planar patches of the mesh for cell_patch_blocks, on first need of a triangle: its
// whole patch by a flood over its interior edges (patch_of_, patch_edges_), so once per
// solve and only where cells look. An edge is interior when exactly two triangles use it
// (mesh::PreparedTriangle::neighbors), their four vertices are exactly coplanar and the
// two third vertices lie strictly on opposite sides of it in that plane (orient2d_exact
// in a projection where the first triangle is not flat): near it the two closed
// triangles cover the plane on both sides. Every other edge is a boundary edge (bit e of
// patch_edges_). A triangle alone in its patch gets kNoPatch.
bool Traversal::patch_interior_edge(uint32_t t, int e) const {
  const mesh::PreparedTriangle& T = mesh_.triangles[t];
  const int32_t u = T.neighbors[size_t(e)];
  if (u < 0) return false;
  const mesh::PreparedTriangle& U = mesh_.triangles[size_t(u)];
  const uint32_t va = T.v[size_t(e)], vb = T.v[size_t((e + 1) % 3)];
  int f = -1;
  for (int g = 0; g < 3; ++g)
    if (U.v[size_t(g)] == vb && U.v[size_t((g + 1) % 3)] == va) f = g;
  if (f < 0) return false;
  const Vec3f &a = mesh_.vertex_pos[va], &b = mesh_.vertex_pos[vb];
  const Vec3f c1 = mesh_.corner(t, (e + 2) % 3), c2 = mesh_.corner(size_t(u), (f + 2) % 3);
  // An axis on which all four agree (a box's face) makes them coplanar; otherwise only
  // a pair whose double determinant is zero gets the exact test (its expansion
  // arithmetic is slow on nearly planar quads, such as a sphere's). A coplanar pair left
  // apart only leaves a smaller patch.
  bool flat = false;
  for (int ax = 0; ax < 3; ++ax) flat |= a[ax] == b[ax] && a[ax] == c1[ax] && a[ax] == c2[ax];
  if (!flat && (orient3d(to_double(a), to_double(b), to_double(c1), to_double(c2)) != 0.0 ||
                orient3d_exact(a, b, c1, c2) != Sign::Zero))
    return false;
  for (int ax = 0; ax < 3; ++ax) {
    const int i = (ax + 1) % 3, j = (ax + 2) % 3;
    const Sign s1 = orient2d_exact(a[i], a[j], b[i], b[j], c1[i], c1[j]);
    if (s1 == Sign::Zero) continue;
    return to_int(s1) == -to_int(orient2d_exact(a[i], a[j], b[i], b[j], c2[i], c2[j]));
  }
  return false;
}

void Traversal::flood_cell_patch(uint32_t t0) {
  patch_stack_.assign(1, t0);
  patch_of_[t0] = t0;
  size_t size = 0;
  while (!patch_stack_.empty()) {
    const uint32_t t = patch_stack_.back();
    patch_stack_.pop_back();
    ++size;
    uint8_t boundary = 7;
    for (int e = 0; e < 3; ++e) {
      if (!patch_interior_edge(t, e)) continue;
      boundary &= uint8_t(~(1u << e));
      const uint32_t u = uint32_t(mesh_.triangles[t].neighbors[size_t(e)]);
      if (patch_of_[u] == kPatchUnknown) {
        patch_of_[u] = t0;
        patch_stack_.push_back(u);
      }
    }
    patch_edges_[t] = boundary;
  }
  if (size == 1) patch_of_[t0] = kNoPatch;
}

// The connected-surface certificate of a mixed cell (paper 000 section 4.8's merged
// patches, for a point-to-box shaft): the mixed candidates of one planar patch block
// every segment from p into Q when the patch's plane separates p from Q, none of their
// boundary edges meets a segment, and one corner segment crosses one of them inside
// (cell_patch_flags); lev: the mixed candidates (those cell_classify did not clear). The
// segments' crossings with the plane form a convex, connected
// set P'. Every patch triangle meeting P' is a mixed candidate (the others miss every
// segment or lie outside the leaf shaft), so no boundary edge of the patch meets P';
// around a point of P' in a patch triangle, the interior edges' triangle pairs then
// cover the plane, so the covered part of P' is open and closed in P', and not empty: it
// is all of P'. Each segment crosses the closed patch strictly between its ends.
bool Traversal::cell_patch_blocks(const CellLevel& lev, const double* cd, int nc) {
  cell_members_.clear();
  for (size_t k = 0; k < lev.count; ++k) {
    if (patch_of_[lev.tris[k]] == kPatchUnknown) flood_cell_patch(lev.tris[k]);
    const uint32_t pt = patch_of_[lev.tris[k]];
    if (pt != kNoPatch) cell_members_.emplace_back(pt, uint32_t(k));
  }
  std::sort(cell_members_.begin(), cell_members_.end());
  // One mixed triangle of a patch certifies nothing that cell_classify did not.
  bool pair = false;
  for (size_t g = 1; g < cell_members_.size() && !pair; ++g) pair = cell_members_[g].first == cell_members_[g - 1].first;
  if (!pair) return false;
  cell_flags_.resize(lev.kp);
  cell_patch_flags(lev.terms.data(), lev.kp, cd, nc, cell_flags_.data());
  for (size_t g0 = 0, g1 = 0; g0 < cell_members_.size(); g0 = g1) {
    bool sep = false, hit = false, edges = true;
    for (g1 = g0; g1 < cell_members_.size() && cell_members_[g1].first == cell_members_[g0].first; ++g1) {
      const uint32_t k = cell_members_[g1].second;
      const uint8_t f = cell_flags_[k];
      sep |= (f & 1) != 0;
      hit |= (f & 16) != 0;
      edges &= (uint8_t(patch_edges_[lev.tris[k]] << 1) & ~f) == 0;
    }
    if (sep && hit && edges) return true;
  }
  return false;
}

// CAST-SHADOW-RAYS. With the custom caster (section 4.10) the shaft's blockers, the
// leaf nodes' inside triangles (Figure 4.35) and, in pre-traversal, the pruned
// triangle list decide the ray.
void Traversal::cast_rays(int r, int l, const Shaft* sh, const std::vector<uint32_t>* tris) {
  ScopedTimer t(times_[kRays]);
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  // Cell shafts where the light node has a subtree and the light is not split (a
  // whole-light leaf, or automatic rays of a whole light); they hand a shaft with more
  // candidates than theirs to the direct test. A split light's automatic-ray shafts
  // (columns: up to 64 receivers x a few samples) keep the direct test grouped by light
  // point, which costs less there than terms per receiver (1.5% more on crop49).
  if (!p_.custom_rays && p_.direct_rays && direct_ok_ && sh) {
    if (p_.cell_shafts && !split_now_ && !in_trial_ && !L.is_leaf ? cell_rays(r, l, *sh) : direct_rays(r, l, *sh)) return;
  }
  if (!p_.custom_rays && p_.ray_queue && L.size() < kFanWidth) {
    queue_rays(r, l);
    return;
  }
  const auto& ro = rtree_->order();
  const auto& lo = ltree_->order();
  size_t blocked = 0;
  for (uint32_t a = R.begin; a < R.end; ++a) {
    uint32_t i = ro[a];
    if (p_.custom_rays) {
      ReceiverResult& rr = result_.receivers[i];
      const Vec3f& rp = scene_.receivers[i].p;
      for (uint32_t b = L.begin; b < L.end; ++b) {
        int j = int(lo[b]);
        bool occ = custom_occluded(rp, sample_position(*light_, j, i), R, L, sh, tris);
        rr.set_visible(light_offset_ + size_t(j), !occ);
        n_rays_blocked_ += occ;
      }
      continue;
    }
    fan_rays(i, lo.data() + L.begin, L.size());
  }
  n_rays_ += double(R.size()) * double(L.size());
  n_rays_blocked_ += double(blocked);
}

// Asked at each ray past min_rays until it upgrades: the rays so far over the relations
// decided so far estimate the share of the rest (a cost estimate; the answers are the same).
void Traversal::leaf_caster_upgrade() {
  const double decided = std::max(1.0, decided_relations());
  if (embree_rays_ * upgrade_relations_ < upgrade_rays_ * decided) return;
  embree_ = upgrade_();
  upgrade_ = nullptr;
  embree_upgraded_ = true;
}

// The standard caster: the receiver's segments to the samples form a coherent fan,
// traced kFanWidth at a time as one Embree packet (occluded_fan).
void Traversal::fan_rays(uint32_t i, const uint32_t* samples, size_t count) {
  ReceiverResult& rr = result_.receivers[i];
  const Vec3f& rp = scene_.receivers[i].p;
  const uint64_t prefix = relation_hash_prefix(i, light_->seed);
  size_t blocked = 0;
  for (size_t b0 = 0; b0 < count; b0 += kFanWidth) {
    int n = int(std::min<size_t>(kFanWidth, count - b0));
    Vec3f to[kFanWidth];
    bool occ[kFanWidth];
    for (int k = 0; k < n; ++k) to[k] = leaf_sample_at(*light_, int(samples[b0 + size_t(k)]), prefix);
    leaf_caster(n).occluded_fan(rp, to, n, occ);
    for (int k = 0; k < n; ++k) {
      // Bits start blocked (make_empty_result): only visible ones are written.
      if (!occ[k]) rr.set_visible(light_offset_ + size_t(samples[b0 + size_t(k)]), true);
      blocked += occ[k];
    }
  }
  n_rays_blocked_ += double(blocked);
}

void Traversal::cast_light(size_t li) {
  ScopedTimer t(times_[kRays]);
  light_ = &scene_.lights[li];
  light_offset_ = scene_.light_offset(li);
  light_samples_.resize(size_t(std::max(0, light_->samples)));
  for (size_t j = 0; j < light_samples_.size(); ++j) light_samples_[j] = uint32_t(j);
  for (size_t i = 0; i < scene_.receivers.size(); ++i) fan_rays(uint32_t(i), light_samples_.data(), light_samples_.size());
  n_rays_ += double(scene_.receivers.size()) * double(light_samples_.size());
  n_dense_lights_ += 1;
}

void Traversal::queue_rays(int r, int l) {
  const TreeNode& L = ln(l);
  PendingRays& p = pending_[r];
  p.ranges.emplace_back(L.begin, L.end);
  p.samples += L.size();
  n_rays_ += double(rn(r).size()) * double(L.size());
  if (p.samples >= kFanWidth) flush_rays(r);
}

void Traversal::flush_rays(int r) {
  auto it = pending_.find(r);
  if (it == pending_.end()) return;
  const auto& lo = ltree_->order();
  pending_samples_.clear();
  for (auto [b, e] : it->second.ranges) pending_samples_.insert(pending_samples_.end(), lo.begin() + b, lo.begin() + e);
  pending_.erase(it);
  const TreeNode& R = rn(r);
  const auto& ro = rtree_->order();
  for (uint32_t a = R.begin; a < R.end; ++a) fan_rays(ro[a], pending_samples_.data(), pending_samples_.size());
}

void Traversal::flush_all_rays() {
  ScopedTimer t(times_[kRays]);
  while (!pending_.empty()) flush_rays(pending_.begin()->first);
}

bool Traversal::custom_occluded(const Vec3f& rpf, const Vec3f& lpf, const TreeNode& R, const TreeNode& L, const Shaft* sh,
                     const std::vector<uint32_t>* tris) {
  Vec3d rp = to_double(rpf), lp = to_double(lpf);
  auto hits = [&](uint32_t t) {
    return segment_hits_triangle_d(rp, lp, to_double(mesh_.corner(t, 0)), to_double(mesh_.corner(t, 1)),
                                   to_double(mesh_.corner(t, 2)));
  };
  if (!sh) {
    for (uint32_t t : *tris)
      if (hits(t)) return true;
    return false;
  }
  for (uint32_t t : R.inside)
    if (hits(t)) return true;
  for (uint32_t t : L.inside)
    if (hits(t)) return true;
  // BLOCKS-RAY clamps a surface's boundary to the segment's extent on the main axis.
  // Rays of the shaft start and end inside the node boxes, not on the clip planes (the
  // boxes' outer faces), so a surface may reach past an endpoint's level; clamping then
  // flattens that part onto the endpoint's plane, right at the endpoint, where the
  // winding's signs are decided by rounding. A surface entirely beyond an endpoint's
  // level cannot meet the segment (one
  // touching that level can meet it only at the endpoint, which does not block); one
  // reaching past it is left to the ray.
  const int ax = sh->g.main_axis();
  const double lo = std::min(rp[ax], lp[ax]), hi = std::max(rp[ax], lp[ax]);
  for (const Surface& s : sh->surfaces) {
    // Where the triangles are is the hull's to say; a boundary missing the slab while
    // the hull does not (a merged or collapsed patch, Surface::hull) leaves the ray.
    if (misses_slab(s.hull, ax, lo, hi, lo < hi)) continue;
    if (misses_slab(s.box, ax, lo, hi, lo < hi) || s.box.lo[ax] < lo || s.box.hi[ax] > hi) {
      ++n_fallback_;
      return leaf_caster(1).occluded(rpf, lpf);
    }
    if (blocks_ray(ctx_, s, ax, rp, lp)) return true;
  }
  for (const AABBd& gb : sh->ghosts) {
    if (segment_may_hit_box(rp, lp, gb, 0x1p-40 * scale_)) {
      ++n_fallback_;
      return leaf_caster(1).occluded(rpf, lpf);
    }
  }
  return false;
}

}  // namespace visgate::iss
