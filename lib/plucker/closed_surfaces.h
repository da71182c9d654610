// Closed surfaces of the scene, for occluder selection on dense meshes (paper 002 section
// 4.4 leaves the occluder set open: any set blocking the same lines will do).
//
// A closed surface here is a connected set of triangles in which every edge is shared by
// exactly two of them traversing it in opposite directions (the welded neighbours of
// lib/mesh/prepare.h): as an integer 2-chain its boundary is zero, self-intersections
// or not. Its winding number w(x) is then defined off the surface, is 0 outside its
// bounding box, and along a segment r -> l in general position (missing every edge and
// vertex) w(l) - w(r) is the number of crossings with r on the positive side of the
// crossed triangle's plane (orient3d(a, b, c, r) > 0) minus those with r on the negative
// side. So when r and l are both outside the surface's box, every such segment that
// crosses the surface crosses it at least once with r on each side: the triangles that
// can only be crossed with r on the negative side (or not at all) can be dropped, and
// those kept block the same segments in general position. Occluder selection decides
// "can only be crossed that way" from the sides of the group's receiver box and of the
// light polygon (occluder_selection.cpp closed_surface_culling); the closed shadows of the
// kept triangles then cover the same light region, since the segments in general
// position are dense in every triangle's shadow.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/mesh/prepare.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

class ClosedSurfaces {
 public:
  // `pm`: prepare_mesh(mesh), shared with the triangle tree's patches.
  ClosedSurfaces(const TriangleSoup& mesh, const mesh::PreparedMesh& pm);
  explicit ClosedSurfaces(const TriangleSoup& mesh) : ClosedSurfaces(mesh, mesh::prepare_mesh(mesh)) {}

  // The closed surface of input triangle t, or -1 (open, non-manifold, inconsistently
  // oriented, or degenerate after welding).
  int32_t surface(uint32_t t) const { return surface_of_.empty() ? -1 : surface_of_[t]; }
  size_t count() const { return boxes_.size(); }
  // The float box of its vertices (world coordinates).
  const AABB& box(int32_t s) const { return boxes_[size_t(s)]; }
  // Triangles of surface s.
  uint32_t triangles(int32_t s) const { return sizes_[size_t(s)]; }
  // Per surface its input triangles, ascending.
  std::vector<std::vector<uint32_t>> triangle_lists() const {
    std::vector<std::vector<uint32_t>> out(count());
    for (size_t s = 0; s < count(); ++s) out[s].reserve(sizes_[s]);
    for (uint32_t t = 0; t < surface_of_.size(); ++t)
      if (surface_of_[t] >= 0) out[size_t(surface_of_[t])].push_back(t);
    return out;
  }
  // +1 when the triangles face outwards (signed volume clearly positive), -1 inwards, 0
  // when the double sum cannot tell. A choice of which crossing side to keep, never a
  // condition of correctness (occluder_selection.cpp).
  int orientation(int32_t s) const { return orient_[size_t(s)]; }
  // The input triangles glued to t across its edges (welded neighbours, each edge
  // traversed in opposite directions; -1 none), for a triangle of a closed surface.
  const std::array<int32_t, 3>& neighbors(uint32_t t) const { return nb_[t]; }
  size_t memory_bytes() const {
    return surface_of_.capacity() * sizeof(int32_t) + nb_.capacity() * sizeof(std::array<int32_t, 3>) +
           boxes_.capacity() * sizeof(AABB) +
           sizes_.capacity() * sizeof(uint32_t) +
           orient_.capacity();
  }

 private:
  std::vector<int32_t> surface_of_;  // empty when the scene has no closed surface
  std::vector<std::array<int32_t, 3>> nb_;  // by input triangle; empty with surface_of_
  std::vector<AABB> boxes_;
  std::vector<uint32_t> sizes_;
  std::vector<int8_t> orient_;
};

}  // namespace visgate::plucker
