// Umbra culling by planar convex occluders (see occluders.h).
#include "lib/ssv/occluders.h"

#include <algorithm>
#include <cmath>

#include "lib/geom/predicates.h"

namespace visgate::ssv {

double PlanarOccluder::inside(const Vec3d& x) const {
  double m = dot(edge_n[0], x) - edge_d[0];
  for (int k = 1; k < n; ++k) m = std::min(m, dot(edge_n[size_t(k)], x) - edge_d[size_t(k)]);
  return m;
}

namespace {

// The occluder with vertices v[0..n) (convex, counter-clockwise about `unit`), or false
// when some vertex is not strictly inside the other edges by 1e-9 of the size (a
// degenerate or non-convex polygon is not used: an occluder only speeds things up).
bool make_occluder(const Vec3d* v, int n, const Vec3d& unit, PlanarOccluder& o) {
  o.n = n;
  o.normal = unit;
  double size = 0.0;
  for (int k = 0; k < n; ++k) {
    o.v[size_t(k)] = v[k];
    size = std::max(size, length(v[(k + 1) % n] - v[k]));
  }
  o.offset = dot(unit, v[0]);
  for (int k = 0; k < n; ++k) {
    const Vec3d e = v[(k + 1) % n] - v[k];
    Vec3d en = cross(unit, e);  // inward for a counter-clockwise polygon
    const double len = length(en);
    if (!(len > 0.0)) return false;
    en = en / len;
    o.edge_n[size_t(k)] = en;
    o.edge_d[size_t(k)] = dot(en, v[k]);
    for (int j = 0; j < n; ++j)
      if (j != k && j != (k + 1) % n && !(dot(en, v[j]) - o.edge_d[size_t(k)] > 1e-9 * size)) return false;
  }
  o.box = AABBd();
  for (int k = 0; k < n; ++k) o.box.extend(v[k]);
  o.area = 0.0;
  for (int k = 1; k + 1 < n; ++k) o.area += 0.5 * length(cross(v[k] - v[0], v[k + 1] - v[0]));
  return true;
}

}  // namespace

std::vector<PlanarOccluder> planar_occluders(const mesh::PreparedMesh& m, const std::vector<Edge>& edges,
                                             PlaneSource planes, size_t max_count, double min_area,
                                             const std::vector<uint32_t>* large) {
  std::vector<PlanarOccluder> out;
  if (max_count == 0) return out;
  // Candidates of at least min_area: triangle t as (area, t), the union of the two exactly
  // coplanar triangles of double edge e as (area, T + e). Only the largest max_count are
  // built (linear selection, then a sort of those).
  const size_t T = m.triangles.size();
  auto tri_area = [&](size_t t) { return 0.5 * std::sqrt(planes[t].nn); };
  auto area_of = [](double nn) { return 0.5 * std::sqrt(nn); };
  auto third = [&](int32_t t, const Edge& e) {
    for (uint32_t w : m.triangles[size_t(t)].v)
      if (w != e.a && w != e.b) return w;
    return e.a;
  };
  // Squared prefilters with a relative slack of 1e-6 (far above the rounding of the
  // square roots): what they drop is surely below min_area, the rest is decided by the
  // exact expressions (a dense mesh's triangles are mostly far below a light's area).
  const double nn_tri = 4.0 * min_area * min_area * (1.0 - 1e-6), nn_pair = 0.25 * nn_tri;
  std::vector<std::pair<double, size_t>> cand;
  // Per triangle nn >= nn_pair, for the pairs' prefilter: each plane is read (or
  // computed) once here, and only the pairs that pass read theirs again. A triangle whose
  // float bound |b - a|^2 |c - a|^2 >= nn (with a relative slack of 1e-4, far above the
  // float rounding) is below nn_pair has no plane computed at all: on a dense mesh
  // nearly every triangle (the plane costs several times the bound).
  // With `large`, only the triangles of those edges can pass the prefilter below, and
  // only their edges can join two of them (each edge's leaf box holds both its triangles):
  // the candidates are the same, found in another order (the selection below orders them
  // totally).
  std::vector<bool> pair_size(T), seen(large ? T : 0);
  auto triangle = [&](size_t t) {
    if (nn_pair > 0.0) {
      const Vec3f &a = m.corner(t, 0), e1 = m.corner(t, 1) - a, e2 = m.corner(t, 2) - a;
      const double bound = double(dot(e1, e1)) * double(dot(e2, e2)) * (1.0 + 1e-4);
      if (bound < nn_pair) return;
    }
    const double nn = planes[t].nn;
    pair_size[t] = nn >= nn_pair;
    if (nn > 0.0 && nn >= nn_tri && area_of(nn) >= min_area) cand.emplace_back(area_of(nn), t);
  };
  if (large) {
    for (uint32_t i : *large)
      for (int32_t t : {edges[i].t1, edges[i].t2})
        if (t >= 0 && !seen[size_t(t)]) {
          seen[size_t(t)] = true;
          triangle(size_t(t));
        }
  } else {
    for (size_t t = 0; t < T; ++t) triangle(t);
  }
  const size_t n_edges = large ? large->size() : edges.size();
  for (size_t k = 0; k < n_edges; ++k) {
    const size_t i = large ? (*large)[k] : k;
    const Edge& e = edges[i];
    if (e.t2 < 0) continue;
    if (!pair_size[size_t(e.t1)] && !pair_size[size_t(e.t2)]) continue;  // both below min_area / 2
    if (!(planes[size_t(e.t1)].nn > 0.0)) continue;
    const double area = tri_area(size_t(e.t1)) + tri_area(size_t(e.t2));
    if (!(area >= min_area)) continue;
    const uint32_t c = third(e.t1, e), d = third(e.t2, e);
    if (c == e.a || d == e.a || c == d) continue;
    if (orient3d_exact(m.vertex_pos[e.a], m.vertex_pos[e.b], m.vertex_pos[c], m.vertex_pos[d]) != Sign::Zero)
      continue;
    cand.emplace_back(area, T + i);
  }
  auto larger = [](const std::pair<double, size_t>& a, const std::pair<double, size_t>& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  };
  const size_t keep = std::min(cand.size(), max_count);
  std::nth_element(cand.begin(), cand.begin() + long(keep), cand.end(), larger);
  cand.resize(keep);
  std::sort(cand.begin(), cand.end(), larger);
  auto pos = [&](uint32_t i) { return to_double(m.vertex_pos[i]); };
  for (const auto& [area, id] : cand) {
    PlanarOccluder o;
    if (id < T) {
      const auto& tv = m.triangles[id].v;
      const Vec3d v[3] = {pos(tv[0]), pos(tv[1]), pos(tv[2])};
      if (make_occluder(v, 3, planes[id].unit(), o)) out.push_back(o);
      continue;
    }
    // t1 winds a -> b -> c, its neighbour t2 winds b -> a -> d: the union is the polygon
    // a, d, b, c in t1's orientation (a non-convex one is rejected by make_occluder).
    const Edge& e = edges[id - T];
    const Vec3d v[4] = {pos(e.a), pos(third(e.t2, e)), pos(e.b), pos(third(e.t1, e))};
    if (make_occluder(v, 4, planes[size_t(e.t1)].unit(), o)) out.push_back(o);
  }
  return out;
}

namespace {

// Values per light point: its signed distance from the plane, then its inside value for
// each edge (the affine functions of PlanarOccluder).
constexpr size_t kLightValues = 5;

// The light points' side of the occluder's plane: +1 when every one is at least `margin`
// below it (the box must then be above), -1 when above, 0 otherwise; lv their values.
int light_side(const PlanarOccluder& o, const std::vector<Vec3d>& light, double margin, double* lv) {
  double lmin = INFINITY, lmax = -INFINITY;
  for (size_t j = 0; j < light.size(); ++j) {
    double* v = lv + j * kLightValues;
    v[0] = o.eval(light[j]);
    for (int k = 0; k < o.n; ++k) v[1 + k] = dot(o.edge_n[size_t(k)], light[j]) - o.edge_d[size_t(k)];
    lmin = std::min(lmin, v[0]);
    lmax = std::max(lmax, v[0]);
  }
  if (lmax <= -margin) return 1;
  if (lmin >= margin) return -1;
  return 0;
}

// occluder_blocks_shaft with the light's side and values known: +1 when the occluder
// blocks the box's shaft, -1 when it cannot block the shaft of any box inside this one, 0
// otherwise. -1 when the box lies on the light's side of the plane (so does every box
// inside it), or when every crossing point lies less than margin inside one edge of the
// occluder: the crossings of a box inside lie in the hull of these (the plane separates
// it too), so none of them is at least margin inside that edge. The functions are affine,
// so a crossing x = b + (l - b) t has the values g(b) + (g(l) - g(b)) t.
int classify(const PlanarOccluder& o, int side, const double* lv, const AABBd& box, size_t nl, double margin) {
  double bmin = -o.offset, bmax = -o.offset;
  for (int k = 0; k < 3; ++k) {
    const double a = o.normal[k] * box.lo[k], b = o.normal[k] * box.hi[k];
    bmin += std::min(a, b);
    bmax += std::max(a, b);
  }
  // The box's extreme values on the light's side of the plane (side * f < 0).
  const double far = side > 0 ? bmin : -bmax, near = side > 0 ? bmax : -bmin;
  if (!(near > -margin)) return -1;  // the whole box at least margin on the light's side
  if (!(far >= margin)) return 0;    // straddles: a box inside may be separated
  // The distinct corners (a flat or point box has fewer).
  int axes = 0;
  for (int k = 0; k < 3; ++k) axes |= box.lo[k] < box.hi[k] ? 1 << k : 0;
  // Per edge of the occluder, the smallest and the largest inside value of a crossing.
  std::array<double, 4> lo{INFINITY, INFINITY, INFINITY, INFINITY}, hi{-INFINITY, -INFINITY, -INFINITY, -INFINITY};
  for (int c = 0; c < 8; ++c) {
    if ((c & ~axes) != 0) continue;
    const Vec3d b(c & 1 ? box.hi.x : box.lo.x, c & 2 ? box.hi.y : box.lo.y, c & 4 ? box.hi.z : box.lo.z);
    const double fb = o.eval(b);
    double gb[4];
    for (int k = 0; k < o.n; ++k) gb[k] = dot(o.edge_n[size_t(k)], b) - o.edge_d[size_t(k)];
    for (size_t j = 0; j < nl; ++j) {
      const double* v = lv + j * kLightValues;
      const double t = fb / (fb - v[0]);
      for (int k = 0; k < o.n; ++k) {
        const double g = gb[k] + (v[1 + k] - gb[k]) * t;
        lo[size_t(k)] = std::min(lo[size_t(k)], g);
        hi[size_t(k)] = std::max(hi[size_t(k)], g);
      }
    }
  }
  bool inside = true, apart = false;
  for (int k = 0; k < o.n; ++k) {
    inside = inside && lo[size_t(k)] >= margin;
    apart = apart || hi[size_t(k)] < margin;
  }
  if (inside) return 1;
  // Every crossing less than margin inside one edge: so is every crossing of a box inside
  // (their hull lies in this one's), and none of those boxes is blocked.
  return apart ? -1 : 0;
}

}  // namespace

bool occluder_blocks_shaft(const PlanarOccluder& o, const AABBd& box, const std::vector<Vec3d>& light,
                           double margin) {
  if (light.empty() || box.empty()) return false;
  std::vector<double> lv(light.size() * kLightValues);
  const int side = light_side(o, light, margin, lv.data());
  return side != 0 && classify(o, side, lv.data(), box, light.size(), margin) > 0;
}

ReceiverTree::ReceiverTree(const std::vector<Vec3d>& points, uint32_t leaf_size) {
  order_.resize(points.size());
  for (size_t i = 0; i < points.size(); ++i) order_[i] = uint32_t(i);
  if (!points.empty()) build(points, 0, uint32_t(points.size()), std::max(leaf_size, 1u));
}

int32_t ReceiverTree::build(const std::vector<Vec3d>& points, uint32_t begin, uint32_t end, uint32_t leaf_size) {
  const int32_t id = int32_t(nodes_.size());
  nodes_.emplace_back();
  AABBd box;
  for (uint32_t k = begin; k < end; ++k) box.extend(points[order_[k]]);
  nodes_[size_t(id)].box = box;
  nodes_[size_t(id)].begin = begin;
  nodes_[size_t(id)].end = end;
  if (end - begin <= leaf_size) return id;
  // Median on the box's longest axis, ties by index: the tree depends on the points only.
  const int axis = box.longest_axis();
  const uint32_t mid = begin + (end - begin) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end, [&](uint32_t a, uint32_t b) {
    const double pa = points[a][axis], pb = points[b][axis];
    return pa < pb || (pa == pb && a < b);
  });
  const int32_t left = build(points, begin, mid, leaf_size);
  const int32_t right = build(points, mid, end, leaf_size);
  nodes_[size_t(id)].left = left;
  nodes_[size_t(id)].right = right;
  return id;
}

