// lib/accel/bvh_pairs.h: overlapping pairs by dual traversal, serial and parallel, against
// all pairs by brute force, float and double, both split rules.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <vector>

#include "lib/accel/bvh_pairs.h"
#include "tests/support/random_boxes.h"

using namespace visgate;
using namespace visgate::accel;

namespace {

using Pair = std::array<uint32_t, 2>;

// Boxes of sides up to 6 in a cube of side 100, and box 1 touching box 0 on a face
// (closed boxes overlap there).
template <class T>
std::vector<AABBT<T>> random_boxes(size_t n, uint32_t seed, double offset) {
  auto out = test::random_boxes<T>(n, seed, offset, 100.0, 6.0);
  if (n >= 2) out[1] = AABBT<T>(Vec3<T>(out[0].hi.x, out[0].lo.y, out[0].lo.z), out[0].hi + Vec3<T>(1, 1, 1));
  return out;
}

template <class T>
std::vector<Pair> brute_pairs(const std::vector<AABBT<T>>& boxes) {
  std::vector<Pair> out;
  for (uint32_t i = 0; i < boxes.size(); ++i)
    for (uint32_t j = i + 1; j < boxes.size(); ++j)
      if (boxes[i].overlaps(boxes[j])) out.push_back({i, j});
  return out;
}

Pair ordered(uint32_t i, uint32_t j) { return i < j ? Pair{i, j} : Pair{j, i}; }

template <class T>
class BvhPairsTest : public ::testing::Test {};
using Scalars = ::testing::Types<float, double>;
TYPED_TEST_SUITE(BvhPairsTest, Scalars);

}  // namespace

TYPED_TEST(BvhPairsTest, SerialAndParallelMatchBruteForce) {
  using T = TypeParam;
  for (size_t n : {0u, 1u, 2u, 7u, 300u, 2500u})
    for (double offset : {0.0, 1e5})
      for (Split s : {Split::MortonHalves, Split::MedianAxis})
        for (uint32_t leaf : {1u, 4u}) {
          SCOPED_TRACE(std::to_string(n) + (s == Split::MedianAxis ? " median" : " morton") + " leaf " +
                       std::to_string(leaf));
          const auto boxes = random_boxes<T>(n, uint32_t(n) + 3, offset);
          Bvh<T> t(boxes, BuildRule{s, leaf, true});
          const auto want = brute_pairs(boxes);
          std::vector<Pair> serial;
          self_pairs(t, [&](uint32_t i, uint32_t j) {
            ASSERT_NE(i, j);
            serial.push_back(ordered(i, j));
          });
          std::sort(serial.begin(), serial.end());
          EXPECT_EQ(serial, want);  // equal as sorted lists: each pair exactly once
          tbb::enumerable_thread_specific<std::vector<Pair>> locals;
          self_pairs_parallel(t, locals, [](std::vector<Pair>& mine, uint32_t i, uint32_t j) {
            mine.push_back(ordered(i, j));
          });
          std::vector<Pair> parallel;
          for (const auto& l : locals) parallel.insert(parallel.end(), l.begin(), l.end());
          std::sort(parallel.begin(), parallel.end());
          EXPECT_EQ(parallel, want);
        }
}

TYPED_TEST(BvhPairsTest, SerialOrderIsFixedByTheTree) {
  // Two builds of the same boxes report the same pairs in the same order.
  using T = TypeParam;
  const auto boxes = random_boxes<T>(800, 4, 0.0);
  auto run = [&] {
    Bvh<T> t(boxes, BuildRule{Split::MedianAxis, 4, true});
    std::vector<Pair> out;
    self_pairs(t, [&](uint32_t i, uint32_t j) { out.push_back({i, j}); });
    return out;
  };
  EXPECT_EQ(run(), run());
}
