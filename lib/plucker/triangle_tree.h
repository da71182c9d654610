// A bounding-volume hierarchy over the scene's triangles for occluder selection (paper
// 002 section 4.4, implementation details: Haines' shaft per receiver group and light).
// Without it every group tested every triangle against its shaft: on `rooms` (26k
// triangles, 27 lights, 64 groups) that was 45M shaft tests per solve.
//
// The shared hierarchy (lib/accel/bvh.h) with median splits on the centres' longest axis
// and four triangles per leaf: built once per solve, queried once per group and light.
//
// Guarantee: conservative. A node is skipped only when Shaft::culls_box says its box
// misses the shaft; the box translated to a light's local frame (coordinates relative to
// an origin, rounded once per corner) still contains every triangle vertex translated and
// rounded the same way, because rounding is monotonic (fl(lo - o) <= fl(v - o) for
// lo <= v). So the triangles reported are a superset of those the per-triangle test
// keeps, and they are reported in increasing index order (the order of a plain scan, so
// the solver's results do not depend on the tree).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <span>
#include <type_traits>
#include <vector>

#include "lib/accel/bvh.h"
#include "lib/geom/aabb.h"
#include "lib/mesh/prepare.h"
#include "lib/plucker/shaft.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

// The corner boxes of the triangles tris[0], tris[1], ... of mesh (of every triangle in
// index order when tris is null): per triangle AABB() extended by corners 0, 1 and 2, the
// same bits (the hierarchies' item boxes, TriangleTree's and triangle_hierarchy's).
std::vector<AABB> triangle_boxes(const TriangleSoup& mesh, const std::vector<uint32_t>* tris = nullptr);
// The same box of triangle t alone.
AABB triangle_box(const TriangleSoup& mesh, uint32_t t);

class TriangleTree {
 public:
  // SurfaceTrees copies this tree for a surface that holds every triangle: keep the rule
  // and the boxes those of triangle_hierarchy (silhouette_region.h).
  static constexpr accel::BuildRule kRule{accel::Split::MedianAxis, 4, false};

  // `pm`: prepare_mesh(mesh) (its welded neighbours grow the coplanar patches).
  TriangleTree(const TriangleSoup& mesh, const mesh::PreparedMesh& pm);
  explicit TriangleTree(const TriangleSoup& mesh) : TriangleTree(mesh, mesh::prepare_mesh(mesh)) {}

