// The per-surface refinement steps of CONSTRUCT-SUB-SHAFT (paper 000 section 4.7):
// CLASSIFY-EDGES (4.7.2, Figure 4.21), UPDATE-PATCH-FACINGS (4.7.3, Figure 4.22),
// MERGE-PATCHES (4.7.4, Figure 4.23) and SIMPLIFY-PATCHES (4.7.5, Figure 4.24).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"

namespace visgate::iss {

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

Facing triangle_facing(const ConservativePlane& pl, const ShaftGeometry& g) {
  if (pl.n == Vec3d(0, 0, 0)) return Facing::Inconsistent;  // zero-area triangle
  const int rr = classify_box_plane(g.receiver(), pl), lr = classify_box_plane(g.light(), pl);
  // Table 4.1.
  if (rr == 0) return Facing::TowardsReceiver;
  if (rr == 1) return Facing::TowardsLight;
  if (lr == 0) return Facing::TowardsLight;
  if (lr == 1) return Facing::TowardsReceiver;
  return Facing::Inconsistent;
}

size_t update_patch_facings(const BlockerContext& ctx, Surface& s, const ShaftGeometry& g) {
  size_t changed = 0;
  for (Patch& p : s.patches) {
    if (p.facing != Facing::Inconsistent || p.tri < 0) continue;
    uint32_t t = uint32_t(p.tri);
    ConservativePlane pl = plane_through(corner_d(*ctx.mesh, t, 0), corner_d(*ctx.mesh, t, 1), corner_d(*ctx.mesh, t, 2),
                               g.scale());
    p.facing = triangle_facing(pl, g);
    changed += p.facing != Facing::Inconsistent;
  }
  return changed;
}

void merge_patches(Surface& s, Workspace& ws) {
  size_t np = s.patches.size();
  uf_reset(ws.uf, np);
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

size_t extract_inconsistent(Surface& s, std::vector<uint32_t>& band, Workspace& ws) {
  auto removed = [](const Patch& p) { return p.facing == Facing::Inconsistent && p.tri >= 0; };
  if (std::none_of(s.patches.begin(), s.patches.end(), removed)) return 0;
  const size_t np = s.patches.size();
  ws.remap2.assign(np, kNoPatch);  // a removed patch's side of an edge becomes empty
  std::vector<Edge>& out = ws.edge_tmp;
  out.clear();
  std::vector<Patch>& newp = ws.patch_tmp2;
  newp.clear();
  size_t n = 0;
  for (size_t pi = 0; pi < np; ++pi) {
    Patch p = s.patches[pi];
    if (removed(p)) {
      band.push_back(uint32_t(p.tri));
      ++n;
      continue;
    }
    ws.remap2[pi] = int32_t(newp.size());
    const uint32_t first = uint32_t(out.size());
    for (uint32_t k = p.first; k < p.first + p.count; ++k) out.push_back(s.edges[k]);
    p.first = first;
    newp.push_back(p);
  }
  s.edges.swap(out);
  s.patches.assign(newp.begin(), newp.end());
  for (RawEdge& re : s.raw)
    for (int k = 0; k < 2; ++k)
      if (re.nb[k] != kNoPatch) re.nb[k] = ws.remap2[size_t(re.nb[k])];
  compact_raw(s, ws);  // raw edges only the removed patches used
  return n;
}

namespace {

// Section 4.13's early exit for SIMPLIFY-PATCHES: a patch is simplified only when an edge
// of it left the shaft since the last simplification and it has two outside edges.
bool may_collapse(const Surface& s, const Patch& p) {
  uint32_t n_out = 0;
  bool fresh = false;
  for (uint32_t k = p.first; k < p.first + p.count; ++k) {
    const RawEdge& re = s.raw[s.edges[k].raw];
    n_out += re.inside ? 0 : 1;
    fresh = fresh || re.fresh;
  }
  return n_out >= 2 && fresh;
}

// Chains the edges of patch p into loops: ws.next[k] is the edge that starts where edge
// k ends. False when they do not close (cannot happen in a valid surface).
bool chain_loops(const Surface& s, const Patch& p, Workspace& ws) {
  const uint32_t n = p.count;
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
  if (sequential) return true;
  ws.next.assign(n, -1);
  ord.resize(n);
  std::iota(ord.begin(), ord.end(), 0u);
  std::sort(ord.begin(), ord.end(), [&](uint32_t x, uint32_t y) { return lex_less(start(x), start(y)); });
  for (uint32_t k = 0; k < n; ++k) {
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
    if (!found) return false;
  }
  return true;
}

// Collapses adjacent outside edges of the loop ws.loop of patch pi while the removed
// triangle stays outside the (extended) shaft, Figure 4.24.
void collapse_loop(Surface& s, const ShaftGeometry& g, size_t pi, Workspace& ws) {
  std::vector<Edge>& loop = ws.loop;
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
}

}  // namespace

void simplify_patches(Surface& s, const ShaftGeometry& g, Workspace& ws) {
  // Early exit (section 4.13): when no patch qualifies (may_collapse) the rebuild below
  // would reproduce the surface, so only the fresh marks are cleared (the surface is
  // compact on entry: every producer ends in compact_raw).
  if (std::none_of(s.patches.begin(), s.patches.end(), [&](const Patch& p) { return may_collapse(s, p); })) {
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
    const uint32_t n = p.count;
    const uint32_t first_out = uint32_t(out.size());
    if (!may_collapse(s, p) || !chain_loops(s, p, ws)) {  // nothing to collapse, or not loops
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
        collapse_loop(s, g, pi, ws);
        for (const Edge& e : loop) out.push_back(e);
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

}  // namespace visgate::iss
