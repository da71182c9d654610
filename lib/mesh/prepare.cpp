// Mesh preparation (paper 000 section 4.2); see prepare.h.
#include "lib/mesh/prepare.h"

#include <algorithm>
#include <numeric>
#include <string>
#include <unordered_map>

namespace visgate::mesh {

namespace {

struct PosKey {
  uint32_t x, y, z;
  bool operator==(const PosKey& o) const { return x == o.x && y == o.y && z == o.z; }
  bool operator<(const PosKey& o) const { return x != o.x ? x < o.x : y != o.y ? y < o.y : z < o.z; }
};
struct PosHash {  // validate()
  size_t operator()(const PosKey& k) const {
    uint64_t h = (uint64_t(k.x) * 0x9E3779B97F4A7C15ull) ^ (uint64_t(k.y) * 0xC2B2AE3D27D4EB4Full) ^
                 (uint64_t(k.z) * 0x165667B19E3779F9ull);
    return size_t(h ^ (h >> 29));
  }
};

}  // namespace

// Equal positions (canonical bits: -0 and +0 are one) get one index, numbered in order of
// first use by the triangles. By sorting the used vertices on (position, first use)
// rather than a hash map of positions: the map allocated a node per vertex, 7% of
// fuzz_iss's allocations under ASan (2026-12-03), and the numbering is the same.
size_t weld_vertices(const TriangleSoup& in, std::vector<Vec3f>& pos, std::vector<std::array<uint32_t, 3>>& tris) {
  // The used vertices in order of first use: rank r is vertex first[r].
  std::vector<int64_t> remap(in.vertices.size(), -1);
  std::vector<uint32_t> first;
  first.reserve(in.vertices.size());
  for (const auto& t : in.triangles)
    for (uint32_t old : t)
      if (remap[old] < 0) {
        remap[old] = int64_t(first.size());
        first.push_back(old);
      }
  const size_t used = first.size();
  std::vector<PosKey> key(used);
  for (size_t r = 0; r < used; ++r) {
    const Vec3f& v = in.vertices[first[r]];
    key[r] = PosKey{canonical_bits(v.x), canonical_bits(v.y), canonical_bits(v.z)};
  }
  std::vector<uint32_t> by_pos(used);
  std::iota(by_pos.begin(), by_pos.end(), 0u);
  std::sort(by_pos.begin(), by_pos.end(), [&](uint32_t a, uint32_t b) { return key[a] < key[b] || (key[a] == key[b] && a < b); });
  // rep[r]: the first-used rank of r's position; new indices follow first use.
  std::vector<uint32_t> rep(used), id(used);
  for (size_t k = 0; k < used; ++k)
    rep[by_pos[k]] = k > 0 && key[by_pos[k]] == key[by_pos[k - 1]] ? rep[by_pos[k - 1]] : by_pos[k];
  pos.clear();
  for (size_t r = 0; r < used; ++r) {
    if (rep[r] == r) {
      id[r] = uint32_t(pos.size());
      pos.push_back(in.vertices[first[r]]);
    } else {
      id[r] = id[rep[r]];
    }
  }
  tris.resize(in.triangles.size());
  for (size_t t = 0; t < in.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) tris[t][k] = id[size_t(remap[in.triangles[t][k]])];
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

void compute_neighbors_and_labels(PreparedMesh& m, PrepareCounts& counts) {
  // One entry per (triangle, edge): undirected key, then sort to group incidences.
  struct Inc {
    uint64_t key;
    uint32_t tri;
    uint8_t k;
    bool forward;  // traverses the edge from the smaller to the larger vertex index
  };
  std::vector<Inc> inc;
  inc.reserve(m.triangles.size() * 3);
  for (uint32_t t = 0; t < m.triangles.size(); ++t) {
    auto& tri = m.triangles[t];
    tri.neighbors = {-1, -1, -1};
    for (uint8_t k = 0; k < 3; ++k) {
      uint32_t a = tri.v[k], b = tri.v[(k + 1) % 3];
      uint64_t key = (uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      inc.push_back({key, t, k, a < b});
    }
  }
  std::sort(inc.begin(), inc.end(), [](const Inc& x, const Inc& y) {
    return x.key != y.key ? x.key < y.key : (x.tri != y.tri ? x.tri < y.tri : x.k < y.k);
  });
  m.is_double_edge.clear();
  for (size_t i = 0; i < inc.size();) {
    size_t j = i;
    while (j < inc.size() && inc[j].key == inc[i].key) ++j;
    size_t n = j - i;
    if (n == 2 && inc[i].forward != inc[i + 1].forward) {
      uint32_t label = uint32_t(m.is_double_edge.size());
      m.is_double_edge.push_back(1);
      auto& ta = m.triangles[inc[i].tri];
      auto& tb = m.triangles[inc[i + 1].tri];
      ta.edge_labels[inc[i].k] = label;
      tb.edge_labels[inc[i + 1].k] = label;
      ta.neighbors[inc[i].k] = int32_t(inc[i + 1].tri);
      tb.neighbors[inc[i + 1].k] = int32_t(inc[i].tri);
      ++counts.double_edges;
    } else {
      if (n == 2) ++counts.inconsistent_joins;
      if (n >= 3) ++counts.nonmanifold_edges;
      for (size_t q = i; q < j; ++q) {
        m.triangles[inc[q].tri].edge_labels[inc[q].k] = uint32_t(m.is_double_edge.size());
        m.is_double_edge.push_back(0);
        ++counts.single_edges;
      }
    }
    i = j;
  }
}

PreparedMesh prepare_mesh(const TriangleSoup& soup, PrepareCounts* counts_out) {
  PrepareCounts counts;
  counts.input_vertices = soup.vertices.size();
  counts.input_triangles = soup.triangles.size();
  PreparedMesh m;
  std::vector<std::array<uint32_t, 3>> tris;
  counts.welded_vertices = weld_vertices(soup, m.vertex_pos, tris);
  std::vector<uint32_t> source(tris.size());
  for (uint32_t t = 0; t < source.size(); ++t) source[t] = t;
  counts.degenerate_removed = remove_degenerate(tris, source);
  m.triangles.resize(tris.size());
  for (size_t t = 0; t < tris.size(); ++t) {
    m.triangles[t].v = tris[t];
    m.triangles[t].source = source[t];
  }
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