  // Appends to `out` (cleared first), in increasing order, the index of every triangle
  // whose leaf box is not culled by the shaft; the shaft is in local coordinates
  // relative to `origin`. Callers still test each triangle.
  void candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out) const;

  // A run of triangles of one subtree: positions [begin, begin + count) of the leaf order
  // (a subtree's triangles are contiguous there, lib/accel/bvh.h).
  struct Range {
    uint32_t begin = 0, count = 0;
  };
  // As candidates, but a subtree the shaft does not cull whose box `skip(lo, hi)`
  // accepts is left out of `out` whole, its triangles recorded as one Range in `skipped`
  // (cleared first; append_items gives them back; a skipped subtree may also hold
  // triangles the shaft culls further down, so kept and skipped together are a superset
  // of the plain candidates, each triangle once). lo, hi: the node's float box
  // translated to the local frame of `origin` in double and widened by two ulps or more
  // per side (a translation is rounded by at most half an ulp), so it holds the exact
  // translation of every point of the float box and thus of every triangle below:
  // a predicate true for every triangle inside that box may skip them all.
  template <class Skip>
  void candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out, std::vector<Range>& skipped,
                  Skip&& skip) const;
  // `skip` may also take the node's index first, skip(i, lo, hi) (nodes as bvh()'s).
  // The local box candidates gives `skip` for node i (its float box translated to the
  // frame of `origin`, widened as above).
  void local_box(uint32_t i, const Vec3d& od, Vec3d& lo, Vec3d& hi) const {
    // Outward by 2^-50 of the value (at least two ulps, and the subtraction rounds by at
    // most half of one): cheaper than nextafter, as safe. A zero or subnormal difference
    // of two doubles is exact.
    auto down = [](double x) { return x - std::abs(x) * 0x1p-50; };
    auto up = [](double x) { return x + std::abs(x) * 0x1p-50; };
    const auto& nd = bvh_.node(i);
    lo = Vec3d(down(double(nd.box.lo.x) - od.x), down(double(nd.box.lo.y) - od.y), down(double(nd.box.lo.z) - od.z));
    hi = Vec3d(up(double(nd.box.hi.x) - od.x), up(double(nd.box.hi.y) - od.y), up(double(nd.box.hi.z) - od.z));
  }
  // The hierarchy: items are triangle indices, boxes the triangles' corner boxes.
  const accel::Bvh<float>& bvh() const { return bvh_; }
  // Appends the triangles of r to `out` (in leaf order, not sorted).
  void append_items(const Range& r, std::vector<uint32_t>& out) const {
    const auto order = bvh_.order();
    out.insert(out.end(), order.begin() + r.begin, order.begin() + r.begin + r.count);
  }

  // True when some triangle of `mesh` (the one the tree was built on) blocks the open
  // segment r -> s by lines.h segment_blocked on its vertices translated to the local
  // frame of `origin` (r and s are local): the same answer as testing every triangle
  // (local_light.h segment_blocked_by_scene), since a triangle that segment_blocked
  // accepts meets the segment, so its local box does (segment_meets_box is
  // conservative), and that box lies in its leaf's box translated the same way.
  bool segment_blocked(const TriangleSoup& mesh, const Vec3f& origin, const Vec3f& r, const Vec3f& s) const;

  size_t node_count() const { return bvh_.node_count(); }
  size_t memory_bytes() const {
    return bvh_.memory_bytes() + patch_of_.capacity() * sizeof(int32_t) + patches_.capacity() * sizeof(Patch) +
           patch_tris_.capacity() * sizeof(uint32_t) + patch_poly_.capacity() * sizeof(Vec3f);
  }

  // Coplanar convex patches for occluder merging (plucker_solver.cpp shade_group).
  // Triangles glued edge to edge (the same two vertex positions, exactly, on an edge of
  // exactly two triangles that traverse it in opposite directions: the neighbours of
  // lib/mesh/prepare.h), lying exactly in one plane (orient3d exact) and forming a
  // strictly convex polygon (exact 2D orientations in the plane's dominant projection,
  // which preserves them for coplanar points) block exactly the segments their union,
  // that polygon, blocks: one convex occluder of k edges instead of several triangles,
  // without the inner edges, whose node planes cut fragments that come out visible on
  // both sides (the surfaces of columns, rooms and most meshes are made of such
  // patches: rectangles of two triangles, fans of caps). Grown greedily from the lowest
  // unassigned triangle, a triangle across one of the polygon's edges at a time, while
  // the polygon stays strictly convex and has at most kMaxPatchVertices corners; each
  // triangle in at most one patch. Meshes without any patch of two or more store nothing.
  static constexpr int kMaxPatchVertices = 8;
  // The patch of t (-1: none, t stands alone).
  int32_t patch(uint32_t t) const { return patch_of_.empty() ? -1 : patch_of_[t]; }
  // Its triangles (increasing) and its polygon (in the orientation of every one of them:
  // they are glued across consistently traversed edges only).
  std::span<const uint32_t> patch_triangles(int32_t p) const {
    const Patch& q = patches_[size_t(p)];
    return {patch_tris_.data() + q.tri_begin, q.tri_count};
  }
  std::span<const Vec3f> patch_polygon(int32_t p) const {
    const Patch& q = patches_[size_t(p)];
    return {patch_poly_.data() + q.poly_begin, q.poly_count};
  }

 private:
  void find_patches(const TriangleSoup& mesh, const mesh::PreparedMesh& pm);
  accel::Bvh<float> bvh_;
  struct Patch {
    uint32_t tri_begin = 0, tri_count = 0, poly_begin = 0, poly_count = 0;
  };
  std::vector<int32_t> patch_of_;  // empty when no patch exists
  std::vector<Patch> patches_;
  std::vector<uint32_t> patch_tris_;
  std::vector<Vec3f> patch_poly_;
};

template <class Skip>
void TriangleTree::candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out,
                              std::vector<Range>& skipped, Skip&& skip) const {
  out.clear();
  skipped.clear();
  if (bvh_.empty()) return;
  const Vec3d od = to_double(origin);
  std::array<uint32_t, accel::Bvh<float>::kMaxStack> stack;
  size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const uint32_t i = stack[--top];
    const auto& nd = bvh_.node(i);
    if (shaft.culls_box(nd.box.lo - origin, nd.box.hi - origin)) continue;
    Vec3d lo, hi;
    local_box(i, od, lo, hi);
    bool skipped_here = false;
    if constexpr (std::is_invocable_v<Skip, uint32_t, const Vec3d&, const Vec3d&>)
      skipped_here = skip(i, lo, hi);
    else
      skipped_here = skip(lo, hi);
    if (skipped_here) {
      uint32_t first = i;  // the leftmost leaf holds the subtree's first position
      while (!bvh_.is_leaf(bvh_.node(first))) first = bvh_.left(first);
      skipped.push_back(Range{bvh_.node(first).first, nd.count});
      continue;
    }
    if (bvh_.is_leaf(nd)) {
      const auto items = bvh_.leaf_items(nd);
      out.insert(out.end(), items.begin(), items.end());
      continue;
    }
    stack[top++] = bvh_.left(i);
    stack[top++] = bvh_.right(i);
  }
  std::sort(out.begin(), out.end());
}

}  // namespace visgate::plucker
