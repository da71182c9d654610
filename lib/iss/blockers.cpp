// Blocker representation and sub-shaft operations (paper 000 sections 4.4.2-4.7; see
// blockers.h for the storage scheme and the guarantee).
#include "lib/iss/blockers.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"

namespace visgate::iss {

namespace {

Vec3d corner_d(const mesh::PreparedMesh& m, uint32_t t, int k) { return to_double(m.corner(t, k)); }

bool lex_less(const Vec3d& a, const Vec3d& b) {
  if (a.x != b.x) return a.x < b.x;
  if (a.y != b.y) return a.y < b.y;
  return a.z < b.z;
}

int32_t uf_find(std::vector<int32_t>& uf, int32_t i) {
  while (uf[size_t(i)] != i) {
    uf[size_t(i)] = uf[size_t(uf[size_t(i)])];
    i = uf[size_t(i)];
  }
  return i;
}

void uf_union(std::vector<int32_t>& uf, int32_t a, int32_t b) {
  a = uf_find(uf, a);
  b = uf_find(uf, b);
  if (a != b) uf[size_t(std::max(a, b))] = std::min(a, b);
}

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

// Removes raw edges with no neighbour and renumbers the edge references.
void compact_raw(Surface& s, Workspace& ws) {
  ws.remap.assign(s.raw.size(), -1);
  size_t w = 0;
  for (size_t i = 0; i < s.raw.size(); ++i) {
    if (s.raw[i].nb[0] == kNoPatch && s.raw[i].nb[1] == kNoPatch) continue;
    ws.remap[i] = int32_t(w);
    if (w != i) s.raw[w] = s.raw[i];
    ++w;
  }
  s.raw.resize(w);
  for (Edge& e : s.edges) e.raw = uint32_t(ws.remap[e.raw]);
}

// Clamps the directed edge p0 -> p1 to the slab lo <= x[ax] <= hi (section 4.5): split
// where it pierces a clip plane, project the outside parts orthogonally onto the plane.
int clamp_edge(const Vec3d& p0, const Vec3d& p1, int ax, double lo, double hi, Vec3d* out) {
  double ts[2], cs[2];
  int nt = 0;
  double a0 = p0[ax], a1 = p1[ax];
  // The planes in the order the edge meets them: by its direction, not by the rounded
  // parameters, which tie when both planes are within an ulp of an endpoint (t = 1 for
  // both): the split points were then emitted lower plane first on a descending edge,
  // a zig-zag through the slab.
  double first = a0 <= a1 ? lo : hi, second = a0 <= a1 ? hi : lo;
  for (double c : {first, second}) {
    if ((a0 < c && a1 > c) || (a0 > c && a1 < c)) {
      ts[nt] = (c - a0) / (a1 - a0);
      cs[nt++] = c;
    }
  }
  int n = 0;
  out[n++] = p0;
  for (int i = 0; i < nt; ++i) {
    // The split point lies on its clip plane by definition, so its main-axis coordinate
    // is the plane's, not that of p0 + (p1 - p0) t evaluated in double: for t within an
    // ulp of 1 (a clip plane 1e-33 from an endpoint, relative to the edge's length:
    // a light node 3e-33 above the receivers' plane) that expression is the endpoint
    // itself, the clamp below kept it on the far side of the slab, and the clamped
    // boundary cut diagonally through the slab, changing its winding number about the
    // test line (corpus/iss/other, grid-snapped-19532).
    // The cross coordinates come from the endpoint nearer to the plane, so their error
    // is a few ulps of that endpoint's distance from it.
    double c = cs[i];
    Vec3d x = ts[i] <= 0.5 ? p0 + (p1 - p0) * ts[i] : p1 + (p0 - p1) * ((c - a1) / (a0 - a1));
    x[ax] = c;
    out[n++] = x;
  }
  out[n++] = p1;
  for (int i = 0; i < n; ++i) out[i][ax] = std::min(hi, std::max(lo, out[i][ax]));
  return n;
}

struct TestPlanes {
  Vec3d q, na, nb;
  double pa(const Vec3d& v) const { return dot(na, v - q); }
  double pb(const Vec3d& v) const { return dot(nb, v - q); }
};

// CONSTRUCT-TEST-PLANES: two planes meeting in the test line q1 q2 (Figure 4.14).
TestPlanes make_test_planes(const Vec3d& q1, const Vec3d& q2) {
  TestPlanes t;
  t.q = q1;
  Vec3d d = q2 - q1;
  Vec3d ad = vabs(d);
  int k = (ad.x <= ad.y && ad.x <= ad.z) ? 0 : (ad.y <= ad.z ? 1 : 2);
  Vec3d ek(0, 0, 0);
  ek[k] = 1.0;
  t.na = normalize(cross(d, ek));
  t.nb = normalize(cross(d, t.na));
  return t;
}

// Lines 16-32 of Figure 4.18 for one directed edge, in half units.
int winding_update(const TestPlanes& tp, const Vec3d& v0, const Vec3d& v1) {
  double d0 = tp.pa(v0), d1 = tp.pa(v1);
  auto sgn = [](double x) { return (x > 0) - (x < 0); };
  if (sgn(d0) == sgn(d1)) return 0;
  double f0 = tp.pb(v0), f1 = tp.pb(v1);
  if (f0 < 0 && f1 < 0) return 0;
  if ((d0 < d1) == (d0 * f1 > d1 * f0)) return 0;
  int adjust = (d0 == 0 || d1 == 0) ? 1 : 2;
  return d0 > d1 ? -adjust : adjust;
}

// True when the part of edge p0 p1 beyond the clip plane x[ax] = plane (below it when
// `below`), projected along the main axis onto the plane, may meet the rectangle `face`
// (the node's outer face there) grown by `tol` in the two other axes. Liang-Barsky in
// the plane, closed comparisons; the crossing parameter's rounding is far inside tol.
bool beyond_part_meets_face(const Vec3d& p0, const Vec3d& p1, int ax, double plane, bool below, const AABBd& face,
                            double tol) {
  const double a = below ? plane - p0[ax] : p0[ax] - plane, b = below ? plane - p1[ax] : p1[ax] - plane;
  if (!(a > 0) && !(b > 0)) return false;  // nothing beyond: no clamping
  double t0 = 0.0, t1 = 1.0;
  if (!(a > 0)) t0 = a / (a - b);
  else if (!(b > 0)) t1 = a / (a - b);
  const int u = (ax + 1) % 3, v = (ax + 2) % 3;
  for (int k : {u, v}) {
    const double o = p0[k], d = p1[k] - p0[k], lo = face.lo[k] - tol, hi = face.hi[k] + tol;
    if (d == 0) {
      if (o < lo || o > hi) return false;
      continue;
    }
    double ta = (lo - o) / d, tb = (hi - o) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

int clamped_winding(const TestPlanes& tp, const Vec3d& p0, const Vec3d& p1, int ax, double lo, double hi) {
  Vec3d pts[4];
  int n = clamp_edge(p0, p1, ax, lo, hi, pts);
  int w = 0;
  for (int i = 0; i + 1 < n; ++i) w += winding_update(tp, pts[i], pts[i + 1]);
  return w;
}

}  // namespace

void Workspace::reset_labels(size_t n) {
  if (label_slot.size() < n) {
    label_slot.assign(n, -1);
    label_stamp.assign(n, 0);
  }
  ++stamp;
}

Surface Workspace::take_surface() {
  if (spare.empty()) return Surface{};
  Surface s = std::move(spare.back());
  spare.pop_back();
  return s;
}

void Workspace::recycle(Surface&& s) {
  if (spare.size() >= kMaxSpare) return;
  if (s.raw.capacity() == 0 && s.edges.capacity() == 0) return;  // a moved-from husk
  if (s.raw.capacity() > kMaxSpareEdges || s.edges.capacity() > 2 * kMaxSpareEdges) return;  // let it go
  s.raw.clear();
  s.edges.clear();
  s.patches.clear();
  s.loose.clear();
  s.box = empty_box();
  s.hull = empty_box();
  s.vsum = Vec3d(0, 0, 0);
  s.vcount = 0;
  s.refined = true;
  s.unchanged = false;
  spare.push_back(std::move(s));
}

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

size_t classify_edges(Surface& s, const ShaftGeometry& g) {
  size_t left = 0;
  for (RawEdge& re : s.raw) {
    if (!re.inside) continue;  // line 3: outside the parent, outside the sub-shaft
    re.inside = g.may_intersect_segment(re.v[0], re.v[1]) ? 1 : 0;
    re.fresh = re.inside ? 0 : 1;
    left += re.fresh;
  }
  return left;
}

int classify_box_plane(const AABBd& b, const ConservativePlane& pl) {
  // The smallest and largest eval() over the eight corners, as evaluated: each rounded
  // operation of n.q - d is monotone in its operands, so eval() is monotone in q_k
  // (non-decreasing for n_k > 0, non-increasing for n_k < 0, constant up to the sign of
  // a zero for n_k = 0), and the extremes are at the two corners the signs of n pick.
  // The same values as evaluating all eight (a zero's sign aside, which no comparison
  // below sees); test IssBlockers.BoxPlaneClassificationEqualsTheEightCorners.
  auto corner = [&](bool high) {
    auto pick = [&](double n, double lo, double hi) { return (n > 0) == high ? std::max(lo, hi) : std::min(lo, hi); };
    return Vec3d(pick(pl.n.x, b.lo.x, b.hi.x), pick(pl.n.y, b.lo.y, b.hi.y), pick(pl.n.z, b.lo.z, b.hi.z));
  };
  double mn = pl.eval(corner(false)), mx = pl.eval(corner(true));
  if (mn > pl.tol) return 0;
  if (mx < -pl.tol) return 1;
  return 2;
}

size_t update_patch_facings(const BlockerContext& ctx, Surface& s, const ShaftGeometry& g) {
  size_t changed = 0;
  for (Patch& p : s.patches) {
    if (p.facing != Facing::Inconsistent || p.tri < 0) continue;
    uint32_t t = uint32_t(p.tri);
    ConservativePlane pl = plane_through(corner_d(*ctx.mesh, t, 0), corner_d(*ctx.mesh, t, 1), corner_d(*ctx.mesh, t, 2),
                               g.scale());
    if (pl.n == Vec3d(0, 0, 0)) continue;  // zero-area triangle: stays inconsistent
    int rr = classify_box_plane(g.receiver(), pl), lr = classify_box_plane(g.light(), pl);
    // Table 4.1.
    if (rr == 0) p.facing = Facing::TowardsReceiver;
    else if (rr == 1) p.facing = Facing::TowardsLight;
    else if (lr == 0) p.facing = Facing::TowardsLight;
    else if (lr == 1) p.facing = Facing::TowardsReceiver;
    else p.facing = Facing::Inconsistent;
    changed += p.facing != Facing::Inconsistent;
  }
  return changed;
}

void merge_patches(Surface& s, Workspace& ws) {
  size_t np = s.patches.size();
  ws.uf.resize(np);
  std::iota(ws.uf.begin(), ws.uf.end(), 0);
  bool any = false;
  for (const RawEdge& re : s.raw) {
    if (!re.inside || re.nb[0] == kNoPatch || re.nb[1] == kNoPatch || re.nb[0] == re.nb[1]) continue;
    const Patch& a = s.patches[size_t(re.nb[0])];
    const Patch& b = s.patches[size_t(re.nb[1])];
    if (a.facing == Facing::Inconsistent || a.facing != b.facing) continue;
    uf_union(ws.uf, re.nb[0], re.nb[1]);
    any = true;
  }
  if (!any) return;  // early exit (section 4.13)
  // New patch per group, in order of the group's first patch.
  ws.remap2.assign(np, -1);
  int32_t ng = 0;
  for (size_t i = 0; i < np; ++i) {
    int32_t r = uf_find(ws.uf, int32_t(i));
    if (ws.remap2[size_t(r)] < 0) ws.remap2[size_t(r)] = ng++;
  }
  ws.patch_tmp.assign(size_t(ng), Patch{});
  std::vector<uint32_t>& cnt = ws.order;
  cnt.assign(size_t(ng) + 1, 0);
  auto group = [&](int32_t p) { return ws.remap2[size_t(uf_find(ws.uf, p))]; };
  // Lines 26-33: keep the edges on the boundary of the merged patch.
  auto keep = [&](const Edge& e, int32_t owner_group) {
    int32_t nb = edge_neighbor(s, e);
    return nb == kNoPatch || group(nb) != owner_group;
  };
  for (size_t i = 0; i < np; ++i) {
    int32_t gi = group(int32_t(i));
    const Patch& p = s.patches[i];
    for (uint32_t k = p.first; k < p.first + p.count; ++k)
      if (keep(s.edges[k], gi)) ++cnt[size_t(gi) + 1];
  }
  for (size_t gi = 0; gi < size_t(ng); ++gi) cnt[gi + 1] += cnt[gi];
  ws.edge_tmp.resize(cnt[size_t(ng)]);
  std::vector<uint32_t>& fill = ws.fill;
  fill.assign(cnt.begin(), cnt.end() - 1);
  for (size_t i = 0; i < np; ++i) {
    int32_t gi = group(int32_t(i));
    const Patch& p = s.patches[i];
    Patch& q = ws.patch_tmp[size_t(gi)];
    if (q.count == 0 && q.tri == -1 && q.facing == Facing::Inconsistent) {
      q.facing = p.facing;
      q.tri = p.tri;
    }
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Edge& e = s.edges[k];
      if (keep(e, gi)) ws.edge_tmp[fill[size_t(gi)]++] = e;
    }
  }
  // Lines 38-43: remap the neighbour pointers to the new patches; edges inside a merged
  // patch are forgotten.
  for (RawEdge& re : s.raw) {
    if (re.nb[0] != kNoPatch && re.nb[1] != kNoPatch && group(re.nb[0]) == group(re.nb[1])) {
      re.nb[0] = re.nb[1] = kNoPatch;
      continue;
    }
    for (int k = 0; k < 2; ++k)
      if (re.nb[k] != kNoPatch) re.nb[k] = group(re.nb[k]);
  }
  // Install; drop groups left without boundary (closed consistent pieces cannot meet
  // any ray between the nodes: every ray would cross them in both directions).
  s.edges.swap(ws.edge_tmp);
  s.patches.clear();
  ws.remap.assign(size_t(ng), -1);
  for (size_t gi = 0; gi < size_t(ng); ++gi) {
    Patch q = ws.patch_tmp[gi];
    q.first = cnt[gi];
    q.count = cnt[gi + 1] - cnt[gi];
    if (q.count == 0) continue;
    if (q.facing != Facing::Inconsistent) q.tri = -1;
    ws.remap[gi] = int32_t(s.patches.size());
    s.patches.push_back(q);
  }
  if (s.patches.size() != size_t(ng)) {
    for (RawEdge& re : s.raw)
      for (int k = 0; k < 2; ++k)
        if (re.nb[k] != kNoPatch) re.nb[k] = ws.remap[size_t(re.nb[k])];
  }
  compact_raw(s, ws);
}

void simplify_patches(Surface& s, const ShaftGeometry& g, Workspace& ws) {
  // Early exits (section 4.13): a patch is simplified only when an edge of it left the
  // shaft since the last simplification and it has two outside edges; when no patch
  // qualifies the rebuild below would reproduce the surface, so only the fresh marks
  // are cleared (the surface is compact on entry: every producer ends in compact_raw).
  bool any_candidate = false;
  for (const Patch& p : s.patches) {
    uint32_t n_out = 0;
    bool fresh = false;
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const RawEdge& re = s.raw[s.edges[k].raw];
      n_out += re.inside ? 0 : 1;
      fresh = fresh || re.fresh;
    }
    if (n_out >= 2 && fresh) {
      any_candidate = true;
      break;
    }
  }
  if (!any_candidate) {
    for (RawEdge& re : s.raw) re.fresh = 0;
    return;
  }
  std::vector<Edge>& out = ws.edge_tmp;
  out.clear();
  std::vector<Patch>& newp = ws.patch_tmp2;
  newp.clear();
  newp.reserve(s.patches.size());
  ws.remap2.assign(s.patches.size(), -1);
  std::vector<Edge>& loop = ws.loop;
  for (size_t pi = 0; pi < s.patches.size(); ++pi) {
    Patch p = s.patches[pi];
    uint32_t n = p.count;
    // Early exit: collapsing needs two outside edges.
    uint32_t n_out = 0;
    bool any_fresh = false;
    for (uint32_t k = 0; k < n; ++k) {
      const RawEdge& re = s.raw[s.edges[p.first + k].raw];
      n_out += re.inside ? 0 : 1;
      any_fresh = any_fresh || re.fresh;
    }
    bool any_outside = n_out >= 2 && any_fresh;
    uint32_t first_out = uint32_t(out.size());
    if (!any_outside) {  // nothing to collapse
      for (uint32_t k = 0; k < n; ++k) out.push_back(s.edges[p.first + k]);
    } else {
      // Chain the edges into loops: successor = an unused edge starting where this ends.
      std::vector<uint32_t>& ord = ws.order;
      auto start = [&](uint32_t k) -> const Vec3d& { return edge_vertex(s, s.edges[p.first + k], 0); };
      auto end = [&](uint32_t k) -> const Vec3d& { return edge_vertex(s, s.edges[p.first + k], 1); };
      ws.next.assign(n, -1);
      ws.used.assign(n, 0);
      // Fast path (section 4.13, avoid work): the edges are usually stored loop by loop
      // already (triangles and every simplified patch are written that way), so chain
      // them in storage order when each edge starts where the previous one ends and
      // each run closes on its first edge. Otherwise chain by sorted start vertices.
      bool sequential = true;
      for (uint32_t k0 = 0, k = 0; k < n && sequential; ++k) {
        if (k + 1 < n && end(k) == start(k + 1)) {
          ws.next[k] = int32_t(k + 1);
        } else if (end(k) == start(k0)) {
          ws.next[k] = int32_t(k0);
          k0 = k + 1;
        } else {
          sequential = false;
        }
      }
      bool ok = true;
      if (!sequential) {
        ws.next.assign(n, -1);
        ord.resize(n);
        std::iota(ord.begin(), ord.end(), 0u);
        std::sort(ord.begin(), ord.end(), [&](uint32_t x, uint32_t y) { return lex_less(start(x), start(y)); });
      }
      for (uint32_t k = 0; k < n && ok && !sequential; ++k) {
        const Vec3d& e = end(k);
        auto it = std::lower_bound(ord.begin(), ord.end(), e, [&](uint32_t x, const Vec3d& v) { return lex_less(start(x), v); });
        bool found = false;
        for (; it != ord.end() && start(*it) == e; ++it) {
          if (!ws.used[*it]) {
            ws.used[*it] = 1;
            ws.next[k] = int32_t(*it);
            found = true;
            break;
          }
        }
        ok = found;
      }
      if (!ok) {  // not closed loops (cannot happen in a valid surface): leave as is
        for (uint32_t k = 0; k < n; ++k) out.push_back(s.edges[p.first + k]);
      } else {
        std::fill(ws.used.begin(), ws.used.end(), 0);
        for (uint32_t k0 = 0; k0 < n; ++k0) {
          if (ws.used[k0]) continue;
          loop.clear();
          for (uint32_t k = k0; !ws.used[k]; k = uint32_t(ws.next[k])) {
            ws.used[k] = 1;
            loop.push_back(s.edges[p.first + k]);
          }
          // Collapse adjacent outside edges while the removed triangle stays outside the
          // (extended) shaft, Figure 4.24.
          // `fail[i]`: the pair (i, i+1) was tested with these very edges and cannot be
          // collapsed; only pairs next to a collapse are tested again (section 4.13).
          std::vector<uint8_t>& fail = ws.fail;
          fail.assign(loop.size(), 0);
          auto clear_fail = [&](long k) {
            long m = long(loop.size());
            if (m > 0) fail[size_t(((k % m) + m) % m)] = 0;
          };
          bool changed = true;
          while (changed && loop.size() >= 2) {
            changed = false;
            for (size_t i = 0; i < loop.size() && loop.size() >= 2;) {
              if (fail[i]) { ++i; continue; }
              size_t j = (i + 1) % loop.size();
              Edge e1 = loop[i], e2 = loop[j];
              if (s.raw[e1.raw].inside || s.raw[e2.raw].inside) { fail[i] = 1; ++i; continue; }
              Vec3d u = edge_vertex(s, e1, 0), v = edge_vertex(s, e1, 1), w = edge_vertex(s, e2, 1);
              if (u != w && g.may_intersect_extended(u, v, w)) { fail[i] = 1; ++i; continue; }
              // Detach this patch from the two edges (their other patch keeps them).
              s.raw[e1.raw].nb[e1.flipped ? 0 : 1] = kNoPatch;
              s.raw[e2.raw].nb[e2.flipped ? 0 : 1] = kNoPatch;
              changed = true;
              if (u == w || loop.size() == 2) {
                if (j > i) {
                  loop.erase(loop.begin() + long(j));
                  loop.erase(loop.begin() + long(i));
                  fail.erase(fail.begin() + long(j));
                  fail.erase(fail.begin() + long(i));
                  clear_fail(long(i) - 1);
                } else {
                  loop.erase(loop.begin() + long(i));
                  loop.erase(loop.begin() + long(j));
                  fail.erase(fail.begin() + long(i));
                  fail.erase(fail.begin() + long(j));
                  clear_fail(-1);
                  i = 0;
                }
              } else {
                RawEdge ne;
                ne.v[0] = u;
                ne.v[1] = w;
                ne.nb[1] = int32_t(pi);
                ne.mesh_edge = kClipEdge;
                ne.inside = 0;
                loop[i] = Edge{uint32_t(s.raw.size()), 0};
                s.raw.push_back(ne);
                loop.erase(loop.begin() + long(j));
                fail.erase(fail.begin() + long(j));
                size_t at = j > i ? i : i - 1;
                clear_fail(long(at));
                clear_fail(long(at) - 1);
                if (j < i) i = 0;
              }
            }
          }
          for (const Edge& e : loop) out.push_back(e);
        }
      }
    }
    uint32_t cnt = uint32_t(out.size()) - first_out;
    if (cnt == 0) continue;  // the patch vanished (section 4.7.5)
    ws.remap2[pi] = int32_t(newp.size());
    p.first = first_out;
    p.count = cnt;
    newp.push_back(p);
  }
  s.edges.swap(out);
  s.patches.assign(newp.begin(), newp.end());  // never more patches: no reallocation
  for (RawEdge& re : s.raw) re.fresh = 0;
  for (RawEdge& re : s.raw)
    for (int k = 0; k < 2; ++k)
      if (re.nb[k] != kNoPatch) re.nb[k] = ws.remap2[size_t(re.nb[k])];
  compact_raw(s, ws);
}

void split_surface(Surface&& s, std::vector<Surface>& out, Workspace& ws) {
  size_t np = s.patches.size();
  if (np == 0) return;
  ws.uf.resize(np);
  std::iota(ws.uf.begin(), ws.uf.end(), 0);
  for (const RawEdge& re : s.raw)
    if (re.inside && re.nb[0] != kNoPatch && re.nb[1] != kNoPatch) uf_union(ws.uf, re.nb[0], re.nb[1]);
  ws.remap2.assign(np, -1);
  int32_t nc = 0;
  for (size_t i = 0; i < np; ++i) {
    int32_t r = uf_find(ws.uf, int32_t(i));
    if (ws.remap2[size_t(r)] < 0) ws.remap2[size_t(r)] = nc++;
  }
  if (nc == 1) {
    out.push_back(std::move(s));
    return;
  }
  auto comp = [&](int32_t p) { return ws.remap2[size_t(uf_find(ws.uf, p))]; };
  // Lines 22-31: edges joining two components get a duplicate; each side keeps one.
  size_t nraw = s.raw.size();
  ws.remap.assign(nraw, -1);  // raw index -> duplicate for the nb[0] side
  for (size_t i = 0; i < nraw; ++i) {
    RawEdge& re = s.raw[i];
    if (re.nb[0] == kNoPatch || re.nb[1] == kNoPatch || comp(re.nb[0]) == comp(re.nb[1])) continue;
    RawEdge dup = re;
    dup.nb[1] = kNoPatch;
    re.nb[0] = kNoPatch;
    ws.remap[i] = int32_t(s.raw.size());
    s.raw.push_back(dup);
  }
  for (Edge& e : s.edges)
    if (e.flipped && ws.remap[e.raw] >= 0) e.raw = uint32_t(ws.remap[e.raw]);
  // Distribute patches, edges and raw edges to the components.
  size_t base = out.size();
  for (int32_t c = 0; c < nc; ++c) {
    out.push_back(ws.take_surface());
    out.back().hull = s.hull;  // a superset of each component's triangles
  }
  std::vector<int32_t>& local_patch = ws.local_patch;
  std::vector<int32_t>& local_raw = ws.local_raw;
  local_patch.assign(np, -1);
  local_raw.assign(s.raw.size(), -1);
  for (size_t i = 0; i < np; ++i) {
    Surface& c = out[base + size_t(comp(int32_t(i)))];
    local_patch[i] = int32_t(c.patches.size());
    c.patches.push_back(s.patches[i]);
  }
  for (size_t i = 0; i < s.raw.size(); ++i) {
    const RawEdge& re = s.raw[i];
    int32_t owner = re.nb[0] != kNoPatch ? re.nb[0] : re.nb[1];
    if (owner == kNoPatch) continue;
    Surface& c = out[base + size_t(comp(owner))];
    RawEdge r2 = re;
    for (int k = 0; k < 2; ++k)
      if (r2.nb[k] != kNoPatch) r2.nb[k] = local_patch[size_t(r2.nb[k])];
    local_raw[i] = int32_t(c.raw.size());
    c.raw.push_back(r2);
  }
  for (size_t i = 0; i < np; ++i) {
    Surface& c = out[base + size_t(comp(int32_t(i)))];
    Patch& q = c.patches[size_t(local_patch[i])];
    const Patch& p = s.patches[i];
    q.first = uint32_t(c.edges.size());
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      Edge e = s.edges[k];
      e.raw = uint32_t(local_raw[e.raw]);
      c.edges.push_back(e);
    }
  }
  ws.recycle(std::move(s));
}

