// Radial pairing of non-manifold edges for ISS (an extension of paper 000 section 4.2).
//
// Section 4.2 makes two triangles neighbours only across an edge that exactly those two
// traverse in opposite directions; lib/mesh leaves every edge with three or more
// triangles single on all of them. Boxes that abut (the wall segments of an
// architectural model, a door frame's parts) meet in such edges: the front faces of two
// wall boxes that touch end to end share the vertical edge at the joint with the two
// end faces. ISS then sees two separate surfaces where the wall is one plane, and since
// it does no occluder fusion (section 4.6) no shaft through the joint is ever blocked.
//
// This pass pairs the triangles around such an edge the way the boundary of the union
// of the solids runs: sorted by the angle of their third vertex about the edge, a
// triangle traversing the edge forwards has its (outward) normal turning
// counter-clockwise about the edge, one traversing it backwards clockwise; when the
// directions alternate around the edge, each forward triangle is paired with the next
// backward one counter-clockwise, i.e. across the wedge both normals point into (the
// empty side). Around the wall joint this joins the two front faces into one plane and
// the two coincident end faces into a pair.
//
// Guarantee: exactness does not depend on the pairing. Every paired edge is traversed
// in opposite directions by its two triangles, so every surface ISS builds is still an
// oriented 2-chain (the sum of its triangles) whose boundary is its set of single raw
// edges, which is all that blocks_shaft relies on (blockers.h); the pairing only decides
// which triangles form one connected surface. Angles are computed in double and only
// order the pairing; an edge whose directions do not alternate (rounding at a tie,
// odd counts, inconsistent facings) keeps single labels, as before. Labels are
// renumbered densely so that mesh::validate() holds afterwards.
#pragma once

#include <cstddef>

#include "lib/mesh/prepare.h"

namespace visgate::iss {

// Pairs the triangles of every non-manifold edge of `m` as described above. Returns the
// number of new double edges.
size_t pair_nonmanifold_edges(mesh::PreparedMesh& m);

}  // namespace visgate::iss
