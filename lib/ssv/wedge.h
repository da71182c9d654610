// Potential silhouette edges and penumbra wedges (paper 001 section 2.1) with the
// silhouette regions of section 4.2, and the wedge/box tests with active plane masks that
// the lazy wedge BSP (section 4.1) uses.
//
// Edges come from the prepared mesh (lib/mesh/prepare.h, paper 000 section 4.2): every
// edge label is one edge, a double edge between two consistently oriented neighbours or a
// single edge of one triangle (mesh boundaries, non-manifold edges and joins of
// inconsistently oriented neighbours all become single edges, one per incidence).
//
// Guarantee: conservative up to float rounding covered by a tolerance. The wedge of an
// edge (the part with h >= 0 above the light plane) is the intersection of the half-spaces
// of its separating planes with the expanded light L' (light_frame.h), computed in double
// and stored as float unit planes; points and boxes are tested with the tolerance
// `eps` (a distance), so a point within eps outside a plane still counts as inside. The
// exact region {x : some segment from x to L' meets the edge} is contained in it: each
// separating plane has the edge on its closed inner side and L' on its closed outer side,
// so x = p + t (p - l) (p on the edge, l in L', t >= 0) evaluates to
// (1 + t) f(p) - t f(l) >= 0; "closed" up to the rounding of the double plane test only
// (1e-13 M, not `tol`: t is unbounded for an edge next to L', wedge.cpp
// orient_against_light). A candidate plane that contains L' (within the tolerance
// `tol`; only the light plane can, for an edge touching or lying in it) separates
// nothing and is dropped: the light plane enters once, as h >= 0. The silhouette region of a double edge (section 3.3: exactly
// one triangle front-facing) is tested the same way: a box is excluded only when it lies
// at least eps inside both front half-spaces or both back half-spaces.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "lib/geom/aabb.h"
#include "lib/geom/plane.h"
#include "lib/mesh/prepare.h"
#include "lib/ssv/light_frame.h"
#include "lib/ssv/populated.h"

