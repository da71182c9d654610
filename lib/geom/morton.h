// Morton (Z-order) codes: the one bit spread that BVH builds, the SSV edge tree and
// plucker-bsp's spatial orders share. Each caller picks its own axis order.
#pragma once

#include <cstdint>

namespace visgate {

// The low 10 bits of x spread to every third bit (bit i to bit 3i), 30 bits in all.
constexpr uint32_t morton_spread10(uint32_t x) {
  x &= 0x3ffu;
  x = (x | (x << 16)) & 0x030000ffu;
  x = (x | (x << 8)) & 0x0300f00fu;
  x = (x | (x << 4)) & 0x030c30c3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}
static_assert(morton_spread10(0x3ffu) == 0x09249249u && morton_spread10(0x5u) == 0x41u);

}  // namespace visgate
