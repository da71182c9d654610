// The candidate planes of Haines' shaft between two axis-aligned boxes (Haines & Wallace,
// "Shaft culling for efficient ray-cast radiosity", 1991; paper 000 section 4.4.1,
// Figure 4.3b; paper 002 section 4.4): the convex hull of two boxes is their common
// bounding box cut by planes parallel to one axis, each through a line of the hull of
// the two boxes' projections onto the other two axes. The support point of a rectangle
// in an oblique direction is the corner the direction's signs pick, the same corner type
// for both rectangles, so only lines through corresponding corners can be hull edges.
//
// The shaft's two users share this enumeration and differ in what they keep:
//  - iss::ShaftGeometry (lib/iss/shaft.h): oblique lines only, both orientations tried,
//    the offset raised to the largest evaluated corner value, unnormalised planes with a
//    margin of 2^-40 |n|_1 S (S the scene's largest coordinate), duplicates dropped.
//  - plucker::Shaft (lib/plucker/shaft.h): also axis-parallel lines, oriented towards
//    the corner, unit normals with one margin of 2^-20 of the shaft's extent plus its
//    distance from the origin.
// Both are conservative: a plane is kept only after a support test, and a plane that
// fails it only leaves the shaft larger.
#pragma once

#include "lib/geom/aabb.h"

namespace visgate {

// The line through corner `corner` of both boxes' projections onto axes (i, j).
struct ShaftCornerLine {
  int i = 0, j = 0;   // the projection's axes, i < j
  int corner = 0;     // bit 0: the high side on axis i, bit 1: on axis j
  double ai = 0, aj = 0;  // the corner of box a's projection
  double bi = 0, bj = 0;  // the same corner of box b's projection
};

// Calls f(line) for the three projections (i, j) = (0, 1), (0, 2), (1, 2) and, within
// each, the four corners in order 0..3.
template <class F>
void for_each_shaft_corner_line(const AABBd& a, const AABBd& b, F&& f) {
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j)
      for (int c = 0; c < 4; ++c) {
        ShaftCornerLine line;
        line.i = i;
        line.j = j;
        line.corner = c;
        line.ai = c & 1 ? a.hi[i] : a.lo[i];
        line.aj = c & 2 ? a.hi[j] : a.lo[j];
        line.bi = c & 1 ? b.hi[i] : b.lo[i];
        line.bj = c & 2 ? b.hi[j] : b.lo[j];
        f(line);
      }
}

}  // namespace visgate