namespace visgate::ssv {

// An edge a -> b in the winding of triangle t1; t2 the neighbour (traversing b -> a) or -1.
struct Edge {
  uint32_t a = 0, b = 0;
  int32_t t1 = -1, t2 = -1;
};

// Per triangle, computed once per solve (light-independent): the unnormalised normal
// cross(b - a, c - a) and corner a in double, |n|^2, and the squared distance from a to
// the farthest other corner. Used by ReceiverIntegrator::facing and build_wedges. 64
// bytes: a dense mesh's planes are written once per solve, and each fresh page costs a
// fault (the unit normal is derived on demand, the same double every time).
struct TrianglePlane {
  Vec3d n, a;
  double nn = 0.0, reach2 = 0.0;
  // The unit normal (0 for zero area).
  Vec3d unit() const {
    const double len = std::sqrt(nn);
    return len > 0.0 ? n / len : Vec3d(0, 0, 0);
  }
};
// On populated mappings (populated.h): 19 MB of fresh pages at 300k triangles.
using TrianglePlanes = PopulatedVector<TrianglePlane>;
TrianglePlanes triangle_planes(const mesh::PreparedMesh& m);
// Triangle t's record computed from the mesh: the same doubles as triangle_planes' entry.
inline TrianglePlane triangle_plane(const mesh::PreparedMesh& m, size_t t) {
  TrianglePlane p;
  const Vec3d a = to_double(m.corner(t, 0)), b = to_double(m.corner(t, 1)), c = to_double(m.corner(t, 2));
  p.n = cross(b - a, c - a);
  p.a = a;
  p.nn = dot(p.n, p.n);
  p.reach2 = std::max(dot(b - a, b - a), dot(c - a, c - a));
  return p;
}
// The planes from an array when the caller built one (the wedge indexes: every edge per
// light), else from the mesh on each call (the edge index: only candidates' triangles are
// read, and a 64-byte record per triangle of a dense mesh is more fresh memory per solve
// than the few hundred thousand cross products it saves). The same doubles either way.
struct PlaneSource {
  const mesh::PreparedMesh* m = nullptr;
  const TrianglePlanes* planes = nullptr;
  TrianglePlane operator[](size_t t) const { return planes ? (*planes)[t] : triangle_plane(*m, t); }
};

// The side of L' (vertices `light`) w.r.t. the triangle's plane: +1 when every vertex lies
// more than `tol` in front of it, -1 when every one lies more than tol behind, else 0
// (build_wedges' potential-silhouette test: a double edge whose two triangles give the
// same nonzero side is a silhouette from no light point).
inline int light_side(const TrianglePlane& p, const std::vector<Vec3d>& light, double tol) {
  bool all_pos = true, all_neg = true;
  const Vec3d unit = p.unit();
  for (const auto& l : light) {
    const double f = dot(unit, l - p.a);
    all_pos &= f > tol;
    all_neg &= f < -tol;
  }
  return all_pos ? 1 : all_neg ? -1 : 0;
}

// One edge per label of the prepared mesh, in label order.
std::vector<Edge> mesh_edges(const mesh::PreparedMesh& m);

constexpr int kMaxWedgePlanes = 16;

// Field order: what every box test reads (header, triangle planes, first planes) shares
// the first cache line.
struct Wedge {
  uint32_t edge = 0;                          // index into the edge list
  uint8_t plane_count = 0;
  bool has_region = false;                    // double edge: silhouette region planes valid
  std::array<Plane, 2> tri;                   // unit triangle planes, front side positive
  std::array<Plane, kMaxWedgePlanes> planes;  // unit normals; inside: n.x - d >= -eps
};

// Active-plane state of a wedge in a BSP node: bit i of `mask` set while wedge plane i does
// not yet contain the node's box; `region` holds the four silhouette-region bits of
// section 4.2 (kPos1, kNeg1, kPos2, kNeg2: box at least eps on the front / back side of
// triangle plane 1 / 2).
struct WedgeState {
  uint32_t wedge = 0;
  uint16_t mask = 0;
  uint8_t region = 0;
};
constexpr uint8_t kPos1 = 1, kNeg1 = 2, kPos2 = 4, kNeg2 = 8;

enum class BoxClass { Outside, Partial, Contains };

// Classifies `box` against the wedge (and its silhouette region when `use_region`),
// updating the state's masks for this box: Outside when some active plane (or the region
// test) excludes the box, Contains when the box lies inside every plane (and inside the
// silhouette region), else Partial.
BoxClass classify_box(const Wedge& w, WedgeState& s, const AABB& box, float eps, bool use_region);

// The two halves of a box split at `mid` along `axis` (left: box.lo..mid, right:
// mid..box.hi) as centres and one common half-extent (the larger of the two halves'
// per component: a box range can only grow, never shrink).
struct SplitBoxes {
  Vec3f c_left, c_right, half;
};
SplitBoxes split_boxes(const AABB& box, int axis, float mid);

// classify_box for both halves of a split, from the state `s` of the parent box: each
// active plane is evaluated once for both halves. Box ranges come from the centre and
// half-extent (n.c - d -/+ |n|.e): the same as the corner evaluation of classify_box
// up to float rounding, far below eps.
void classify_split(const Wedge& w, const WedgeState& s, const SplitBoxes& b, float eps, bool use_region,
                    WedgeState& left, BoxClass& left_class, WedgeState& right, BoxClass& right_class);

// True when p lies inside every wedge plane within eps.
bool point_in_wedge(const Wedge& w, const Vec3f& p, float eps);
// The same over the planes in `mask` only (the others are known to hold p: the BSP
// node's box p lies in is inside them within eps).
bool point_in_wedge(const Wedge& w, uint32_t mask, const Vec3f& p, float eps);

struct WedgeBuildCounts {
  size_t edges = 0, below_light = 0, not_silhouette = 0, wedges = 0, planes_dropped = 0, region_culled = 0;
};

// Boxes covering every receiver that needs wedges (`parts`), and their union (`all`): a
// double edge whose silhouette region excludes every part (within eps, as classify_box
// decides) is a silhouette from none of those receivers and gets no wedge.
struct RegionBoxes {
  AABB all;
  std::vector<AABB> parts;
  float eps = 0.0f;
};

// Potential silhouette edges w.r.t. L' and their wedges. `frame_pos` holds the prepared
// vertices in frame coordinates (used for the h >= 0 classification, the same values the
// projection uses). An edge is dropped when no incident triangle has a vertex above the
// light plane (it cannot meet a segment from a receiver above the plane to the light) or,
// for a double edge with both neighbours active (a vertex above the light plane), when
// every vertex of L' lies at least `tol` on the same side of both triangle planes (no
// light point sees it as a silhouette, so no receiver in its wedge does: section 2.1).
// A double edge with one inactive neighbour is treated as a single edge of the active
// one, matching its integration weight (integrate.h). `tol` is a distance.
std::vector<Wedge> build_wedges(const mesh::PreparedMesh& m, const std::vector<Edge>& edges,
                                const std::vector<Vec3d>& frame_pos, const LightFrame& frame, double tol,
                                WedgeBuildCounts& counts, const TrianglePlanes* planes = nullptr);
// The same into `out` (cleared first; its capacity is reused from light to light), for
// the edges whose indices `subset` lists (ascending), or for all edges without it; with
// `regions`, only for edges that may be a silhouette from some of its boxes.
void build_wedges(const mesh::PreparedMesh& m, const std::vector<Edge>& edges, const std::vector<Vec3d>& frame_pos,
                  const LightFrame& frame, double tol, WedgeBuildCounts& counts,
                  const TrianglePlanes* planes, std::vector<Wedge>& out,
                  const std::vector<uint32_t>* subset = nullptr, const RegionBoxes* regions = nullptr);

}  // namespace visgate::ssv
