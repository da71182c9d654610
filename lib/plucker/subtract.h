// Subtracting one polygon's shadow from a receiver's light fragments (paper 002 section
// 4.2: Algorithm 1 lines 17-29 on bsp(o) walked once and never stored): the float path
// for near polygons and the exact near-plane path for triangles that rounding cannot
// place. Used by the per-receiver shading (shade_receiver.cpp). Internal to lib/plucker.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "lib/plucker/bsp.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/fragment.h"

namespace visgate::plucker {

// An index over a fragment list for subtract_polygon: the list cut into runs of
// consecutive fragments, each with a box that holds the boxes of its fragments (their
// union when built, grown since, never shrunk: a superset). A shadow box that misses a
// run's box misses every fragment box in it, so the run is passed over at once and the
// fragments visited, in their order, are exactly those a scan of every box visits.
// Lists of at most kIndexFrom fragments have no runs (size() == 0): every box is tested,
// which costs less than keeping the runs (columns, scan).
struct FragmentRuns {
  static constexpr uint32_t kRun = 16;  // fragments per run when built
  static constexpr size_t kIndexFrom = 2 * kRun;
  // Run j holds len[j] fragments, those after the runs before it (kept as lengths: a
  // replacement changes only its own run's).
  std::vector<uint32_t> len;
  std::vector<UVBox> box;
  size_t size() const { return box.size(); }
  size_t count() const;  // fragments in all runs
  // Runs of kRun fragments over `boxes` (the list's boxes), each with their union; none
  // for kIndexFrom boxes or fewer.
  void build(const std::vector<UVBox>& boxes);
};

// Subtracts the near polygon q (oriented: the receiver on its negative side) from the
// fragments, in place: bsp(q) walked once (Algorithm 1 lines 17-29 on a tree that is
// never stored). `qbox` bounds q's shadow on the light (shadow_box); a fragment whose
// box misses it is disjoint from the shadow and kept whole. boxes[frags.polys[k].box]
// is fragment k's box (FragmentList::Span): a list made by add() with its boxes pushed
// in the same order fits. Edges with skip[m] set (from q[m] to q[m+1]) are not tested:
// the caller knows every light line from r is on their inner side (the edge q has at
// r's own level, see the near-polygon loop in shade_receiver.cpp).
// Each fragment q's shadow meets is replaced, where it is, by its visible pieces (none
// when q hides all of it; the fragment itself, unsplit, when q hides none of it); the
// other fragments, their vertices and boxes stay as they are, uncopied (FragmentList
// may then hold garbage vertices, and `boxes` boxes no fragment uses; the pieces' boxes
// are appended). `pieces` and `piece_boxes` receive the pieces put in (the boxes bound
// the new fragments: with the old ones, every current fragment's).
// `runs` indexes frags (built over `boxes`) and is kept so: runs whose box misses qbox
// are passed over, replaced fragments' runs are grown by their pieces' boxes and their
// lengths changed, and runs grown long are cut anew; a list without runs gets them when
// it grows past kIndexFrom.
// With `defer_cuts` a met fragment's cut by edge m (not the last) is put off to the end
// of its walk when the cut's chord lies beyond the next edge's plane (q's edge m does not
// cross what is left of the fragment there): a fragment q's shadow overlaps at a corner
// is cut along the edges that bound the overlap, less often also along the others' lines.
// The walk through q's edges in another order: the same visible set, as fragments that
// differ from the in-order walk's by where they are cut and by the rounding of the cut
// vertices (each within a plane's error bound, fragment.h); c.deferred_cuts counts them.
// Returns false, with nothing changed, when q's shadow misses every fragment (box or
// edge plane; about half of the calls on columns).
bool subtract_polygon(const Vec3d& r, const Vec3d* q, int nq, const uint8_t* skip, const UVBox& qbox,
                      const UVAxes& axes, const LightBounds& light, FragmentList& frags, std::vector<UVBox>& boxes,
                      FragmentRuns& runs, FragmentList& pieces, std::vector<UVBox>& piece_boxes, std::vector<Vec3d>& cur,
                      std::vector<Vec3d>& pos, std::vector<Vec3d>& neg, BspCounters& c, bool defer_cuts = true);

// The exact near-plane path: removes from the fragments (local coordinates relative to
// `origin`) the light points x whose open segment from rw crosses the triangle tw
// properly (DESIGN section 3), with rw on side sigma (exact, nonzero) of tw's plane:
// x strictly on the other side of the plane, and the line rw -> x strictly on the
// stabbing side of every edge line (lines.h: side(rw -> x, t_e -> t_e+1) has the sign
// -sigma for lines crossing from side sigma). Then the crossing point lies strictly
// inside the triangle and strictly between rw and x, so no slab clipping is needed.
// Every sign is exact, taken at the region oracle's own light point of x: the exact
// lift onto the light's plane of x's (u, v) coordinates (origin + local, summed
// exactly; exact_orient.h LiftedLight); new vertices are interpolated in double from
// values accurate to 2^-30, so only points within rounding of a plane can be
// misjudged. Used where float cannot tell which way the planes through rw and the
// edges lean: receivers within rounding of a triangle's plane, extreme and undecided
// receivers, and triangles reaching far away or lying within rounding of the light's
// plane (occluder_selection.cpp, shade_receiver.cpp).
void subtract_triangle_exact(const Vec3f& rw, const Vec3f tw[3], int sigma, const Vec3f& origin,
                             const UVAxes& axes, const LiftedLight& lift, const FragmentList& in, FragmentList& out,
                             std::vector<UVBox>& out_boxes, std::vector<Vec3d>& cur);

}  // namespace visgate::plucker
