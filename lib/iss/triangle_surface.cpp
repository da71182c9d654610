// CONSTRUCT-TRIANGLE-SURFACE (paper 000 section 4.7.1, Figure 4.20): one clipped patch
// per valid blocker triangle, clipped to the slab between the clip planes (section 4.5).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"

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

}  // namespace

Surface construct_triangle_surface(const BlockerContext& ctx, const std::vector<uint32_t>& tris,
                                   const ShaftGeometry& g, const TreeNode& rnode, const TreeNode& lnode, Workspace& ws) {
  Surface s = ws.take_surface();
  const mesh::PreparedMesh& m = *ctx.mesh;
  ws.reset_labels(m.edge_count());
  std::vector<PolyVertex>& poly = ws.poly;
  std::vector<PolyVertex>& tmp = ws.poly_tmp;
  int ax = g.main_axis();
  for (uint32_t t : tris) {
    // Lines 6-8: a valid blocker intersects the shaft and neither node (cheapest test
    // first: the shaft planes reject most triangles).
    Vec3d a = corner_d(m, t, 0), b = corner_d(m, t, 1), c = corner_d(m, t, 2);
    if (g.separated_by_shaft_plane(a, b, c)) continue;
    if (rnode.contains_triangle(t) || lnode.contains_triangle(t)) continue;
    if (g.separated_by_triangle_plane(a, b, c)) continue;
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
    if (poly.size() < 3) continue;
    int32_t pi = int32_t(s.patches.size());
    Patch p;
    p.first = uint32_t(s.edges.size());
    p.facing = Facing::Inconsistent;  // line 10: determined later from the triangle
    p.tri = int32_t(t);
    size_t n = poly.size();
    for (size_t i = 0; i < n; ++i) {
      const Vec3d& v0 = poly[i].p;
      const Vec3d& v1 = poly[(i + 1) % n].p;
      if (v0 == v1) continue;
      int32_t label = poly[i].label;
      // Lines 13-21: reuse the raw edge of the neighbour across this mesh edge.
      if (label >= 0 && ws.label_stamp[size_t(label)] == ws.stamp) {
        int32_t ri = ws.label_slot[size_t(label)];
        RawEdge& re = s.raw[size_t(ri)];
        if (re.v[0] == v1 && re.v[1] == v0 && re.nb[0] == kNoPatch) {
          re.nb[0] = pi;
          s.edges.push_back({uint32_t(ri), 1});
          continue;
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
    p.count = uint32_t(s.edges.size()) - p.first;
    if (p.count < 3) {  // zero-area after clipping: undo
      for (uint32_t k = p.first; k < s.edges.size(); ++k) {
        Edge e = s.edges[k];
        s.raw[e.raw].nb[e.flipped ? 0 : 1] = kNoPatch;
      }
      s.edges.resize(p.first);
      continue;
    }
    s.patches.push_back(p);
  }
  compact_raw(s, ws);
  for (const RawEdge& re : s.raw) {  // the clipped triangles, before any merge
    s.hull.extend(re.v[0]);
    s.hull.extend(re.v[1]);
  }
  return s;
}

}  // namespace visgate::iss
