// Silhouette regions of closed surfaces; see silhouette_region.h.
#include "lib/plucker/silhouette_region.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "lib/plucker/exact_orient.h"
#include "lib/plucker/lines.h"
#include "lib/plucker/local_light.h"

namespace visgate::plucker {

namespace {

FacePlane face_plane(const TriangleSoup& mesh, uint32_t t) {
  FacePlane f;
  f.t = t;
  f.a = to_double(mesh.corner(t, 0));
  const Vec3d e1 = to_double(mesh.corner(t, 1)) - f.a, e2 = to_double(mesh.corner(t, 2)) - f.a;
  f.n = cross(e1, e2);
  f.s12 = norm1(e1) * norm1(e2);
  return f;
}

int face_side(const TriangleSoup& mesh, const FacePlane& f, const SumPoint& p) {
  const int s = plane_side_filtered(f.a, f.n, f.s12, p);
  return s != 0 ? s : plane_side_rest(mesh.corner(f.t, 0), mesh.corner(f.t, 1), mesh.corner(f.t, 2), p);
}

// The box of the unit normals of the faces of every node's edges (SurfaceEdges::
// node_normals; item e's faces: unit[local[edges[e].t0]], unit[local[edges[e].t1]]),
// children before parents (pre-order: both children follow their parent). A face whose
// computed normal n is small next to s12 (|n|_1 <= 2^-20 s12, where n's rounding, a few
// ulps of s12, could turn it) bounds nothing (bad): its node gets [-1, 1]^3.
void node_normal_boxes(const EdgeTree& tree, const std::vector<Vec3d>& unit, const std::vector<uint8_t>& bad,
                       const std::vector<SurfaceEdges::Edge>& edges, const std::vector<uint32_t>& local,
                       std::vector<AABBd>& out) {
  const AABBd full{Vec3d(-1, -1, -1), Vec3d(1, 1, 1)};
  out.assign(tree.node_count(), AABBd());
  for (size_t i = tree.node_count(); i-- > 0;) {
    const auto& nd = tree.node(uint32_t(i));
    AABBd& b = out[i];
    if (!tree.is_leaf(nd)) {
      b = out[tree.left(uint32_t(i))];
      b.extend(out[tree.right(uint32_t(i))]);
      continue;
    }
    for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) {
      const uint32_t e = tree.item(k);
      for (const uint32_t f : {local[edges[e].t0], local[edges[e].t1]}) {
        if (bad[f]) {
          b = full;
          break;
        }
        b.extend(unit[f]);
      }
    }
  }
}

// item(k) for every leaf-order position k of a leaf of tree reached through nodes that
// enter(i) accepts.
template <class Enter, class Item>
void walk_tree(const EdgeTree& tree, Enter&& enter, Item&& item) {
  if (tree.empty()) return;
  std::array<uint32_t, accel::Bvh<double>::kMaxStack> stack;  // halving: the same depth bound
  size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const uint32_t i = stack[--top];
    const auto& nd = tree.node(i);
    if (!enter(i)) continue;
    if (!tree.is_leaf(nd)) {
      stack[top++] = tree.left(i);
      stack[top++] = tree.right(i);
      continue;
    }
    for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) item(k);
  }
}

// item(t, k, u) for every edge of the group's region surfaces in a leaf reached through
// nodes that enter(world box, normal box) accepts and with a face among the group's
// candidates: the edge from corner k to k + 1 of face t, its other face u. Each edge is
// taken as the group's collection takes it, from its lower face when both faces are
// candidates, else from the candidate face (the half (t, k) with neighbour u exactly
// when t is a candidate and not both u < t and u a candidate). Only edges whose faces
// pair(t0, t1) accepts (a test symmetric in the two faces, before their candidacy,
// which costs tree node tests the first time a face is asked about in the group).
template <class Enter, class Pair, class Item>
void walk_group_edges(const SurfaceTrees& trees, SilhouetteGroup& g, Enter&& enter, Pair&& pair, Item&& item) {
  for (const int32_t s : g.surfaces) {
    const SurfaceEdges& se = trees.edges(s);
    walk_tree(
        se.tree, [&](uint32_t i) { return enter(se.tree.node(i).box, se.node_normals[i]); },
        [&](uint32_t k) {
          const SurfaceEdges::Edge& e = se.edges[se.tree.item(k)];
          if (!pair(e.t0, e.t1)) return;
          // t1's verdict only when it matters (each is decided on demand).
          const bool c0 = g.candidate(e.t0);
          if (c0 && (!(e.t1 < e.t0) || !g.candidate(e.t1)))
            item(e.t0, uint32_t(e.k0), e.t1);
          else if (e.k1 < 3 && !(e.t0 < e.t1 && c0) && g.candidate(e.t1))
            item(e.t1, uint32_t(e.k1), e.t0);
        });
  }
}

// The local box of the edge a -> b (to_local_d of its ends).
AABBd local_edge_box(const Vec3d& la, const Vec3d& lb) {
  AABBd b{la, la};
  b.extend(lb);
  return b;
}

// A world box (double) in local coordinates: the rounded differences keep every local
// point of the box's world points inside (rounding is monotone).
AABBd to_local_box(const AABBd& w, const Vec3d& od) { return AABBd{w.lo - od, w.hi - od}; }

}  // namespace