void compute_loose_edges(const BlockerContext& ctx, Surface& s) {
  s.loose.clear();
  for (const RawEdge& re : s.raw) {
    if (re.mesh_edge < 0 || !ctx.mesh->is_double_edge[size_t(re.mesh_edge)]) continue;
    if (re.inside && (re.nb[0] == kNoPatch) != (re.nb[1] == kNoPatch)) s.loose.push_back(re.mesh_edge);
  }
}

void combine_surfaces(const BlockerContext& ctx, std::vector<Surface>& in, std::vector<Surface>& out,
                      const ShaftGeometry& g, Workspace& ws) {
  size_t ns = in.size();
  ws.reset_labels(ctx.mesh->edge_count());
  std::vector<int32_t>& suf = ws.sets;
  suf.resize(ns);
  std::iota(suf.begin(), suf.end(), 0);
  bool any = false;
  for (size_t i = 0; i < ns; ++i) {
    for (int32_t label : in[i].loose) {
      if (ws.label_stamp[size_t(label)] == ws.stamp) {
        uf_union(suf, int32_t(i), ws.label_slot[size_t(label)]);
        any = true;
      } else {
        ws.label_stamp[size_t(label)] = ws.stamp;
        ws.label_slot[size_t(label)] = int32_t(i);
      }
    }
  }
  if (!any) {
    for (Surface& s : in) out.push_back(std::move(s));
    return;
  }
  // Members of each set in index order, grouped by a counting sort on the set's root
  // (the smallest member, uf_union keeps the smaller index as the root).
  std::vector<uint32_t>& start = ws.group_start;
  std::vector<int32_t>& members = ws.members;
  start.assign(ns + 1, 0);
  members.resize(ns);
  for (size_t i = 0; i < ns; ++i) ++start[size_t(uf_find(suf, int32_t(i))) + 1];
  for (size_t r = 0; r < ns; ++r) start[r + 1] += start[r];
  ws.fill.assign(start.begin(), start.end() - 1);
  for (size_t i = 0; i < ns; ++i) members[ws.fill[size_t(uf_find(suf, int32_t(i)))]++] = int32_t(i);
  for (size_t r = 0; r < ns; ++r) {
    uint32_t m0 = start[r], m1 = start[r + 1];
    if (m0 == m1) continue;
    if (m1 - m0 == 1) {
      out.push_back(std::move(in[size_t(members[m0])]));
      continue;
    }
    // CONSTRUCT-COMBINED-SURFACE: concatenate, then unify matching loose edges.
    Surface c = ws.take_surface();
    for (uint32_t mi = m0; mi < m1; ++mi) {
      Surface& s = in[size_t(members[mi])];
      uint32_t rb = uint32_t(c.raw.size()), eb = uint32_t(c.edges.size());
      int32_t pb = int32_t(c.patches.size());
      for (RawEdge re : s.raw) {
        for (int k = 0; k < 2; ++k)
          if (re.nb[k] != kNoPatch) re.nb[k] += pb;
        c.raw.push_back(re);
      }
      for (Edge e : s.edges) {
        e.raw += rb;
        c.edges.push_back(e);
      }
      for (Patch p : s.patches) {
        p.first += eb;
        c.patches.push_back(p);
      }
      c.hull.extend(s.hull);
      ws.recycle(std::move(s));
    }
    ws.reset_labels(ctx.mesh->edge_count());
    auto& extra = ws.extra;      // edges appended to a patch
    auto& replace = ws.replace;  // raw B -> edge to use instead
    extra.clear();
    replace.clear();
    size_t nraw0 = c.raw.size();
    for (size_t i = 0; i < nraw0; ++i) {
      RawEdge& b = c.raw[i];
      if (b.mesh_edge < 0 || !b.inside || (b.nb[0] == kNoPatch) == (b.nb[1] == kNoPatch)) continue;
      size_t label = size_t(b.mesh_edge);
      if (ws.label_stamp[label] != ws.stamp) {
        ws.label_stamp[label] = ws.stamp;
        ws.label_slot[label] = int32_t(i);
        continue;
      }
      uint32_t ai = uint32_t(ws.label_slot[label]);
      RawEdge& a = c.raw[ai];
      if ((a.nb[0] == kNoPatch) == (a.nb[1] == kNoPatch)) continue;  // already unified
      int sa = a.nb[1] != kNoPatch ? 1 : 0, sb = b.nb[1] != kNoPatch ? 1 : 0;
      int32_t P = a.nb[sa], Q = b.nb[sb];
      if (P == Q) continue;
      // Owner traversal directions: P goes pa -> pb, Q goes qa -> qb (about pb -> pa).
      Vec3d pa = sa == 1 ? a.v[0] : a.v[1], pbv = sa == 1 ? a.v[1] : a.v[0];
      Vec3d qa = sb == 1 ? b.v[0] : b.v[1], qb = sb == 1 ? b.v[1] : b.v[0];
      // Figure 4.29: Q takes the flipped version of a, glue edges close the gaps.
      a.nb[1 - sa] = Q;
      Edge qa_edge{ai, uint8_t(sa == 1 ? 1 : 0)};
      replace.push_back({uint32_t(i), qa_edge});
      auto glue = [&](const Vec3d& from, const Vec3d& to) {
        RawEdge ge;
        ge.v[0] = from;
        ge.v[1] = to;
        ge.nb[1] = Q;
        ge.mesh_edge = kClipEdge;
        ge.inside = g.may_intersect_segment(from, to) ? 1 : 0;
        ge.fresh = ge.inside ? 0 : 1;
        extra.push_back({Q, Edge{uint32_t(c.raw.size()), 0}});
        c.raw.push_back(ge);
      };
      if (qa != pbv) glue(qa, pbv);
      if (pa != qb) glue(pa, qb);
      c.raw[i].nb[0] = c.raw[i].nb[1] = kNoPatch;  // b is replaced
      ws.label_stamp[label] = 0;                    // the label is consumed
    }
    // Replace references to the unified raw edges, then rebuild the edge ranges with the
    // glue edges appended to their patches.
    if (!replace.empty()) {
      ws.remap.assign(c.raw.size(), -1);
      for (size_t k = 0; k < replace.size(); ++k) ws.remap[replace[k].first] = int32_t(k);
      for (Edge& e : c.edges)
        if (ws.remap[e.raw] >= 0) e = replace[size_t(ws.remap[e.raw])].second;
    }
    if (!extra.empty()) {
      std::vector<Edge>& ne = ws.edge_tmp2;
      ne.clear();
      ne.reserve(c.edges.size() + extra.size());
      for (size_t pi = 0; pi < c.patches.size(); ++pi) {
        Patch& p = c.patches[pi];
        uint32_t f = uint32_t(ne.size());
        for (uint32_t k = p.first; k < p.first + p.count; ++k) ne.push_back(c.edges[k]);
        for (auto& [q, e] : extra)
          if (q == int32_t(pi)) ne.push_back(e);
        p.first = f;
        p.count = uint32_t(ne.size()) - f;
      }
      c.edges.swap(ne);
    }
    compact_raw(c, ws);
    merge_patches(c, ws);          // merging may be possible after combining
    simplify_patches(c, g, ws);    // same with simplifying
    compute_loose_edges(ctx, c);
    if (!c.patches.empty()) out.push_back(std::move(c));
    else ws.recycle(std::move(c));
  }
}

