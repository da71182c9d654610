// Lazy point trees (paper 000 section 4.3, Figure 4.2; see tree.h).
#include "lib/iss/tree.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/geom/check.h"

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

}  // namespace

bool TreeNode::contains_triangle(uint32_t t) const { return std::binary_search(inside.begin(), inside.end(), t); }

PointTree::PointTree(std::vector<AABB> boxes, std::vector<Vec3f> centers, int max_points_in_leaf,
                     const mesh::PreparedMesh& mesh, const std::vector<AABB>& triangle_boxes)
    : boxes_(std::move(boxes)), centers_(std::move(centers)), max_leaf_(std::max(1, max_points_in_leaf)),
      mesh_(mesh), tri_boxes_(triangle_boxes) {
  order_.resize(boxes_.size());
  std::iota(order_.begin(), order_.end(), 0u);
  nodes_.emplace_back();
  TreeNode& r = nodes_.back();
  r.begin = 0;
  r.end = uint32_t(order_.size());
  std::vector<uint32_t> all(mesh_.triangles.size());
  std::iota(all.begin(), all.end(), 0u);
  finish_node(r, all);
  r.gone.clear();
}

void PointTree::finish_node(TreeNode& n, const std::vector<uint32_t>& parent_triangles) {
  // COMPUTE-BOUNDING-BOX over the point boxes (jitter boxes for light samples).
  n.box = AABB{};
  for (uint32_t k = n.begin; k < n.end; ++k) n.box.extend(boxes_[order_[k]]);
  if (n.size() <= uint32_t(max_leaf_)) n.is_leaf = true;
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
    // Otherwise minimise N_left * A_left + N_right * A_right over every axis.
    double best = 1e300;
    int best_ax = -1;
    uint32_t best_mid = 0;
    scratch_area_.resize(cnt + 1);
    AABB cb;
    for (uint32_t k = b; k < e; ++k) cb.extend(centers_[ord[k]]);
    double pad = point_spacing(cb.extent(), cnt);
    for (int ax = 0; ax < 3; ++ax) {
      std::sort(ord + b, ord + e, [&](uint32_t p, uint32_t q) { return centers_[p][ax] < centers_[q][ax]; });
      AABB acc;
      for (uint32_t k = cnt; k-- > 0;) {
        acc.extend(boxes_[ord[b + k]]);
        scratch_area_[k] = split_area(acc, pad);
      }
      acc = AABB{};
      for (uint32_t k = 1; k < cnt; ++k) {
        acc.extend(boxes_[ord[b + k - 1]]);
        // Only split between distinct centres so that the split is a plane.
        if (!(centers_[ord[b + k - 1]][ax] < centers_[ord[b + k]][ax])) continue;
        double c = double(k) * split_area(acc, pad) + double(cnt - k) * scratch_area_[k];
        if (c < best) { best = c; best_ax = ax; best_mid = b + k; }
      }
    }
    if (best_ax < 0) {  // every centre identical: cannot be split, a real leaf
      n->is_leaf = true;
      return;
    }
    std::sort(ord + b, ord + e, [&](uint32_t p, uint32_t q) { return centers_[p][best_ax] < centers_[q][best_ax]; });
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
