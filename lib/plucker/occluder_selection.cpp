// Occluder selection for one group of receivers and one light (paper 002 section 4.4,
// "Implementation details": Haines' shaft between the group's box and the light's;
// Figure 8 column "SC"), with the slab of DESIGN section 3 (plucker_solver.h): each
// candidate triangle is clipped to the light side of the light plane and split at the
// group's g-plane cut into a tree occluder (beyond it, between every receiver and the
// light) and a near polygon (the rest, handled per receiver). Triangles that rounding
// cannot place this way go to the exact list, subtracted per receiver exactly.
#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <optional>
#include <span>

#include "lib/base/check.h"
#include "lib/geom/morton.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/group_state.h"
#include "lib/plucker/shaft.h"

namespace visgate::plucker {

namespace {

// True when a polygon clipped at the light plane has a clip point and a neighbour that
// rounding cannot tell apart: two consecutive vertices at most eps apart, one of them
// on the plane, eps = 2^-36 of the two points' own coordinates (local frame; a clip
// point is interpolated from its edge's near end, fragment.h, so its rounding is
// relative to its own magnitude, not the polygon's). Such an edge's direction is
// rounding noise, and merging the two points instead can drop a sliver seen edge-on
// (test SliverSeenEdgeOnIsNotMergedAwayAtTheLightPlane): such triangles are subtracted
// exactly per receiver (subtract_triangle_exact, which needs no clipping at the light
// plane), as those within rounding of the plane (`plane_point_triangles`).
// `poly` has at least 3 vertices.
bool close_plane_points(const std::vector<Vec3d>& poly, const std::vector<uint8_t>& on_plane) {
  auto close = [](const Vec3d& a, const Vec3d& b) {
    const double eps = 0x1p-36 * std::max(max_component(vabs(a)), max_component(vabs(b)));
    return max_component(vabs(a - b)) <= eps;
  };
  const size_t n = poly.size();
  for (size_t k = 0; k < n; ++k) {
    const size_t k1 = (k + 1) % n;
    if ((on_plane[k] || on_plane[k1]) && close(poly[k], poly[k1])) return true;
  }
  return false;
}

// Side of the corners of the receivers' box (its distinct ones: GroupState::wcorners)
// against the plane of the triangle t, in world coordinates (the inputs as given: the
// local frame's rounding moves points by u |x - o|, enough to put a receiver just below
// a face above it; test ReceiverWithinRoundingOfAFace): per corner x the sign of
// orient3d(t0, t1, t2, x), in float as (x - base) . N with N = edge_plane_normal_err(t0,
// t1, t2) (the cross product of its two shortest edges, which keeps the plane of a
// sliver with a far vertex) and base the vertex nearest to x (lines.h nearest_base),
// decided against dot_err; undecided counts for neither side. +1 when every corner is
// strictly on the positive side, -1 when every one is strictly negative, else 0; the
// normal and its bound are computed once and the loop stops at the first corner that
// breaks the common sign.
int box_side(const Vec3f t[3], const Vec3f* corners, int ncorners) {
  Vec3f err;
  const Vec3f nrm = edge_plane_normal_err(t[0], t[1], t[2], err);
  int side = 0;
  for (int c = 0; c < ncorners; ++c) {
    const Vec3f d = corners[c] - nearest_base(t[0], t[1], t[2], corners[c]);
    const float s = dot(d, nrm), bound = dot_err(d, nrm, err);
    const int sd = s > bound ? 1 : (s < -bound ? -1 : 0);
    if (sd == 0 || (c > 0 && sd != side)) return 0;
    side = sd;
  }
  return side;
}

// Per interior occluder added (interior_occluders): its edges' fans against the light
// and the receivers' box corners (lines.h EdgeFan), for covered_by_interior.
struct Cover {
  int n = 0;
  EdgeFan light[kMaxOccluderVertices], region[kMaxOccluderVertices];
  mutable int hint = 0;  // the edge that failed last (covered_by_interior, covered_box)
};

bool covered_box(const std::vector<Cover>& covers, bool rloc_exact, const Vec3d& lo, const Vec3d& hi);

// The group's shaft and covers (Selection), shared with the receivers' candidate test.
struct WalkTest {
  std::optional<Shaft> shaft;
  std::vector<Cover> covers;
  bool rloc_exact = false;
};

// The selection over one group's state; each step one method.
class Selection {
 public:
  Selection(GroupState& gs, Totals& tot)
      : gs_(gs), tot_(tot), scene_(*gs.ctx->scene), lf_(*gs.lf), sigma_(gs.sigma) {}

  void run() {
    receivers_and_slab();
    working_scale();
    shaft_.emplace(rbox_, lf_.box);
    interior_occluders();
    candidates();
    sort_near();
  }

 private:
  void receivers_and_slab();
  void working_scale();
  void candidates();
  void closed_surface_culling();
  void region_surfaces(bool use_covers);
  void interior_occluders();
  bool covered_by_interior(const Vec3d* pts, int n) const;
  bool covered_box(const Vec3d& lo, const Vec3d& hi) const {
    return plucker::covered_box(covers_, gs_.rloc_exact, lo, hi);
  }
  bool select_patch(int32_t pid, std::span<const uint32_t> tris, const Vec3d tt[3]);
  void select_triangle(uint32_t t, const Vec3d tri[3]);
  bool closed_near(uint32_t t) const;
  [[gnu::always_inline]] inline NearPoly make_near(uint32_t t, const Vec3d tri[3], double tmax,
                                                   const std::vector<Vec3d>& part) const;
  void add_near(const NearPoly& np, const std::vector<Vec3d>& part) {
    gs_.near.push_back(np);
    gs_.near_verts.insert(gs_.near_verts.end(), part.begin(), part.end());
  }
  void sort_near();
  void blocks();

