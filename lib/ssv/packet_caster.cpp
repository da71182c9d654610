// Shared-origin packet rays (see packet_caster.h).
#include "lib/ssv/packet_caster.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__GNUC__) && defined(__x86_64__)
#include <immintrin.h>
#define VG_SSV_PACKET_AVX2 1
#endif

#include "lib/base/cpu_features.h"

namespace visgate::ssv {

namespace {

// What walk_group reads of the caster.
struct PacketWalk {
  const PacketCaster::Node* nodes;
  const PacketCaster::Leaf* leaves;
};

#if defined(VG_SSV_PACKET_AVX2)
// Every function of the AVX2 build gets the avx2 target: GCC by its target pragma, clang
// (the libFuzzer build), which ignores that pragma, by an attribute on each function.
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
namespace avx2_build {
#define VG_PACKET_MOVEMASK(m) _mm256_movemask_ps(reinterpret_cast<__m256>(m))
#define VG_MIN8(a, b) _mm256_min_ps(a, b)
#define VG_MAX8(a, b) _mm256_max_ps(a, b)
#include "lib/ssv/packet_leaf_kernel.inc"
#undef VG_PACKET_MOVEMASK
#undef VG_MIN8
#undef VG_MAX8
}  // namespace avx2_build
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

namespace default_build {
#if defined(__SSE2__)
// The two 4-lane halves' sign bits.
#define VG_PACKET_MOVEMASK(m)                                                                            \
  (_mm_movemask_ps(reinterpret_cast<__m128>(__builtin_shufflevector(m, m, 0, 1, 2, 3))) |                \
   (_mm_movemask_ps(reinterpret_cast<__m128>(__builtin_shufflevector(m, m, 4, 5, 6, 7))) << 4))
#else
#define VG_PACKET_MOVEMASK(m)                                                                            \
  ((m[0] & 1) | (m[1] & 2) | (m[2] & 4) | (m[3] & 8) | (m[4] & 16) | (m[5] & 32) | (m[6] & 64) | (m[7] & 128))
#endif
// minps / maxps lane by lane: a < b ? a : b and a > b ? a : b (the second operand where
// either is NaN), which the AVX2 build's _mm256_min_ps / _mm256_max_ps compute.
#define VG_MIN8(a, b) ((a) < (b) ? (a) : (b))
#define VG_MAX8(a, b) ((a) > (b) ? (a) : (b))
#include "lib/ssv/packet_leaf_kernel.inc"
#undef VG_PACKET_MOVEMASK
#undef VG_MIN8
#undef VG_MAX8
}  // namespace default_build

#if defined(VG_SSV_PACKET_AVX2)
// The AVX2 build where the processor has it and VISGATE_SSV_NO_AVX2 is unset.
const bool kPacketAvx2 = avx2_enabled("VISGATE_SSV_NO_AVX2");
#endif

bool within(const Vec3f& v, float b) {
  return std::fabs(v.x) <= b && std::fabs(v.y) <= b && std::fabs(v.z) <= b;  // false for NaN
}

}  // namespace

uint64_t packet_leaf_test(const PacketCaster::Leaf& leaf, const Vec3f& p, const PacketGroup& g, uint64_t active,
                          uint64_t& undecided, float bound_scale) {
#if defined(VG_SSV_PACKET_AVX2)
  if (kPacketAvx2) return avx2_build::leaf_test_entry(leaf, p, g, active, undecided, bound_scale);
#endif
  return default_build::leaf_test_entry(leaf, p, g, active, undecided, bound_scale);
}

uint64_t packet_box_test(const Vec3f& lo, const Vec3f& hi, const Vec3f& p, const PacketGroup& g, uint64_t mask) {
#if defined(VG_SSV_PACKET_AVX2)
  if (kPacketAvx2) return avx2_build::box_test_entry(lo, hi, p, g, mask);
#endif
  return default_build::box_test_entry(lo, hi, p, g, mask);
}

PacketCaster::PacketCaster(const TriangleSoup& soup, float bound) : bound_(bound) {
  std::vector<AABB> boxes(soup.size());
  for (size_t t = 0; t < soup.size(); ++t) {
    AABB b;
    for (int k = 0; k < 3; ++k) {
      const Vec3f v = soup.corner(t, k);
      bound_ = std::max(bound_, std::max(std::fabs(v.x), std::max(std::fabs(v.y), std::fabs(v.z))));
      b.extend(v);
    }
    boxes[t] = b;
  }
  usable_ = bound_ <= kCoordinateBound;  // false for NaN
  if (!usable_ || boxes.empty()) return;
  // Leaves of at most 8 triangles: one 8-lane test per leaf and segment.
  const accel::Bvh<float> bvh(boxes, accel::BuildRule{accel::Split::MedianAxis, 8, false});
  // The boxes grown by 2^-19 bound (box_test's error bound); growing them by delta
  // rounds each bound by at most 2^-24 (bound + delta), so they grow by at least 0.9 delta.
  const float delta = 0x1p-19f * bound_;
  nodes_.resize(bvh.node_count());
  for (uint32_t i = 0; i < bvh.node_count(); ++i) {
    const auto& nd = bvh.node(i);
    Node& out = nodes_[i];
    out.box = AABB(nd.box.lo - Vec3f(delta, delta, delta), nd.box.hi + Vec3f(delta, delta, delta));
    if (!bvh.is_leaf(nd)) {
      out.first = bvh.right(i);
      continue;
    }
    out.first = uint32_t(leaves_.size());
    Leaf leaf{};
    const auto items = bvh.leaf_items(nd);
    leaf.count = out.count = uint32_t(items.size());
    for (int lane = 0; lane < 8; ++lane) {
      const uint32_t t = items[std::min<size_t>(size_t(lane), items.size() - 1)];
      for (int k = 0; k < 3; ++k) {
        const Vec3f v = soup.corner(t, k);
        leaf.v[3 * k][lane] = v.x, leaf.v[3 * k + 1][lane] = v.y, leaf.v[3 * k + 2][lane] = v.z;
      }
    }
    leaves_.push_back(leaf);
  }
}

void PacketCaster::cast(const Vec3f& p, const Vec3f* q, const uint8_t* order, int n, uint64_t& blocked,
                        uint64_t& undecided) const {
  blocked = 0, undecided = 0;
  const uint64_t all = n >= 64 ? ~uint64_t(0) : (uint64_t(1) << n) - 1;
  if (!usable_ || !within(p, bound_)) {
    undecided = all;
    return;
  }
  if (nodes_.empty()) return;
  const PacketWalk walk{nodes_.data(), leaves_.data()};
  for (int g0 = 0; g0 < n; g0 += kGroup) {
    const int m = std::min(kGroup, n - g0);
    PacketGroup g{};
    uint64_t active = 0, undec = 0;
    for (int k = 0; k < m; ++k) {
      const Vec3f& qk = q[order[g0 + k]];
      if (!within(qk, bound_) || qk == p) {
        undec |= uint64_t(1) << k;  // beyond the bound, or no segment: the caller's ray decides
        continue;
      }
      // d = fl(q - p): the kernels' difference (packet_leaf_kernel.inc).
      const float dx = qk.x - p.x, dy = qk.y - p.y, dz = qk.z - p.z;
      g.dx[k] = dx, g.dy[k] = dy, g.dz[k] = dz;
      g.dmax[0] = std::max(g.dmax[0], std::fabs(dx));
      g.dmax[1] = std::max(g.dmax[1], std::fabs(dy));
      g.dmax[2] = std::max(g.dmax[2], std::fabs(dz));
      const float kTiny = 0x1p-60f;
      if (std::fabs(dx) >= kTiny && std::fabs(dy) >= kTiny && std::fabs(dz) >= kTiny) {
        g.ix[k] = 1.0f / dx, g.iy[k] = 1.0f / dy, g.iz[k] = 1.0f / dz;
        g.slab |= uint64_t(1) << k;
      }
      active |= uint64_t(1) << k;
    }
    uint64_t group_blocked;
#if defined(VG_SSV_PACKET_AVX2)
    if (kPacketAvx2)
      group_blocked = avx2_build::walk_group(walk, p, g, active, undec);
    else
#endif
      group_blocked = default_build::walk_group(walk, p, g, active, undec);
    undec &= ~group_blocked;
    for (int k = 0; k < m; ++k) {
      blocked |= uint64_t(group_blocked >> k & 1u) << order[g0 + k];
      undecided |= uint64_t(undec >> k & 1u) << order[g0 + k];
    }
  }
}

}  // namespace visgate::ssv