namespace {

struct CullWalk {
  const ReceiverTree& tree;
  const std::vector<PlanarOccluder>& occ;
  const std::vector<Vec3d>& light;
  double margin;
  std::vector<uint8_t>& blocked;
  std::vector<int8_t> side;  // per occluder (light_side)
  std::vector<double> lv;    // per occluder, its light points' values (light_side)
  size_t count = 0;

  void walk(int32_t id, std::vector<uint32_t>& cand) {
    const ReceiverTree::Node& nd = tree.nodes()[size_t(id)];
    const size_t nl = light.size();
    std::vector<uint32_t> sub;  // the candidates that may block a box inside this one
    sub.reserve(cand.size());
    for (size_t k = 0; k < cand.size(); ++k) {
      const uint32_t c = cand[k];
      const int r = classify(occ[c], side[c], lv.data() + c * nl * kLightValues, nd.box, nl, margin);
      if (r > 0) {
        // Later siblings try the blocker first.
        std::rotate(cand.begin(), cand.begin() + long(k), cand.begin() + long(k) + 1);
        const auto& ord = tree.order();
        for (uint32_t p = nd.begin; p < nd.end; ++p) blocked[ord[p]] = 1;
        count += nd.end - nd.begin;
        return;
      }
      if (r == 0) sub.push_back(c);
    }
    if (nd.left < 0 || sub.empty()) return;
    walk(nd.left, sub);
    walk(nd.right, sub);
  }
};

}  // namespace

size_t cull_occluded_receivers(const ReceiverTree& tree, const std::vector<PlanarOccluder>& occluders,
                               const std::vector<Vec3d>& light, double margin, std::vector<uint8_t>& blocked) {
  if (tree.nodes().empty() || occluders.empty() || light.empty()) return 0;
  CullWalk w{tree, occluders, light, margin, blocked, {}, {}, 0};
  w.side.assign(occluders.size(), 0);
  w.lv.assign(occluders.size() * light.size() * kLightValues, 0.0);
  std::vector<uint32_t> cand;
  for (uint32_t k = 0; k < occluders.size(); ++k) {
    w.side[k] = int8_t(light_side(occluders[k], light, margin, w.lv.data() + size_t(k) * light.size() * kLightValues));
    if (w.side[k] != 0) cand.push_back(k);
  }
  if (!cand.empty()) w.walk(0, cand);
  return w.count;
}

}  // namespace visgate::ssv
