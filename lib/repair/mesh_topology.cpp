// Edge table, adjacency, boundary loops, vertex fans and duplicate faces (see
// mesh_topology.h).
#include "lib/repair/mesh_topology.h"

#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace visgate::mesh {

// Edge records bucketed by their lower vertex (a counting sort, stable in triangle
// order), then each bucket sorted by its upper vertex: O(records) plus small sorts
// rather than a comparison sort of all 3 records per triangle.
EdgeTable build_edges(const std::vector<Tri>& tris, const std::vector<uint8_t>* active, size_t nverts) {
  EdgeTable e;
  std::vector<uint32_t> off(nverts + 1, 0);
  size_t m = 0;
  for (uint32_t t = 0; t < tris.size(); ++t) {
    if (active && !(*active)[t]) continue;
    for (uint8_t k = 0; k < 3; ++k) ++off[size_t(std::min(tris[t][k], tris[t][(k + 1) % 3])) + 1];
    m += 3;
  }
  for (size_t v = 0; v < nverts; ++v) off[v + 1] += off[v];
  e.recs.resize(m);
  {
    std::vector<uint32_t> fill(off.begin(), off.end() - 1);
    for (uint32_t t = 0; t < tris.size(); ++t) {
      if (active && !(*active)[t]) continue;
      for (uint8_t k = 0; k < 3; ++k) {
        uint32_t a = tris[t][k], b = tris[t][(k + 1) % 3];
        const uint64_t key = edge_key(a, b);
        e.recs[fill[std::min(a, b)]++] = {key, t, k, uint8_t(a < b)};
      }
    }
  }
  // Within a bucket the records are in (triangle, corner) order; a stable sort by key
  // gives the (key, triangle, corner) order.
  auto by_key = [](const EdgeRec& x, const EdgeRec& y) { return x.key < y.key; };
  tbb::parallel_for(tbb::blocked_range<size_t>(0, nverts, 1 << 12), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v < r.end(); ++v) {
      EdgeRec* b = e.recs.data() + off[v];
      EdgeRec* en = e.recs.data() + off[v + 1];
      if (en - b <= 1) continue;
      if (en - b <= 32) {
        for (EdgeRec* i = b + 1; i < en; ++i)
          for (EdgeRec* j = i; j > b && by_key(*j, *(j - 1)); --j) std::swap(*j, *(j - 1));
      } else {
        std::stable_sort(b, en, by_key);
      }
    }
  });
  e.tri_edge.assign(tris.size() * 3, kNone);
  e.start.reserve(m / 2 + 1);
  for (uint32_t i = 0; i < e.recs.size(); ++i) {
    if (i == 0 || e.recs[i].key != e.recs[i - 1].key) e.start.push_back(i);
    e.tri_edge[3 * size_t(e.recs[i].tri) + e.recs[i].k] = uint32_t(e.start.size() - 1);
  }
  e.start.push_back(uint32_t(e.recs.size()));
  return e;
}

Adjacency build_adjacency(const EdgeTable& e, size_t ntris) {
  Adjacency a;
  a.nb.assign(ntris * 3, kNone);
  a.same.assign(ntris * 3, 0);
  for (size_t g = 0; g < e.groups(); ++g) {
    if (e.size(g) != 2) continue;
    const EdgeRec& r1 = e.recs[e.start[g]];
    const EdgeRec& r2 = e.recs[e.start[g] + 1];
    a.nb[3 * size_t(r1.tri) + r1.k] = r2.tri;
    a.nb[3 * size_t(r2.tri) + r2.k] = r1.tri;
    uint8_t s = r1.fwd == r2.fwd;
    a.same[3 * size_t(r1.tri) + r1.k] = s;
    a.same[3 * size_t(r2.tri) + r2.k] = s;
  }
  return a;
}

