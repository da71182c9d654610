// Closed, outward-oriented (counter-clockwise seen from outside) triangle shapes for the
// scene families: boxes, cylinders, spheres, tori, quads.
#pragma once

#include "lib/scene/scene.h"

namespace visgate::shapes {

void add_quad(TriangleSoup& s, const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);  // a,b,c,d CCW
void add_box(TriangleSoup& s, const Vec3d& lo, const Vec3d& hi);
void add_cylinder(TriangleSoup& s, const Vec3d& base, double radius, double height, int segments);
void add_sphere(TriangleSoup& s, const Vec3d& center, double radius, int slices, int stacks);
// Torus around the z axis through `center`: major radius R, minor radius r.
void add_torus(TriangleSoup& s, const Vec3d& center, double R, double r, int major_segments, int minor_segments);

}  // namespace visgate::shapes