void compute_bounds(Surface& s, const ShaftGeometry& g) {
  s.box = empty_box();
  s.vsum = Vec3d(0, 0, 0);
  s.vcount = 0;
  for (const RawEdge& re : s.raw) {
    s.box.extend(re.v[0]);
    s.box.extend(re.v[1]);
    if (re.inside) {
      s.vsum += re.v[0] + re.v[1];
      s.vcount += 2;
    }
  }
}

bool all_edges_outside(const Surface& s) {
  for (const RawEdge& re : s.raw)
    if (re.inside) return false;
  return true;
}

AABBd clamp_box(const AABBd& box, int axis, double lo, double hi) {
  AABBd c = box;
  if (c.empty() || axis < 0) return c;
  c.lo[axis] = std::min(hi, std::max(lo, box.lo[axis]));
  c.hi[axis] = std::min(hi, std::max(lo, box.hi[axis]));
  return c;
}

AABBd clamped_box(const AABBd& box, const ShaftGeometry& g) {
  return clamp_box(box, g.main_axis(), g.clip_lo(), g.clip_hi());
}

bool can_block_shaft(const AABBd& box, const ShaftGeometry& g) {
  // The winding number is computed for the boundary clamped to the slab between the
  // clip planes (section 4.5), which lies in the clamped box. For every segment from
  // the receiver box's outer face to the light box's outer face, the winding of the
  // clamped boundary about it equals the (constant) intersection number of blockers.h,
  // so a nonzero winding needs the clamped box to meet every such segment; three are
  // tested: the test segment and the segments between the two faces' low corners and
  // between their high corners, each grown by the plane tolerance of shaft.h.
  // Neither the unclamped box nor segments from other corners of the node boxes will
  // do: a boundary entirely below the receiver's clip plane, of a surface reaching up
  // through the shaft, is clamped onto that plane around the test segment's end, and
  // a segment from the top of the receiver box passes above it (corpus/iss/other,
  // on-surface-110).
  AABBd c = clamped_box(box, g);
  Vec3d q1, q2;
  g.test_segment(q1, q2);
  int ax = g.main_axis();
  Vec3d r_lo = g.receiver().lo, r_hi = g.receiver().hi, l_lo = g.light().lo, l_hi = g.light().hi;
  r_lo[ax] = r_hi[ax] = q1[ax];  // the outer faces, on the clip planes
  l_lo[ax] = l_hi[ax] = q2[ax];
  double grow = 0x1p-40 * g.scale();
  return segment_may_hit_box(q1, q2, c, grow) && segment_may_hit_box(r_lo, l_lo, c, grow) &&
         segment_may_hit_box(r_hi, l_hi, c, grow);
}

