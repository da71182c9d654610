// Triangle shapes for the scene families (DESIGN section 7): closed, outward-oriented
// (counter-clockwise seen from outside) solids (boxes, cylinders, spheres, tori), open
// surfaces (quads, tessellated patches, fans, open sacks, the two-sheeted double cover
// of a disc of paper 000 Fig. 4.17) and rigid placement of a range of vertices. Every
// surface is indexed so that shared edges and vertices are shared indices: after
// lib/mesh/prepare's weld, a closed solid has zero single edges and an open surface has
// single edges only on its boundary.
#pragma once

#include <vector>

#include "lib/scene/scene.h"

namespace visgate::shapes {

void add_quad(TriangleSoup& s, const Vec3d& a, const Vec3d& b, const Vec3d& c, const Vec3d& d);  // a,b,c,d CCW
void add_box(TriangleSoup& s, const Vec3d& lo, const Vec3d& hi);
void add_cylinder(TriangleSoup& s, const Vec3d& base, double radius, double height, int segments);
void add_sphere(TriangleSoup& s, const Vec3d& center, double radius, int slices, int stacks);
// Torus around the z axis through `center`: major radius R, minor radius r; outward.
void add_torus(TriangleSoup& s, const Vec3d& center, double R, double r, int major_segments, int minor_segments);

// A planar patch origin + u*a/nu + v*b/nv (0 <= a <= nu, 0 <= b <= nv) split into
// 2*nu*nv triangles with shared vertices, counter-clockwise seen from the side u x v
// points to; the diagonal of each cell alternates in a checkerboard.
void add_patch(TriangleSoup& s, const Vec3d& origin, const Vec3d& u, const Vec3d& v, int nu, int nv);
// A fan of rim.size() triangles (center, rim[k], rim[k+1]) around a shared centre
// vertex; closed (the last triangle joins rim.back() to rim.front()) when `closed`.
void add_fan(TriangleSoup& s, const Vec3d& center, const std::vector<Vec3d>& rim, bool closed);
// A sphere with the polar cap around the pole +z (open_top) or -z removed down to polar
// angle `opening` (radians from that pole): an open sack whose outer side faces
// outwards. One boundary loop of `slices` edges.
void add_open_sphere(TriangleSoup& s, const Vec3d& center, double radius, int slices, int stacks, double opening,
                     bool open_top);
// The double cover of a disc (paper 000 Fig. 4.17): (r cos t, r sin t, h r sin(t/2)),
// 0 <= r <= R, t in [0, 4 pi), centred at `center`. `rings` rings of 2*`spokes`
// vertices at angles t = (k + 1/2) 2 pi / spokes (the half step keeps the two sheets'
// vertices apart), joined to one centre vertex: a consistently oriented, self-
// intersecting disc whose single boundary loop winds twice around the z axis.
void add_double_cover_disc(TriangleSoup& s, const Vec3d& center, double R, double h, int rings, int spokes);

// Rotates vertices [first, end) about `pivot` by `angle` radians around unit `axis`
// (Rodrigues, in double, rounded once to float).
void rotate(TriangleSoup& s, size_t first, const Vec3d& pivot, const Vec3d& axis, double angle);

}  // namespace visgate::shapes