std::vector<Loop> boundary_loops(const EdgeTable& e) {
  std::vector<uint32_t> bedges;
  for (uint32_t g = 0; g < e.groups(); ++g)
    if (e.size(g) == 1) bedges.push_back(g);
  // vertex -> boundary edges, as a sorted (vertex, edge) list.
  std::vector<std::pair<uint32_t, uint32_t>> inc;
  inc.reserve(bedges.size() * 2);
  for (uint32_t g : bedges) {
    inc.push_back({e.lo(g), g});
    inc.push_back({e.hi(g), g});
  }
  std::sort(inc.begin(), inc.end());
  auto first_of = [&](uint32_t v) {
    return std::lower_bound(inc.begin(), inc.end(), std::make_pair(v, 0u)) - inc.begin();
  };
  std::unordered_map<uint32_t, uint8_t> used;
  used.reserve(bedges.size() * 2);
  std::vector<Loop> loops;
  for (uint32_t g0 : bedges) {
    if (used.count(g0)) continue;
    Loop L;
    used[g0] = 1;
    uint32_t start = e.lo(g0), cur = e.hi(g0);
    L.verts.push_back(start);
    L.groups.push_back(g0);
    while (cur != start) {
      uint32_t next = kNone;
      for (auto i = size_t(first_of(cur)); i < inc.size() && inc[i].first == cur; ++i)
        if (!used.count(inc[i].second)) { next = inc[i].second; break; }
      if (next == kNone) { L.closed = false; break; }
      used[next] = 1;
      L.verts.push_back(cur);
      L.groups.push_back(next);
      cur = e.lo(next) == cur ? e.hi(next) : e.lo(next);
    }
    if (!L.closed) L.verts.push_back(cur);  // a chain: one more vertex than edges
    loops.push_back(std::move(L));
  }
  return loops;
}

UnionFind corner_fans(const std::vector<Tri>& tris, const EdgeTable& e) {
  UnionFind uf(tris.size() * 3);
  for (size_t g = 0; g < e.groups(); ++g) {
    if (e.size(g) != 2) continue;
    const EdgeRec& r1 = e.recs[e.start[g]];
    const EdgeRec& r2 = e.recs[e.start[g] + 1];
    for (int s = 0; s < 2; ++s) {
      uint32_t c1 = 3 * r1.tri + (r1.k + uint32_t(s)) % 3;
      uint32_t v = tris[r1.tri][(r1.k + uint32_t(s)) % 3];
      uint32_t c2 = 3 * r2.tri + (tris[r2.tri][0] == v ? 0u : (tris[r2.tri][1] == v ? 1u : 2u));
      uf.unite(c1, c2);
    }
  }
  return uf;
}

// Faces are bucketed by their smallest vertex (a stable counting sort), then each bucket
// is sorted by the other two.
std::vector<uint8_t> find_duplicates(const std::vector<Tri>& tris, const std::vector<uint8_t>& active, size_t nverts) {
  std::vector<uint32_t> off(nverts + 1, 0);
  for (uint32_t t = 0; t < tris.size(); ++t)
    if (active[t]) ++off[size_t(std::min(tris[t][0], std::min(tris[t][1], tris[t][2]))) + 1];
  for (size_t v = 0; v < nverts; ++v) off[v + 1] += off[v];
  struct Rec {
    uint64_t key;  // (middle << 32) | largest vertex
    uint32_t t;
  };
  std::vector<Rec> recs(off[nverts]);
  {
    std::vector<uint32_t> fill(off.begin(), off.end() - 1);
    for (uint32_t t = 0; t < tris.size(); ++t) {
      if (!active[t]) continue;
      const auto k = sorted3(tris[t]);
      recs[fill[k[0]]++] = {uint64_t(k[1]) << 32 | k[2], t};
    }
  }
  std::vector<uint8_t> dup(tris.size(), 0);
  auto by_key = [](const Rec& x, const Rec& y) { return x.key < y.key; };
  for (size_t v = 0; v < nverts; ++v) {
    Rec* b = recs.data() + off[v];
    Rec* en = recs.data() + off[v + 1];
    if (en - b <= 1) continue;
    std::stable_sort(b, en, by_key);  // stable: the first of a group is the earliest face
    for (Rec* i = b; i < en;) {
      Rec* j = i + 1;
      for (; j < en && j->key == i->key; ++j) dup[j->t] = same_orientation(tris[j->t], tris[i->t]) ? 1 : 2;
      i = j;
    }
  }
  return dup;
}

}  // namespace visgate::mesh
