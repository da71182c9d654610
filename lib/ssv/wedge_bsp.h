// The lazy wedge BSP of paper 001 section 4.1 (Figure 5: INIT-BSP, SPLIT-LEAF,
// WEDGE-QUERY) with the silhouette-region test of section 4.2.
//
// An axis-aligned BSP over the scene bounds whose nodes hold wedges: an internal node
// keeps the wedges that contain its whole box, a leaf the wedges that intersect it. A
// query walks from the root to the leaf containing the point, splitting the leaves it
// meets on the way (SPLIT-LEAF: stop below the minimum node size, 1/200 of the root's
// longest side, or when the leaf holds no more than 25% of the wedges already collected
// above it), and returns every wedge of every node on the path. Splits are always at the
// middle of the longest axis, so the tree does not depend on the order of the queries.
//
// Guarantee: conservative (within the wedge tests' tolerance, wedge.h): every wedge whose
// wedge (and silhouette region) contains the query point is returned, for query points
// inside the root box. Thread-safe: concurrent queries split leaves under a per-node lock
// (taken only when the leaf is to be split); a leaf's list never changes, an internal
// node's list is written before its split is published. A query that reads a leaf
// while another thread splits it reports the leaf's list, a superset of what the split
// node and its child would report: still conservative, and identical answers, since
// validation (point_in_wedge) decides every candidate.
#pragma once

#include <array>
#include <atomic>
#include <deque>
#include <memory>
#include <mutex>
#include <vector>

#include "lib/base/memory_budget.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

class WedgeBsp {
 public:
  // INIT-BSP: the root over `bounds` holding every wedge that intersects it; leaves
  // smaller than `min_size` along their longest axis are not split (section 4.1: 1/200
  // of the scene's longest side).
  WedgeBsp(const std::vector<Wedge>& wedges, const AABB& bounds, float min_size, float eps, bool use_region);
  ~WedgeBsp();
  WedgeBsp(const WedgeBsp&) = delete;
  WedgeBsp& operator=(const WedgeBsp&) = delete;

  // WEDGE-QUERY: appends the indices (into the wedge list) of the candidate wedges of p.
  void query(const Vec3f& p, std::vector<uint32_t>& out);
  // The same with each wedge's state in the node it came from: mask 0 for the wedges of
  // internal nodes (they contain the node's box), the leaf's active planes otherwise;
  // validation then tests only the planes in the mask (point_in_wedge).
  void query(const Vec3f& p, std::vector<WedgeState>& out);

  size_t node_count() const { return nodes_.load(); }
  size_t entry_count() const { return entries_.load(); }  // wedge entries in all nodes
  // Bytes held by nodes and their wedge lists.
  size_t memory_bytes() const;
  // Counts memory_bytes() against `budget` from now on, after every split (which throws
  // MemoryBudgetExceeded past it); call before the queries.
  void set_memory_budget(MemoryBudget* budget) {
    budget_charge_.bind(budget, "wedge BSP");
    budget_charge_.set(memory_bytes());
  }

 private:
  struct Node {
    AABB box;
    // As a leaf: the `count` wedges meeting the box (written once, before the node is
    // reachable, never changed). Once split: the `kept` wedges containing the box.
    WedgeState* wedges = nullptr;
    uint32_t count = 0;
    WedgeState* kept = nullptr;
    uint32_t kept_count = 0;
    std::atomic<bool> split{false};
    Node* child = nullptr;  // the two children, adjacent in the node arena
    int axis = 0;
    float mid = 0.0f;
  };

  bool should_split(const Node& n, size_t wedges_above) const;
  void split_leaf(Node& n);
  // `count` contiguous states from the list arena (never moved or freed before the tree).
  WedgeState* allocate(size_t count);
  WedgeState* allocate_locked(size_t count);  // arena_lock_ held
  std::mutex& lock_of(const Node* n) { return locks_[(reinterpret_cast<uintptr_t>(n) / sizeof(Node)) % locks_.size()]; }

  const std::vector<Wedge>& wedges_;
  float eps_;
  bool use_region_;
  float min_size_;
  Node root_;
  // Children are allocated in pairs from an arena (one allocation per split, freed at
  // once), wedge lists as exact-size spans of chunks of a list arena (a split writes its
  // children's lists once; a node's list only shrinks, in place, when it is split);
  // leaves are locked through a small table of striped mutexes.
  std::deque<std::array<Node, 2>> arena_;
  std::vector<std::unique_ptr<WedgeState[]>> chunks_;
  size_t chunk_used_ = 0, chunk_size_ = 0, list_capacity_ = 0;
  std::mutex arena_lock_;
  std::array<std::mutex, 64> locks_;
  MemoryCharge budget_charge_;  // set under arena_lock_
  std::atomic<size_t> nodes_{0}, entries_{0};
};

}  // namespace visgate::ssv
