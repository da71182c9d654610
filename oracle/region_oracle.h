// The region oracle (DESIGN section 5): the exact visible region of a light polygon from
// a receiver. Each blocker is clipped exactly to the open slab between the receiver and
// the light plane, projected centrally from the receiver onto the light plane, the
// projections are unioned and subtracted from the light polygon, all with exact rational
// arithmetic (Epeck, CGAL 2D Boolean set operations). Blockers outside the
// receiver-light pyramid are culled before any exact work.
//
// Exact frame. The float32 light vertices are planar only within rounding, so the oracle
// fixes one exact light: its plane has the exact Newell normal n = sum v_i x v_(i+1) of
// the float vertices and passes through their exact centroid; the 2D frame drops the
// axis k of the largest |n_k| (coordinates (k+1)%3, (k+2)%3); the light region is the
// polygon of the float vertices with coordinate k dropped, lifted back onto the plane
// (an affine bijection). Areas in the frame are 3D areas times |n_k| / |n|, so the
// fraction is a ratio of exact frame areas; visible_area applies the scale in double.
// Lights in an axis plane (the usual case) are exactly their float polygon.
//
// Blockers, exactly (g = signed height over the light plane, positive on the receiver's
// side, g_r = g(receiver) > 0; the open slab is 0 < g < g_r):
//   - zero-area triangles and triangles whose plane contains the receiver project to a
//     segment or a point: zero area, skipped (this covers a receiver on a face, edge or
//     vertex of a blocker: such a triangle cannot meet an open segment leaving its plane);
//   - all g <= 0 (beyond or in the light plane) or all g >= g_r: outside the open slab,
//     skipped; a triangle touching the light plane keeps its part with g >= 0 (points with
//     g = 0 project onto themselves, a measure-zero boundary);
//   - max g < g_r: clipped to g >= 0 and projected;
//   - otherwise (reaching the receiver's level): first clipped to the receiver-light
//     pyramid (planes through the receiver and the lifted light edges), which leaves only
//     points with g > 0 apart from the receiver itself, then clipped to g >= 0.
// Fast paths (no Boolean operations, same exact answer). After the double cull, every
// triangle is classified in double with forward error bounds (region_oracle.cpp
// FastPass): a triangle certainly strictly inside the open slab (0 < g < g_r at every
// vertex) whose shadow, the wedge of the planes through r and its edges, certainly has
// the whole light outside one edge plane is a Miss and is dropped; one whose wedge
// certainly holds every light vertex strictly inside is a Cover: every segment from r
// to the light crosses its interior strictly between the endpoints, the fraction is 0.
// Anything not certain in double (near-degenerate, crossing a slab plane, partial) is
// Unknown and goes to the exact path, so the answers are those of the exact path (checked
// bit for bit against RegionOptions{false} in tests/oracle/region_oracle_test.cpp). With no Unknown
// triangle the region is the light polygon itself, without an arrangement.
// Receiver on the light plane (g_r = 0): edge_on = true, no region is computed
// (fraction 0, no polygons, irradiance 0); the comparator skips such pairs.
//
// Irradiance: the visible polygons, lifted to 3D in double and clipped to the receiver's
// upper half-space n_r . (x - r) >= 0, give F = -sum_edges theta_e (n_r . unit(v_e x
// v_e+1)) / (2 pi) with v = vertex - r and theta_e the angle between v_e and v_e+1
// (Lambert's polygon formula; outer boundaries in the light's orientation, holes
// reversed). F is the irradiance of a light of unit radiant exitance (radiance 1/pi);
// multiply by pi for unit radiance. 0 when the receiver is behind the emitting side.
// Double precision, not exact.
#pragma once

#include <memory>
#include <vector>

#include "lib/scene/scene.h"
#include "lib/solver.h"