// With d = r - x over the box and u over the normals' box, u . d lies within the sums of
// the per-axis interval products' extremes. The margin covers a unit normal off by 2^-25
// per component (times |d|_1 <= dm) and the rounding of local coordinates and of the
// sums (2^-30 of the largest coordinate; a few ulps of dm).
bool faces_one_side(const AABBd& box, const AABBd& normals, const Vec3d& r) {
  double lo = 0.0, hi = 0.0, dm = 0.0;
  for (int a = 0; a < 3; ++a) {
    const double d0 = r[a] - box.hi[a], d1 = r[a] - box.lo[a];
    const double p0 = normals.lo[a] * d0, p1 = normals.lo[a] * d1, p2 = normals.hi[a] * d0, p3 = normals.hi[a] * d1;
    lo += std::min(std::min(p0, p1), std::min(p2, p3));
    hi += std::max(std::max(p0, p1), std::max(p2, p3));
    dm += std::max(std::abs(d0), std::abs(d1));
  }
  const double mag = std::max({max_component(vabs(r)), max_component(vabs(box.lo)), max_component(vabs(box.hi))});
  const double m = 0x1p-24 * dm + 0x1p-30 * mag;
  return lo > m || hi < -m;
}

int exact_side(const Vec3f& a, const Vec3f& b, const Vec3f& c, const SumPoint& p) {
  const Vec3d ad = to_double(a), e1 = to_double(b) - ad, e2 = to_double(c) - ad;
  const int s = plane_side_filtered(ad, cross(e1, e2), norm1(e1) * norm1(e2), p);
  return s != 0 ? s : plane_side_rest(a, b, c, p);
}

bool EdgeTree::start(uint32_t n) {
  nodes.clear();
  order.clear();
  if (n == 0) return false;
  order.resize(n);
  for (uint32_t e = 0; e < n; ++e) order[e] = e;
  nodes.reserve(2 * (n / kLeaf) + 2);
  return true;
}

accel::Bvh<float> triangle_hierarchy(const TriangleSoup& mesh, const std::vector<uint32_t>& tris) {
  return accel::Bvh<float>(triangle_boxes(mesh, &tris), kTriangleHierarchyRule);
}

SurfaceTrees::SurfaceTrees(const TriangleSoup& mesh, const ClosedSurfaces& cs, uint32_t min_edge_triangles,
                           const accel::Bvh<float>* mesh_tree) {
  tris_ = cs.triangle_lists();
  bvh_.reserve(cs.count());
  // A surface's list is ascending and distinct, so one of mesh.size() triangles is 0, 1, ...
  // and takes the mesh tree as it is; one of most of them takes the mesh tree restricted
  // to its triangles (item i: tris[i]) instead of a second median build.
  const bool whole_tree = mesh_tree && mesh_tree->item_count() == mesh.size();
  for (const std::vector<uint32_t>& tris : tris_) {
    if (whole_tree && tris.size() == mesh.size()) {
      bvh_.push_back(*mesh_tree);
    } else if (whole_tree && uint64_t(tris.size()) * kDerivedDen >= uint64_t(mesh.size()) * kDerivedNum) {
      std::vector<uint32_t> keep(mesh.size(), accel::Bvh<float>::kDropped);
      for (uint32_t i = 0; i < tris.size(); ++i) keep[tris[i]] = i;
      bvh_.push_back(accel::Bvh<float>::restricted(*mesh_tree, keep,
                                                   [&](uint32_t i) { return triangle_box(mesh, tris[i]); }));
    } else {
      bvh_.push_back(triangle_hierarchy(mesh, tris));
    }
  }
  rank_.assign(mesh.size(), 0u);
  uint32_t pos = 0;
  for (size_t s = 0; s < bvh_.size(); ++s)
    for (uint32_t item : bvh_[s].order()) rank_[tris_[s][item]] = pos++;
  // Each surface's edges: the halves (t, k) and (u, j) between the same two faces paired
  // in the order of k and j (any pairing: each half is taken with its own corners, and
  // the box holds both), a half left unpaired as an edge of its own.
  edges_.resize(bvh_.size());
  std::vector<uint32_t> local(mesh.size(), 0u);
  std::vector<Vec3d> unit;
  std::vector<uint8_t> bad;
  for (size_t s = 0; s < bvh_.size(); ++s) {
    const std::vector<uint32_t>& tris = tris_[s];
    SurfaceEdges& se = edges_[s];
    if (cs.triangles(int32_t(s)) < min_edge_triangles) continue;
    unit.assign(tris.size(), Vec3d(0, 0, 0));
    bad.assign(tris.size(), 0);
    for (uint32_t i = 0; i < tris.size(); ++i) {
      local[tris[i]] = i;
      const FacePlane fp = face_plane(mesh, tris[i]);
      if (!(norm1(fp.n) > 0x1p-20 * fp.s12))
        bad[i] = 1;
      else
        unit[i] = fp.n * (1.0 / length(fp.n));
    }
    // A closed surface's triangles have three neighbours each and its halves pair up: 3T / 2
    // edges (more only where a half finds no partner; the vectors then grow).
    const size_t edges = (3 * tris.size() + 1) / 2;
    se.edges.reserve(edges);
    // The m-th half of t toward u (m counted over t's k from 0), or 3.
    auto nth_half = [&](uint32_t t, uint32_t u, int m) -> int {
      for (int j = 0; j < 3; ++j)
        if (cs.neighbors(t)[size_t(j)] == int32_t(u) && m-- == 0) return j;
      return 3;
    };
    // The triangles in rank order (the surface hierarchy's leaf order): the edges come in
    // the order of their key rank_[t0], the edge tree's leaf order.
    for (uint32_t item : bvh_[s].order()) {
      const uint32_t t = tris[item];
      const std::array<int32_t, 3>& nb = cs.neighbors(t);
      for (int k = 0; k < 3; ++k) {
        if (nb[size_t(k)] < 0) continue;
        const uint32_t u = uint32_t(nb[size_t(k)]);
        // The neighbours are symmetric with their multiplicities (lib/mesh/prepare.h): u
        // has t as often as t has u, so when u < t, u's m-th half toward t (m: t's halves
        // toward u before k) exists and this half is paired from u's side.
        if (u < t) continue;
        SurfaceEdges::Edge e;
        e.t0 = t;
        e.k0 = uint8_t(k);
        e.t1 = u;
        if (u > t) {
          int m = 0;
          for (int j = 0; j < k; ++j) m += nb[size_t(j)] == nb[size_t(k)] ? 1 : 0;
          e.k1 = uint8_t(nth_half(u, t, m));
        }
        se.edges.push_back(e);
      }
    }
    // An edge's leaf box, taken by the build when it makes the leaves (no array of them):
    // in float, whose double is the box of the corners in double (exact, monotone
    // conversion). u's half has the same two welded points, equal to t's as floats (their
    // bits differ at most in a zero's sign), and extend moves lo (hi) only for a point
    // strictly below (above) it, so they would leave the box's bits as t's two corners
    // make them.
    se.tree.build_in_order_by(uint32_t(se.edges.size()), [&](uint32_t k) {
      const SurfaceEdges::Edge& e = se.edges[k];
      AABB b{mesh.corner(e.t0, e.k0), mesh.corner(e.t0, e.k0)};
      b.extend(mesh.corner(e.t0, (e.k0 + 1) % 3));
      return b;
    });
    node_normal_boxes(se.tree, unit, bad, se.edges, local, se.node_normals);
  }
}

