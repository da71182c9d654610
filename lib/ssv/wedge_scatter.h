// Wedges scattered to the receivers they may contain, through the receiver tree
// (occluders.h): the alternative to the lazy wedge BSP of paper 001 section 4.1 when, as
// here, every query point is known before the first query. Each wedge walks down the
// tree from a batch's node with the BSP's box tests (classify_box, silhouette regions of
// section 4.2 included): a node outside the wedge is left, a node inside it hands the
// wedge to each of its receivers with no plane left to test, a leaf it meets hands it to
// each receiver with the planes that do not yet contain the leaf's box. The cost is one
// walk per wedge and batch plus the candidates handed out, against the BSP's splits of
// nodes down to 1/200 of the scene, which dominated the solve on scenes with few
// receivers per node (columns, scan).
//
// Guarantee: conservative like WedgeBsp::query (the same box tests with the same
// tolerance): every wedge whose wedge and silhouette region contain a receiver (within
// eps) is among its candidates, with a mask whose cleared planes contain it within eps.
// Candidates come in wedge order per receiver: the result does not depend on threads.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/ssv/occluders.h"
#include "lib/ssv/wedge.h"

namespace visgate::ssv {

class WedgeScatter {
 public:
  // Candidates of the receivers under tree node `batch` (positions begin..end of the
  // tree's order); receivers with skip[i] != 0 get none. One tree per object.
  // With `passed` (pass_batches' list for this batch) only those wedges are tried, and
  // with AVX2 and eps > 0 without walks: each against the batch's leaves, eight per step
  // (a receiver's candidates depend on its leaf alone, see build). The same candidates
  // with the same states.
  void build(const ReceiverTree& tree, int32_t batch, const std::vector<Wedge>& wedges, float eps, bool use_region,
             const std::vector<uint8_t>& skip, const std::vector<uint32_t>* passed = nullptr);
  // For batches[first] .. batches[first + kPassGroup - 1] (those that exist), lists[i]
  // holds, in wedge order, the wedges that classify_box from the root's state does not
  // call Outside at batch first + i's node: exactly the wedges whose walk in build goes
  // past that node. The group's boxes in AVX2 lanes, with the same products and sums as
  // classify_box's box ranges, so the same floats; without AVX2 (or with
  // VISGATE_SSV_NO_AVX2 set) every wedge. A group at a time: at most kPassGroup lists.
  static constexpr size_t kPassGroup = 8;
  void pass_batches(const ReceiverTree& tree, const std::vector<int32_t>& batches, size_t first,
                    const std::vector<Wedge>& wedges, float eps, bool use_region,
                    std::vector<std::vector<uint32_t>>& lists);
  // The candidates of the receiver at tree-order position p of the batch.
  const WedgeState* begin(uint32_t p) const { return items_.data() + start_[p - first_]; }
  const WedgeState* end(uint32_t p) const { return items_.data() + start_[p - first_ + 1]; }
  size_t entries() const { return items_.size(); }  // of the last build
  size_t total_entries() const { return total_; }     // of every build so far
  size_t memory_bytes() const {
    return items_.capacity() * sizeof(WedgeState) + pairs_.capacity() * sizeof(Pair) + start_.capacity() * sizeof(uint32_t);
  }
  // Batches of at most `max_receivers` receivers: the highest tree nodes that small, in
  // tree order (their ranges tile the order).
  static std::vector<int32_t> batches(const ReceiverTree& tree, uint32_t max_receivers);

 private:
  struct Pair {
    uint32_t pos;  // tree-order position
    WedgeState s;
  };
  uint32_t first_ = 0;
  std::vector<Pair> pairs_;
  std::vector<WedgeState> items_;
  std::vector<uint32_t> start_;
  void float_boxes(const ReceiverTree& tree);  // boxes_, once per tree
  std::vector<AABB> boxes_;  // float boxes (outwards) of the tree's nodes
  size_t total_ = 0;
};

}  // namespace visgate::ssv
