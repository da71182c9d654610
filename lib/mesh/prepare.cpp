// Mesh preparation (paper 000 section 4.2); see prepare.h.
#include "lib/mesh/prepare.h"

#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_map>

namespace visgate::mesh {

namespace {

struct PosKey {
  uint32_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
PosKey pos_key(const Vec3f& v) { return PosKey{canonical_bits(v.x), canonical_bits(v.y), canonical_bits(v.z)}; }
struct PosHash {
  size_t operator()(const PosKey& k) const {
    uint64_t h = ((uint64_t(k.x) << 32) | k.y) * 0x9E3779B97F4A7C15ull ^ uint64_t(k.z) * 0xC2B2AE3D27D4EB4Full;
    h ^= h >> 32;
    h *= 0x94D049BB133111EBull;
    return size_t(h ^ (h >> 29));
  }
};

constexpr uint32_t kNone = UINT32_MAX;

// Welded index of every input vertex (kNone when no triangle uses it) and the welded
// positions. Vertices are visited in order of first use by the triangles; a position
// gets the next index when it is first met, so the numbering is the first use of each
// position (Figure 4.1). Positions are found in an open-addressing table of welded
// indices (linear probing, load <= 1/2, one allocation): expected O(1) per used vertex.
// Returns the number of used input vertices.
size_t weld_ids(const TriangleSoup& in, std::vector<Vec3f>& pos, std::vector<uint32_t>& id) {
  id.assign(in.vertices.size(), kNone);
  pos.clear();
  const size_t max_used = std::min(in.vertices.size(), in.triangles.size() * 3);
  int bits = 4;
  while ((size_t(1) << bits) < 2 * max_used) ++bits;
  const size_t mask = (size_t(1) << bits) - 1;
  std::vector<uint32_t> slot(mask + 1, kNone);  // welded index, or kNone for empty
  size_t used = 0;
  for (const auto& t : in.triangles)
    for (uint32_t old : t) {
      if (id[old] != kNone) continue;
      ++used;
      const Vec3f& v = in.vertices[old];
      const PosKey key = pos_key(v);
      size_t h = PosHash{}(key) & mask;
      while (slot[h] != kNone && !(pos_key(pos[slot[h]]) == key)) h = (h + 1) & mask;
      if (slot[h] == kNone) {
        slot[h] = uint32_t(pos.size());
        pos.push_back(v);
      }
      id[old] = slot[h];
    }
  return used;
}

}  // namespace

size_t weld_vertices(const TriangleSoup& in, std::vector<Vec3f>& pos, std::vector<std::array<uint32_t, 3>>& tris) {
  std::vector<uint32_t> id;
  const size_t used = weld_ids(in, pos, id);
  tris.resize(in.triangles.size());
  for (size_t t = 0; t < in.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) tris[t][k] = id[in.triangles[t][k]];
  return used - pos.size();
}

size_t remove_degenerate(std::vector<std::array<uint32_t, 3>>& tris, std::vector<uint32_t>& source) {
  size_t w = 0;
  for (size_t t = 0; t < tris.size(); ++t) {
    const auto& v = tris[t];
    if (v[0] == v[1] || v[1] == v[2] || v[2] == v[0]) continue;
    tris[w] = tris[t];
    source[w] = source[t];
    ++w;
  }
  size_t removed = tris.size() - w;
  tris.resize(w);
  source.resize(w);
  return removed;
}

// Labels follow the order of the undirected edges (smaller vertex, larger vertex), and
// within an edge the order of (triangle, k). The incidences are bucketed by their
// smaller vertex (a counting sort: linear), each bucket then sorted on (larger vertex,
// 3 * triangle + k), all distinct, so any sort gives that one order; buckets hold about
// six incidences on a manifold mesh.
void compute_neighbors_and_labels(PreparedMesh& m, PrepareCounts& counts) {
  const size_t n = m.triangles.size();
  if (n > UINT32_MAX / 3) throw std::length_error("prepare_mesh: more than 2^32 / 3 triangles");
  size_t nv = 0;
  for (auto& tri : m.triangles) {
    tri.neighbors = {-1, -1, -1};
    nv = std::max(nv, size_t(std::max({tri.v[0], tri.v[1], tri.v[2]})) + 1);
  }
  // end[a]: after the scatter, one past the last incidence whose smaller vertex is a.
  std::vector<uint32_t> end(nv + 1, 0);
  for (const auto& tri : m.triangles)
    for (int k = 0; k < 3; ++k) ++end[size_t(std::min(tri.v[k], tri.v[(k + 1) % 3])) + 1];
  for (size_t a = 0; a < nv; ++a) end[a + 1] += end[a];
  // Incidence: larger vertex in the high half, 3 * triangle + k in the low half.
  std::vector<uint64_t> inc(3 * n);
  for (uint32_t t = 0; t < n; ++t) {
    const auto& v = m.triangles[t].v;
    for (uint32_t k = 0; k < 3; ++k) {
      const uint32_t a = v[k], b = v[(k + 1) % 3];
      inc[end[std::min(a, b)]++] = (uint64_t(std::max(a, b)) << 32) | (3 * t + k);
    }
  }
  // At most one label per incidence: written through a cursor, trimmed at the end.
  m.is_double_edge.assign(3 * n, 0);
  uint8_t* const flags = m.is_double_edge.data();
  uint32_t labels = 0;
  auto use = [&](uint64_t e, uint32_t& t, uint32_t& k) {
    t = uint32_t(e) / 3;
    k = uint32_t(e) % 3;
  };
  for (size_t a = 0, begin = 0; a < nv; begin = end[a], ++a) {
    uint64_t* first = inc.data() + begin;
    uint64_t* last = inc.data() + end[a];
    if (last - first <= 16) {  // insertion sort: the buckets are small
      for (uint64_t* p = first + 1; p < last; ++p)
        for (uint64_t* q = p; q > first && q[-1] > q[0]; --q) std::swap(q[-1], q[0]);
    } else {
      std::sort(first, last);
    }
    for (uint64_t* i = first; i < last;) {
      uint64_t* j = i + 1;
      while (j < last && (*j >> 32) == (*i >> 32)) ++j;
      const size_t count = size_t(j - i);
      uint32_t t0, k0, t1, k1;
      use(i[0], t0, k0);
      if (count == 2) use(i[1], t1, k1);
      // Neighbours iff two incidences traverse the edge in opposite directions; forward:
      // from the smaller vertex a to the larger b (never on a degenerate edge, b == a).
      const uint32_t b = uint32_t(*i >> 32);
      auto forward = [&](uint32_t t, uint32_t k) { return b != a && m.triangles[t].v[k] == a; };
      if (count == 2 && forward(t0, k0) != forward(t1, k1)) {
        const uint32_t label = labels++;
        flags[label] = 1;
        auto& ta = m.triangles[t0];
        auto& tb = m.triangles[t1];
        ta.edge_labels[k0] = label;
        tb.edge_labels[k1] = label;
        ta.neighbors[k0] = int32_t(t1);
        tb.neighbors[k1] = int32_t(t0);
        ++counts.double_edges;
      } else {
        if (count == 2) ++counts.inconsistent_joins;
        if (count >= 3) ++counts.nonmanifold_edges;
        for (uint64_t* q = i; q < j; ++q) {
          uint32_t t, k;
          use(*q, t, k);
          m.triangles[t].edge_labels[k] = labels++;
          ++counts.single_edges;
        }
      }
      i = j;
    }
  }
  m.is_double_edge.resize(labels);
}

PreparedMesh prepare_mesh(const TriangleSoup& soup, PrepareCounts* counts_out) {
  PrepareCounts counts;
  counts.input_vertices = soup.vertices.size();
  counts.input_triangles = soup.triangles.size();
  PreparedMesh m;
  std::vector<uint32_t> id;
  counts.welded_vertices = weld_ids(soup, m.vertex_pos, id);
  counts.welded_vertices -= m.vertex_pos.size();
  // Weld, then drop triangles with two equal welded vertices (section 4.2's order).
  m.triangles.reserve(soup.triangles.size());
  for (size_t t = 0; t < soup.triangles.size(); ++t) {
    PreparedTriangle pt;
    for (int k = 0; k < 3; ++k) pt.v[k] = id[soup.triangles[t][k]];
    if (pt.v[0] == pt.v[1] || pt.v[1] == pt.v[2] || pt.v[2] == pt.v[0]) continue;
    pt.source = uint32_t(t);
    m.triangles.push_back(pt);
  }
  counts.degenerate_removed = soup.triangles.size() - m.triangles.size();
  compute_neighbors_and_labels(m, counts);
  if (counts_out) *counts_out = counts;
  return m;
}

std::string validate(const PreparedMesh& m) {
  auto tri_name = [](size_t t) { return "triangle " + std::to_string(t); };
  std::vector<int> label_uses(m.edge_count(), 0);
  {
    std::unordered_map<PosKey, size_t, PosHash> seen;
    for (size_t i = 0; i < m.vertex_pos.size(); ++i) {
      const Vec3f& v = m.vertex_pos[i];
      PosKey key{canonical_bits(v.x), canonical_bits(v.y), canonical_bits(v.z)};
      if (!seen.emplace(key, i).second) return "vertices " + std::to_string(seen[key]) + " and " + std::to_string(i) + " are equal";
    }
  }
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tr = m.triangles[t];
    for (int k = 0; k < 3; ++k)
      if (tr.v[k] >= m.vertex_pos.size()) return tri_name(t) + ": vertex index out of range";
    if (tr.v[0] == tr.v[1] || tr.v[1] == tr.v[2] || tr.v[0] == tr.v[2]) return tri_name(t) + ": repeated vertex";
    for (int k = 0; k < 3; ++k) {
      uint32_t label = tr.edge_labels[k];
      if (label >= m.edge_count()) return tri_name(t) + ": edge label out of range";
      ++label_uses[label];
      int32_t nb = tr.neighbors[k];
      if (nb < 0) {
        if (m.is_double_edge[label]) return tri_name(t) + ": double edge without neighbour";
        continue;
      }
      if (size_t(nb) >= m.triangles.size()) return tri_name(t) + ": neighbour out of range";
      if (!m.is_double_edge[label]) return tri_name(t) + ": neighbour across a single edge";
      const auto& o = m.triangles[size_t(nb)];
      uint32_t a = tr.v[k], b = tr.v[(k + 1) % 3];
      bool found = false;
      for (int q = 0; q < 3; ++q)
        if (o.v[q] == b && o.v[(q + 1) % 3] == a) {
          found = true;
          if (o.neighbors[q] != int32_t(t)) return tri_name(t) + ": neighbour relation not symmetric";
          if (o.edge_labels[q] != label) return tri_name(t) + ": neighbours disagree on the edge label";
        }
      if (!found) return tri_name(t) + ": neighbour does not traverse the edge in the opposite direction";
    }
  }
  for (size_t l = 0; l < label_uses.size(); ++l) {
    int want = m.is_double_edge[l] ? 2 : 1;
    if (label_uses[l] != want) return "edge label " + std::to_string(l) + " used " + std::to_string(label_uses[l]) + " times";
  }
  return {};
}

}  // namespace visgate::mesh