bool blocks_shaft(const Surface& s, const ShaftGeometry& g) { return blocking_test(s, g) == BlockTest::Blocked; }

BlockTest blocking_test(const Surface& s, const ShaftGeometry& g) {
  // A shaft whose boxes are closer on the main axis than 2^-30 of the scale is thinner
  // than the tolerances of its planes (2^-40 of the scale, shaft.h) allow to resolve: its
  // test line and clamped boundaries lie in a slab where the winding number's signs are
  // rounding (products of such differences underflow). Its relations go to the rays.
  if (shaft_too_thin(g)) return BlockTest::Unknown;
  if (stands_beyond_clip_planes(s, g)) return BlockTest::Unknown;
  // Line 1, CAN-BLOCK-SHAFT.
  if (!can_block_shaft(s.box, g)) return BlockTest::Clear;
  Vec3d q1, q2;
  g.test_segment(q1, q2);
  // Lines 3-7: a boundary edge inside the shaft means a hole.
  for (const RawEdge& re : s.raw)
    if ((re.nb[0] == kNoPatch || re.nb[1] == kNoPatch) && re.inside) return BlockTest::Clear;
  // Lines 8-34: winding number of the clamped boundary around the test line.
  TestPlanes tp = make_test_planes(q1, q2);
  int ax = g.main_axis();
  // Clamping (section 4.5) moves a boundary part beyond a clip plane onto that plane,
  // sweeping only through space beyond it; shaft segments meet the plane only where
  // they end, on the node's outer face. So the winding about every shaft segment is the
  // one of the unclamped geometry unless a clamped part lands on that face: then it is
  // not (corpus/iss/other/bef549c1...), and the shaft is not called blocked (its
  // relations go to sub-shafts and rays).
  const double face_tol = 0x1p-40 * g.scale();
  const AABBd& lo_face = g.dir() > 0 ? g.receiver() : g.light();
  const AABBd& hi_face = g.dir() > 0 ? g.light() : g.receiver();
  int winding = 0;  // in halves
  for (const RawEdge& re : s.raw) {
    if (re.nb[0] != kNoPatch && re.nb[1] != kNoPatch) continue;  // double edge
    bool owner_is_1 = re.nb[1] != kNoPatch;
    const Vec3d& v0 = owner_is_1 ? re.v[0] : re.v[1];
    const Vec3d& v1 = owner_is_1 ? re.v[1] : re.v[0];
    if (beyond_part_meets_face(v0, v1, ax, g.clip_lo(), true, lo_face, face_tol) ||
        beyond_part_meets_face(v0, v1, ax, g.clip_hi(), false, hi_face, face_tol))
      return BlockTest::Unknown;
    winding += clamped_winding(tp, v0, v1, ax, g.clip_lo(), g.clip_hi());
  }
  return winding != 0 ? BlockTest::Blocked : BlockTest::Clear;
}

