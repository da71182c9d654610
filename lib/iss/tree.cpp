// Lazy point trees (paper 000 section 4.3, Figure 4.2; see tree.h).
#include "lib/iss/tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"

namespace visgate::iss {

namespace {

// The "A" of the N*A cost (section 4.3): the surface area of the box grown by `pad` on
// every axis, `pad` being the typical point spacing of the node being split. Points on a
// regular grid are cells of that size rather than dimensionless points: with the bare
// box area a strip of collinear points has zero area, and the greedy split then peels
// the node into long one- or two-point-wide strips (on the rooms family such strips span
// several rooms, so the walls between the rooms are in the strip's inside list and can
// never block its shafts). With the padding the cost prefers compact, square-ish nodes.
double split_area(const AABB& b, double pad) {
  if (b.empty()) return 0.0;
  Vec3f e = b.extent();
  double x = double(e.x) + pad, y = double(e.y) + pad, z = double(e.z) + pad;
  return 2.0 * (x * y + y * z + z * x);
}

// Typical spacing of n points whose centres span the extent e: the side of the square
// cell each point covers on the two widest axes (the points are treated as a 2D set,
// which receivers on surfaces and samples on area lights are), or the 1D spacing when
// the set is collinear.
double point_spacing(const Vec3f& e, uint32_t n) {
  double a[3] = {double(e.x), double(e.y), double(e.z)};
  std::sort(a, a + 3);
  if (n <= 1) return 0.0;
  if (a[1] > 0.0) return std::sqrt(a[2] * a[1] / double(n));
  return a[2] / double(n);
}

// Orders the points ord[0, n) of a leaf for its leaf rays: recursive median splits on
// the widest axis of the centres until groups of kPacketGroup, so that consecutive
// points, which occluded_fan traces as one 8-wide Embree packet, are close together
// (a light's stratified samples come row by row through an area-preserving fan map,
// and eight consecutive ones span half the light). Ties broken by index:
// deterministic. Only the order of the rays within a leaf changes, never an answer
// (each lane of a packet is decided alone).
constexpr uint32_t kPacketGroup = 8;
void order_for_packets(uint32_t* ord, uint32_t n, const std::vector<Vec3f>& centers) {
  if (n <= kPacketGroup) return;
  AABB cb;
  for (uint32_t k = 0; k < n; ++k) cb.extend(centers[ord[k]]);
  const int ax = cb.longest_axis();
  if (!(cb.extent()[ax] > 0.0f)) return;
  // A split at a multiple of the group size keeps whole groups on each side.
  const uint32_t half = ((n / kPacketGroup + 1) / 2) * kPacketGroup;
  if (half >= n) return;
  std::nth_element(ord, ord + half, ord + n, [&](uint32_t a, uint32_t b) {
    const float ca = centers[a][ax], cb2 = centers[b][ax];
    return ca < cb2 || (ca == cb2 && a < b);
  });
  order_for_packets(ord, half, centers);
  order_for_packets(ord + half, n - half, centers);
}

}  // namespace

bool TreeNode::contains_triangle(uint32_t t) const { return std::binary_search(inside.begin(), inside.end(), t); }

PointTree::PointTree(std::vector<AABB> boxes, std::vector<Vec3f> centers, int max_points_in_leaf,
                     const mesh::PreparedMesh& mesh, const std::vector<AABB>& triangle_boxes,
                     const std::vector<uint32_t>* root_candidates, int packet_order_max)
    : boxes_(std::move(boxes)), centers_(std::move(centers)), max_leaf_(std::max(1, max_points_in_leaf)),
      packet_max_(std::max(max_leaf_, packet_order_max)), mesh_(mesh), tri_boxes_(triangle_boxes) {
  order_.resize(boxes_.size());
  std::iota(order_.begin(), order_.end(), 0u);
  nodes_.emplace_back();
  TreeNode& r = nodes_.back();
  r.begin = 0;
  r.end = uint32_t(order_.size());
  if (root_candidates) {
    finish_node(r, *root_candidates);
  } else {
    std::vector<uint32_t> all(mesh_.triangles.size());
    std::iota(all.begin(), all.end(), 0u);
    finish_node(r, all);
  }
  r.gone.clear();
}

AABB PointTree::bounds_of(const std::vector<AABB>& boxes) {
  AABB b;
  for (const AABB& x : boxes) b.extend(x);
  return b;
}

void PointTree::finish_node(TreeNode& n, const std::vector<uint32_t>& parent_triangles) {
  // COMPUTE-BOUNDING-BOX over the point boxes (jitter boxes for light samples).
  n.box = AABB{};
  for (uint32_t k = n.begin; k < n.end; ++k) n.box.extend(boxes_[order_[k]]);
  if (n.size() <= uint32_t(max_leaf_)) n.is_leaf = true;
  if (n.size() <= uint32_t(packet_max_)) order_for_packets(order_.data() + n.begin, n.size(), centers_);
  // Distribute the parent's triangles (lines 16-22).
  for (uint32_t t : parent_triangles) {
    bool hit = tri_boxes_[t].overlaps(n.box) &&
               triangle_overlaps_aabb(mesh_.corner(t, 0), mesh_.corner(t, 1), mesh_.corner(t, 2), n.box);
    (hit ? n.inside : n.gone).push_back(t);
  }
  n.had_triangles = !n.inside.empty();
  n.inside.shrink_to_fit();
  n.gone.shrink_to_fit();
  list_bytes_ += (n.inside.size() + n.gone.size()) * sizeof(uint32_t);
}

void PointTree::split(int i) {
  TreeNode* n = &nodes_[size_t(i)];
  if (n->is_leaf || n->split_done()) return;
  uint32_t b = n->begin, e = n->end, cnt = e - b;
  uint32_t* ord = order_.data();
  uint32_t mid = b;
  // FIND-SPLIT-PLANE: above 1024 points the midpoint of the longest side.
  if (cnt > 1024) {
    AABB cb;
    for (uint32_t k = b; k < e; ++k) cb.extend(centers_[ord[k]]);
    int ax = cb.longest_axis();
    float pos = cb.center()[ax];
    uint32_t* m = std::partition(ord + b, ord + e, [&](uint32_t p) { return centers_[p][ax] < pos; });
    mid = uint32_t(m - ord);
    if (mid == b || mid == e) {  // all centres on one side of the midpoint: median split
      mid = b + cnt / 2;
      std::nth_element(ord + b, ord + mid, ord + e, [&](uint32_t p, uint32_t q) { return centers_[p][ax] < centers_[q][ax]; });
    }
  } else {
    // Otherwise minimise the cost of tree.h's file comment over every axis and every
    // split between distinct centres.
    double best = 1e300;
    int best_ax = -1;
    uint32_t best_mid = 0;
    scratch_pre_.resize(cnt + 1);
    scratch_suf_.resize(cnt + 1);
    scratch_cl_.resize(cnt + 2);
    scratch_cr_.resize(cnt + 2);
    AABB cb;
    for (uint32_t k = b; k < e; ++k) cb.extend(centers_[ord[k]]);
    double pad = point_spacing(cb.extent(), cnt);
    // The node's large blockers: inside triangles whose box spans at least half of the
    // node box on an axis where the node has extent (a wall through a floor node; not a
    // table leg). Their boxes are what the split tries to keep out of the children.
    big_.clear();
    Vec3f ne = n->box.extent();
    for (uint32_t t : n->inside) {
      Vec3f te = tri_boxes_[t].extent();
      for (int a = 0; a < 3; ++a)
        if (ne[a] > 0.0f && te[a] >= 0.5f * ne[a]) {
          big_.push_back(t);
          break;
        }
    }
    for (int ax = 0; ax < 3; ++ax) {
      // The points in centre order on this axis (ties by index): (key, index) pairs
      // sort without indirection; the order is kept for the final split.
      std::vector<std::pair<float, uint32_t>>& keyed = scratch_keyed_;
      keyed.resize(cnt);
      for (uint32_t k = 0; k < cnt; ++k) keyed[k] = {centers_[ord[b + k]][ax], ord[b + k]};
      std::sort(keyed.begin(), keyed.end());
      scratch_axis_ord_[ax].resize(cnt);
      uint32_t* sorted = scratch_axis_ord_[ax].data();
      for (uint32_t k = 0; k < cnt; ++k) sorted[k] = keyed[k].second;
      // pre[k]: box of the first k points; suf[k]: box of the points from k on.
      scratch_pre_[0] = AABB{};
      for (uint32_t k = 0; k < cnt; ++k) {
        scratch_pre_[k + 1] = scratch_pre_[k];
        scratch_pre_[k + 1].extend(boxes_[sorted[k]]);
      }
      scratch_suf_[cnt] = AABB{};
      for (uint32_t k = cnt; k-- > 0;) {
        scratch_suf_[k] = scratch_suf_[k + 1];
        scratch_suf_[k].extend(boxes_[sorted[k]]);
      }
      // Large blockers per side: overlap with pre[k] only grows with k and overlap with
      // suf[k] only shrinks, so each triangle's first (last) overlapping k is a binary
      // search; histograms and prefix sums give the counts for every k.
      std::fill(scratch_cl_.begin(), scratch_cl_.end(), 0u);
      std::fill(scratch_cr_.begin(), scratch_cr_.end(), 0u);
      for (uint32_t t : big_) {
        const AABB& tb = tri_boxes_[t];
        uint32_t lo = 1, hi = cnt + 1;  // first k in [1, cnt] with overlap, cnt + 1: none
        while (lo < hi) {
          uint32_t mid2 = (lo + hi) / 2;
          if (tb.overlaps(scratch_pre_[mid2])) hi = mid2;
          else lo = mid2 + 1;
        }
        ++scratch_cl_[lo];
        lo = 0;
        hi = cnt;  // first k in [0, cnt) without overlap with suf[k]
        while (lo < hi) {
          uint32_t mid2 = (lo + hi) / 2;
          if (tb.overlaps(scratch_suf_[mid2])) lo = mid2 + 1;
          else hi = mid2;
        }
        ++scratch_cr_[lo];  // overlaps suf[k] exactly for k < lo
      }
      for (uint32_t k = 1; k <= cnt + 1; ++k) scratch_cl_[k] += scratch_cl_[k - 1];  // cl[k]: first overlap <= k
      for (uint32_t k = cnt + 1; k-- > 0;) scratch_cr_[k] += scratch_cr_[k + 1];  // cr[k]: first k without overlap >= k
      for (uint32_t k = 1; k < cnt; ++k) {
        // Only split between distinct centres so that the split is a plane.
        if (!(keyed[k - 1].first < keyed[k].first)) continue;
        // Triangles overlapping suf[k]: those whose first k without overlap is > k.
        double tl = double(scratch_cl_[k]), tr = double(scratch_cr_[k + 1]);
        double c = double(k) * split_area(scratch_pre_[k], pad) * (1.0 + tl) +
                   double(cnt - k) * split_area(scratch_suf_[k], pad) * (1.0 + tr);
        if (c < best) { best = c; best_ax = ax; best_mid = b + k; }
      }
    }
    if (best_ax < 0) {  // every centre identical: cannot be split, a real leaf
      n->is_leaf = true;
      return;
    }
    std::copy(scratch_axis_ord_[best_ax].begin(), scratch_axis_ord_[best_ax].begin() + cnt, ord + b);
    mid = best_mid;
  }
  int li = int(nodes_.size());
  nodes_.emplace_back();
  nodes_.emplace_back();
  n = &nodes_[size_t(i)];  // deque: references stay valid, but re-fetch for clarity
  TreeNode& L = nodes_[size_t(li)];
  TreeNode& R = nodes_[size_t(li + 1)];
  L.parent = R.parent = i;
  L.begin = b;
  L.end = mid;
  R.begin = mid;
  R.end = e;
  finish_node(L, n->inside);
  finish_node(R, n->inside);
  n->left = li;
  n->right = li + 1;
}

size_t PointTree::memory_bytes() const {
  return nodes_.size() * sizeof(TreeNode) + list_bytes_ + order_.size() * sizeof(uint32_t) +
         boxes_.size() * (sizeof(AABB) + sizeof(Vec3f));
}

}  // namespace visgate::iss
