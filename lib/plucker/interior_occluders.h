// Interior occluders of closed surfaces (paper 002 section 4.4 leaves the occluder set
// open: any set blocking exactly the lines the scene blocks will do).
//
// A convex polygon Q strictly inside the solid of a closed surface (closed_surfaces.h:
// Q meets no triangle of the surface, and the winding number w of the surface is nonzero
// on Q) blocks only segments the surface already blocks: a segment r -> l with w(r) = 0
// (r outside the surface's box) that passes through a point of Q changes w along the
// way, so it crosses the surface (in general position, through a triangle's interior).
// Adding Q to a group's tree occluders therefore changes no visible region; what it
// changes is the cost: the lazy BSP (bsp.h) ends a fragment inside Q's shadow at Q's
// invisible class, and insertOccluder drops every triangle whose lines through the light
// all stab Q, so the tree's size and the query's splits follow the band between Q's
// shadow and the surface's silhouette instead of every triangle of the shadow.
//
// Per closed surface (of at least kMinTriangles triangles) and light: the cross-section
// of the solid by the plane through the surface box's centre facing the light, and in it
// a convex polygon of up to kMaxVertices corners inscribed along rays from the centre;
// then, for non-convex solids, further polygons from other centres and planes where the
// cross-sections leave the polygons taken (the constructor's `extra`).
// Exactness does not depend on how the polygon is found, only on its checks:
//  - exactly planar: its corners are points p + i u + j v of a lattice (p, u, v on a
//    dyadic grid fine enough that every corner is a float, computed exactly in double),
//    so all of them lie in the plane through p spanned by u and v;
//  - strictly convex: integer hull of the lattice coordinates (i, j);
//  - disjoint from every triangle of the surface, closed (touching counts as meeting):
//    exact orientations (orient3d_filtered, then orient3d_exact) of every triangle edge
//    against Q's fan triangles and of every Q edge against the triangle;
//  - inside: the signed count of proper crossings of a segment from an interior lattice
//    point of Q to a point outside the surface's box is nonzero (exact orientations; a
//    segment through an edge or vertex is not used).
// A surface or light where a check fails gets no polygon (the polygons are optional).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "lib/plucker/closed_surfaces.h"
#include "lib/scene/scene.h"

namespace visgate::plucker {

class SurfaceTrees;

class InteriorOccluders {
 public:
  static constexpr uint32_t kMinTriangles = 256;
  static constexpr int kMaxVertices = 10;  // bsp.h kMaxOccluderVertices

  // `extra`: at most this many further polygons per surface and light, inscribed from
  // other centres and in planes offset along the light's direction where the
  // cross-sections leave the first polygon's projection (a non-convex solid: ears,
  // limbs, folds); 0: one polygon as before.
  static constexpr size_t kDefaultExtra = 24;
  // `trees`: when given, its per-surface triangle hierarchies are walked instead of
  // building the same ones again (the same boxes and rule, so the same polygons).
  InteriorOccluders(const Scene& scene, const ClosedSurfaces& cs, size_t extra = kDefaultExtra,
                    const SurfaceTrees* trees = nullptr);

  struct Entry {
    int32_t surface;
    uint32_t light;
    uint32_t begin, count;  // corners in poly_
  };
  // Every polygon found, by light then surface.
  const std::vector<Entry>& entries() const { return entries_; }
  // The polygons of light li (a range of entries()).
  std::span<const Entry> of_light(size_t li) const {
    return {entries_.data() + light_begin_[li], light_begin_[li + 1] - light_begin_[li]};
  }
  // Its corners (world floats), convex, in one plane.
  std::span<const Vec3f> polygon(const Entry& e) const { return {poly_.data() + e.begin, e.count}; }
  size_t memory_bytes() const {
    return entries_.capacity() * sizeof(Entry) + poly_.capacity() * sizeof(Vec3f) +
           light_begin_.capacity() * sizeof(size_t);
  }

 private:
  std::vector<Entry> entries_;
  std::vector<Vec3f> poly_;
  std::vector<size_t> light_begin_;
};

// The checks of the polygon Q (world floats, strictly convex, corners in order, in one
// plane) against one triangle (a, b, c): true when they meet, closed, or when the exact
// test cannot tell them apart (Q in the triangle's plane, or an edge of the triangle in
// Q's). Exposed for tests.
bool polygon_meets_triangle(std::span<const Vec3f> q, const Vec3f& a, const Vec3f& b, const Vec3f& c);
// The same with sides[i] the exact sign (+1, -1, 0) of orient3d(q[0], q[1], q[2], x) for
// x = a, b, c (the builder keeps them per vertex).
bool polygon_meets_triangle(std::span<const Vec3f> q, const Vec3f& a, const Vec3f& b, const Vec3f& c,
                            const int sides[3]);

}  // namespace visgate::plucker
