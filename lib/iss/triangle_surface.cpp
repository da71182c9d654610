// CONSTRUCT-TRIANGLE-SURFACE (paper 000 section 4.7.1, Figure 4.20): one clipped patch
// per valid blocker triangle, clipped to the slab between the clip planes (section 4.5);
// and its clustered form for initial shafts (surface_clusters.h).
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"
#include "lib/iss/surface_clusters.h"

namespace visgate::iss {

namespace {

// Intersection of segment p0-p1 with the plane x[ax] = c, computed from the endpoints
// in lexicographic order so that two triangles sharing a mesh edge (traversing it in
// opposite directions) get the bit-identical clip vertex.
Vec3d clip_point(Vec3d p0, Vec3d p1, int ax, double c) {
  if (lex_less(p1, p0)) std::swap(p0, p1);
  double t = (c - p0[ax]) / (p1[ax] - p0[ax]);
  Vec3d x = p0 + (p1 - p0) * t;
  x[ax] = c;
  return x;
}

// One Sutherland-Hodgman pass keeping side * (x[ax] - c) >= 0.
void clip_poly(const std::vector<PolyVertex>& in, std::vector<PolyVertex>& out, int ax, double c, double side) {
  out.clear();
  size_t n = in.size();
  for (size_t i = 0; i < n; ++i) {
    const PolyVertex& cur = in[i];
    const PolyVertex& nxt = in[(i + 1) % n];
    bool cin = side * (cur.p[ax] - c) >= 0, nin = side * (nxt.p[ax] - c) >= 0;
    if (cin) out.push_back(cur);
    if (cin != nin) {
      Vec3d x = clip_point(cur.p, nxt.p, ax, c);
      out.push_back({x, cin ? kClipEdge : cur.label});
    }
  }
}

// One raw edge v0 -> v1 of patch pi (lines 13-21 of Figure 4.20): the raw edge of the
// neighbour across the same mesh edge when it is there, traversed the other way.
void add_edge(Surface& s, Workspace& ws, int32_t pi, const Vec3d& v0, const Vec3d& v1, int32_t label) {
  if (label >= 0 && ws.label_stamp[size_t(label)] == ws.stamp) {
    int32_t ri = ws.label_slot[size_t(label)];
    RawEdge& re = s.raw[size_t(ri)];
    if (re.v[0] == v1 && re.v[1] == v0 && re.nb[0] == kNoPatch) {
      re.nb[0] = pi;
      s.edges.push_back({uint32_t(ri), 1});
      return;
    }
  }
  RawEdge re;
  re.v[0] = v0;
  re.v[1] = v1;
  re.nb[1] = pi;
  re.mesh_edge = label;
  re.inside = 1;
  if (label >= 0) {
    ws.label_stamp[size_t(label)] = ws.stamp;
    ws.label_slot[size_t(label)] = int32_t(s.raw.size());
  }
  s.edges.push_back({uint32_t(s.raw.size()), 0});
  s.raw.push_back(re);
}

// Ends patch p begun at edge p.first: kept with three edges or more, else undone (zero
// area after clipping).
void end_patch(Surface& s, Patch& p) {
  p.count = uint32_t(s.edges.size()) - p.first;
  if (p.count < 3) {
    for (uint32_t k = p.first; k < s.edges.size(); ++k) {
      Edge e = s.edges[k];
      s.raw[e.raw].nb[e.flipped ? 0 : 1] = kNoPatch;
    }
    s.edges.resize(p.first);
    return;
  }
  s.patches.push_back(p);
}

// Lines 6-21 for triangle t: its clipped patch, when it is a valid blocker.
void add_triangle(const mesh::PreparedMesh& m, uint32_t t, const ShaftGeometry& g, const TreeNode& rnode,
                  const TreeNode& lnode, Workspace& ws, Surface& s) {
  std::vector<PolyVertex>& poly = ws.poly;
  std::vector<PolyVertex>& tmp = ws.poly_tmp;
  const int ax = g.main_axis();
  // Lines 6-8: a valid blocker intersects the shaft and neither node (cheapest test
  // first: the shaft planes reject most triangles).
  Vec3d a = corner_d(m, t, 0), b = corner_d(m, t, 1), c = corner_d(m, t, 2);
  if (g.separated_by_shaft_plane(a, b, c)) return;
  if (rnode.contains_triangle(t) || lnode.contains_triangle(t)) return;
  if (g.separated_by_triangle_plane(a, b, c)) return;
  // CONSTRUCT-CLIPPED-PATCH: clip to the slab between the clip planes.
  const auto& tri = m.triangles[t];
  poly.clear();
  poly.push_back({a, int32_t(tri.edge_labels[0])});
  poly.push_back({b, int32_t(tri.edge_labels[1])});
  poly.push_back({c, int32_t(tri.edge_labels[2])});
  double mn = std::min({a[ax], b[ax], c[ax]}), mx = std::max({a[ax], b[ax], c[ax]});
  if (mn < g.clip_lo()) {
    clip_poly(poly, tmp, ax, g.clip_lo(), 1.0);
    poly.swap(tmp);
  }
  if (mx > g.clip_hi() && poly.size() >= 3) {
    clip_poly(poly, tmp, ax, g.clip_hi(), -1.0);
    poly.swap(tmp);
  }
  if (poly.size() < 3) return;
  Patch p;
  p.first = uint32_t(s.edges.size());
  p.facing = Facing::Inconsistent;  // line 10: determined later from the triangle
  p.tri = int32_t(t);
  const int32_t pi = int32_t(s.patches.size());
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec3d& v0 = poly[i].p;
    const Vec3d& v1 = poly[(i + 1) % n].p;
    if (v0 == v1) continue;
    add_edge(s, ws, pi, v0, v1, poly[i].label);
  }
  end_patch(s, p);
}

// Compaction, then the hull: the clipped triangles' edges (before any merge) joined
// with `whole`, the boxes of the clusters taken whole.
void finish_surface(Surface& s, Workspace& ws, const AABBd& whole) {
  compact_raw(s, ws);
  for (const RawEdge& re : s.raw) {
    s.hull.extend(re.v[0]);
    s.hull.extend(re.v[1]);
  }
  if (!whole.empty()) s.hull.extend(whole);
}

}  // namespace

