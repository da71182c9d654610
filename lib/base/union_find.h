// Disjoint sets over the indices 0..n-1 (union-find with path halving). The root of a set
// is always its smallest member, so callers can name a set by its lowest index and group
// members in index order without another pass. Used by ISS's blocker merging (paper 000
// section 4.7) and by mesh repair (welding clusters, components, vertex fans).
//
// The free functions work on a caller-owned parent vector, so a workspace can reuse its
// storage across calls; UnionFind owns one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <numeric>
#include <vector>

namespace visgate {

// parent[i] = i for every i < n (capacity kept).
template <class I>
void uf_reset(std::vector<I>& parent, size_t n) {
  parent.resize(n);
  std::iota(parent.begin(), parent.end(), I(0));
}

template <class I>
I uf_find(std::vector<I>& parent, I x) {
  while (parent[size_t(x)] != x) {
    parent[size_t(x)] = parent[size_t(parent[size_t(x)])];
    x = parent[size_t(x)];
  }
  return x;
}

// Joins the sets of a and b under the smaller root; false when they were one set.
template <class I>
bool uf_union(std::vector<I>& parent, I a, I b) {
  a = uf_find(parent, a);
  b = uf_find(parent, b);
  if (a == b) return false;
  if (a < b) parent[size_t(b)] = a;
  else parent[size_t(a)] = b;
  return true;
}

class UnionFind {
 public:
  explicit UnionFind(size_t n) { uf_reset(parent_, n); }
  uint32_t find(uint32_t x) { return uf_find(parent_, x); }
  bool unite(uint32_t a, uint32_t b) { return uf_union(parent_, a, b); }

 private:
  std::vector<uint32_t> parent_;
};

}  // namespace visgate
