// A walk over every node of a hierarchy (lib/accel/bvh.h) with its leaf-order range, for
// tests that check node contents against brute force (tests/accel, tests/plucker).
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "lib/accel/bvh.h"

namespace visgate::test {

// f(node, pos) for every node of t, pos the first leaf-order position below it (its
// items are positions [pos, pos + count)), each derived from the counts alone. Checks
// the shape every tree keeps: pre-order (left child i + 1, right child after it), inner
// nodes over more than leaf_size items whose children's counts add up, leaves of one to
// leaf_size items starting at pos, every node reached once, every position in one leaf.
template <class T, class F>
void expect_bvh_shape(const accel::Bvh<T>& t, F&& f) {
  if (t.empty()) return;
  struct Todo {
    uint32_t node, pos;
  };
  std::vector<Todo> todo = {{0, 0}};
  std::vector<uint32_t> seen(t.item_count(), 0);
  size_t visited = 0;
  while (!todo.empty()) {
    const Todo d = todo.back();
    todo.pop_back();
    ++visited;
    ASSERT_LT(d.node, t.node_count());
    const auto& nd = t.node(d.node);
    ASSERT_GT(nd.count, 0u);
    ASSERT_LE(size_t(d.pos) + nd.count, t.item_count());
    f(d.node, d.pos);
    if (t.is_leaf(nd)) {
      ASSERT_EQ(nd.first, d.pos);
      for (uint32_t p = d.pos; p < d.pos + nd.count; ++p) ++seen[p];
      continue;
    }
    const uint32_t l = t.left(d.node), r = t.right(d.node);
    ASSERT_EQ(l, d.node + 1);
    ASSERT_GT(r, l);
    ASSERT_EQ(t.node(l).count + t.node(r).count, nd.count);
    todo.push_back({l, d.pos});
    todo.push_back({r, d.pos + t.node(l).count});
  }
  ASSERT_EQ(visited, t.node_count());
  for (uint32_t p = 0; p < seen.size(); ++p) ASSERT_EQ(seen[p], 1u) << "position " << p;
}

}  // namespace visgate::test