Surface construct_triangle_surface(const BlockerContext& ctx, const std::vector<uint32_t>& tris,
                                   const ShaftGeometry& g, const TreeNode& rnode, const TreeNode& lnode, Workspace& ws) {
  // Room for three raw edges per candidate (more only where clipping adds edges): the
  // arrays do not grow by copying, and reserve() touches no page that is not written.
  Surface s = ws.take_surface(3 * tris.size());
  if (tris.size() > Workspace::kMaxSpareEdges) {
    s.raw.reserve(3 * tris.size());
    s.edges.reserve(3 * tris.size());
    s.patches.reserve(tris.size());
  }
  ws.reset_labels(ctx.mesh->edge_count());
  for (uint32_t t : tris) add_triangle(*ctx.mesh, t, g, rnode, lnode, ws, s);
  finish_surface(s, ws, empty_box());
  return s;
}

Surface construct_clustered_surface(const BlockerContext& ctx, const SurfaceClusters& clusters, const ShaftGeometry& g,
                                    const TreeNode& rnode, const TreeNode& lnode, Workspace& ws,
                                    double* whole_nodes, std::vector<uint32_t>* band, size_t exact_max) {
  Surface s = ws.take_surface();
  const mesh::PreparedMesh& m = *ctx.mesh;
  ws.reset_labels(m.edge_count());
  const accel::Bvh<float>& bvh = clusters.tree();
  const int ax = g.main_axis();
  // Exact facings (SurfaceClusters::exact_facing): computed once for the positions
  // [exact_lo, exact_hi) of the topmost node the cone could not decide, and read by its
  // descendants, which the depth-first walk visits before any other node.
  const bool exact = exact_max > 0;
  std::vector<uint8_t> facing;  // Facing per position - exact_lo
  uint32_t exact_lo = 0, exact_hi = 0;
  AABBd whole = empty_box();
  std::vector<SurfaceClusters::BoundaryEdge> be;  // the boundary of the node taken whole
  auto take_whole = [&](Facing f, const AABBd& box) {
    Patch p;
    p.first = uint32_t(s.edges.size());
    p.facing = f;
    p.tri = -1;
    const int32_t pi = int32_t(s.patches.size());
    for (const SurfaceClusters::BoundaryEdge e : be) {
      const uint32_t t = e >> 2;
      const int k = int(e & 3);
      add_edge(s, ws, pi, corner_d(m, t, k), corner_d(m, t, (k + 1) % 3), int32_t(m.triangles[t].edge_labels[size_t(k)]));
    }
    end_patch(s, p);
    whole.extend(box);
    if (whole_nodes) *whole_nodes += 1;
  };
  std::array<uint32_t, accel::Bvh<float>::kMaxStack> stack;
  size_t top = 0;
  if (!bvh.empty()) stack[top++] = 0;
  while (top > 0) {
    const uint32_t i = stack[--top];
    const auto& nd = bvh.node(i);
    const AABBd box = to_double(nd.box);
    if (!g.may_intersect_box(box)) continue;  // every triangle below misses the shaft
    const uint32_t lo = clusters.first_pos(i), hi = lo + nd.count;
    const bool in_exact = exact && lo >= exact_lo && hi <= exact_hi;
    // Taken whole: no triangle below can be in a node's inside list (those meet the
    // node's box, tree.cpp), none needs clipping (add_triangle's test), and the cone
    // or every triangle's own Table 4.1 facing proves one facing for all
    // (surface_clusters.h).
    if (!nd.box.overlaps(rnode.box) && !nd.box.overlaps(lnode.box) && !(box.lo[ax] < g.clip_lo()) &&
        !(box.hi[ax] > g.clip_hi())) {
      Facing f = clusters.eligible(i) ? clusters.facing_of(i, g.receiver(), g.light()) : Facing::Inconsistent;
      if (f == Facing::Inconsistent && exact && (in_exact || nd.count <= exact_max)) {
        if (!in_exact) {
          exact_lo = lo;
          exact_hi = hi;
          facing.resize(nd.count);
          for (uint32_t p = lo; p < hi; ++p) facing[p - lo] = uint8_t(clusters.exact_facing(p, g));
        }
        // One facing for every triangle below, or Inconsistent.
        const uint8_t f0 = facing[lo - exact_lo];
        bool same = true;
        for (uint32_t p = lo + 1; p < hi && same; ++p) same = facing[p - exact_lo] == f0;
        if (same) f = Facing(f0);
      }
      if (f != Facing::Inconsistent) {
        be.clear();
        clusters.boundary(i, be);
        // A closed consistent piece meets no segment between the boxes (each would cross
        // it as often in as out, and all cross it the same way): MERGE-PATCHES drops it.
        if (be.empty()) continue;
        if (be.size() >= 3) {
          take_whole(f, box);
          continue;
        }
      }
    }
    if (bvh.is_leaf(nd)) {
      const bool known = exact && lo >= exact_lo && hi <= exact_hi;
      uint32_t p = lo;
      for (uint32_t t : bvh.leaf_items(nd)) {
        const uint32_t pos = p++;
        if (band) {
          // add_triangle's valid-blocker tests, then the band's: an inconsistent one
          // is not built (its patch would only be taken out again, extract_inconsistent).
          const Vec3d a = corner_d(m, t, 0), b = corner_d(m, t, 1), c = corner_d(m, t, 2);
          if (g.separated_by_shaft_plane(a, b, c) || rnode.contains_triangle(t) || lnode.contains_triangle(t) ||
              g.separated_by_triangle_plane(a, b, c))
            continue;
          AABBd tb(a, b);
          tb.extend(c);
          if (beyond_clip_planes(tb, g)) continue;  // clipped away: not a blocker
          const Facing tf = known ? Facing(facing[pos - exact_lo])
                                  : triangle_facing(plane_through(a, b, c, g.scale()), g);
          if (tf == Facing::Inconsistent) {
            band->push_back(t);
            continue;
          }
        }
        add_triangle(m, t, g, rnode, lnode, ws, s);
      }
      continue;
    }
    stack[top++] = bvh.right(i);
    stack[top++] = bvh.left(i);
  }
  finish_surface(s, ws, whole);
  return s;
}

}  // namespace visgate::iss