  GroupState& gs_;
  Totals& tot_;
  const Scene& scene_;
  const LocalLight& lf_;
  const float sigma_;
  AABB rbox_;  // the receivers' float box for the shaft (its margin covers the rounding)
  // What the shaft walk tests per tree node, kept past the selection for the
  // receivers' candidate test (SilhouetteGroup::node_passes).
  std::shared_ptr<WalkTest> walk_ = std::make_shared<WalkTest>();
  std::optional<Shaft>& shaft_ = walk_->shaft;  // made once the receivers' box is known
  std::vector<Cover>& covers_ = walk_->covers;
  int8_t keep_side_ = 0;  // NearPoly::keep_side of the triangle being selected
};

// Slab (DESIGN section 3): let g point towards the light with g . x > g . r for every
// light point x and receiver r. A point p on the line r -> x lies strictly between r
// and x iff g . p > g . r and h(p) > 0 (h: distance from the light plane, positive on
// the receivers' side): along the line g grows from r to x and h falls to 0 at x. With
// gmax the largest g . r of the group, a triangle part with g . p >= gmax + delta and
// h >= 0 is between every receiver of the group and the light (tree occluders); the
// band g . p <= gmax + delta is clipped per receiver (near polygons). g is the receiver
// grid's normal when the light lies beyond the group's grid plane (flat tiles: a band
// of rounding width), else the light's normal (the band spans the group's depth).
void Selection::receivers_and_slab() {
  const std::vector<uint32_t>& group = *gs_.group;
  // Everything below is in the light's local frame (plucker_solver.h): the group's
  // receivers are translated here, the triangles as they are selected.
  std::vector<Vec3d>& rloc = gs_.rloc;
  rloc.resize(group.size());
  Vec3d dlo(std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
            std::numeric_limits<double>::infinity());
  Vec3d dhi = -dlo;
  gs_.rloc_exact = true;
  for (size_t k = 0; k < group.size(); ++k) {
    rloc[k] = to_local_d(scene_.receivers[group[k]].p, lf_.origin);
    gs_.rloc_exact = gs_.rloc_exact && translates_exactly(scene_.receivers[group[k]].p, lf_.origin);
    rbox_.extend(Vec3f(rloc[k]));
    dlo = vmin(dlo, rloc[k]);
    dhi = vmax(dhi, rloc[k]);
  }
  gs_.dlo = dlo;
  gs_.dhi = dhi;
  // g-values are taken relative to a reference receiver (g . p keeps the digits of the
  // differences, not those of the local coordinates).
  const Vec3d ref = rloc[0];
  gs_.ref = ref;
  AABB both = rbox_;
  both.extend(lf_.box);
  double coord_max = max_component(vmax(vabs(to_double(both.lo) - ref), vabs(to_double(both.hi) - ref)));
  auto gval = [&](const Vec3d& g, const Vec3d& p) { return dot(g, p - ref); };
  auto group_plane = [&](const Vec3d& g, double& gmin, double& gmax) {
    gmin = std::numeric_limits<double>::infinity();
    gmax = -gmin;
    for (const Vec3d& p : rloc) {
      double v = gval(g, p);
      gmin = std::min(gmin, v);
      gmax = std::max(gmax, v);
    }
  };
  // delta: a separation of the tree occluders from every receiver's g-plane far above
  // the rounding of g . (p - ref) (in float it had error < 5.01 u |g|_1 |p - ref|_1;
  // now in double, the float-sized delta is kept as a wide, conservative band): with
  // |p - ref|_inf <= coord_max inside the shaft, 16 u |g|_1 3 coord_max.
  Vec3d g = lf_.nd * double(-sigma_);
  double gmin = 0, gmax = 0;
  group_plane(g, gmin, gmax);
  if (scene_.grid) {
    Vec3d gn = to_double(normalize(scene_.grid->normal));
    double nmin = 0, nmax = 0;
    group_plane(gn, nmin, nmax);
    double dlt = 16.0 * double(kUnitRoundoffF) * (std::abs(gn.x) + std::abs(gn.y) + std::abs(gn.z)) * 3.0 * coord_max;
    bool beyond = true, below = true;
    for (const Vec3d& v : lf_.poly) {
      double gv = gval(gn, v);
      beyond &= gv > nmax + 2 * dlt;
      below &= gv < nmin - 2 * dlt;
    }
    if (below) {
      gn = -gn;
      group_plane(gn, nmin, nmax);
    }
    if (beyond || below) {
      g = gn;
      gmin = nmin;
      gmax = nmax;
    }
  }
  gs_.g = g;
  gs_.gmin = gmin;
  gs_.gmax = gmax;
  gs_.delta = 16.0 * double(kUnitRoundoffF) * (std::abs(g.x) + std::abs(g.y) + std::abs(g.z)) * 3.0 * coord_max;
  gs_.gcut = gmax + gs_.delta;
  // World corners of the receivers' box, for the one-sided test (box_side).
  AABB wbox;
  for (uint32_t i : group) wbox.extend(scene_.receivers[i].p);
  gs_.nwcorners = distinct_corners(wbox.lo, wbox.hi, gs_.wcorners);
  gs_.ncorners = distinct_corners(dlo, dhi, gs_.corners);
}

// Triangles reaching far beyond the group's working scale (the light's extent and the
// receivers' distance from it): every double quantity of their clipping carries an
// absolute rounding of about 2^-53 of their coordinates (and the translation to the local
// frame one of u_d |x| when exponents differ by more than 29). Up to 2^20 times the
// working scale that stays below 2^-33 of it, the level the far-receiver bound
// (shade_receiver.cpp) accepts; beyond, such triangles are subtracted exactly per
// receiver (subtract_triangle_exact on the float inputs), never clipped in double (test
// TriangleReachingFarBeyondTheSceneIsSubtractedExactly). The receivers that set the scale are
// those the float path shades: one more than 2^20 light widths from the light is extreme
// and shaded exactly, so it does not count (test
// ExtremeReceiverDoesNotSetTheGroupsWorkingScale).
void Selection::working_scale() {
  // The light's width: its longest side, or its area over that side when that is smaller.
  gs_.light_width = std::min(double(lf_.extent), double(scene_.lights[gs_.li].area) / double(lf_.extent));
  double work_scale = double(lf_.extent);
  for (const Vec3d& rl : gs_.rloc) {
    const double d = max_component(vabs(rl - lf_.bounds.centroid));
    if (std::max(d, double(lf_.extent)) <= 0x1p20 * gs_.light_width) work_scale = std::max(work_scale, d);
  }
  gs_.work_scale = work_scale;
}

// tmax: the largest |local coordinate| of the triangle (the selection loop's).
NearPoly Selection::make_near(uint32_t t, const Vec3d tri[3], double tmax, const std::vector<Vec3d>& part) const {
  NearPoly np;
  np.triangle = t;
  np.begin = uint32_t(gs_.near_verts.size());
  np.count = uint32_t(part.size());
  np.lo = np.hi = part[0];
  for (const Vec3d& v : part) np.lo = vmin(np.lo, v), np.hi = vmax(np.hi, v);
  np.pmax = max_component(vmax(vabs(np.lo), vabs(np.hi)));
  for (int k = 0; k < 3; ++k) np.t[k] = tri[k];
  np.n = edge_plane_normal_err(tri[0], tri[1], tri[2], np.err);
  Vec3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0];
  np.e1 = std::abs(e1.x) + std::abs(e1.y) + std::abs(e1.z);
  np.e2 = std::abs(e2.x) + std::abs(e2.y) + std::abs(e2.z);
  np.tmax = tmax;
  np.keep_side = keep_side_;
  np.exact_local = translates_exactly(scene_.mesh.corner(t, 0), lf_.origin) &&
                   translates_exactly(scene_.mesh.corner(t, 1), lf_.origin) &&
                   translates_exactly(scene_.mesh.corner(t, 2), lf_.origin);
  return np;
}

// The shaft's candidates in order; a coplanar convex patch is taken from its first
// triangle when all of its triangles are candidates (select_patch), every other
// triangle alone (select_triangle).
void Selection::candidates() {
  std::vector<uint32_t>& cand = gs_.cand;
  const TriangleTree& tree = *gs_.ctx->tree;
  walk_->rloc_exact = gs_.rloc_exact;
  const bool use_covers = !covers_.empty() && gs_.ctx->cover_nodes;
  region_surfaces(use_covers);
  const SilhouetteGroup& sil = gs_.sil;
  if (!use_covers && sil.surfaces.empty()) {
    tree.candidates(*shaft_, lf_.origin, cand);
  } else {
    // Whole subtrees whose box is covered (covered_by_interior on its 8 corners: the
    // orientation of lines through a convex set follows from its corners, lines.h) are
    // left out before the closed-surface sides and the per-triangle tests, which cost
    // more per triangle than the box test per node (scan: most of the shaft is covered).
    // So are subtrees of a region surface's triangles alone (region_surfaces): the
    // receivers ask which of them are candidates when they reach their edges. Both are
    // recorded as skipped ranges, whose triangles the exact path still subtracts.
    std::vector<uint8_t>& covered = gs_.merged;  // per skipped range: 1 covered, 0 a region surface's (scratch until below)
    covered.clear();
    // Set whenever a region surface is (region_surfaces returns early without it).
    const int32_t* node_surface = sil.surfaces.empty() ? nullptr : gs_.ctx->tree_surfaces->node_surface.data();
    tree.candidates(*shaft_, lf_.origin, cand, gs_.cand_skipped, [&](uint32_t i, const Vec3d& lo, const Vec3d& hi) {
      if (node_surface && node_surface[i] >= 0 && sil.is_region[size_t(node_surface[i])]) {
        covered.push_back(0);
        return true;
      }
      if (use_covers && covered_box(lo, hi)) {
        covered.push_back(1);
        return true;
      }
      return false;
    });
    for (size_t k = 0; k < covered.size(); ++k)
      if (covered[k]) tot_.interior_skipped += gs_.cand_skipped[k].count;
  }
  // The region surfaces' candidates in leaves shared with other triangles, left out too.
  gs_.region_drop.clear();
  if (!sil.surfaces.empty()) {
    const ClosedSurfaces& cs = *gs_.ctx->closed;
    gs_.region_drop.assign(cand.size(), 0);
    for (size_t ci = 0; ci < cand.size(); ++ci) {
      const int32_t s = cs.surface(cand[ci]);
      gs_.region_drop[ci] = s >= 0 && sil.is_region[size_t(s)];
    }
  }
  closed_surface_culling();
  std::vector<uint8_t>& merged = gs_.merged;  // per candidate: shaded as part of a patch
  merged.assign(cand.size(), 0);
  for (size_t ci = 0; ci < cand.size(); ++ci) {
    const uint32_t t = cand[ci];
    if (merged[ci]) continue;
    if (!gs_.region_drop.empty() && gs_.region_drop[ci]) continue;  // its surface's region, per receiver
    if (!gs_.closed_drop.empty() && gs_.closed_drop[ci]) {
      ++tot_.closed_dropped;
      continue;
    }
    Vec3d tri[3] = {to_local_d(scene_.mesh.corner(t, 0), lf_.origin), to_local_d(scene_.mesh.corner(t, 1), lf_.origin),
                    to_local_d(scene_.mesh.corner(t, 2), lf_.origin)};
    if (shaft_->culls(Vec3f(tri[0]), Vec3f(tri[1]), Vec3f(tri[2]))) continue;
    if (!covers_.empty() && translates_exactly(scene_.mesh.corner(t, 0), lf_.origin) &&
        translates_exactly(scene_.mesh.corner(t, 1), lf_.origin) &&
        translates_exactly(scene_.mesh.corner(t, 2), lf_.origin) && covered_by_interior(tri, 3)) {
      ++tot_.interior_covered;
      continue;
    }
    if (const int32_t pid = tree.patch(t); pid >= 0 && tree.patch_triangles(pid)[0] == t) {
      const std::span<const uint32_t> tris = tree.patch_triangles(pid);
      std::vector<uint32_t>& at = gs_.patch_at;  // positions of tris[1..] in cand
      at.clear();
      for (size_t j = 1; j < tris.size(); ++j) {
        const auto it = std::lower_bound(cand.begin() + ptrdiff_t(ci) + 1, cand.end(), tris[j]);
        if (it == cand.end() || *it != tris[j]) break;
        at.push_back(uint32_t(it - cand.begin()));
      }
      if (at.size() + 1 == tris.size() && select_patch(pid, tris, tri)) {
        for (uint32_t k : at) merged[k] = 1;
        continue;
      }
    }
    keep_side_ = gs_.closed_keep.empty() ? 0 : gs_.closed_keep[ci];
    select_triangle(t, tri);
  }
}

// The closed surfaces shaded per receiver as silhouette regions (silhouette_region.h),
// decided before the shaft walk, which leaves their triangles out; their silhouette
// edges come from the faces the walk would list (SilhouetteGroup::node_passes: the
// walk's own node test on the same floats, without the region surfaces' skip).
void Selection::region_surfaces(bool use_covers) {
  gs_.sil.surfaces.clear();
  if (!gs_.ctx->closed || !gs_.ctx->surface_trees || !gs_.ctx->tree_surfaces) return;
  const TriangleTree& tree = *gs_.ctx->tree;
  SilhouetteGroup& sil = gs_.sil;
  sil.tree_surfaces = gs_.ctx->tree_surfaces;
  sil.node_passes = [w = walk_, &tree, origin = lf_.origin, use_covers](uint32_t i) {
    const auto& nd = tree.bvh().node(i);
    if (w->shaft->culls_box(nd.box.lo - origin, nd.box.hi - origin)) return false;
    if (!use_covers) return true;
    Vec3d lo, hi;
    tree.local_box(i, to_double(origin), lo, hi);
    return !plucker::covered_box(w->covers, w->rloc_exact, lo, hi);
  };
  sil.new_group(scene_.mesh.size(), tree.node_count(), gs_.ctx->closed->count());
  AABB rbox;
  for (uint32_t i : *gs_.group) rbox.extend(scene_.receivers[i].p);
  const Light& light = scene_.lights[gs_.li];
  select_region_surfaces(scene_.mesh, *gs_.ctx->closed, *gs_.ctx->surface_trees, *shaft_, rbox, light.polygon.data(),
                         int(light.polygon.size()), sigma_, lf_.origin, gs_.rloc, lf_.poly,
                         gs_.ctx->silhouette_estimate, sil, tot_.sil);
}

// Strict side of every point of pts against the plane of the triangle a, b, c (world
// floats): +1 / -1 when orient3d(a, b, c, p) has that sign for every p, else 0. First the
// double filter sharing the triangle's normal over the points (exact_orient.h
// plane_side_filtered), else orient3d_filtered, then exact.
// Inlined into closed_surface_culling, which calls it once or twice per candidate
// (measured: 1.5% fewer selection instructions on scan 75k than the call).
[[gnu::always_inline]] inline int strict_side(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint* pts,
                                              size_t n) {
  const Vec3d ad = to_double(a), e1 = to_double(b) - ad, e2 = to_double(c) - ad, nrm = cross(e1, e2);
  const double s12 = norm1(e1) * norm1(e2);
  int side = 0;
  for (size_t k = 0; k < n; ++k) {
    int sd = plane_side_filtered(ad, nrm, s12, pts[k]);
    if (sd == 0) sd = plane_side_rest(a, b, c, pts[k]);
    if (sd == 0 || (k > 0 && sd != side)) return 0;
    side = sd;
  }
  return side;
}

// Closed surfaces (closed_surfaces.h) whose box is strictly apart from the receivers'
// box and from the light: w = 0 at every receiver and light point, so every segment in
// general position that crosses the surface crosses it with r on the positive side of
// the crossed triangle's plane and with r on the negative side. Per candidate the sides
// of the receivers' box (its distinct corners) and of the light (points whose convex
// hull holds it, below) are decided exactly; a crossing with r positive needs r's side
// not all negative and l's side not all positive (l is on the other side), and
// symmetrically.
// Per surface the side kept is where the segments enter it (r on the outer side, the
// surface's faces towards the receivers: measured on scan 75k, 1.7x faster than keeping
// the exits, with fewer developments), or, when the double signed volume cannot tell
// outer from inner, the side with fewer crossable candidates; candidates
// that cannot be crossed from it are marked in closed_drop. Since the other crossing of
// each blocked segment is kept, the same segments in general position stay blocked and
// the closed shadows cover the same light region (closed_surfaces.h). Nothing is marked
// for surfaces too close, or for a lifted light with a vertex not translated exactly.
void Selection::closed_surface_culling() {
  std::vector<uint8_t>& drop = gs_.closed_drop;
  drop.clear();
  const ClosedSurfaces* cs = gs_.ctx->closed;
  if (!cs) return;
  const std::vector<uint32_t>& cand = gs_.cand;
  const Light& light = scene_.lights[gs_.li];
  AABB lbox, rbox;
  for (const Vec3f& v : light.polygon) lbox.extend(v);
  for (uint32_t i : *gs_.group) rbox.extend(scene_.receivers[i].p);
  // The distinct corners of rbox (the receivers' world box: gs_.wcorners).
  SumPoint rc[8];
  for (int c = 0; c < gs_.nwcorners; ++c) rc[c] = SumPoint(gs_.wcorners[c]);
  // The light's points: a planar light is its float polygon. A lifted one (local_light.h)
  // is the oracle's polygon of the vertices moved along axis w onto its Newell plane;
  // lf_.poly holds that lift rounded in double (a few ulps of the light's coordinates),
  // so each exact lifted vertex lies on the segment along w from its float vertex to
  // lf_.poly's, widened by 2^-30 of the light's local coordinates at both ends: every
  // light point is a convex combination of those ends (exact as origin + local double).
  std::vector<SumPoint> lpts;
  for (const Vec3f& v : light.polygon) lpts.emplace_back(v);
  if (!lf_.planar) {
    for (const Vec3f& v : light.polygon)
      if (!translates_exactly(v, lf_.origin)) return;  // lf_.poly's (u, v) rounded: no culling
    const int w = 3 - lf_.axes.u - lf_.axes.v;
    double scale = 0.0;
    for (const Vec3d& p : lf_.poly) scale = std::max(scale, max_component(vabs(p)));
    const double m = 0x1p-30 * scale;
    for (size_t k = 0; k < lf_.poly.size(); ++k) {
      const double wf = to_local_d(light.polygon[k], lf_.origin)[w], wl = lf_.poly[k][w];
      Vec3d lo = lf_.poly[k], hi = lf_.poly[k];
      lo[w] = std::min(wf, wl) - m;
      hi[w] = std::max(wf, wl) + m;
      lpts.emplace_back(lf_.origin, lo);
      lpts.emplace_back(lf_.origin, hi);
    }
  }
  auto apart = [](const AABB& a, const AABB& b) {
    return a.hi.x < b.lo.x || b.hi.x < a.lo.x || a.hi.y < b.lo.y || b.hi.y < a.lo.y || a.hi.z < b.lo.z ||
           b.hi.z < a.lo.z;
  };
  std::vector<int32_t>& slot = gs_.closed_slot;
  if (slot.size() != cs->count()) slot.assign(cs->count(), -1);
  std::vector<uint32_t>& count = gs_.closed_count;
  std::vector<int32_t>& used = gs_.closed_used;
  count.clear();
  used.clear();
  drop.assign(cand.size(), 0);  // here: bit 0 crossable with r positive, bit 1 with r negative, 4 none
  bool any = false;
  for (size_t ci = 0; ci < cand.size(); ++ci) {
    const uint32_t t = cand[ci];
    const int32_t s = cs->surface(t);
    if (s < 0 || (!gs_.region_drop.empty() && gs_.region_drop[ci])) continue;
    if (slot[size_t(s)] == -1) {
      const bool usable = apart(cs->box(s), rbox) && apart(cs->box(s), lbox);
      slot[size_t(s)] = usable ? int32_t(used.size()) : -2;
      used.push_back(s);
      count.push_back(0);
      count.push_back(0);
    }
    const int32_t k = slot[size_t(s)];
    if (k < 0) continue;
    const Vec3f &a = scene_.mesh.corner(t, 0), &b = scene_.mesh.corner(t, 1), &c = scene_.mesh.corner(t, 2);
    const int sr = strict_side(a, b, c, rc, size_t(gs_.nwcorners));
    any = true;
    // A surface of known orientation needs one bit only (below): when the receivers' side
    // already decides it (r all on the side that bit excludes) the light's is not computed.
    const int orient = cs->orientation(s);
    if ((orient > 0 && sr == -1) || (orient < 0 && sr == 1)) {
      drop[ci] = 4;  // the needed bit false; the other one unused (counts serve orient == 0)
      continue;
    }
    const int sl = strict_side(a, b, c, lpts.data(), lpts.size());
    const bool pos = sr != -1 && sl != 1, neg = sr != 1 && sl != -1;
    drop[ci] = uint8_t(4 | (pos ? 1 : 0) | (neg ? 2 : 0));
    count[2 * size_t(k)] += pos;
    count[2 * size_t(k) + 1] += neg;
  }
  std::vector<int8_t>& keep = gs_.closed_keep;
  keep.assign(cand.size(), 0);
  for (size_t ci = 0; ci < cand.size(); ++ci) {
    if (!drop[ci]) continue;
    const int32_t k = slot[size_t(cs->surface(cand[ci]))];
    const int orient = cs->orientation(cs->surface(cand[ci]));
    const uint8_t need = orient != 0 ? (orient > 0 ? 1 : 2) : (count[2 * size_t(k)] <= count[2 * size_t(k) + 1] ? 1 : 2);
    const bool kept = drop[ci] & need;
    drop[ci] = kept ? 0 : 1;
    if (kept) keep[ci] = need == 1 ? 1 : -1;
  }
  for (int32_t s : used) slot[size_t(s)] = -1;
  if (!any) drop.clear(), keep.clear();
}

// The interior polygons of this light (interior_occluders.h) of closed surfaces whose box
// is strictly apart from the receivers' (so w = 0 at every receiver: a segment through a
// polygon crosses the surface) and from the light, put first among the tree occluders
// when they need no clipping: every corner translated exactly, strictly beyond gcut and
// before the light plane beyond its rounding (the tests of select_patch). Else left out:
// they block nothing the surface does not. One-sided, facing the light, even when the
// receivers' box straddles the plane: the tree hides the lines that stab an occluder
// positively (bsp.h), and every such line from a receiver crosses it between the
// receiver and the light (it lies in the slab), so what it hides is hidden; receivers on
// the light's side merely get nothing from it (bsp.h's one-sided condition makes real
// occluders hide all they block; an interior one need not).
void Selection::interior_occluders() {
  const InteriorOccluders* io = gs_.ctx->interior;
  if (!io) return;
  const ClosedSurfaces& cs = *gs_.ctx->closed;
  AABB lbox, rbox;
  for (const Vec3f& v : scene_.lights[gs_.li].polygon) lbox.extend(v);
  for (uint32_t i : *gs_.group) rbox.extend(scene_.receivers[i].p);
  auto apart = [](const AABB& a, const AABB& b) {
    return a.hi.x < b.lo.x || b.hi.x < a.lo.x || a.hi.y < b.lo.y || b.hi.y < a.lo.y || a.hi.z < b.lo.z ||
           b.hi.z < a.lo.z;
  };
  const Vec3d nd = lf_.nd, gd = gs_.g, refd = gs_.ref;
  size_t added = 0;
  for (const InteriorOccluders::Entry& e : io->of_light(gs_.li)) {
    if (!apart(cs.box(e.surface), rbox) || !apart(cs.box(e.surface), lbox)) continue;
    const std::span<const Vec3f> wq = io->polygon(e);
    Occluder o;
    o.n = int(wq.size());
    bool ok = o.n <= kMaxOccluderVertices;
    for (int k = 0; k < o.n && ok; ++k) {
      ok = translates_exactly(wq[size_t(k)], lf_.origin);
      o.v[k] = to_local_d(wq[size_t(k)], lf_.origin);
      ok = ok && double(sigma_) * (dot(nd, o.v[k]) - lf_.h0) > double(lf_.plane_tol) &&
           dot(gd, o.v[k] - refd) - gs_.gcut > 0.0;
    }
    if (!ok) continue;
    // Facing the light (its centroid on the positive side of the plane): lines that
    // stab it positively cross it from the receivers' side towards the light.
    if (dot(cross(o.v[1] - o.v[0], o.v[2] - o.v[0]), lf_.bounds.centroid - o.v[0]) < 0.0) std::reverse(o.v, o.v + o.n);
    gs_.occluders.insert(gs_.occluders.begin() + std::ptrdiff_t(added++), o);
    gs_.interior.push_back(o);
    Cover& cv = covers_.emplace_back();
    cv.n = o.n;
    for (int m = 0; m < o.n; ++m) {
      cv.light[m].set(o.v[m], o.v[(m + 1) % o.n], lf_.poly.data(), int(lf_.poly.size()));
      cv.region[m].set(o.v[m], o.v[(m + 1) % o.n], gs_.corners, gs_.ncorners);
    }
  }
  tot_.interior += added;
}

// True when every line from the receivers' box through the convex hull of pts (local,
// exact: a triangle translated exactly, or a tree node's widened box) to the light stabs
// one interior occluder of this group: per edge of it, the lines through the hull and
// the light (Theorem 1 on their vvset), or those from the box through the hull, are
// strictly positive (bsp.h orientation, either bound; the sign of a line's side is
// bilinear in its two points, so the corners decide it for the hulls). Such a segment
// r -> l passes through the occluder, which lies strictly between every receiver and
// the light (interior_occluders), so it is blocked there: what lies in the hull blocks
// nothing the tree does not, for any receiver of the group.
bool Selection::covered_by_interior(const Vec3d* pts, int n) const {
  for (const Cover& cv : covers_) {
    bool all = true;
    for (int mi = 0; mi < cv.n && all; ++mi) {
      const int m = (cv.hint + mi) % cv.n;  // from the edge that failed last: same answer, sooner
      all = cv.light[m].orientation(pts, n, true) == Orientation::Positive ||
            (gs_.rloc_exact && cv.region[m].orientation(pts, n, false) == Orientation::Positive);
      if (!all) cv.hint = m;
    }
    if (all) return true;
  }
  return false;
}

// covered_by_interior for the box [lo, hi] with one corner per plane instead of eight:
// for a fixed far point p_k an EdgeFan value det[x - a, p_k - a, b - a] = (x - a) . W_k
// is linear in x, so over the box its exact minimum is at some corner c*. With W_k
// rounded (its error within the fan's bound), the computed (c - a) . W_k is smallest
// at the corner nv chosen by W_k's signs, and the value at c* exceeds it less the
// rounding of W_k over |c* - a|_1 <= D (the box's largest 1-norm distance from a): so
// a value at nv above the fan's bound taken at D (scale_k D, the bound EdgeFan gives a
// point at distance D) proves every point of the box strictly positive. Same answer as
// the 8 corners or a weaker one (undecided counts as not covered).
bool covered_box(const std::vector<Cover>& covers, bool rloc_exact, const Vec3d& lo, const Vec3d& hi) {
  auto positive = [&](const EdgeFan& fan, double sign) {
    const Vec3d dl = lo - fan.a, dh = hi - fan.a;
    const double dmax = std::max(std::abs(dl.x), std::abs(dh.x)) + std::max(std::abs(dl.y), std::abs(dh.y)) +
                        std::max(std::abs(dl.z), std::abs(dh.z));
    for (size_t k = 0; k < fan.w.size(); ++k) {
      const Vec3d w = fan.w[k] * sign;  // exact: negation
      const Vec3d d(w.x >= 0.0 ? dl.x : dh.x, w.y >= 0.0 ? dl.y : dh.y, w.z >= 0.0 ? dl.z : dh.z);
      if (!(dot(d, w) > fan.scale[k] * dmax)) return false;
    }
    return true;
  };
  for (const Cover& cv : covers) {
    bool all = true;
    for (int mi = 0; mi < cv.n && all; ++mi) {
      const int m = (cv.hint + mi) % cv.n;
      all = positive(cv.light[m], 1.0) || (rloc_exact && positive(cv.region[m], -1.0));
      if (!all) cv.hint = m;
    }
    if (all) return true;
  }
  return false;
}

// A coplanar convex patch (triangle_tree.h; its triangles tris, the first of them with
// local coordinates tt) shaded as one polygon: only when each triangle would take the
// plain float path of select_triangle without a clip at the light plane (kept by the
// shaft, translated exactly, not far reaching, every vertex before the light plane
// beyond its rounding, not behind every receiver). Then the polygon's parts beyond and
// below gcut are the unions of the triangles' parts: beyond gcut one occluder (bsp.h)
// when the receivers lie strictly on one side of the plane, else one near polygon, and
// below gcut one near polygon; a near polygon of a patch names it for the exact paths,
// which subtract all its triangles (NearPoly::patch). Else false, having added nothing.
bool Selection::select_patch(int32_t pid, std::span<const uint32_t> tris, const Vec3d tt[3]) {
  static_assert(TriangleTree::kMaxPatchVertices + 1 <= kMaxOccluderVertices, "a patch clipped once is an occluder");
  const Vec3d nd = lf_.nd, gd = gs_.g, refd = gs_.ref;
  double tmax = 0.0;
  Vec3d tri0[3];
  for (size_t j = 0; j < tris.size(); ++j) {
    Vec3d loc[3];
    for (int k = 0; k < 3; ++k) {
      const Vec3f& w = scene_.mesh.corner(tris[j], k);
      if (!translates_exactly(w, lf_.origin)) return false;
      loc[k] = j == 0 ? tt[k] : to_local_d(w, lf_.origin);
    }
    if (j == 0) std::copy(loc, loc + 3, tri0);
    if (j > 0 && shaft_->culls(Vec3f(loc[0]), Vec3f(loc[1]), Vec3f(loc[2]))) return false;
    const double tm = std::max({max_component(vabs(loc[0])), max_component(vabs(loc[1])), max_component(vabs(loc[2]))});
    if (!(tm <= 0x1p20 * gs_.work_scale)) return false;
    tmax = std::max(tmax, tm);
    double gmx = -std::numeric_limits<double>::infinity();
    for (int k = 0; k < 3; ++k) {
      if (!(double(sigma_) * (dot(nd, loc[k]) - lf_.h0) > double(lf_.plane_tol))) return false;
      gmx = std::max(gmx, dot(gd, loc[k] - refd));
    }
    if (gmx <= gs_.gmin - gs_.delta) return false;
  }
  const std::span<const Vec3f> wq = gs_.ctx->tree->patch_polygon(pid);
  // Three corners of the polygon: its plane, in its orientation.
  const int bside = box_side(wq.data(), gs_.wcorners, gs_.nwcorners);
  std::vector<Vec3d>& q = gs_.patch;
  std::vector<double>& vals = gs_.vals;
  q.resize(wq.size());
  vals.resize(wq.size());
  for (size_t k = 0; k < wq.size(); ++k) {
    q[k] = to_local_d(wq[k], lf_.origin);
    vals[k] = dot(gd, q[k] - refd) - gs_.gcut;
  }
  auto add_patch_near = [&](const std::vector<Vec3d>& part) {
    NearPoly np = make_near(tris[0], tri0, tmax, part);
    np.patch = pid;
    np.keep_side = 0;
    np.exact_local = false;
    add_near(np, part);
  };
  std::vector<Vec3d>&lower = gs_.lower, &upper = gs_.upper;
  clip_by_values(q.data(), vals.data(), int(q.size()), true, lower);
  if (!lower.empty()) {
    if (bside != 0) {
      VG_CHECK(lower.size() <= size_t(kMaxOccluderVertices));
      Occluder o;
      o.n = int(lower.size());
      for (int k = 0; k < o.n; ++k) o.v[k] = lower[size_t(bside > 0 ? o.n - 1 - k : k)];
      gs_.occluders.push_back(o);
    } else {
      add_patch_near(lower);
    }
  }
  clip_by_values(q.data(), vals.data(), int(q.size()), false, upper);
  if (!upper.empty()) add_patch_near(upper);
  ++tot_.patches;
  tot_.patch_triangles += tris.size();
  return true;
}

// One candidate triangle (local coordinates tri): to the exact list, culled, or clipped
// to the slab and split at gcut into a tree occluder and a near polygon.
void Selection::select_triangle(uint32_t t, const Vec3d tri[3]) {
  const Light& light = scene_.lights[gs_.li];
  const Vec3d nd = lf_.nd, gd = gs_.g, refd = gs_.ref;
  // Far reaching (working_scale): exact, per receiver, before the double rejections
  // below (their values carry the same rounding).
  const double tmax = std::max({max_component(vabs(tri[0])), max_component(vabs(tri[1])), max_component(vabs(tri[2]))});
  if (!(tmax <= 0x1p20 * gs_.work_scale)) {
    gs_.exact_tris.push_back(t);
    ++tot_.far_triangles;
    return;
  }
  // A triangle whose translation to the local frame was rounded (a coordinate below
  // 2^-29 of the light origin's, or far above it) may have lost its shape there (test
  // SliverLostInTheLocalFrameIsSubtractedExactly). The rounding moves a vertex by at
  // most 2^-53 of its largest local coordinate; a rounded triangle whose height (twice
  // its area over its longest edge) is not above 2^-32 of that coordinate is subtracted
  // exactly per receiver from its float inputs, as the far-reaching ones. Fatter ones
  // keep their shape to 2^-20 and stay on the float path, whose bounds count the
  // translation's rounding.
  if (!(translates_exactly(scene_.mesh.corner(t, 0), lf_.origin) &&
        translates_exactly(scene_.mesh.corner(t, 1), lf_.origin) &&
        translates_exactly(scene_.mesh.corner(t, 2), lf_.origin))) {
    const Vec3d e1 = tri[1] - tri[0], e2 = tri[2] - tri[0], e3 = tri[2] - tri[1];
    const double longest = std::max({length(e1), length(e2), length(e3)});
    if (!(length(cross(e1, e2)) > 0x1p-32 * tmax * longest)) {
      gs_.exact_tris.push_back(t);
      ++tot_.rounded_triangles;
      return;
    }
  }
  // Heights over the light plane and g-values in double on the float vertices (the
  // clipping below interpolates in double, fragment.h clip_by_values).
  double h[3], gv[3];
  for (int k = 0; k < 3; ++k) {
    const Vec3d& x = tri[k];
    h[k] = double(sigma_) * (dot(nd, x) - lf_.h0);
    gv[k] = dot(gd, x - refd);
  }
  // Beyond, or lying in, the light plane: it never meets an open segment (occluders
  // touching the light plane with a vertex or an edge are kept). Within the plane's
  // rounding bound h cannot tell; there the exact side of each such vertex against the
  // light's plane (the region oracle's Newell plane, exact_orient.h newell_side_exact)
  // decides: a triangle with a vertex strictly before it is subtracted exactly per
  // receiver, which needs no clipping at the light plane (subtract_triangle_exact hides
  // a light point only beyond the triangle's plane as seen from r; test
  // TriangleWithinRoundingBeforeTheLightPlane).
  if (const double hmax = std::max(h[0], std::max(h[1], h[2])); hmax <= double(lf_.plane_tol)) {
    if (hmax < -double(lf_.plane_tol)) return;
    bool before = false;
    for (int k = 0; k < 3 && !before; ++k)
      before = h[k] >= -double(lf_.plane_tol) &&
               double(sigma_) * newell_side_exact(light.polygon.data(), int(light.polygon.size()),
                                                  scene_.mesh.corner(t, k)) > 0.0;
    if (before) {
      gs_.exact_tris.push_back(t);
      ++tot_.band_triangles;
    }
    return;
  }
  // Behind every receiver's g-plane.
  if (std::max(gv[0], std::max(gv[1], gv[2])) <= gs_.gmin - gs_.delta) return;
  // Clip to the light side h >= 0.
  std::vector<Vec3d>&poly0 = gs_.poly0, &lower = gs_.lower, &upper = gs_.upper;
  clip_by_values(tri, h, 3, true, poly0, &gs_.on_plane0);
  if (poly0.size() < 3) return;
  if (close_plane_points(poly0, gs_.on_plane0)) {
    gs_.exact_tris.push_back(t);
    ++tot_.plane_point_triangles;
    return;
  }
  // Split at gmax + delta: beyond it, between every receiver and the light (tree);
  // the rest per receiver.
  std::vector<double>& vals = gs_.vals;
  vals.resize(poly0.size());
  for (size_t k = 0; k < poly0.size(); ++k) vals[k] = dot(gd, poly0[k] - refd) - gs_.gcut;
  clip_by_values(poly0.data(), vals.data(), int(poly0.size()), true, lower);
  clip_by_values(poly0.data(), vals.data(), int(poly0.size()), false, upper);
  if (!lower.empty()) {
    // Orientation (bsp.h Occluder): receivers strictly on one side of the triangle's
    // plane (decided in float on the corners of their box; undecided counts for
    // neither) give a one-sided occluder, else two-sided.
    const Vec3f wtri[3] = {scene_.mesh.corner(t, 0), scene_.mesh.corner(t, 1), scene_.mesh.corner(t, 2)};
    const int bside = box_side(wtri, gs_.wcorners, gs_.nwcorners);
    VG_CHECK(lower.size() <= size_t(kMaxOccluderVertices));
    Occluder o;
    o.n = int(lower.size());
    o.two_sided = bside == 0;
    for (int k = 0; k < o.n; ++k) o.v[k] = lower[size_t(bside > 0 ? o.n - 1 - k : k)];
    if (o.two_sided || closed_near(t)) {
      // Two-sided occluders in the tree are mixed against most hyperplanes and multiply
      // the developments (about 25x on columns); per receiver they cost one
      // subtraction. So they go to the near list.
      if (!o.two_sided) ++tot_.closed_near;
      add_near(make_near(t, tri, tmax, lower), lower);
    } else {
      gs_.occluders.push_back(o);
    }
  }
  if (!upper.empty()) add_near(make_near(t, tri, tmax, upper), upper);
}

// A one-sided triangle of a dense closed surface (at least kMinRegionTriangles: a
// scanned or modelled mesh, not columns' or rooms' small solids) goes to the near list
// when the group's tree holds interior occluders (closed_near). The tree then hides the
// solid's core first (shade_float) and the near path cuts only the silhouette's band
// that is left, merging glued triangles a receiver sees as one convex polygon; in the
// tree the same small triangles cost insertion tests in every subtree they straddle
// (CGAL's bunny: 28.7M tests for 10k occluders). A near polygon removes exactly its
// shadow, as the tree would: the visible set is the same, only its pieces differ.
bool Selection::closed_near(uint32_t t) const {
  if (!gs_.ctx->closed_near || gs_.interior.empty() || !gs_.ctx->closed) return false;
  const int32_t s = gs_.ctx->closed->surface(t);
  return s >= 0 && gs_.ctx->closed->triangles(s) >= kMinRegionTriangles;
}

// The near polygons in decreasing size over distance from the receivers' box centre
// (box diagonal squared over the squared distance of the box centres): per receiver
// they are subtracted in this order, and the big, close ones first leave fewer and
// larger fragments to cut for the others (measured on columns: fewer splits and
// instructions than nearest, largest or largest solid angle first). The visible set does
// not depend on the order (each subtraction removes exactly its shadow).
void Selection::sort_near() {
  std::vector<NearPoly>& near = gs_.near;
  const Vec3d cen = (gs_.dlo + gs_.dhi) * 0.5;
  std::vector<std::pair<double, uint32_t>>& key = gs_.near_key;
  key.resize(near.size());
  for (size_t k = 0; k < near.size(); ++k) {
    const Vec3d d = near[k].hi - near[k].lo, m = (near[k].hi + near[k].lo) * 0.5 - cen;
    double q = dot(d, d) / std::max(dot(m, m), std::numeric_limits<double>::min());
    if (!(q >= 0.0)) q = 0.0;  // inf / inf: any place, but a strict weak order
    key[k] = {-q, uint32_t(k)};
    // With interior occluders (closed surfaces: the near polygons are the silhouette's
    // band) the farthest from the receivers first: measured on scan 20k, 16% fewer
    // instructions per solve than the order above (near splits 277k -> 222k).
    if (!gs_.interior.empty()) key[k] = {-dot(m, m), uint32_t(k)};
  }
  std::sort(key.begin(), key.end());
  std::vector<NearPoly>& sorted = gs_.near_sorted;
  sorted.resize(near.size());
  for (size_t k = 0; k < near.size(); ++k) sorted[k] = near[key[k].second];
  near.swap(sorted);
  // Closed surfaces' near triangles by triangle, for the merged polygons of shade_receiver.cpp.
  if (gs_.ctx->closed && gs_.ctx->near_merge && !gs_.interior.empty()) {
    if (gs_.near_of_tri.size() != scene_.mesh.size()) gs_.near_of_tri.assign(scene_.mesh.size(), -1);
    for (size_t k = 0; k < near.size(); ++k) {
      if (near[k].patch >= 0) continue;
      int32_t& slot = gs_.near_of_tri[near[k].triangle];
      slot = slot == -1 ? int32_t(k) : -2;
    }
    gs_.near_done.assign(near.size(), 0);
  }
  blocks();
}

// Blocks of kNearBlock near polygons close together (in the Morton order of their box
// centres in the group's box of them), for the per-receiver culling of whole blocks
// (shade_receiver.cpp): a receiver's pyramid meets few of a long list's polygons.
void Selection::blocks() {
  constexpr size_t kNearBlock = 16;
  const std::vector<NearPoly>& near = gs_.near;
  gs_.near_blocks.clear();
  gs_.near_spatial.clear();
  if (near.size() < 16 * kNearBlock) return;  // short lists (columns: ~64 per group) gain nothing
  Vec3d lo = near[0].lo, hi = near[0].hi;
  for (const NearPoly& np : near) lo = vmin(lo, np.lo), hi = vmax(hi, np.hi);
  const Vec3d ext = hi - lo;
  std::vector<std::pair<uint64_t, uint32_t>> keys(near.size());
  for (size_t k = 0; k < near.size(); ++k) {
    const Vec3d c = (near[k].lo + near[k].hi) * 0.5 - lo;
    uint64_t code = 0;
    for (int a = 0; a < 3; ++a) {
      const double f = ext[a] > 0.0 ? c[a] / ext[a] * 1023.0 : 0.0;
      code |= uint64_t(morton_spread10(uint32_t(std::min(1023.0, std::max(0.0, f))))) << a;
    }
    keys[k] = {code, uint32_t(k)};
  }
  std::sort(keys.begin(), keys.end());
  for (const auto& kv : keys) gs_.near_spatial.push_back(kv.second);
  for (size_t b = 0; b < near.size(); b += kNearBlock) {
    GroupState::NearBlock blk;
    blk.begin = uint32_t(b);
    blk.count = uint32_t(std::min(kNearBlock, near.size() - b));
    blk.lo = near[gs_.near_spatial[b]].lo;
    blk.hi = near[gs_.near_spatial[b]].hi;
    for (uint32_t k = blk.begin; k < blk.begin + blk.count; ++k) {
      blk.lo = vmin(blk.lo, near[gs_.near_spatial[k]].lo);
      blk.hi = vmax(blk.hi, near[gs_.near_spatial[k]].hi);
    }
    blk.pmax = max_component(vmax(vabs(blk.lo), vabs(blk.hi)));
    gs_.near_blocks.push_back(blk);
  }
}

}  // namespace

void select_occluders(GroupState& gs, Totals& tot) { Selection(gs, tot).run(); }

}  // namespace visgate::plucker
