// SPLIT-SURFACE (paper 000 section 4.7.6, Figure 4.25), COMPUTE-LOOSE-EDGES and
// COMBINE-SURFACES with glue edges (4.7.7, Figures 4.26-4.29).
#include <algorithm>
#include <cmath>
#include <numeric>

#include "lib/base/check.h"
#include "lib/iss/blocker_helpers.h"
#include "lib/iss/blockers.h"

namespace visgate::iss {

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

}  // namespace visgate::iss
