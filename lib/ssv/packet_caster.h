// Shared-origin packet rays for SSV's receivers answered by rays (ray_solve, edge_rays):
// the up to 64 segments from one receiver p to the light's sample points walk a triangle
// BVH together, each node with the mask of the segments whose slab test meets its box,
// each leaf testing its 8 triangles at a time against each of those segments (the edge
// functions' normals and the plane are computed once per leaf and receiver).
//
// Guarantee: exact where it answers. A segment p q is reported blocked only when some
// triangle's three edge functions w_e = (q - p) . N_e (N_a = B x C, N_b = C x A,
// N_c = A x B with A, B, C the corners less p) certainly share one strict sign and the
// plane crossing t = det / (w_a + w_b + w_c), det = A . (B x C), certainly lies strictly
// inside (0, 1); reported visible only when every triangle in a leaf whose box the
// segment may meet is certainly missed (two edge functions of strictly opposite signs,
// or the crossing certainly outside (0, 1]), the box test being conservative. Each sign
// is certified by Shewchuk's orient3d forward bound (each w_e and det is an orient3d of
// float differences; packet_leaf_kernel.inc). Every other segment is `undecided`: the
// caller casts it (the verified Embree ray), so an answer differs from the ray's only
// where the ray itself misjudges a relation within float rounding of a degeneracy.
// Segments along an edge shared by two triangles stay undecided (neither triangle alone
// certifies them); foliage: 24 of 65,536.
//
// The AVX2 build of the kernels (chosen at run time; VISGATE_SSV_NO_AVX2 selects the
// SSE2 build) performs the same float operations in the same order (no FMA; the build
// has -ffp-contract=off): the same bits, the same answers.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/scene/scene.h"

namespace visgate::ssv {

class PacketCaster {
 public:
  // Largest coordinate magnitude it accepts (mesh, receivers, light points): products of
  // three differences stay below 2^9 (2^30)^3 = 2^99, far from float overflow.
  static constexpr float kCoordinateBound = 0x1p30f;
  // Segments per walk of the BVH (the masks' width).
  static constexpr int kGroup = 64;

  // `soup` need not outlive the caster (the corners are copied into the leaves).
  // `bound`: the largest coordinate magnitude of the segments' end points to come (the
  // caster takes the larger of it and the mesh's; a segment beyond it comes back
  // undecided). The boxes' error bound grows with it.
  PacketCaster(const TriangleSoup& soup, float bound);

  // False when the bound exceeds kCoordinateBound (or is not finite): cast nothing.
  bool usable() const { return usable_; }

  // The segments p -> q[k], k < n <= 64: bit k of `blocked` when certainly blocked, of
  // `undecided` when not decided (neither bit: certainly visible). A segment with an end
  // point beyond the bound comes back undecided.
  // `order`, a permutation of [0, n), places the segments in the box test's 8-lane runs:
  // order[0..7] first, and so on (nearby light points together let a run that misses a
  // box skip it whole; any order gives the same answers).
  void cast(const Vec3f& p, const Vec3f* q, const uint8_t* order, int n, uint64_t& blocked,
            uint64_t& undecided) const;

  // Leaf of up to 8 triangles, corners as 8 lanes per coordinate (a.x, a.y, a.z, b.x,
  // ..., c.z); unused lanes repeat the last triangle and are masked by `count`.
  struct alignas(32) Leaf {
    float v[9][8];
    uint32_t count;
  };
  // BVH node in pre-order (the left child of inner node i is i + 1; accel::Bvh's shape,
  // median splits, leaves of at most 8), its box grown by 2^-19 bound (box_test).
  struct Node {
    AABB box;
    uint32_t first = 0;  // inner: the right child; leaf: its Leaf
    uint32_t count = 0;  // leaf: its triangles (1 to 8); inner: 0
  };
  // Depth of the walk's stack: accel::Bvh halves its items, at most 33 levels.
  static constexpr size_t kMaxStack = accel::Bvh<float>::kMaxStack;

 private:
  std::vector<Node> nodes_;
  std::vector<Leaf> leaves_;
  float bound_ = 0.0f;
  bool usable_ = true;
};

// A group's segments p -> p + d[k], k < kGroup, as the kernels read them: d = fl(q - p),
// its reciprocals, dmax[i] >= |d[k].i| over the group, and `slab`: the segments whose
// every |d.i| is at least 2^-60 (the box test's range; the others pass every box).
struct alignas(32) PacketGroup {
  float dx[PacketCaster::kGroup], dy[PacketCaster::kGroup], dz[PacketCaster::kGroup];
  float ix[PacketCaster::kGroup], iy[PacketCaster::kGroup], iz[PacketCaster::kGroup];
  float dmax[3];
  uint64_t slab;
};

// The box test, exposed for tests: the segments of `mask` that may meet the box
// [lo, hi], a box grown by 2^-19 B from the one to test (PacketCaster::Node), B at least
// every coordinate of the box, p and the q: then no segment p q that meets the
// original box is dropped.
uint64_t packet_box_test(const Vec3f& lo, const Vec3f& hi, const Vec3f& p, const PacketGroup& g, uint64_t mask);

// The leaf test, exposed for tests: the segments of `active` against the leaf's
// triangles. Returns the certainly blocked segments; adds to `undecided` the segments
// neither blocked nor certainly missing every triangle. `bound_scale` multiplies the
// certification bound (1 in production; tests set 0 to show that the bound matters).
uint64_t packet_leaf_test(const PacketCaster::Leaf& leaf, const Vec3f& p, const PacketGroup& g, uint64_t active,
                          uint64_t& undecided, float bound_scale = 1.0f);

}  // namespace visgate::ssv