size_t SurfaceEdges::memory_bytes() const {
  return edges.capacity() * sizeof(Edge) + tree.nodes.capacity() * sizeof(EdgeTree::Node) +
         tree.order.capacity() * sizeof(uint32_t) +
         node_normals.capacity() * sizeof(AABBd);
}

size_t SurfaceTrees::memory_bytes() const {
  size_t n = 0;
  for (size_t s = 0; s < bvh_.size(); ++s)
    n += bvh_[s].memory_bytes() + tris_[s].capacity() * sizeof(uint32_t) + edges_[s].memory_bytes();
  return n + rank_.capacity() * sizeof(uint32_t);
}

// The boxes are tested against the segment in double, each widened by 2^-20 of the
// largest coordinate met (far above the rounding of pd and of the slab arithmetic): a
// box the segment meets is never passed over. Then per triangle the closed test on
// exact signs: r and p not strictly on one side of its plane, and the line r -> p not
// strictly outside any of its edges (orient3d(r, t_k, t_k+1, p) never of r's sign).
int SurfaceTrees::segment_meets(int32_t s, const TriangleSoup& mesh, const Vec3f& r, const SumPoint& p,
                                const Vec3d& pd) const {
  const accel::Bvh<float>& bvh = bvh_[size_t(s)];
  if (bvh.empty()) return 0;
  const Vec3d rd = to_double(r), d = pd - rd;
  const AABB& root = bvh.node(0).box;
  const double mag = std::max({max_component(vabs(rd)), max_component(vabs(pd)), max_component(vabs(to_double(root.lo))),
                               max_component(vabs(to_double(root.hi)))});
  const double eps = 0x1p-20 * mag;
  auto meets_box = [&](const AABB& b) {
    double t0 = 0.0, t1 = 1.0;
    for (int a = 0; a < 3; ++a) {
      const double lo = double(b.lo[a]) - eps, hi = double(b.hi[a]) + eps;
      if (d[a] == 0.0) {
        if (rd[a] < lo || rd[a] > hi) return false;
        continue;
      }
      double ta = (lo - rd[a]) / d[a], tb = (hi - rd[a]) / d[a];
      if (ta > tb) std::swap(ta, tb);
      t0 = std::max(t0, ta);
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    return true;
  };
  int m = 0;
  visit(s, [&](const AABB& b, bool) { return meets_box(b); },
        [&](uint32_t t) {
          m = triangle_meets(mesh, t, r, p);
          return m != 0;
        });
  return m;
}

int SurfaceTrees::triangle_meets(const TriangleSoup& mesh, uint32_t t, const Vec3f& r, const SumPoint& p) {
  const Vec3f tv[3] = {mesh.corner(t, 0), mesh.corner(t, 1), mesh.corner(t, 2)};
  const int sr = exact_side(tv[0], tv[1], tv[2], SumPoint(r)), sp = exact_side(tv[0], tv[1], tv[2], p);
  if (sr == 0 && sp == 0) return -1;  // the segment in the triangle's plane
  if (sr == 0 || sp == sr) return 0;  // r in its plane (not on it: outside the box), or p beside r
  for (int k = 0; k < 3; ++k)
    if (exact_side(r, tv[k], tv[(k + 1) % 3], p) == sr) return 0;
  return 1;
}

void SilhouetteGroup::clear() {
  for (const int32_t s : surfaces) is_region[size_t(s)] = 0;
  surfaces.clear();
  edges.clear();
  edge_keys.clear();
}

void SilhouetteGroup::new_group(size_t triangles, size_t nodes, size_t nsurfaces) {
  if (in_cand.size() != triangles) in_cand.assign(triangles, 0u), tri_ok.assign(triangles, 0), counted.assign(triangles, 0);
  if (node_stamp.size() != nodes) node_stamp.assign(nodes, 0u), node_ok.assign(nodes, 0);
  is_region.assign(nsurfaces, 0);  // GroupState::clear empties `surfaces` alone
  if (++serial == 0) {
    std::fill(in_cand.begin(), in_cand.end(), 0u);
    std::fill(node_stamp.begin(), node_stamp.end(), 0u);
    serial = 1;
  }
}

// A node passes when its parent does and node_passes accepts it (the walk reaches it
// and does not leave it out): the verdict of the walk, which enters a node only through
// its parent. The chain is at most the tree's depth (kMaxStack).
bool SilhouetteGroup::decide(uint32_t t) {
  std::array<uint32_t, accel::Bvh<float>::kMaxStack> chain;
  size_t n = 0;
  uint32_t i = tree_surfaces->leaf_of[t];
  bool ok = true;
  while (node_stamp[i] != serial) {
    chain[n++] = i;
    if (i == 0) break;
    i = tree_surfaces->parent[i];
  }
  if (node_stamp[i] == serial) ok = node_ok[i] != 0;
  while (n > 0) {
    const uint32_t k = chain[--n];
    ok = ok && node_passes(k);
    node_stamp[k] = serial;
    node_ok[k] = uint8_t(ok);
  }
  in_cand[t] = serial;
  tri_ok[t] = uint8_t(ok);
  counted[t] = 0;
  return ok;
}

TreeSurfaces::TreeSurfaces(const TriangleTree& tree, const ClosedSurfaces& cs) {
  const accel::Bvh<float>& bvh = tree.bvh();
  const size_t nn = bvh.node_count();
  node_surface.assign(nn, -1);
  parent.assign(nn, 0u);
  leaf_of.assign(bvh.item_count(), 0u);
  // Pre-order: both children follow their parent, so children are done first backwards.
  for (size_t i = nn; i-- > 0;) {
    const auto& nd = bvh.node(uint32_t(i));
    if (bvh.is_leaf(nd)) {
      const auto items = bvh.leaf_items(nd);
      int32_t s = items.empty() ? -1 : cs.surface(items[0]);
      for (const uint32_t t : items) {
        leaf_of[t] = uint32_t(i);
        if (cs.surface(t) != s) s = -1;
      }
      node_surface[i] = s;
      continue;
    }
    const uint32_t l = bvh.left(uint32_t(i)), r = bvh.right(uint32_t(i));
    parent[l] = parent[r] = uint32_t(i);
    node_surface[i] = node_surface[l] == node_surface[r] ? node_surface[l] : -1;
  }
}

void select_region_surfaces(const TriangleSoup& mesh, const ClosedSurfaces& cs, const SurfaceTrees& trees,
                            const Shaft& shaft, const AABB& rbox, const Vec3f* light, int m, float sigma,
                            const Vec3f& origin, const std::vector<Vec3d>& rloc, const std::vector<Vec3d>& lpoly,
                            bool estimate, SilhouetteGroup& g, SilhouetteCounters& c) {
  g.clear();
  auto apart = [](const AABB& a, const AABB& b) {
    return a.hi.x < b.lo.x || b.hi.x < a.lo.x || a.hi.y < b.lo.y || b.hi.y < a.lo.y || a.hi.z < b.lo.z ||
           b.hi.z < a.lo.z;
  };
  // r outside S's box for every receiver (float comparisons: exact), and every corner of
  // S's box strictly on the receivers' side of the light's exact plane (so are S's
  // vertices, and the light, on that plane, is outside S's box).
  auto qualifies = [&](int32_t s) {
    if (estimate && cs.triangles(s) < kMinRegionTriangles) return false;
    const AABB& b = cs.box(s);
    if (!apart(b, rbox)) return false;
    for (int k = 0; k < 8; ++k) {
      const Vec3f x((k & 1) ? b.hi.x : b.lo.x, (k & 2) ? b.hi.y : b.lo.y, (k & 4) ? b.hi.z : b.lo.z);
      if (!(double(sigma) * newell_side_exact(light, m, x) > 0.0)) return false;
    }
    return true;
  };
  // A surface whose box the shaft culls has no candidate (its tree leaves lie in that
  // box: culled too). The others are taken whether or not a triangle of theirs is a
  // candidate: one without any has no edge of the group.
  for (int32_t s = 0; s < int32_t(cs.count()); ++s) {
    if (estimate && cs.triangles(s) < kMinRegionTriangles) continue;
    if (shaft.culls_box(cs.box(s).lo - origin, cs.box(s).hi - origin) || !qualifies(s)) continue;
    g.surfaces.push_back(s);
    g.is_region[size_t(s)] = 1;
  }
  if (g.surfaces.empty()) return;
  // The estimate at five receivers spread over the group (its first, quarters and last):
  // the candidate edges whose box meets the box of the receiver's pyramid, whose faces'
  // double sides from it differ and whose ends are not both outside one of the pyramid's
  // side planes (in double, unbounded: it only picks the path).
  const Vec3d od = to_double(origin);
  size_t most = 0;
  thread_local std::vector<Vec3d> side;
  for (size_t q = 0; q < 5 && estimate && most <= kMaxSampledEdges; ++q) {
    const Vec3d& rl = rloc[(rloc.size() - 1) * q / 4];
    Vec3d lo = rl, hi = rl;
    for (const Vec3d& l : lpoly) lo = vmin(lo, l), hi = vmax(hi, l);
    const Vec3d rwd = rl + od;
    // The pyramid's side planes through r, the light's centroid on their positive side.
    Vec3d cen(0, 0, 0);
    for (const Vec3d& l : lpoly) cen = cen + l;
    cen = cen * (1.0 / double(lpoly.size()));
    side.clear();
    for (size_t j = 0; j < lpoly.size(); ++j) {
      Vec3d nj = cross(lpoly[j] - rl, lpoly[(j + 1) % lpoly.size()] - rl);
      if (dot(cen - rl, nj) < 0.0) nj = -nj;
      side.push_back(nj);
    }
    size_t n = 0;
    auto meets = [&](const AABBd& b) {
      return !(b.hi.x < lo.x || b.hi.y < lo.y || b.hi.z < lo.z || b.lo.x > hi.x || b.lo.y > hi.y || b.lo.z > hi.z);
    };
    // A node wholly outside one side plane, beyond a margin far above the rounding of the
    // edges' own tests below (2^-20 of the terms' bound), holds only edges they reject.
    auto outside_side = [&](const AABBd& b) {
      const Vec3d h = (b.hi - b.lo) * 0.5, d = (b.hi + b.lo) * 0.5 - rl;
      for (const Vec3d& sj : side) {
        const Vec3d a = vabs(sj);
        const double top = dot(d, sj) + a.x * h.x + a.y * h.y + a.z * h.z;
        if (top < -0x1p-20 * max_component(a) * norm1(vabs(d) + h)) return true;
      }
      return false;
    };
    // Nodes whose faces all have r strictly on one side (faces_one_side) hold no edge
    // counted here but one whose double sides are wrong (the estimate is float anyway).
    walk_group_edges(
        trees, g,
        [&](const AABBd& wb, const AABBd& normals) {
          const AABBd lb = to_local_box(wb, od);
          return meets(lb) && !outside_side(lb) && !faces_one_side(wb, normals, rwd);
        },
        [](uint32_t, uint32_t) { return true; },
        [&](uint32_t t, uint32_t k, uint32_t u) {
          const Vec3d la = to_local_d(mesh.corner(t, int(k)), origin), lb = to_local_d(mesh.corner(t, int(k + 1) % 3), origin);
          if (!meets(local_edge_box(la, lb))) return;
          const FacePlane f0 = face_plane(mesh, t), f1 = face_plane(mesh, u);
          if ((dot(rwd - f0.a, f0.n) > 0.0) == (dot(rwd - f1.a, f1.n) > 0.0)) return;
          for (size_t j = 0; j < side.size(); ++j)
            if (dot(la - rl, side[j]) < 0.0 && dot(lb - rl, side[j]) < 0.0) return;
          ++n;
        });
    most = std::max(most, n);
  }
  if (most > kMaxSampledEdges) {
    ++c.declined;
    g.clear();
    return;
  }
  ++c.groups;
}

bool subtract_silhouette_regions(const TriangleSoup& mesh, const SurfaceTrees& trees, SilhouetteGroup& g,
                                 const Vec3f& rw, const Vec3d& r, const Vec3f& origin,
                                 const std::vector<Vec3d>& light, const std::vector<Vec3d>& pyramid,
                                 const std::vector<Vec3d>& pyramid_err, const LightBounds& bounds,
                                 const LightPlane& lp, FragmentList& frags, SilhouetteCounters& c) {
  // The edges whose faces r does not see from one strict side, and that may meet the
  // pyramid of r and the light: an edge whose box lies strictly outside one side plane
  // of it (by 16 times the plane's error bound plus 2^-30 of the scale, far above the
  // rounding of the local coordinates) has no point on a segment from r to the light.
  // Per face (input triangle) its side from r, computed once per receiver (stamped, not
  // cleared).
  thread_local std::vector<int8_t> side;
  thread_local std::vector<uint32_t> stamp;
  thread_local uint32_t serial = 0;
  if (stamp.size() < mesh.size()) stamp.resize(mesh.size(), 0), side.resize(mesh.size(), 0);
  if (++serial == 0) {
    std::fill(stamp.begin(), stamp.end(), 0u);
    serial = 1;
  }
  const SumPoint rs(rw);
  auto face_side_r = [&](uint32_t t) {
    if (stamp[t] != serial) stamp[t] = serial, side[t] = int8_t(face_side(mesh, face_plane(mesh, t), rs));
    return int(side[t]);
  };
  // A box wholly outside one side plane: its largest value there below the margin taken
  // with the box's largest |x - l| per axis (which bounds every point's dot_err) and
  // largest coordinate; the rounding of the centre and half sides (a few ulps of the
  // coordinates) is far inside the 2^-30 term.
  // First against the pyramid's own box (r and the light, grown by 2^-20 of its size):
  // a box apart from it is apart from the pyramid.
  Vec3d plo = r, phi = r;
  for (const Vec3d& l : light) plo = vmin(plo, l), phi = vmax(phi, l);
  {
    const double grow = 0x1p-20 * (max_component(phi - plo) + max_component(vmax(vabs(plo), vabs(phi))));
    plo = plo - Vec3d(grow, grow, grow);
    phi = phi + Vec3d(grow, grow, grow);
  }
  // Per side plane: n, its point l and the weights of the margin, |d_i| w_i summed (16
  // times dot_err's weights plus 2^-30 |n|_1), plus 2^-30 |n|_1 of the box's largest
  // coordinate. The box's largest value n . (x - l) is n . c + |n| . h (c its centre
  // less l, h its half sides), and every |x_i - l_i| in it is at most |c_i| + h_i.
  struct SidePlane {
    Vec3d n, l, w;
    double k = 0.0;
  };
  thread_local std::vector<SidePlane> sp;
  sp.resize(pyramid.size());
  for (size_t j = 0; j < pyramid.size(); ++j) {
    const Vec3d& n = pyramid[j];
    const Vec3d& e = pyramid_err[j];
    constexpr double k8 = 8.0 * kUnitRoundoffD;  // lines.h dot_err's factor
    const double k = 0x1p-30 * norm1(n);
    sp[j] = {n, light[j], Vec3d(16.0 * (e.x + k8 * std::abs(n.x)) + k, 16.0 * (e.y + k8 * std::abs(n.y)) + k,
                                16.0 * (e.z + k8 * std::abs(n.z)) + k), k};
  }
  size_t hint = 0;  // the plane that rejected the last box (any order gives the same answer)
  auto box_outside = [&](const AABBd& b) {
    if (b.hi.x < plo.x || b.hi.y < plo.y || b.hi.z < plo.z || b.lo.x > phi.x || b.lo.y > phi.y || b.lo.z > phi.z)
      return true;
    const Vec3d h = (b.hi - b.lo) * 0.5, mid = (b.hi + b.lo) * 0.5;
    const double mag = std::max(max_component(vabs(b.lo)), max_component(vabs(b.hi)));
    for (size_t jj = 0; jj < sp.size(); ++jj) {
      const size_t j = hint + jj < sp.size() ? hint + jj : hint + jj - sp.size();
      const SidePlane& q = sp[j];
      const Vec3d d = mid - q.l;
      const double top = dot(q.n, d) + std::abs(q.n.x) * h.x + std::abs(q.n.y) * h.y + std::abs(q.n.z) * h.z;
      if (!(top < 0.0)) continue;
      const double m = (std::abs(d.x) + h.x) * q.w.x + (std::abs(d.y) + h.y) * q.w.y + (std::abs(d.z) + h.z) * q.w.z;
      if (top < -m - q.k * mag) {
        hint = j;
        return true;
      }
    }
    return false;
  };
  // A node whose faces all have r strictly on one common side (normal cones) holds no
  // edge the exact sides below would take: faces_one_side only skips their tests. The
  // used edges are then sorted into the group's edge order (by the face each is taken
  // from, then k), whatever the trees' order.
  g.edges.clear();
  g.edge_keys.clear();
  const Vec3d rwd = to_double(rw), od = to_double(origin);
  walk_group_edges(
      trees, g, [&](const AABBd& wb, const AABBd& normals) { return !faces_one_side(wb, normals, rwd) && !box_outside(to_local_box(wb, od)); },
      // The faces' sides first: they reject most edges of a leaf the walk reaches (before
      // their faces' candidacy is decided), and each face's side serves its three edges.
      [&](uint32_t t0, uint32_t t1) {
        const int s0 = face_side_r(t0), s1 = face_side_r(t1);
        return !(s0 != 0 && s0 == s1);
      },
      [&](uint32_t t, uint32_t k, uint32_t u) {
        const Vec3f a = mesh.corner(t, int(k)), b = mesh.corner(t, int(k + 1) % 3);
        const Vec3d la = to_local_d(a, origin), lb = to_local_d(b, origin);
        if (box_outside(local_edge_box(la, lb))) return;
        // silhouette_edges: the distinct edges the group's receivers use.
        if (!(g.counted[t] & (1u << k))) g.counted[t] |= uint8_t(1u << k), ++c.edges;
        g.edges.push_back(SilEdge{a, b, la, lb, t, u});
        g.edge_keys.push_back(uint64_t(t) << 2 | k);
      });
  g.used.resize(g.edges.size());
  for (uint32_t e = 0; e < g.used.size(); ++e) g.used[e] = e;
  std::sort(g.used.begin(), g.used.end(), [&](uint32_t x, uint32_t y) { return g.edge_keys[x] < g.edge_keys[y]; });
  c.receiver_edges += g.used.size();
  // The fragments split by the planes through r and those edges.
  g.planes.clear();
  const Vec3d dn = (lp.nd.x != 0.0 || lp.nd.y != 0.0 || lp.nd.z != 0.0) ? lp.nd : to_double(lp.n);
  std::vector<Vec3d>& cur = g.cur;
  for (uint32_t e : g.used) {
    const NodePlane pl = node_plane(r, g.edges[e].la, g.edges[e].lb, bounds);
    if (pl.on_line) {
      ++c.undecided;
      return false;
    }
    g.planes.push_back(pl);
    // The edge's projection lies between the planes through r and each of its ends that
    // hold the light's normal direction D ("vertex planes", shared by the edges that
    // share the end: the same plane, computed from the same point). A fragment wholly on
    // the far side of one of them (away from the other end, which is strictly on the near
    // side, else the edge has no such planes) does not meet the projection and is kept
    // whole: c does not change inside it across this edge; one that straddles one is cut
    // there first and its far part kept whole. So a chain of edges across the light cuts
    // it into sectors between its vertices' planes, each cut by its own edge's plane,
    // not into the arrangement of every edge's full line. Inexact planes only refine:
    // any plane through r and the end will do.
    const SilEdge& se = g.edges[e];
    auto vertex_plane = [&](const Vec3d& x) { return node_plane(r, x, x + dn * norm1(x - r), bounds); };
    NodePlane vp[2] = {vertex_plane(se.la), vertex_plane(se.lb)};
    int near[2] = {0, 0};  // the other end's side of each vertex plane (0: no wedge)
    for (int k = 0; k < 2; ++k) {
      if (vp[k].on_line) continue;
      const Vec3d d = (k == 0 ? se.lb : se.la) - r;
      const double v = dot(d, vp[k].n), m = 0x1p-20 * norm1(d) * norm1(vp[k].n);
      near[k] = v > m ? 1 : (v < -m ? -1 : 0);
    }
    if (near[0] == 0 || near[1] == 0) near[0] = near[1] = 0;
    FragmentList& out = g.out;
    out.clear();
    for (size_t f = 0; f < frags.size(); ++f) {
      cur.assign(frags.data(f), frags.data(f) + frags.count(f));
      bool done = false;
      for (int k = 0; k < 2 && near[k] != 0 && !done; ++k) {
        const SplitResult far_class = near[k] > 0 ? SplitResult::Negative : SplitResult::Positive;
        const SplitResult s = split_fragment(vp[k], cur.data(), int(cur.size()), g.pos, g.neg);
        if (s == far_class) {
          out.add(cur.data(), cur.size());
          done = true;
        } else if (s == SplitResult::Both) {
          std::vector<Vec3d>& far_part = near[k] > 0 ? g.neg : g.pos;
          std::vector<Vec3d>& near_part = near[k] > 0 ? g.pos : g.neg;
          if (far_part.size() >= 3) out.add(far_part.data(), far_part.size());
          cur.swap(near_part);
          if (cur.size() < 3) done = true;
        } else if (s == SplitResult::ZeroArea) {
          ++c.dropped;
          done = true;
        }  // near side or OnLine (impossible here: checked above): on to the edge's plane
      }
      if (done) continue;
      switch (split_fragment(pl, cur.data(), int(cur.size()), g.pos, g.neg)) {
        case SplitResult::Positive:
        case SplitResult::Negative: out.add(cur.data(), cur.size()); break;
        case SplitResult::Both:
          if (g.pos.size() >= 3) out.add(g.pos.data(), g.pos.size());
          if (g.neg.size() >= 3) out.add(g.neg.data(), g.neg.size());
          break;
        case SplitResult::ZeroArea: ++c.dropped; break;  // within rounding of the plane: no area
        case SplitResult::OnLine: ++c.undecided; return false;
      }
    }
    std::swap(frags, out);
  }
  // Each piece by one point strictly inside its cell (the vertex average p), confirmed
  // exactly against every edge plane the piece lies on one side of; the first piece
  // the exact tests do not confirm leaves the receiver undecided, and only the pieces
  // before it are tested against the surfaces.
  g.pts.clear();
  g.zero.clear();
  bool bad = false;
  for (size_t f = 0; f < frags.size() && !bad; ++f) {
    const Vec3d* poly = frags.data(f);
    const int n = frags.count(f);
    Vec3d p(0, 0, 0);
    for (int k = 0; k < n; ++k) p = p + poly[k];
    p = p * (1.0 / double(n));
    const SumPoint ps(origin, p);
    bool ok = true, zero = false;
    for (size_t j = 0; j < g.planes.size() && ok; ++j) {
      const SplitResult cls = classify_fragment(g.planes[j], poly, n);
      if (cls == SplitResult::ZeroArea) {
        zero = true;
        break;
      }
      // Both: a piece beside the edge's projection, never split by its plane (above).
      if (cls == SplitResult::Both) continue;
      const int want = cls == SplitResult::Positive ? 1 : (cls == SplitResult::Negative ? -1 : 0);
      const SilEdge& se = g.edges[g.used[j]];
      ok = want != 0 && exact_side(rw, se.a, se.b, ps) == want;
    }
    if (!zero && !ok) bad = true;
    g.pts.push_back(p);
    g.zero.push_back(uint8_t(zero ? 1 : (ok ? 0 : 2)));
  }
  // With several pieces, the segment tests run triangle by triangle over those whose
  // shadow box (shadow_box) may hold a piece's point, each against the pieces' points
  // in its box (sorted by u): the segment r -> p meets a triangle only where p lies in
  // its shadow. A piece keeps the first nonzero result in the triangles' walk order,
  // and the walk stops once every piece has one: the results of one walk per piece.
  const bool listed = frags.size() > 16;
  g.meet.assign(g.pts.size(), 0);
  if (listed) {
    ++c.listed;
    const size_t np = g.pts.size() - (bad ? 1 : 0);
    g.order.clear();
    for (size_t k = 0; k < np; ++k)
      if (g.zero[k] == 0) g.order.push_back(uint32_t(k));
    const int au = lp.axes.u, av = lp.axes.v;
    std::sort(g.order.begin(), g.order.end(),
              [&](uint32_t x, uint32_t y) { return g.pts[x][au] < g.pts[y][au] || (g.pts[x][au] == g.pts[y][au] && x < y); });
    g.order_u.clear();
    UVBox all;
    for (uint32_t k : g.order) {
      g.order_u.push_back(g.pts[k][au]);
      all.extend(UVBox{g.pts[k][au], g.pts[k][au], g.pts[k][av], g.pts[k][av]});
    }
    size_t open = g.order.size();
    // A float world box in local coordinates, widened by 2^-40 of its coordinates (the
    // translation rounds once per corner).
    auto local_box = [&](const AABB& b) {
      AABBd d{to_double(b.lo) - od, to_double(b.hi) - od};
      const double w = 0x1p-40 * (max_component(vabs(d.lo)) + max_component(vabs(d.hi)));
      d.lo = d.lo - Vec3d(w, w, w);
      d.hi = d.hi + Vec3d(w, w, w);
      return d;
    };
    // The first open piece whose point lies in sb, from x on (g.order's size: none).
    auto next_in = [&](const UVBox& sb, size_t x) {
      for (; x < g.order_u.size() && g.order_u[x] <= sb.uhi; ++x) {
        const uint32_t k = g.order[x];
        if (g.meet[k] == 0 && sb.contains(g.pts[k][au], g.pts[k][av])) return x;
      }
      return g.order.size();
    };
    auto first_in = [&](const UVBox& sb) {
      return next_in(sb, size_t(std::lower_bound(g.order_u.begin(), g.order_u.end(), sb.ulo) - g.order_u.begin()));
    };
    // A triangle's shadow box from its vertices' projections (ShadowFrame), each computed
    // once per receiver (stamped, not cleared): the floats shadow_box computes.
    const ShadowFrame sf = ShadowFrame::of(lp, r);
    thread_local std::vector<ShadowFrame::Vertex> vproj;
    thread_local std::vector<uint32_t> vstamp;
    thread_local uint32_t vserial = 0;
    if (vstamp.size() < mesh.vertices.size()) vstamp.resize(mesh.vertices.size(), 0), vproj.resize(mesh.vertices.size());
    if (++vserial == 0) {
      std::fill(vstamp.begin(), vstamp.end(), 0u);
      vserial = 1;
    }
    auto triangle_box = [&](uint32_t t) {
      if (!sf.bounded) return UVBox::everything();
      ShadowFrame::Extent e;
      for (int k = 0; k < 3; ++k) {
        const uint32_t vi = mesh.triangles[t][size_t(k)];
        if (vstamp[vi] != vserial) vstamp[vi] = vserial, vproj[vi] = sf.project(lp, to_local_d(mesh.vertices[vi], origin));
        const ShadowFrame::Vertex& x = vproj[vi];
        if (!x.bounded) return UVBox::everything();
        e.add(x);
      }
      return sf.box(lp, e);
    };
    // A node is entered only when the shadow box of its box's corners (that of every
    // triangle in it: the central projection of a convex set is the hull of its corners'
    // projections, shadow_box's margin covering it as any polygon's) holds an open point;
    // shadow_box_of_box gives that box (or one holding it) from six of the corners' t.
    // A leaf passes on the pyramid test alone: its triangles' own shadow boxes decide,
    // which cost less than the box's corners; a triangle the walk reaches only so
    // meets no point's segment (that point lies in its shadow, so in the leaf box's) and
    // gives 0 (or -1 with r, p and it in one plane: undecided, shaded exactly).
    for (size_t si = 0; si < g.surfaces.size() && open > 0; ++si)
      trees.for_each(
          g.surfaces[si],
          [&](const AABB& b, bool leaf) {
            if (open == 0) return false;
            const AABBd lb = local_box(b);
            if (box_outside(lb)) return false;
            if (leaf) return true;
            return first_in(shadow_box_of_box(lp, r, lb.lo, lb.hi)) < g.order.size();
          },
          [&](uint32_t t) {
            if (open == 0) return;
            const UVBox sb = triangle_box(t);
            if (!sb.overlaps(all)) return;
            for (size_t x = first_in(sb); x < g.order.size(); x = next_in(sb, x + 1)) {
              const uint32_t k = g.order[x];
              g.meet[k] = int8_t(SurfaceTrees::triangle_meets(mesh, t, rw, SumPoint(origin, g.pts[k])));
              if (g.meet[k] != 0) --open;
            }
          });
  }
  FragmentList& out = g.out;
  out.clear();
  for (size_t f = 0; f < g.pts.size(); ++f) {
    if (g.zero[f] == 1) {
      ++c.dropped;
      continue;
    }
    if (g.zero[f] == 2) {
      ++c.undecided;
      return false;
    }
    ++c.pieces;
    const Vec3d& p = g.pts[f];
    int blocked = g.meet[f];
    if (!listed)
      for (size_t si = 0; si < g.surfaces.size() && blocked == 0; ++si)
        blocked = trees.segment_meets(g.surfaces[si], mesh, rw, SumPoint(origin, p), od + p);
    if (blocked < 0) {
      ++c.undecided;
      return false;
    }
    if (blocked > 0) {
      ++c.blocked;
      continue;
    }
    out.add(frags.data(f), size_t(frags.count(f)));
  }
  std::swap(frags, out);
  return true;
}

}  // namespace visgate::plucker