namespace visgate::oracle {

struct RegionAnswer {
  double visible_fraction = 0.0;   // exact area ratio, rounded to double at the end
  std::vector<Polygon3f> polygons;  // visible part of the light, rounded to float for output
  double irradiance = 0.0;          // Lambert irradiance at the receiver, unit exitance (see above)
  // Added fields.
  std::vector<bool> hole;           // parallel to polygons: true for a hole boundary
                                    // (outer boundaries run like the light polygon, holes reversed)
  double visible_area = 0.0;        // 3D area of the visible region (double)
  double light_area = 0.0;          // 3D area of the exact light polygon (double)
  size_t blockers_projected = 0;    // triangles that survived culling and were projected
  bool edge_on = false;             // receiver exactly on the light plane: nothing computed
  bool fast_path = false;           // decided without Boolean operations (see "Fast paths")
};

struct RegionOptions {
  bool fast_paths = true;  // false: every culled triangle goes to the exact path (tests)
  // false: only visible_fraction, the areas and the counts are filled; no polygons, hole
  // flags or irradiance (the comparator, which reads the fraction only). The fraction is
  // the same either way.
  bool outputs = true;
};

// Work visible_fraction_bound and visible_region share within one scene, for a caller
// that checks many pairs of it in one thread (the comparator): each light's exact frame
// is made once, and the preparation of the last pair (the frame, the pyramid, the cull
// and the fast-path classification) is kept for a visible_region of that pair that
// follows its bound. Answers are the same with and without a cache (the same exact
// values, only not computed again). Not thread-safe: one cache per thread; the scene
// must outlive it and stay unchanged.
class RegionCache {
 public:
  explicit RegionCache(const Scene& scene);
  ~RegionCache();
  RegionCache(const RegionCache&) = delete;
  RegionCache& operator=(const RegionCache&) = delete;
  struct Impl;  // region_oracle.cpp
  Impl& impl() { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

RegionAnswer visible_region(const Scene& scene, size_t receiver, size_t light, const RegionOptions& opt = {},
                            RegionCache* cache = nullptr);

// Certified enclosure of the visible fraction, without Boolean operations (for the
// comparator: most pairs are decided by it, the rest by visible_region). When
// `certified`, lo <= hi are doubles with lo <= A / A_L <= hi for the exact area ratio
// of visible_region (so also lo <= its visible_fraction <= hi: rounding is monotone).
// Method: the exact path's frame, cull and fast paths (prepare in region_oracle.cpp),
// and its exact skips (zero projected area, outside the open slab). A triangle certainly
// strictly inside the slab is projected in interval arithmetic; any other (or one whose
// intervals come out wide) goes through the exact path's clipping with lazy exact
// numbers (exact signs), its projected vertices taken as intervals, computed exactly
// where those are wide. A shadow reaching beyond L's box grown by its own extent is taken
// from the triangle clipped to the pyramid instead (its part inside L: the same region).
// A triangle's own vertices are projected by one interval formula whichever way the
// triangle goes, and a clip point on an edge is formed from the edge's lexicographically
// smaller end, so shadows sharing a vertex or an edge get the same double points and
// their shared edges are exactly collinear. Each shadow S' is the convex hull of the
// interval midpoints (vertex errors delta). The area of the light minus the union of the S' is computed by
// a boundary integral whose side decisions are exact orientations on the doubles (shared
// and collinear edges included) and whose rounded cut parameters enter with error
// bounds; sum (delta min(per S', per L) + 3 pi delta^2) covers the vertex errors
// (Hausdorff distance and Steiner's formula). The enclosure may be wide (up to [0, 1]):
// nearly collinear edges of different shadows make cut parameters ill-conditioned.
// Interval arithmetic runs only inside rounding-mode guards; the caller's mode is kept.
struct FractionBound {
  bool edge_on = false;     // receiver exactly on the light plane (as RegionAnswer)
  bool certified = false;   // [lo, hi] holds the exact fraction
  double lo = 0.0, hi = 1.0;
  size_t unknown_triangles = 0;  // left undecided by the fast paths
  size_t shadows = 0;            // double shadow triangles in the boundary integral
  const char* why = "";          // when not certified and not edge-on: the reason (rare)
};
FractionBound visible_fraction_bound(const Scene& scene, size_t receiver, size_t light, RegionCache* cache = nullptr);

}  // namespace visgate::oracle