bool misses_slab(const AABBd& box, int axis, double lo, double hi, bool touching_misses) {
  const double blo = box.lo[axis], bhi = box.hi[axis];
  return bhi < lo || blo > hi || (touching_misses && (bhi <= lo || blo >= hi));
}

double main_axis_gap(const ShaftGeometry& g) {
  const int a = g.main_axis();
  // Receiver below the light when dir > 0.
  return g.dir() > 0 ? g.light().lo[a] - g.receiver().hi[a] : g.receiver().lo[a] - g.light().hi[a];
}

bool shaft_too_thin(const ShaftGeometry& g) {
  return g.main_axis() < 0 || !(main_axis_gap(g) > 0x1p-30 * g.scale());
}

bool beyond_clip_planes(const AABBd& box, const ShaftGeometry& g) {
  const int a = g.main_axis();
  if (a < 0 || box.empty()) return false;
  return misses_slab(box, a, g.clip_lo(), g.clip_hi(), main_axis_gap(g) > 0.0);
}

bool stands_beyond_clip_planes(const Surface& s, const ShaftGeometry& g) {
  return beyond_clip_planes(s.box, g) && !beyond_clip_planes(s.hull, g);
}

bool blocks_ray(const BlockerContext& ctx, const Surface& s, int ax, const Vec3d& r, const Vec3d& l) {
  double lo = std::min(r[ax], l[ax]), hi = std::max(r[ax], l[ax]);
  // The patch boundaries are clamped to the ray's extent on the main axis below, so
  // the early exit tests the box clamped the same way (see can_block_shaft).
  if (!segment_may_hit_box(r, l, clamp_box(s.box, ax, lo, hi), 0x1p-40 * ctx.scale)) return false;
  TestPlanes tp = make_test_planes(r, l);
  for (const Patch& p : s.patches) {
    if (p.facing == Facing::Inconsistent && p.tri >= 0) {
      uint32_t t = uint32_t(p.tri);
      if (segment_hits_triangle_d(r, l, corner_d(*ctx.mesh, t, 0), corner_d(*ctx.mesh, t, 1), corner_d(*ctx.mesh, t, 2)))
        return true;
      continue;
    }
    int w = 0;
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Edge& e = s.edges[k];
      w += clamped_winding(tp, edge_vertex(s, e, 0), edge_vertex(s, e, 1), ax, lo, hi);
    }
    if (w != 0) return true;
  }
  return false;
}

