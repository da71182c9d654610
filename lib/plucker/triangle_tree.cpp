// Triangle hierarchy for occluder selection; see triangle_tree.h.
#include "lib/plucker/triangle_tree.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <unordered_map>

#include "lib/geom/check.h"
#include "lib/geom/predicates.h"
#include "lib/plucker/exact_orient.h"

namespace visgate::plucker {

namespace {
constexpr uint32_t kLeafSize = 4;
}

TriangleTree::TriangleTree(const TriangleSoup& mesh) {
  const size_t n = mesh.size();
  index_.resize(n);
  std::vector<AABB> tri_box(n);
  std::vector<Vec3f> centre(n);
  for (size_t t = 0; t < n; ++t) {
    index_[t] = uint32_t(t);
    AABB b;
    for (int k = 0; k < 3; ++k) b.extend(mesh.corner(t, k));
    tri_box[t] = b;
    centre[t] = (b.lo + b.hi) * 0.5f;
  }
  if (n == 0) return;
  nodes_.reserve(2 * (n / kLeafSize + 1));
  // Median split on the longest axis of the centres, built with an explicit stack of
  // (node, first, count).
  struct Item {
    uint32_t node, first, count;
  };
  std::vector<Item> stack;
  nodes_.emplace_back();
  stack.push_back({0, 0, uint32_t(n)});
  while (!stack.empty()) {
    Item it = stack.back();
    stack.pop_back();
    AABB box, cbox;
    for (uint32_t k = it.first; k < it.first + it.count; ++k) {
      box.extend(tri_box[index_[k]]);
      cbox.extend(centre[index_[k]]);
    }
    nodes_[it.node].box = box;
    if (it.count <= kLeafSize) {
      nodes_[it.node].first = it.first;
      nodes_[it.node].count = it.count;
      continue;
    }
    int axis = max_axis(cbox.extent());
    uint32_t half = it.count / 2;
    auto b = index_.begin() + it.first;
    std::nth_element(b, b + half, b + it.count, [&](uint32_t x, uint32_t y) {
      float cx = centre[x][axis], cy = centre[y][axis];
      return cx < cy || (cx == cy && x < y);
    });
    uint32_t left = uint32_t(nodes_.size());
    nodes_.emplace_back();
    uint32_t right = uint32_t(nodes_.size());
    nodes_.emplace_back();
    // Inner node: first = right child, the left child is right - 1.
    nodes_[it.node].first = right;
    nodes_[it.node].count = 0;
    stack.push_back({right, it.first + half, it.count - half});
    stack.push_back({left, it.first, half});
  }
  find_quads(mesh);
}

void TriangleTree::find_quads(const TriangleSoup& mesh) {
  const size_t n = mesh.size();
  // Vertex positions to ids: equal positions (compared as values, so -0 == +0) share one.
  struct KeyHash {
    size_t operator()(const std::array<float, 3>& k) const {
      size_t h = 0;
      for (float f : k) h = h * 0x9E3779B97F4A7C15ull + std::hash<float>()(f);
      return h;
    }
  };
  std::unordered_map<std::array<float, 3>, uint32_t, KeyHash> ids;
  std::vector<std::array<uint32_t, 3>> tv(n);
  for (size_t t = 0; t < n; ++t)
    for (int k = 0; k < 3; ++k) {
      const Vec3f& v = mesh.corner(t, k);
      tv[t][size_t(k)] = ids.emplace(std::array<float, 3>{v.x + 0.0f, v.y + 0.0f, v.z + 0.0f}, uint32_t(ids.size()))
                             .first->second;
    }
  // Edges (lower id, higher id, triangle, corner of the edge's start), sorted: a run of
  // exactly two entries is an edge shared by two triangles (manifold).
  struct Edge {
    uint32_t lo, hi, t;
    uint8_t k;
    bool operator<(const Edge& o) const { return lo != o.lo ? lo < o.lo : hi != o.hi ? hi < o.hi : t < o.t; }
  };
  std::vector<Edge> edges;
  edges.reserve(3 * n);
  for (size_t t = 0; t < n; ++t) {
    const auto& c = tv[t];
    if (c[0] == c[1] || c[1] == c[2] || c[0] == c[2]) continue;
    for (int k = 0; k < 3; ++k) {
      uint32_t a = c[size_t(k)], b = c[size_t((k + 1) % 3)];
      edges.push_back({std::min(a, b), std::max(a, b), uint32_t(t), uint8_t(k)});
    }
  }
  std::sort(edges.begin(), edges.end());
  // For each triangle and corner k: the other triangle on edge (k, k + 1) and its corner.
  constexpr uint32_t kNone = ~uint32_t(0);
  std::vector<std::array<uint32_t, 3>> other(n, {kNone, kNone, kNone});
  for (size_t i = 0; i < edges.size();) {
    size_t j = i;
    while (j < edges.size() && edges[j].lo == edges[i].lo && edges[j].hi == edges[i].hi) ++j;
    if (j - i == 2) {
      other[edges[i].t][edges[i].k] = edges[i + 1].t;
      other[edges[i + 1].t][edges[i + 1].k] = edges[i].t;
    }
    i = j;
  }
  std::vector<Quad> quads(n);
  bool any = false;
  for (uint32_t t = 0; t < n; ++t) {
    if (quads[t].partner >= 0) continue;
    for (int e = 0; e < 3; ++e) {
      const uint32_t p = other[t][size_t(e)];
      if (p == kNone || p == t || quads[p].partner >= 0) continue;
      // t = (a, b, c) with the shared edge a -> b, d the partner's third corner.
      const uint32_t ia = tv[t][size_t(e)], ib = tv[t][size_t((e + 1) % 3)];
      int apex = -1;
      for (int k = 0; k < 3; ++k)
        if (tv[p][size_t(k)] != ia && tv[p][size_t(k)] != ib) apex = k;
      if (apex < 0) continue;
      const Vec3f &a = mesh.corner(t, e), &b = mesh.corner(t, (e + 1) % 3), &c = mesh.corner(t, (e + 2) % 3);
      const Vec3f& d = mesh.corner(p, apex);
      if (orient3d_exact_sign(a, b, c, d) != 0) continue;
      // The dominant axis of t's normal is dropped; t's projected orientation is then
      // nonzero unless t is degenerate.
      const Vec3d nn = cross(to_double(b) - to_double(a), to_double(c) - to_double(a));
      const int w = std::abs(nn.x) >= std::abs(nn.y) ? (std::abs(nn.x) >= std::abs(nn.z) ? 0 : 2)
                                                     : (std::abs(nn.y) >= std::abs(nn.z) ? 1 : 2);
      const int u = (w + 1) % 3, v = (w + 2) % 3;
      auto o2 = [&](const Vec3f& x, const Vec3f& y, const Vec3f& z) {
        return orient2d_exact_sign(x[u], x[v], y[u], y[v], z[u], z[v]);
      };
      const int s = o2(a, b, c);
      // Strictly convex a, d, b, c: d strictly across a -> b, convex at b and at a.
      if (s == 0 || o2(a, b, d) != -s || o2(d, b, c) != s || o2(c, a, d) != s) continue;
      quads[t] = {int32_t(p), uint8_t(e), uint8_t(apex), true};
      quads[p] = {int32_t(t), uint8_t(e), uint8_t(apex), false};
      any = true;
      break;
    }
  }
  if (any) quads_ = std::move(quads);
}

void TriangleTree::quad(const TriangleSoup& mesh, uint32_t t, Vec3f out[4]) const {
  const Quad& q = quads_[t];
  const uint32_t base = q.base ? t : uint32_t(q.partner), other = q.base ? uint32_t(q.partner) : t;
  const int e = q.edge;
  out[0] = mesh.corner(base, e);
  out[1] = mesh.corner(other, q.apex);
  out[2] = mesh.corner(base, (e + 1) % 3);
  out[3] = mesh.corner(base, (e + 2) % 3);
}

void TriangleTree::candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out) const {
  out.clear();
  if (nodes_.empty()) return;
  uint32_t stack[64];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Node& nd = nodes_[stack[--top]];
    if (shaft.culls_box(nd.box.lo - origin, nd.box.hi - origin)) continue;
    if (nd.count > 0) {
      out.insert(out.end(), index_.begin() + nd.first, index_.begin() + nd.first + nd.count);
      continue;
    }
    VG_CHECK(top + 2 <= 64);  // median splits: depth <= log2(n) + 1
    stack[top++] = nd.first;      // right
    stack[top++] = nd.first - 1;  // left
  }
  std::sort(out.begin(), out.end());
}

}  // namespace visgate::plucker
