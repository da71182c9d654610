// Light fragments (paper 002 section 4.2): convex pieces of the light polygon, split by
// the plane through the query point and a node's line (Figure 6), plus the measures the
// soft-shadow framework takes on them (section 4.4): area, point-in-fragment and the
// analytic Lambert irradiance [NN85].
//
// Precision: float32 vertices; split signs decided with the kDetErr bound of lines.h
// (a vertex within the bound lies "on" the plane and goes to both pieces). New vertices
// are interpolated in float, so a fragment's vertices are off the light plane by
// rounding (about 1e-7 relative); areas and irradiance accumulate in double.
#pragma once

#include <cstdint>
#include <vector>

#include "lib/geom/vec.h"

namespace visgate::plucker {

// Result of classifying a fragment against the plane through r and the line a -> b,
// i.e. of the lines r -> x, x in the fragment, against the hyperplane of a -> b.
enum class SplitResult : uint8_t {
  Positive,   // all lines side >= 0 (some > 0): the whole fragment goes left
  Negative,   // all lines side <= 0 (some < 0): the whole fragment goes right
  Both,       // mixed: `pos` and `neg` receive the two convex pieces
  OnLine,     // degenerate: r lies on the line a -> b, every line r -> x meets it: side
              // is 0 for all; callers send the fragment right (Negative), see bsp.h
  ZeroArea,   // degenerate: every vertex lies on the plane, the fragment is a segment
};

// Splits the convex polygon `poly` (n vertices) by the plane through r and a -> b.
// With Both, `pos` and `neg` are overwritten with the pieces (each >= 3 vertices, or
// empty when rounding leaves fewer; a piece of fewer than 3 vertices has zero area).
SplitResult split_fragment(const Vec3f& r, const Vec3f& a, const Vec3f& b, const Vec3f* poly, int n,
                           std::vector<Vec3f>& pos, std::vector<Vec3f>& neg);

// The classification of split_fragment without building the pieces (Both: mixed).
SplitResult classify_fragment(const Vec3f& r, const Vec3f& a, const Vec3f& b, const Vec3f* poly, int n);

// Keeps the part of `poly` where value >= 0 (keep_nonneg) or value <= 0, given one value
// per vertex of an affine function; the result may be empty. Used to clip occluders to
// the slab between a receiver and the light (DESIGN section 3).
void clip_by_values(const Vec3f* poly, const float* values, int n, bool keep_nonneg, std::vector<Vec3f>& out);

// Area of a planar polygon (Newell, double).
double polygon_area(const Vec3f* poly, int n);

// A 2D frame on the light plane: drop the axis where the light normal is largest; `flip`
// makes counter-clockwise (about the light normal) polygons positive in 2D.
struct PlaneFrame {
  int u = 0, v = 1;
  bool flip = false;
  static PlaneFrame from_normal(const Vec3f& n);
};

// Point in a convex fragment on the light plane (counter-clockwise about the light
// normal), boundary included: orientation of p against each edge in the 2D frame,
// accepted when >= -bound with the float bound of a 2D orientation (see fragment.cpp).
bool point_in_fragment(const PlaneFrame& f, const Vec3f* poly, int n, const Vec3f& p);

// Lambert irradiance at r with unit normal nr from a uniformly emitting polygon of unit
// radiance (Nishita-Nakamae: E = 1/2 sum_k theta_k (nr . gamma_k)), the polygon first
// clipped to the receiver's upper half-space nr . (x - r) >= 0. Double precision.
double lambert_irradiance(const Vec3f& r, const Vec3f& nr, const Vec3f* poly, int n);

}  // namespace visgate::plucker