std::string validate(const Surface& s, const mesh::PreparedMesh* m) {
  auto fail = [](const std::string& w) { return "iss surface invalid: " + w; };
  int32_t np = int32_t(s.patches.size());
  std::vector<int> refs(s.raw.size() * 2, 0);
  for (size_t i = 0; i < s.raw.size(); ++i) {
    const RawEdge& re = s.raw[i];
    for (int k = 0; k < 2; ++k)
      if (re.nb[k] < kNoPatch || re.nb[k] >= np) return fail("raw edge " + std::to_string(i) + " neighbour out of range");
    if (re.nb[0] == kNoPatch && re.nb[1] == kNoPatch) return fail("raw edge " + std::to_string(i) + " has no patch");
    if (m && re.mesh_edge >= int32_t(m->edge_count())) return fail("raw edge label out of range");
    if (re.mesh_edge < kClipEdge) return fail("raw edge label negative");
  }
  std::vector<Vec3d> starts, ends;
  for (int32_t pi = 0; pi < np; ++pi) {
    const Patch& p = s.patches[size_t(pi)];
    if (p.count == 0) return fail("patch " + std::to_string(pi) + " without edges");
    if (size_t(p.first) + p.count > s.edges.size()) return fail("patch edge range out of bounds");
    if (p.facing == Facing::Inconsistent && p.tri < 0) return fail("inconsistent patch without triangle");
    starts.clear();
    ends.clear();
    for (uint32_t k = p.first; k < p.first + p.count; ++k) {
      const Edge& e = s.edges[k];
      if (e.raw >= s.raw.size()) return fail("edge raw index out of range");
      if (edge_owner(s, e) != pi) return fail("edge of patch " + std::to_string(pi) + " not owned by it");
      ++refs[size_t(e.raw) * 2 + (e.flipped ? 0 : 1)];
      starts.push_back(edge_vertex(s, e, 0));
      ends.push_back(edge_vertex(s, e, 1));
    }
    // The edges form closed loops: every vertex starts as many edges as it ends.
    std::sort(starts.begin(), starts.end(), lex_less);
    std::sort(ends.begin(), ends.end(), lex_less);
    if (starts != ends) return fail("edges of patch " + std::to_string(pi) + " do not form loops");
  }
  for (size_t i = 0; i < s.raw.size(); ++i)
    for (int k = 0; k < 2; ++k) {
      int want = s.raw[i].nb[k] != kNoPatch ? 1 : 0;
      if (refs[i * 2 + size_t(k)] != want)
        return fail("raw edge " + std::to_string(i) + " side " + std::to_string(k) + " referenced " +
                    std::to_string(refs[i * 2 + size_t(k)]) + " times");
    }
  for (int32_t label : s.loose) {
    if (label < 0 || (m && (size_t(label) >= m->edge_count() || !m->is_double_edge[size_t(label)])))
      return fail("loose edge label is not a double edge");
  }
  auto holds = [&](const AABBd& b, const char* what) -> std::string {
    if (b.empty()) return {};
    for (const RawEdge& re : s.raw)
      for (const Vec3d& v : re.v)
        if (v.x < b.lo.x || v.y < b.lo.y || v.z < b.lo.z || v.x > b.hi.x || v.y > b.hi.y || v.z > b.hi.z)
          return fail(std::string("vertex outside the surface ") + what);
    return {};
  };
  if (!s.patches.empty() && s.hull.empty()) return fail("patches without a hull");
  if (std::string e = holds(s.box, "box"); !e.empty()) return e;
  if (std::string e = holds(s.hull, "hull"); !e.empty()) return e;
  return {};
}

}  // namespace visgate::iss
