// Mesh repair and welding (see repair.h for the guarantee).
#include "lib/mesh/repair.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <unordered_map>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <tbb/enumerable_thread_specific.h>

#include "lib/mesh/box_tree.h"
#include "lib/mesh/repair_predicates.h"

namespace visgate::mesh {

namespace {

constexpr uint32_t kNone = 0xffffffffu;
using Tri = std::array<uint32_t, 3>;

struct UnionFind {
  std::vector<uint32_t> p;
  explicit UnionFind(size_t n) : p(n) { std::iota(p.begin(), p.end(), 0u); }
  uint32_t find(uint32_t x) {
    while (p[x] != x) {
      p[x] = p[p[x]];
      x = p[x];
    }
    return x;
  }
  // The root is always the smaller index, so a cluster's root is its lowest member.
  bool unite(uint32_t a, uint32_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b) p[b] = a; else p[a] = b;
    return true;
  }
};

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// ---------------------------------------------------------------------------------------
// Edge table: every (undirected) edge of the active triangles, grouped.

struct EdgeRec {
  uint64_t key;   // (min << 32) | max
  uint32_t tri;
  uint8_t k;      // edge k runs from corner k to corner k+1
  uint8_t fwd;    // 1 when the triangle traverses it from min to max
};

struct EdgeTable {
  std::vector<EdgeRec> recs;      // sorted by key, then triangle
  std::vector<uint32_t> start;    // group g is recs[start[g], start[g+1])
  std::vector<uint32_t> tri_edge;  // 3t + k -> group, kNone for inactive triangles

  size_t groups() const { return start.empty() ? 0 : start.size() - 1; }
  uint32_t size(size_t g) const { return start[g + 1] - start[g]; }
  uint32_t lo(size_t g) const { return uint32_t(recs[start[g]].key >> 32); }
  uint32_t hi(size_t g) const { return uint32_t(recs[start[g]].key & 0xffffffffu); }
};

// Edge records bucketed by their lower vertex (a counting sort, stable in triangle
// order), then each bucket sorted by its upper vertex: O(records) plus small sorts,
// where a global comparison sort of 3 records per triangle dominated the analysis.
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
        uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
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

// Neighbour across each edge of a triangle when exactly two triangles use it (kNone
// otherwise), and whether the two traverse it in the same direction.
struct Adjacency {
  std::vector<uint32_t> nb;   // 3t + k
  std::vector<uint8_t> same;  // 3t + k
};

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

// ---------------------------------------------------------------------------------------
// Boundary loops: walks of the boundary edges (edges with one face), undirected so that
// loops of non-orientable patches are found too.

struct Loop {
  std::vector<uint32_t> verts;   // closed: edge i joins verts[i] and verts[i+1 mod n]
  std::vector<uint32_t> groups;  // edge group of edge i
  bool closed = true;            // false: a chain that ended at a dead end
};

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

// ---------------------------------------------------------------------------------------
// T-junctions: a boundary vertex lying strictly inside a boundary edge (exact: collinear
// and strictly between the ends on every axis, coordinate comparisons being exact).

struct TJunction {
  uint32_t v, group;
};

bool strictly_inside_segment(const Vec3d& a, const Vec3d& b, const Vec3d& p, const FilteredPredicates& fp) {
  if (p == a || p == b) return false;
  for (int ax = 0; ax < 3; ++ax)
    if (p[ax] < std::min(a[ax], b[ax]) || p[ax] > std::max(a[ax], b[ax])) return false;
  return fp.collinear(a, b, p);
}

// Each boundary edge queries a tree of the boundary vertices with the segment itself:
// a node is visited only when its box overlaps the segment's box and the segment's line
// may meet it (line_may_meet_box, a conservative filter). Querying edge boxes with
// points instead made every vertex a candidate of every long diagonal edge around it.
std::vector<TJunction> find_t_junctions(const std::vector<Vec3d>& pos, const EdgeTable& e,
                                        const FilteredPredicates& fp) {
  std::vector<uint32_t> bedges;
  std::vector<uint32_t> bverts;
  for (uint32_t g = 0; g < e.groups(); ++g)
    if (e.size(g) == 1) {
      bedges.push_back(g);
      bverts.push_back(e.lo(g));
      bverts.push_back(e.hi(g));
    }
  std::vector<TJunction> out;
  if (bedges.empty()) return out;
  std::sort(bverts.begin(), bverts.end());
  bverts.erase(std::unique(bverts.begin(), bverts.end()), bverts.end());
  std::vector<Box3d> points(bverts.size());
  for (size_t i = 0; i < bverts.size(); ++i) points[i] = Box3d{pos[bverts[i]], pos[bverts[i]]};
  BoxTree tree(points);
  tbb::enumerable_thread_specific<std::vector<TJunction>> local;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, bedges.size(), 256), [&](const tbb::blocked_range<size_t>& r) {
    std::vector<TJunction>& mine = local.local();
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const uint32_t g = bedges[i], lo = e.lo(g), hi = e.hi(g);
      const Vec3d &a = pos[lo], &b = pos[hi];
      const Box3d sb{vmin(a, b), vmax(a, b)};
      tree.query_if([&](const Box3d& x) { return boxes_overlap(x, sb) && line_may_meet_box(a, b, x.lo, x.hi); },
                    [&](uint32_t k) {
                      const uint32_t v = bverts[k];
                      if (v != lo && v != hi && strictly_inside_segment(a, b, pos[v], fp)) mine.push_back({v, g});
                    });
    }
  });
  for (auto& part : local) out.insert(out.end(), part.begin(), part.end());
  std::sort(out.begin(), out.end(), [](const TJunction& x, const TJunction& y) {
    return x.group != y.group ? x.group < y.group : x.v < y.v;
  });
  return out;
}

// ---------------------------------------------------------------------------------------
// Fans around vertices: corners (3t + k) joined across two-face edges at their shared
// vertex. A vertex with more than one fan is non-manifold (a bowtie), and so is every end
// of a non-manifold edge (faces across it are never joined).

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

// ---------------------------------------------------------------------------------------
// Exact pair test for self-intersection of two non-degenerate triangles. Corners that
// share a class are the same point; the triangles may meet there (and along a shared
// edge) without intersecting.

bool pair_intersects(const std::vector<Vec3d>& pos, const Tri& A, const Tri& B, const uint32_t* cls,
                     const FilteredPredicates& fp) {
  auto c = [&](uint32_t v) { return cls ? cls[v] : v; };
  int sa[3] = {-1, -1, -1};  // for corner i of A: corner of B with the same class
  int shared = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      if (c(A[size_t(i)]) == c(B[size_t(j)])) { sa[i] = j; ++shared; break; }
  const Vec3d &a0 = pos[A[0]], &a1 = pos[A[1]], &a2 = pos[A[2]];
  const Vec3d &b0 = pos[B[0]], &b1 = pos[B[1]], &b2 = pos[B[2]];
  if (shared == 0) return fp.triangles_intersect(a0, a1, a2, b0, b1, b2);
  if (shared >= 3) return true;  // the same three points: the faces coincide
  if (shared == 2) {
    // Shared edge (u, w); apexes p of A and q of B. The planes meet in line uw, so the
    // faces meet beyond the edge iff they are coplanar and on the same side of it.
    int ia = sa[0] < 0 ? 0 : (sa[1] < 0 ? 1 : 2);
    int iu = (ia + 1) % 3, iw = (ia + 2) % 3;
    const Vec3d& u = pos[A[size_t(iu)]];
    const Vec3d& w = pos[A[size_t(iw)]];
    const Vec3d& p = pos[A[size_t(ia)]];
    int jb = 3 - sa[iu] - sa[iw];
    const Vec3d& q = pos[B[size_t(jb)]];
    if (fp.orientation(u, w, p, q) != 0) return false;
    return fp.coplanar_side(u, w, p, q) > 0;
  }
  // One shared vertex v: A = (v, a, b), B = (v, c, d). Their intersection is convex and
  // contains v; it holds a second point iff an edge opposite v crosses the other face, or
  // an edge at v runs (coplanar) into the other face's angle at v.
  int ia = sa[0] >= 0 ? 0 : (sa[1] >= 0 ? 1 : 2);
  int ib = sa[ia];
  const Vec3d& v = pos[A[size_t(ia)]];
  const Vec3d& a = pos[A[size_t((ia + 1) % 3)]];
  const Vec3d& b = pos[A[size_t((ia + 2) % 3)]];
  const Vec3d& cc = pos[B[size_t((ib + 1) % 3)]];
  const Vec3d& d = pos[B[size_t((ib + 2) % 3)]];
  // Plane sides first: when c and d lie strictly on one side of A's plane, B meets that
  // plane only at v (and likewise with the roles swapped).
  const int sc = fp.orientation(v, a, b, cc), sd = fp.orientation(v, a, b, d);
  if (sc == sd && sc != 0) return false;
  const int s_a = fp.orientation(v, cc, d, a), s_b = fp.orientation(v, cc, d, b);
  if (s_a == s_b && s_a != 0) return false;
  if (fp.segment_triangle_intersect(a, b, v, cc, d)) return true;
  if (fp.segment_triangle_intersect(cc, d, v, a, b)) return true;
  if (sc != 0 || sd != 0) return false;  // not coplanar: the two edge tests decide
  auto in_angle = [&](const Vec3d& x, const Vec3d& p, const Vec3d& q) {
    // x in the closed angle p-v-q, given x coplanar with v, p, q (angle < pi).
    return fp.coplanar_side(v, p, q, x) >= 0 && fp.coplanar_side(v, q, p, x) >= 0;
  };
  return in_angle(a, cc, d) || in_angle(b, cc, d) || in_angle(cc, a, b) || in_angle(d, a, b);
}

// Candidate pairs (overlapping boxes) come from a parallel dual traversal of the box
// tree and are decided where they are found, each thread keeping its own hits.
std::vector<std::array<uint32_t, 2>> self_intersections(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris,
                                                        const std::vector<uint8_t>& candidate, const uint32_t* cls,
                                                        const FilteredPredicates& fp, size_t& pairs_tested) {
  std::vector<uint32_t> ids;
  for (uint32_t t = 0; t < tris.size(); ++t)
    if (candidate[t]) ids.push_back(t);
  std::vector<Box3d> boxes(ids.size());
  tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i) {
      const Tri& t = tris[ids[i]];
      boxes[i] = Box3d{pos[t[0]], pos[t[0]]};
      boxes[i].extend(pos[t[1]]);
      boxes[i].extend(pos[t[2]]);
    }
  });
  BoxTree tree(boxes);
  struct Local {
    std::vector<std::array<uint32_t, 2>> hits;
    size_t pairs = 0;
  };
  tbb::enumerable_thread_specific<Local> local;
  tree.self_pairs_parallel(local, [&](Local& L, uint32_t i, uint32_t j) {
    ++L.pairs;
    uint32_t x = std::min(ids[i], ids[j]), y = std::max(ids[i], ids[j]);
    if (pair_intersects(pos, tris[x], tris[y], cls, fp)) L.hits.push_back({x, y});
  });
  std::vector<std::array<uint32_t, 2>> out;
  pairs_tested = 0;
  for (Local& L : local) {
    out.insert(out.end(), L.hits.begin(), L.hits.end());
    pairs_tested += L.pairs;
  }
  std::sort(out.begin(), out.end());
  return out;
}

// ---------------------------------------------------------------------------------------
// Nesting of closed shells (as CGAL's orient_to_bound_a_volume): a shell inside an odd
// number of other shells bounds a cavity and must face inward, the others outward.
// Inside-ness is ray parity along +x from a vertex, made exact by a symbolic
// perturbation of the ray's start in the (y, z) projection, p' = p + e (1, 0) + e^2 (0, 1)
// for an infinitesimal e: the ray then misses every edge and vertex, so each crossing is
// a strict point-in-triangle test in the projection plus the sign of the 3D orientation.

// Sign of the (y, z) orientation of a, b and the perturbed q; never 0 when a and b
// project to distinct points.
int perturbed_side(const Vec3d& a, const Vec3d& b, const Vec3d& q, const FilteredPredicates& fp) {
  const int s = fp.orient2d(a, b, q, 0);
  if (s != 0) return s;
  // d/de of (b - a) x (q' - a) in (y, z): -(b_z - a_z), then d/de^2: (b_y - a_y).
  if (a.z != b.z) return a.z > b.z ? 1 : -1;
  if (a.y != b.y) return b.y > a.y ? 1 : -1;
  return 0;
}

// 1: the perturbed +x ray from p crosses triangle t beyond p; 0: it does not; -1: p lies
// on the triangle (its plane, inside the perturbed projection), so parity says nothing.
int ray_crosses(const Vec3d& p, const Vec3d& a, const Vec3d& b, const Vec3d& c, const FilteredPredicates& fp) {
  // Cheap exact rejection: p's (y, z) outside the triangle's projected box (closed).
  if (p.y < std::min({a.y, b.y, c.y}) || p.y > std::max({a.y, b.y, c.y}) || p.z < std::min({a.z, b.z, c.z}) ||
      p.z > std::max({a.z, b.z, c.z}) || p.x > std::max({a.x, b.x, c.x}))
    return 0;
  const int area = fp.orient2d(a, b, c, 0);
  if (area == 0) return 0;  // zero projected area: the perturbed ray misses it
  if (perturbed_side(a, b, p, fp) != area || perturbed_side(b, c, p, fp) != area || perturbed_side(c, a, p, fp) != area)
    return 0;
  const int d = fp.orientation(a, b, c, p);
  if (d == 0) return -1;
  return d != area ? 1 : 0;  // the hit is at t = -det / n_x, ahead of p iff the signs differ
}

// Whether `inner` lies inside the closed shell `outer`: parity at the lowest-index vertex
// of `inner` that is not on `outer`. False when every vertex is on `outer` (coincident
// shells). The vertex order, not the triangle order or orientation, picks the vertex, so
// repair and the analysis of its output agree even on shells that cross.
bool shell_inside(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris, const std::vector<uint32_t>& inner,
                  const std::vector<uint32_t>& outer, const FilteredPredicates& fp) {
  std::vector<uint32_t> verts;
  verts.reserve(inner.size() * 3);
  for (uint32_t t : inner) verts.insert(verts.end(), tris[t].begin(), tris[t].end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  for (uint32_t v : verts) {
    const Vec3d& p = pos[v];
    int crossings = 0;
    bool on = false;
    for (uint32_t u : outer) {
      const int r = ray_crosses(p, pos[tris[u][0]], pos[tris[u][1]], pos[tris[u][2]], fp);
      if (r < 0) { on = true; break; }
      crossings += r;
    }
    if (!on) return crossings % 2 == 1;
  }
  return false;
}

// depth[i]: how many of the other shells contain shell i (by a vertex of it; shells
// of a valid solid do not cross). Only shells whose box lies in the other's box are
// tested.
std::vector<int> nesting_depths(const std::vector<Vec3d>& pos, const std::vector<Tri>& tris,
                                const std::vector<std::vector<uint32_t>>& shells, const FilteredPredicates& fp) {
  const size_t n = shells.size();
  std::vector<Box3d> box(n);
  for (size_t i = 0; i < n; ++i) {
    box[i] = Box3d{pos[tris[shells[i][0]][0]], pos[tris[shells[i][0]][0]]};
    for (uint32_t t : shells[i])
      for (uint32_t v : tris[t]) box[i].extend(pos[v]);
  }
  auto within = [](const Box3d& a, const Box3d& b) {
    return b.lo.x <= a.lo.x && b.lo.y <= a.lo.y && b.lo.z <= a.lo.z && a.hi.x <= b.hi.x && a.hi.y <= b.hi.y &&
           a.hi.z <= b.hi.z;
  };
  std::vector<int> depth(n, 0);
  if (n < 2) return depth;
  tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 1), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t i = r.begin(); i < r.end(); ++i)
      for (size_t j = 0; j < n; ++j)
        if (j != i && within(box[i], box[j]) && shell_inside(pos, tris, shells[i], shells[j], fp)) ++depth[i];
  });
  return depth;
}

// Sorted vertex triple, the key of duplicate detection.
inline std::array<uint32_t, 3> sorted3(const Tri& t) {
  std::array<uint32_t, 3> s = t;
  std::sort(s.begin(), s.end());
  return s;
}
// Same cyclic order (same orientation) for two triangles on the same vertex set.
inline bool same_orientation(const Tri& a, const Tri& b) {
  for (int r = 0; r < 3; ++r)
    if (a[0] == b[size_t(r)] && a[1] == b[size_t((r + 1) % 3)] && a[2] == b[size_t((r + 2) % 3)]) return true;
  return false;
}

// Marks later copies of a face: dup[t] = 1 (same orientation as the first), 2 (opposite).
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

}  // namespace

// ---------------------------------------------------------------------------------------

std::vector<std::pair<const char*, size_t>> DefectCounts::items() const {
  return {{"near_duplicate_vertices", near_duplicate_vertices},
          {"repeated_vertex_faces", repeated_vertex_faces},
          {"zero_area_faces", zero_area_faces},
          {"duplicate_faces", duplicate_faces},
          {"opposite_duplicate_faces", opposite_duplicate_faces},
          {"t_junctions", t_junctions},
          {"nonmanifold_edges", nonmanifold_edges},
          {"nonmanifold_vertices", nonmanifold_vertices},
          {"inconsistent_edges", inconsistent_edges},
          {"nonorientable_components", nonorientable_components},
          {"inward_components", inward_components},
          {"zero_volume_components", zero_volume_components},
          {"boundary_loops", boundary_loops},
          {"self_intersections", self_intersections}};
}

size_t DefectCounts::total() const {
  size_t s = 0;
  for (const auto& [name, n] : items()) s += n;
  return s;
}

Analysis analyze_mesh(const IndexedMesh& m, const ExactPredicates& ex, const std::vector<uint32_t>* vertex_class) {
  Analysis A;
  const FilteredPredicates fp(ex);
  const auto& tris = m.triangles;
  const auto& pos = m.vertices;
  const size_t nt = tris.size();
  A.triangles = nt;
  {
    std::vector<uint8_t> seen(pos.size(), 0);
    for (const auto& t : tris)
      for (uint32_t v : t) seen[v] = 1;
    A.vertices = size_t(std::count(seen.begin(), seen.end(), uint8_t(1)));
  }
  auto phase = std::chrono::steady_clock::now();
  auto lap = [&](const char* what) {
    A.seconds.push_back({what, seconds_since(phase)});
    phase = std::chrono::steady_clock::now();
  };
  // Faces: repeated vertices, zero area, duplicates.
  std::vector<uint8_t> active(nt, 1), candidate(nt, 1);
  for (size_t t = 0; t < nt; ++t) {
    const Tri& f = tris[t];
    if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
      active[t] = candidate[t] = 0;
      ++A.defects.repeated_vertex_faces;
    } else if (fp.collinear(pos[f[0]], pos[f[1]], pos[f[2]])) {
      candidate[t] = 0;
      ++A.defects.zero_area_faces;
    }
  }
  std::vector<uint8_t> dup = find_duplicates(tris, active, pos.size());
  for (size_t t = 0; t < nt; ++t) {
    if (dup[t] == 1) ++A.defects.duplicate_faces;
    if (dup[t] == 2) ++A.defects.opposite_duplicate_faces;
    if (dup[t]) candidate[t] = 0;
  }
  lap("faces");
  // Edges.
  EdgeTable e = build_edges(tris, &active, pos.size());
  A.edges = e.groups();
  std::vector<uint8_t> vert_on_nm_edge(pos.size(), 0);
  for (size_t g = 0; g < e.groups(); ++g) {
    uint32_t s = e.size(g);
    if (s == 1) ++A.boundary_edges;
    if (s >= 3) {
      ++A.defects.nonmanifold_edges;
      A.nonmanifold_edges.push_back({e.lo(g), e.hi(g)});
      vert_on_nm_edge[e.lo(g)] = vert_on_nm_edge[e.hi(g)] = 1;
    }
    if (s == 2 && e.recs[e.start[g]].fwd == e.recs[e.start[g] + 1].fwd) ++A.defects.inconsistent_edges;
  }
  // Components: faces joined through any shared edge.
  UnionFind comp_uf(nt);
  for (size_t g = 0; g < e.groups(); ++g)
    for (uint32_t i = e.start[g] + 1; i < e.start[g + 1]; ++i) comp_uf.unite(e.recs[e.start[g]].tri, e.recs[i].tri);
  std::vector<uint32_t> comp_of(nt, kNone);
  std::vector<uint32_t> roots;
  for (uint32_t t = 0; t < nt; ++t) {
    if (!active[t]) continue;
    uint32_t r = comp_uf.find(t);
    if (comp_of[r] == kNone) {
      comp_of[r] = uint32_t(roots.size());
      roots.push_back(r);
    }
    comp_of[t] = comp_of[r];
  }
  const size_t nc = roots.size();
  A.components.assign(nc, ComponentInfo{});
  std::vector<uint8_t> comp_nm(nc, 0), comp_bd(nc, 0);
  for (uint32_t t = 0; t < nt; ++t)
    if (active[t]) ++A.components[comp_of[t]].faces;
  for (size_t g = 0; g < e.groups(); ++g) {
    uint32_t c = comp_of[e.recs[e.start[g]].tri];
    ++A.components[c].edges;
    if (e.size(g) >= 3) comp_nm[c] = 1;
    if (e.size(g) == 1) comp_bd[c] = 1;
    if (e.size(g) == 2 && e.recs[e.start[g]].fwd == e.recs[e.start[g] + 1].fwd) A.components[c].consistent = false;
  }
  {
    // Distinct vertices per component: a vertex counts once for the first component
    // that uses it; the rare other (vertex, component) incidences (vertices shared by
    // components through a corner only) are sorted and counted apart.
    std::vector<uint32_t> first_comp(pos.size(), kNone);
    std::vector<uint64_t> extra;
    for (uint32_t t = 0; t < nt; ++t)
      if (active[t])
        for (uint32_t v : tris[t]) {
          if (first_comp[v] == kNone) {
            first_comp[v] = comp_of[t];
            ++A.components[comp_of[t]].vertices;
          } else if (first_comp[v] != comp_of[t]) {
            extra.push_back(uint64_t(comp_of[t]) << 32 | v);
          }
        }
    std::sort(extra.begin(), extra.end());
    extra.erase(std::unique(extra.begin(), extra.end()), extra.end());
    for (uint64_t x : extra) ++A.components[x >> 32].vertices;
  }
  // Orientability: parity propagation across two-face edges (BFS per component).
  Adjacency adj = build_adjacency(e, nt);
  {
    std::vector<int8_t> parity(nt, -1);
    std::vector<uint32_t> queue;
    for (uint32_t s = 0; s < nt; ++s) {
      if (!active[s] || parity[s] >= 0) continue;
      parity[s] = 0;
      queue.assign(1, s);
      for (size_t qi = 0; qi < queue.size(); ++qi) {
        uint32_t t = queue[qi];
        for (int k = 0; k < 3; ++k) {
          uint32_t u = adj.nb[3 * size_t(t) + size_t(k)];
          if (u == kNone) continue;
          int8_t want = int8_t(parity[t] ^ adj.same[3 * size_t(t) + size_t(k)]);
          if (parity[u] < 0) {
            parity[u] = want;
            queue.push_back(u);
          } else if (parity[u] != want) {
            A.components[comp_of[t]].orientable = false;
          }
        }
      }
    }
  }
  lap("components");
  // Closed components: orientation by the exact sign of the enclosed volume.
  {
    std::vector<std::vector<uint32_t>> members(nc);
    for (uint32_t t = 0; t < nt; ++t)
      if (active[t] && !comp_nm[comp_of[t]] && !comp_bd[comp_of[t]]) members[comp_of[t]].push_back(t);
    for (size_t c = 0; c < nc; ++c) {
      ComponentInfo& ci = A.components[c];
      ci.closed = !comp_nm[c] && !comp_bd[c];
      if (ci.closed) ++A.closed_components;
      if (!ci.orientable) ++A.defects.nonorientable_components;
      if (ci.closed && ci.orientable && ci.consistent) {
        ci.volume_sign = ex.volume_sign(pos, tris, members[c]);
        if (ci.volume_sign == 0) ++A.defects.zero_volume_components;
      }
    }
    // Nesting: a shell inside an odd number of others bounds a cavity and faces inward.
    std::vector<std::vector<uint32_t>> shells;
    std::vector<size_t> shell_comp;
    for (size_t c = 0; c < nc; ++c)
      if (A.components[c].volume_sign != 0) {
        shells.push_back(std::move(members[c]));
        shell_comp.push_back(c);
      }
    const std::vector<int> depth = nesting_depths(pos, tris, shells, fp);
    for (size_t i = 0; i < shells.size(); ++i) {
      ComponentInfo& ci = A.components[shell_comp[i]];
      ci.depth = depth[i];
      if (depth[i] % 2 == 1) ++A.cavities;
      if (ci.volume_sign != (depth[i] % 2 == 1 ? -1 : 1)) ++A.defects.inward_components;
    }
  }
  lap("volumes");
  // Boundary loops.
  for (Loop& L : boundary_loops(e)) {
    ++A.components[comp_of[e.recs[e.start[L.groups[0]]].tri]].boundary_loops;
    A.boundary_loops.push_back(std::move(L.verts));
  }
  A.defects.boundary_loops = A.boundary_loops.size();
  lap("boundary_loops");
  // T-junctions.
  for (const TJunction& tj : find_t_junctions(pos, e, fp)) A.t_junctions.push_back({tj.v, e.lo(tj.group), e.hi(tj.group)});
  A.defects.t_junctions = A.t_junctions.size();
  lap("t_junctions");
  // Non-manifold vertices: more than one fan.
  {
    UnionFind fans = corner_fans(tris, e);
    std::vector<uint32_t> first_root(pos.size(), kNone);
    std::vector<uint8_t> multi(pos.size(), 0);
    for (uint32_t t = 0; t < nt; ++t) {
      if (!active[t]) continue;
      for (uint32_t k = 0; k < 3; ++k) {
        uint32_t v = tris[t][k], r = fans.find(3 * t + k);
        if (first_root[v] == kNone) first_root[v] = r;
        else if (first_root[v] != r) multi[v] = 1;
      }
    }
    std::vector<uint8_t> comp_nmv(nc, 0);
    for (uint32_t v = 0; v < pos.size(); ++v)
      if (multi[v] && !vert_on_nm_edge[v]) A.nonmanifold_vertices.push_back(v);
    for (uint32_t t = 0; t < nt; ++t)
      if (active[t])
        for (uint32_t v : tris[t])
          if (multi[v]) comp_nmv[comp_of[t]] = 1;
    A.defects.nonmanifold_vertices = A.nonmanifold_vertices.size();
    // Genus where defined: orientable 2-manifold with boundary, chi = V - E + F = 2 - 2g - b.
    for (size_t c = 0; c < nc; ++c) {
      ComponentInfo& ci = A.components[c];
      if (!ci.orientable || comp_nm[c] || comp_nmv[c]) continue;
      long chi = long(ci.vertices) - long(ci.edges) + long(ci.faces);
      long twice_g = 2 - chi - long(ci.boundary_loops);
      if (twice_g >= 0 && twice_g % 2 == 0) ci.genus = int(twice_g / 2);
    }
  }
  lap("fans");
  // Self-intersections.
  A.self_intersections = self_intersections(pos, tris, candidate, vertex_class ? vertex_class->data() : nullptr, fp,
                                            A.self_intersection_pairs_tested);
  A.defects.self_intersections = A.self_intersections.size();
  lap("self_intersections");
  return A;
}

// ---------------------------------------------------------------------------------------

bool triangulate_polygon(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& poly, std::vector<Tri>& out) {
  const size_t n = poly.size();
  if (n < 3) return true;
  if (n == 3) {
    out.push_back({poly[0], poly[1], poly[2]});
    return true;
  }
  // Newell normal; project along its dominant axis, keeping the polygon's sense.
  Vec3d nrm(0, 0, 0);
  for (size_t i = 0; i < n; ++i) {
    const Vec3d& a = pos[poly[i]];
    const Vec3d& b = pos[poly[(i + 1) % n]];
    nrm.x += (a.y - b.y) * (a.z + b.z);
    nrm.y += (a.z - b.z) * (a.x + b.x);
    nrm.z += (a.x - b.x) * (a.y + b.y);
  }
  int ax = max_axis(vabs(nrm));
  int u = (ax + 1) % 3, w = (ax + 2) % 3;
  double sense = nrm[ax] >= 0 ? 1.0 : -1.0;
  auto cross2 = [&](uint32_t a, uint32_t b, uint32_t c) {
    const Vec3d &pa = pos[a], &pb = pos[b], &pc = pos[c];
    return sense * ((pb[u] - pa[u]) * (pc[w] - pa[w]) - (pb[w] - pa[w]) * (pc[u] - pa[u]));
  };
  std::vector<uint32_t> ring(poly);
  bool ears_only = true;
  while (ring.size() > 3) {
    const size_t m = ring.size();
    size_t best = m;
    for (size_t i = 0; i < m && best == m; ++i) {
      uint32_t a = ring[(i + m - 1) % m], b = ring[i], c = ring[(i + 1) % m];
      if (!(cross2(a, b, c) > 0)) continue;  // reflex or flat corner: not an ear
      bool empty = true;
      for (size_t j = 0; j < m && empty; ++j) {
        uint32_t p = ring[j];
        if (p == a || p == b || p == c) continue;
        if (cross2(a, b, p) >= 0 && cross2(b, c, p) >= 0 && cross2(c, a, p) >= 0) empty = false;
      }
      if (empty) best = i;
    }
    if (best == m) {  // no ear (self-intersecting or degenerate polygon): fan the rest
      ears_only = false;
      for (size_t k = 1; k + 1 < ring.size(); ++k) out.push_back({ring[0], ring[k], ring[k + 1]});
      return false;
    }
    out.push_back({ring[(best + m - 1) % m], ring[best], ring[(best + 1) % m]});
    ring.erase(ring.begin() + long(best));
  }
  out.push_back({ring[0], ring[1], ring[2]});
  return ears_only;
}

// ---------------------------------------------------------------------------------------

WeldResult weld_vertices_exact(const std::vector<Vec3d>& pos, const std::vector<uint8_t>& used, double tolerance,
                               WeldMode mode, const ExactPredicates& ex) {
  const size_t n = pos.size();
  WeldResult W;
  W.rep.resize(n);
  std::iota(W.rep.begin(), W.rep.end(), 0u);
  std::vector<uint32_t> ids;
  for (uint32_t i = 0; i < n; ++i)
    if (used[i]) ids.push_back(i);
  if (ids.empty()) return W;
  UnionFind uf(n);
  if (tolerance == 0.0) {
    // Exactly equal positions (-0 == +0): neighbours in lexicographic order.
    std::vector<uint32_t> order(ids);
    auto less = [&](uint32_t a, uint32_t b) {
      const Vec3d &p = pos[a], &q = pos[b];
      if (p.x != q.x) return p.x < q.x;
      if (p.y != q.y) return p.y < q.y;
      if (p.z != q.z) return p.z < q.z;
      return a < b;
    };
    std::sort(order.begin(), order.end(), less);
    for (size_t i = 1; i < order.size(); ++i)
      if (pos[order[i]] == pos[order[i - 1]]) uf.unite(order[i], order[i - 1]);
  } else {
    // Spatial hashing. Cells of side h >= T (1 + 2^-8), at most 2^40 per axis so keys
    // fit: two points within T then fall in the same or adjacent cells. The key
    // floor(fl(fl(p - lo) / h)) is monotone in p, and its rounding error (a few ulps of
    // a value below 2^41, i.e. below 2^-10) is smaller than the 2^-8 relative margin, so
    // keys of points within T differ by at most one. The key is computed in long double
    // (64-bit significand, wider exponent) so that p - lo cannot overflow.
    Vec3d lo = pos[ids[0]], hi = lo;
    for (uint32_t i : ids) {
      lo = vmin(lo, pos[i]);
      hi = vmax(hi, pos[i]);
    }
    long double extent = 0;
    for (int k = 0; k < 3; ++k) extent = std::max(extent, (long double)hi[k] - (long double)lo[k]);
    const long double h = std::max((long double)tolerance, extent * 0x1p-40L) * (1.0L + 0x1p-8L);
    struct CellKey {
      int64_t c[3];
      uint32_t id;
    };
    std::vector<CellKey> keys(ids.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, ids.size(), 1 << 14), [&](const tbb::blocked_range<size_t>& r) {
      for (size_t i = r.begin(); i < r.end(); ++i) {
        keys[i].id = ids[i];
        for (int k = 0; k < 3; ++k)
          keys[i].c[k] = int64_t(std::floor(((long double)pos[ids[i]][k] - (long double)lo[k]) / h));
      }
    });
    // Cells as ranges of the keys sorted by cell.
    auto cell_less = [](const CellKey& x, const CellKey& y) {
      if (x.c[0] != y.c[0]) return x.c[0] < y.c[0];
      if (x.c[1] != y.c[1]) return x.c[1] < y.c[1];
      if (x.c[2] != y.c[2]) return x.c[2] < y.c[2];
      return x.id < y.id;
    };
    std::sort(keys.begin(), keys.end(), cell_less);
    auto cmp_cell = [](const int64_t* x, const int64_t* y) {
      for (int k = 0; k < 3; ++k)
        if (x[k] != y[k]) return x[k] < y[k] ? -1 : 1;
      return 0;
    };
    std::vector<uint32_t> cell_start;
    for (uint32_t i = 0; i < keys.size(); ++i)
      if (i == 0 || cmp_cell(keys[i].c, keys[i - 1].c) != 0) cell_start.push_back(i);
    cell_start.push_back(uint32_t(keys.size()));
    const uint32_t ncells = uint32_t(cell_start.size() - 1);
    auto cell_key = [&](uint32_t cell) { return keys[cell_start[cell]].c; };
    const double t2 = tolerance * tolerance;
    auto try_pair = [&](uint32_t i, uint32_t j) {
      // Double filter: d2 and t2 carry relative errors below 8 * 2^-53; a 2^-40 margin
      // decides clear cases, the exact predicate the rest.
      Vec3d d = pos[i] - pos[j];
      double d2 = dot(d, d);
      if (d2 > t2 * (1 + 0x1p-40) && t2 > 0x1p-900) return;
      if ((d2 < t2 * (1 - 0x1p-40) && d2 > 0x1p-900) || ex.compare_distance(pos[i], pos[j], tolerance) <= 0)
        uf.unite(i, j);
    };
    auto cross_cells = [&](uint32_t a, uint32_t b) {
      for (uint32_t i = cell_start[a]; i < cell_start[a + 1]; ++i)
        for (uint32_t j = cell_start[b]; j < cell_start[b + 1]; ++j) try_pair(keys[i].id, keys[j].id);
    };
    // Each pair of adjacent cells once: a cell with itself, with (0, 0, +1), and with the
    // three cells z-1..z+1 of the rows (x, y+1), (x+1, y-1), (x+1, y), (x+1, y+1). Cells
    // are visited in sorted order, so the cells of each such row are found by a pointer
    // that only moves forward (a merge, no hashing).
    const int64_t rows[4][2] = {{0, 1}, {1, -1}, {1, 0}, {1, 1}};
    uint32_t ptr[4] = {0, 0, 0, 0};
    for (uint32_t cell = 0; cell < ncells; ++cell) {
      const int64_t* c = cell_key(cell);
      for (uint32_t i = cell_start[cell]; i < cell_start[cell + 1]; ++i)
        for (uint32_t j = i + 1; j < cell_start[cell + 1]; ++j) try_pair(keys[i].id, keys[j].id);
      if (cell + 1 < ncells) {
        const int64_t up[3] = {c[0], c[1], c[2] + 1};
        if (cmp_cell(cell_key(cell + 1), up) == 0) cross_cells(cell, cell + 1);
      }
      for (int r = 0; r < 4; ++r) {
        const int64_t first[3] = {c[0] + rows[r][0], c[1] + rows[r][1], c[2] - 1};
        const int64_t last[3] = {c[0] + rows[r][0], c[1] + rows[r][1], c[2] + 1};
        while (ptr[r] < ncells && cmp_cell(cell_key(ptr[r]), first) < 0) ++ptr[r];
        for (uint32_t o = ptr[r]; o < ncells && cmp_cell(cell_key(o), last) <= 0; ++o) cross_cells(cell, o);
      }
    }
  }
  // Clusters (root = lowest member; members collected in ascending order).
  std::vector<uint32_t> size(n, 0);
  for (uint32_t i : ids) ++size[uf.find(i)];
  std::unordered_map<uint32_t, std::vector<uint32_t>> members;
  std::vector<uint32_t> roots;
  for (uint32_t i : ids) {
    uint32_t r = uf.find(i);
    if (size[r] < 2) continue;
    if (r == i) roots.push_back(r);
    members[r].push_back(i);
  }
  for (uint32_t r : roots) {
    const std::vector<uint32_t>& list = members[r];
    for (uint32_t i : list) W.rep[i] = r;
    if (tolerance == 0.0) continue;
    // Diameter: all pairs for clusters up to 4096 vertices; larger ones by a double
    // sweep (farthest from the first, then farthest from that), a lower bound.
    WeldCluster wc;
    wc.vertices = list;
    auto farther = [&](uint32_t a, uint32_t b) {
      double d = length(pos[a] - pos[b]);
      wc.diameter = std::max(wc.diameter, d);
      if (!wc.exceeds_tolerance && d >= tolerance * (1 - 0x1p-40) && ex.compare_distance(pos[a], pos[b], tolerance) > 0)
        wc.exceeds_tolerance = true;
    };
    if (list.size() <= 4096) {
      for (size_t a = 0; a < list.size(); ++a)
        for (size_t b = a + 1; b < list.size(); ++b) farther(list[a], list[b]);
    } else {
      uint32_t far = list[0];
      double best = -1;
      for (uint32_t i : list) {
        double d = length(pos[i] - pos[list[0]]);
        if (d > best) { best = d; far = i; }
      }
      for (uint32_t i : list) farther(far, i);
    }
    if (!wc.exceeds_tolerance) continue;
    if (mode == WeldMode::Strict) {
      // Greedy complete linkage in ascending index order: a vertex joins the first group
      // whose every member is within T of it.
      std::vector<std::vector<uint32_t>> groups;
      for (uint32_t i : list) {
        bool placed = false;
        for (auto& g : groups) {
          bool ok = true;
          for (uint32_t j : g)
            if (ex.compare_distance(pos[i], pos[j], tolerance) > 0) { ok = false; break; }
          if (ok) {
            g.push_back(i);
            placed = true;
            break;
          }
        }
        if (!placed) groups.push_back({i});
      }
      W.strict_splits += groups.size() - 1;
      for (auto& g : groups)
        for (uint32_t i : g) W.rep[i] = g[0];
    }
    W.chained.push_back(std::move(wc));
  }
  std::fill(size.begin(), size.end(), 0u);
  for (uint32_t i : ids) {
    if (W.rep[i] != i) ++W.merged;
    if (++size[W.rep[i]] == 2) ++W.clusters;
  }
  return W;
}

// ---------------------------------------------------------------------------------------
// Repair steps.

namespace {

struct Work {
  std::vector<Vec3d> pos;
  std::vector<Tri> tris;
  std::vector<uint32_t> src;  // input face per triangle
};

// Removes triangles with keep[t] == 0, recording `reason` for each.
void remove_triangles(Work& w, const std::vector<uint8_t>& keep, const std::vector<const char*>& reason,
                      std::vector<RemovedTriangle>& removed) {
  size_t o = 0;
  for (size_t t = 0; t < w.tris.size(); ++t) {
    if (keep[t]) {
      w.tris[o] = w.tris[t];
      w.src[o] = w.src[t];
      ++o;
    } else if (w.src[t] != kFilledHole) {
      removed.push_back({w.src[t], reason[t]});
    }
  }
  w.tris.resize(o);
  w.src.resize(o);
}

// Splits every boundary edge at the boundary vertices strictly inside it (T-junctions).
// A triangle whose edge (a, b) holds points p1..pm (ordered from a) becomes the fan
// (a, p1, c), (p1, p2, c), ..., (pm, b, c) with c its third corner; none is degenerate
// because each p lies strictly inside ab and c is off that line (zero-area triangles were
// removed before). Returns the number of points inserted.
size_t split_t_junctions(Work& w, const ExactPredicates& ex, size_t& added) {
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  std::vector<TJunction> tj = find_t_junctions(w.pos, e, FilteredPredicates(ex));
  if (tj.empty()) return 0;
  std::unordered_map<uint64_t, std::vector<uint32_t>> points;  // edge key -> points, ordered from lo
  for (const TJunction& j : tj) points[e.recs[e.start[j.group]].key].push_back(j.v);
  for (auto& [key, list] : points) {
    const Vec3d& a = w.pos[uint32_t(key >> 32)];
    const Vec3d& b = w.pos[uint32_t(key & 0xffffffffu)];
    int ax = max_axis(vabs(b - a));  // a != b on this axis: coordinate order is exact
    bool up = a[ax] < b[ax];
    std::sort(list.begin(), list.end(), [&](uint32_t p, uint32_t q) {
      return up ? w.pos[p][ax] < w.pos[q][ax] : w.pos[p][ax] > w.pos[q][ax];
    });
  }
  std::vector<uint32_t> queue(w.tris.size());
  std::iota(queue.begin(), queue.end(), 0u);
  const size_t before = w.tris.size();
  while (!queue.empty()) {
    uint32_t t = queue.back();
    queue.pop_back();
    for (int k = 0; k < 3; ++k) {
      uint32_t a = w.tris[t][size_t(k)], b = w.tris[t][size_t((k + 1) % 3)], c = w.tris[t][size_t((k + 2) % 3)];
      uint64_t key = a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a);
      auto it = points.find(key);
      if (it == points.end()) continue;
      std::vector<uint32_t> chain{a};
      if (a < b) chain.insert(chain.end(), it->second.begin(), it->second.end());
      else chain.insert(chain.end(), it->second.rbegin(), it->second.rend());
      chain.push_back(b);
      points.erase(it);
      uint32_t s = w.src[t];
      w.tris[t] = {chain[0], chain[1], c};
      queue.push_back(t);
      for (size_t i = 1; i + 1 < chain.size(); ++i) {
        w.tris.push_back({chain[i], chain[i + 1], c});
        w.src.push_back(s);
        queue.push_back(uint32_t(w.tris.size() - 1));
      }
      break;
    }
  }
  added = w.tris.size() - before;
  return tj.size();
}

struct OrientStats {
  size_t consistency_flips = 0, outward_components = 0, outward_flips = 0, nonorientable_skipped = 0, cavities = 0;
};

// Consistent orientation per patch (faces joined across two-face edges), flipping the
// minority; closed patches then bound the solid: outward by the exact volume sign, or
// inward where nesting makes them a cavity.
OrientStats orient(Work& w, const ExactPredicates& ex) {
  OrientStats st;
  const size_t nt = w.tris.size();
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  Adjacency adj = build_adjacency(e, nt);
  std::vector<int8_t> parity(nt, -1);
  std::vector<uint32_t> patch;
  std::vector<std::vector<uint32_t>> closed_patches;
  for (uint32_t s = 0; s < nt; ++s) {
    if (parity[s] >= 0) continue;
    parity[s] = 0;
    patch.assign(1, s);
    bool conflict = false, closed = true;
    for (size_t qi = 0; qi < patch.size(); ++qi) {
      uint32_t t = patch[qi];
      for (int k = 0; k < 3; ++k) {
        uint32_t u = adj.nb[3 * size_t(t) + size_t(k)];
        if (u == kNone) { closed = false; continue; }
        int8_t want = int8_t(parity[t] ^ adj.same[3 * size_t(t) + size_t(k)]);
        if (parity[u] < 0) {
          parity[u] = want;
          patch.push_back(u);
        } else if (parity[u] != want) {
          conflict = true;
        }
      }
    }
    if (conflict) {  // non-orientable: leave it as it is, reported by the analysis
      ++st.nonorientable_skipped;
      continue;
    }
    size_t ones = 0;
    for (uint32_t t : patch) ones += size_t(parity[t]);
    int8_t flip_if = ones * 2 > patch.size() ? 0 : 1;
    for (uint32_t t : patch)
      if (parity[t] == flip_if) {
        std::swap(w.tris[t][1], w.tris[t][2]);
        ++st.consistency_flips;
      }
    if (closed) closed_patches.push_back(patch);
  }
  // Closed patches face outward, or inward where they bound a cavity (nesting parity).
  std::vector<std::vector<uint32_t>> shells;
  std::vector<int> sign;
  for (auto& p : closed_patches) {
    const int s = ex.volume_sign(w.pos, w.tris, p);
    if (s == 0) continue;
    shells.push_back(std::move(p));
    sign.push_back(s);
  }
  const std::vector<int> depth = nesting_depths(w.pos, w.tris, shells, FilteredPredicates(ex));
  for (size_t i = 0; i < shells.size(); ++i) {
    if (depth[i] % 2 == 1) ++st.cavities;
    if (sign[i] == (depth[i] % 2 == 1 ? -1 : 1)) continue;
    for (uint32_t t : shells[i]) std::swap(w.tris[t][1], w.tris[t][2]);
    ++st.outward_components;
    st.outward_flips += shells[i].size();
  }
  return st;
}

// Minimum-area triangulation of the closed polygon `poly` (Liepa's dynamic program over
// sub-polygons, O(n^3)): a float proposal, checked exactly by the caller. Triangles
// whose sides would reuse an existing mesh edge as a chord (`is_edge`) are not allowed.
// Returns false when no triangulation avoids them. Triangles follow the polygon's order.
template <class IsEdge>
bool min_area_triangulation(const std::vector<Vec3d>& pos, const std::vector<uint32_t>& poly, IsEdge&& is_edge,
                            std::vector<Tri>& out) {
  const size_t n = poly.size();
  const double kInf = std::numeric_limits<double>::infinity();
  std::vector<double> W(n * n, 0.0);
  std::vector<uint32_t> K(n * n, kNone);
  auto area = [&](size_t i, size_t k, size_t j) {
    return 0.5 * length(cross(pos[poly[k]] - pos[poly[i]], pos[poly[j]] - pos[poly[i]]));
  };
  // A chord (i, j), j > i + 1 and not the closing pair (0, n-1), must not be a mesh edge.
  auto chord_ok = [&](size_t i, size_t j) { return j == i + 1 || (i == 0 && j == n - 1) || !is_edge(poly[i], poly[j]); };
  for (size_t len = 2; len < n; ++len)
    for (size_t i = 0; i + len < n; ++i) {
      const size_t j = i + len;
      double best = kInf;
      uint32_t arg = kNone;
      if (chord_ok(i, j))
        for (size_t k = i + 1; k < j; ++k) {
          const double c = W[i * n + k] + W[k * n + j] + area(i, k, j);
          if (c < best) { best = c; arg = uint32_t(k); }
        }
      W[i * n + j] = best;
      K[i * n + j] = arg;
    }
  if (K[n - 1] == kNone) return false;
  std::vector<std::pair<size_t, size_t>> stack{{0, n - 1}};
  while (!stack.empty()) {
    auto [i, j] = stack.back();
    stack.pop_back();
    if (j < i + 2) continue;
    const size_t k = K[i * n + j];
    if (k == kNone) return false;
    out.push_back({poly[i], poly[k], poly[j]});
    stack.push_back({i, k});
    stack.push_back({k, j});
  }
  return true;
}

// Why a fill cannot be applied, or nullptr when every check passes: each triangle is
// non-degenerate, no triangle repeats a face of the mesh or of the fill (in either
// orientation), no chord is a mesh edge or used by more than two fill triangles, and no
// triangle meets a mesh triangle or another fill triangle beyond their shared vertices
// and edges (exact).
const char* fill_defect(const std::vector<Vec3d>& pos, const std::vector<Tri>& fill, const std::vector<Tri>& tris,
                        const BoxTree& tree, const std::vector<Box3d>& boxes,
                        const std::unordered_map<uint64_t, uint32_t>& edge_count,
                        const std::unordered_map<uint64_t, uint8_t>& faces, const FilteredPredicates& fp) {
  auto ekey = [](uint32_t a, uint32_t b) { return a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a); };
  auto fkey = [](const Tri& t) {
    const auto k = sorted3(t);
    return uint64_t(k[0]) * 0x9E3779B97F4A7C15ull ^ (uint64_t(k[1]) << 32 | k[2]);
  };
  for (const Tri& t : fill)
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || fp.collinear(pos[t[0]], pos[t[1]], pos[t[2]]))
      return "degenerate_triangle";
  // Faces: the hash only proposes; the sorted triples decide.
  for (size_t i = 0; i < fill.size(); ++i) {
    if (faces.count(fkey(fill[i])))
      for (const Tri& m : tris)
        if (sorted3(m) == sorted3(fill[i])) return same_orientation(m, fill[i]) ? "duplicate_face" : "opposite_duplicate_face";
    for (size_t j = 0; j < i; ++j)
      if (sorted3(fill[j]) == sorted3(fill[i]))
        return same_orientation(fill[j], fill[i]) ? "duplicate_face" : "opposite_duplicate_face";
  }
  // Edges: a fill edge already in the mesh may gain one face (a loop edge); any other
  // use would make it non-manifold.
  std::unordered_map<uint64_t, uint32_t> added;
  for (const Tri& t : fill)
    for (int k = 0; k < 3; ++k) ++added[ekey(t[size_t(k)], t[size_t((k + 1) % 3)])];
  for (const auto& [key, n] : added) {
    auto it = edge_count.find(key);
    const uint32_t have = it == edge_count.end() ? 0 : it->second;
    if (have + n > 2) return "nonmanifold_edge";
  }
  // Intersections with the mesh and within the fill.
  for (size_t i = 0; i < fill.size(); ++i) {
    const Tri& t = fill[i];
    Box3d b{pos[t[0]], pos[t[0]]};
    b.extend(pos[t[1]]);
    b.extend(pos[t[2]]);
    bool hit = false;
    tree.query(b, [&](uint32_t m) {
      if (!hit && boxes_overlap(boxes[m], b) && pair_intersects(pos, t, tris[m], nullptr, fp)) hit = true;
    });
    if (hit) return "self_intersection";
    for (size_t j = 0; j < i; ++j)
      if (pair_intersects(pos, fill[j], t, nullptr, fp)) return "self_intersection";
  }
  return nullptr;
}

// Closed loops that pass a vertex more than once (two holes meeting at a vertex) split
// there into simple cycles, each a hole of its own; chains and simple loops stay as they
// are. A cycle of two edges (an edge walked there and back) is dropped: it bounds nothing.
std::vector<Loop> simple_loops(std::vector<Loop> loops) {
  std::vector<Loop> out;
  std::unordered_map<uint32_t, size_t> at;  // vertex -> index in the current path
  for (Loop& L : loops) {
    if (!L.closed) {
      out.push_back(std::move(L));
      continue;
    }
    const size_t n = L.groups.size();
    std::vector<uint32_t> path{L.verts[0]}, edges;
    at.clear();
    at[L.verts[0]] = 0;
    for (size_t i = 0; i < n; ++i) {
      const uint32_t next = L.verts[(i + 1) % n];
      edges.push_back(L.groups[i]);
      auto it = at.find(next);
      if (it == at.end()) {
        at[next] = path.size();
        path.push_back(next);
        continue;
      }
      const size_t j = it->second;
      Loop C;
      C.verts.assign(path.begin() + long(j), path.end());
      C.groups.assign(edges.begin() + long(j), edges.end());
      if (C.groups.size() >= 3) out.push_back(std::move(C));
      for (size_t k = j + 1; k < path.size(); ++k) at.erase(path[k]);
      path.resize(j + 1);
      edges.resize(j);
    }
  }
  return out;
}

// Fills closed boundary loops of at most `max_len` edges that are simple and
// consistently directed: the minimum-area triangulation of the loop traversed against
// its faces' direction, or else its ear-clipping triangulation, whichever first passes
// every exact check of fill_defect; a loop that neither passes is left open, recorded
// with the first candidate's reason. Fills accepted earlier count as mesh for later ones.
void fill_holes(Work& w, size_t max_len, const ExactPredicates& ex, std::vector<HoleRecord>& holes, size_t& added,
                size_t& longer) {
  const FilteredPredicates fp(ex);
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  std::vector<Loop> loops = simple_loops(boundary_loops(e));
  std::unordered_map<uint64_t, uint32_t> edge_count;
  std::unordered_map<uint64_t, uint8_t> faces;
  auto fkey = [](const Tri& t) {
    const auto k = sorted3(t);
    return uint64_t(k[0]) * 0x9E3779B97F4A7C15ull ^ (uint64_t(k[1]) << 32 | k[2]);
  };
  bool any = false;
  for (const Loop& L : loops) any = any || (L.closed && L.groups.size() <= max_len && L.groups.size() >= 3);
  if (!any) {
    for (const Loop& L : loops) longer += L.closed && L.groups.size() > max_len;
    return;
  }
  for (size_t g = 0; g < e.groups(); ++g) edge_count[e.recs[e.start[g]].key] = e.size(g);
  for (const Tri& t : w.tris) faces[fkey(t)] = 1;
  // A tree of the mesh's triangles; fills accepted later are appended to w.tris and
  // tested directly, outside the tree.
  const size_t base = w.tris.size();
  std::vector<Box3d> boxes(base);
  for (size_t t = 0; t < base; ++t) {
    boxes[t] = Box3d{w.pos[w.tris[t][0]], w.pos[w.tris[t][0]]};
    boxes[t].extend(w.pos[w.tris[t][1]]);
    boxes[t].extend(w.pos[w.tris[t][2]]);
  }
  BoxTree tree(boxes);
  constexpr size_t kMaxTriangulated = 2000;  // the O(n^3) program takes seconds at this size
  for (const Loop& L : loops) {
    const size_t n = L.groups.size();
    if (!L.closed || n < 3) continue;
    if (n > max_len) { ++longer; continue; }
    HoleRecord rec;
    rec.edges = n;
    std::vector<uint32_t> sorted(L.verts);
    std::sort(sorted.begin(), sorted.end());
    const bool simple = std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end();
    // Direction of each edge in its face: along the loop (verts[i] -> verts[i+1]) or not.
    int along = 0;
    for (size_t i = 0; i < n; ++i) {
      const EdgeRec& r = e.recs[e.start[L.groups[i]]];
      along += w.tris[r.tri][r.k] == L.verts[i] ? 1 : -1;
    }
    if (!simple) rec.reason = "not_simple";
    else if (along != int(n) && along != -int(n)) rec.reason = "inconsistent_direction";
    else if (n > kMaxTriangulated) rec.reason = "too_long_to_triangulate";
    if (rec.reason) {
      holes.push_back(rec);
      continue;
    }
    // The candidates are computed on the loop in a canonical order (from its lowest
    // vertex, towards the lower neighbour), so that they do not depend on where the walk
    // started or on the faces' orientation, then turned to run against the faces.
    std::vector<uint32_t> poly(L.verts);
    std::rotate(poly.begin(), std::min_element(poly.begin(), poly.end()), poly.end());
    if (poly[n - 1] < poly[1]) std::reverse(poly.begin() + 1, poly.end());
    const size_t at0 = size_t(std::find(L.verts.begin(), L.verts.end(), poly[0]) - L.verts.begin());
    const bool walk_order = L.verts[(at0 + 1) % n] == poly[1];
    const bool flip = walk_order == (along > 0);  // the fill runs against the faces' direction
    auto is_edge = [&](uint32_t a, uint32_t b) {
      return edge_count.count(a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a)) > 0;
    };
    std::vector<std::vector<Tri>> candidates(2);
    if (!min_area_triangulation(w.pos, poly, is_edge, candidates[0])) candidates[0].clear();
    triangulate_polygon(w.pos, poly, candidates[1]);
    if (flip)
      for (auto& fill : candidates)
        for (Tri& t : fill) std::swap(t[1], t[2]);
    const std::vector<Tri>* chosen = nullptr;
    for (const auto& fill : candidates) {
      if (fill.empty()) {
        if (!rec.reason) rec.reason = "chord_is_an_edge";
        continue;
      }
      const char* why = fill_defect(w.pos, fill, w.tris, tree, boxes, edge_count, faces, fp);
      // Fills accepted before this one are not in the tree: test them directly.
      for (size_t t = base; t < w.tris.size() && !why; ++t)
        for (const Tri& f : fill)
          if (pair_intersects(w.pos, f, w.tris[t], nullptr, fp)) { why = "self_intersection"; break; }
      if (!why) { chosen = &fill; break; }
      if (!rec.reason) rec.reason = why;
    }
    if (!chosen) {
      holes.push_back(rec);
      continue;
    }
    rec.filled = true;
    rec.reason = nullptr;
    rec.triangles = chosen->size();
    for (const Tri& t : *chosen) {
      w.tris.push_back(t);
      w.src.push_back(kFilledHole);
      faces[fkey(t)] = 1;
      for (int k = 0; k < 3; ++k) {
        const uint32_t a = t[size_t(k)], b = t[size_t((k + 1) % 3)];
        ++edge_count[a < b ? (uint64_t(a) << 32 | b) : (uint64_t(b) << 32 | a)];
      }
    }
    added += chosen->size();
    holes.push_back(rec);
  }
}

// Gives every fan of a vertex beyond the first its own copy of the vertex (same
// position); ends of non-manifold edges are fans of their own faces, so this resolves
// non-manifold edges too. `cls` maps every vertex (new ones included) to the original.
size_t split_nonmanifold(Work& w, std::vector<uint32_t>& cls) {
  EdgeTable e = build_edges(w.tris, nullptr, w.pos.size());
  UnionFind fans = corner_fans(w.tris, e);
  const size_t nt = w.tris.size();
  std::vector<uint32_t> root_vertex(nt * 3, kNone);
  std::vector<uint8_t> claimed(w.pos.size(), 0);
  size_t copies = 0;
  for (uint32_t t = 0; t < nt; ++t)
    for (uint32_t k = 0; k < 3; ++k) {
      uint32_t r = fans.find(3 * t + k);
      uint32_t v = w.tris[t][k];
      if (root_vertex[r] == kNone) {
        if (!claimed[v]) {
          claimed[v] = 1;
          root_vertex[r] = v;
        } else {
          root_vertex[r] = uint32_t(w.pos.size());
          w.pos.push_back(w.pos[v]);
          cls.push_back(cls[v]);
          ++copies;
        }
      }
      w.tris[t][k] = root_vertex[r];
    }
  return copies;
}

// The shortest period p >= 3 with face[i] == face[i mod p] for every i (a polygon that
// lists its vertex cycle several times over), else face.size().
size_t repeated_cycle_period(const std::vector<uint32_t>& face) {
  const size_t n = face.size();
  for (size_t p = 3; p * 2 <= n; ++p) {
    if (n % p != 0) continue;
    bool repeats = true;
    for (size_t i = p; i < n && repeats; ++i) repeats = face[i] == face[i - p];
    if (repeats) return p;
  }
  return n;
}

}  // namespace

Result<RepairResult> repair_mesh(const PolygonSoup& soup, const RepairOptions& opt, const ExactPredicates& ex) {
  if (!std::isfinite(opt.weld_tolerance) || opt.weld_tolerance < 0)
    return Error{"--weld-tolerance: must be a finite number >= 0"};
  const FilteredPredicates fp(ex);
  using clock = std::chrono::steady_clock;
  RepairResult R;
  const double T = opt.weld_tolerance;
  R.input_vertices = soup.vertices.size();
  R.input_faces = soup.faces.size();
  if (soup.faces.size() >= kFilledHole) return Error{"too many faces (at most 2^32 - 2)"};

  // Triangulate.
  Work w;
  w.pos = soup.vertices;
  auto t0 = clock::now();
  std::vector<Tri> buf;
  for (uint32_t f = 0; f < soup.faces.size(); ++f) {
    const auto& face = soup.faces[f];
    for (uint32_t v : face)
      if (v >= w.pos.size())
        return Error{"face " + std::to_string(f) + ": vertex index " + std::to_string(v) + " out of range"};
    if (face.size() < 3) {
      R.removed.push_back({f, "short_face"});
      continue;
    }
    buf.clear();
    const size_t period = repeated_cycle_period(face);
    if (period < face.size()) ++R.repeated_cycles_collapsed;
    if (period > 3) {
      ++R.polygons_triangulated;
      const std::vector<uint32_t> cycle(face.begin(), face.begin() + long(period));
      if (!triangulate_polygon(w.pos, cycle, buf)) ++R.fan_fallbacks;
    } else {
      buf.push_back({face[0], face[1], face[2]});
    }
    for (const Tri& t : buf) {
      w.tris.push_back(t);
      w.src.push_back(f);
    }
  }
  R.input_triangles = w.tris.size();
  if (w.tris.empty())
    return Error{"no faces (" + std::to_string(R.input_vertices) + " vertices, " + std::to_string(R.input_faces) +
                 " faces, none with three or more vertices): not a surface mesh"};
  R.steps.push_back({"triangulate",
                     {{"polygons_triangulated", R.polygons_triangulated},
                      {"triangles_from_polygons", R.input_triangles - (R.input_faces - R.removed.size() - R.polygons_triangulated)},
                      {"fan_fallbacks", R.fan_fallbacks},
                      {"repeated_cycles_collapsed", R.repeated_cycles_collapsed},
                      {"short_faces_dropped", R.removed.size()}},
                     seconds_since(t0)});

  std::vector<uint8_t> used(w.pos.size(), 0);
  for (const Tri& t : w.tris)
    for (uint32_t v : t) used[v] = 1;
  R.unreferenced_vertices = size_t(std::count(used.begin(), used.end(), uint8_t(0)));

  // Compacts `tris` after mapping through `rep`; vertices keep ascending input order.
  auto compact = [&](const std::vector<uint32_t>& rep, const std::vector<Tri>& tris, std::vector<Vec3d>& out_pos,
                     std::vector<Tri>& out_tris) {
    std::vector<uint32_t> id(w.pos.size(), kNone);
    out_pos.clear();
    for (uint32_t i = 0; i < w.pos.size(); ++i)
      if (used[i] && rep[i] == i) {
        id[i] = uint32_t(out_pos.size());
        out_pos.push_back(w.pos[i]);
      }
    out_tris.resize(tris.size());
    for (size_t t = 0; t < tris.size(); ++t)
      for (int k = 0; k < 3; ++k) out_tris[t][size_t(k)] = id[rep[tris[t][size_t(k)]]];
  };

  // Before: the input with exactly equal positions merged (an STL file shares none).
  t0 = clock::now();
  WeldResult exact = weld_vertices_exact(w.pos, used, 0.0, WeldMode::Chain, ex);
  const double exact_weld_seconds = seconds_since(t0);
  t0 = clock::now();
  IndexedMesh before;
  before.double_precision = soup.double_precision;
  compact(exact.rep, w.tris, before.vertices, before.triangles);
  R.before = analyze_mesh(before, ex);
  R.before_source = w.src;
  double before_seconds = seconds_since(t0);

  // Weld.
  t0 = clock::now();
  R.weld = T == 0.0 ? exact : weld_vertices_exact(w.pos, used, T, opt.weld_mode, ex);
  R.before.defects.near_duplicate_vertices = T == 0.0 || opt.weld_mode == WeldMode::Chain
                                                 ? R.weld.merged
                                                 : weld_vertices_exact(w.pos, used, T, WeldMode::Chain, ex).merged;
  double weld_seconds = seconds_since(t0) + (T == 0.0 ? exact_weld_seconds : 0.0);
  if (T != 0.0) before_seconds += exact_weld_seconds;
  R.steps.push_back({"analyze_input",
                     {{"self_intersection_pairs_tested", R.before.self_intersection_pairs_tested}},
                     before_seconds});
  if (opt.check_only) {
    R.output = std::move(before);
    R.output_source = w.src;
    std::vector<uint8_t> present(R.input_faces, 0);
    for (uint32_t s : w.src) present[s] = 1;
    R.faces_in_output = size_t(std::count(present.begin(), present.end(), uint8_t(1)));
    R.faces_removed = R.input_faces - R.faces_in_output;
    return R;
  }
  {
    std::vector<Vec3d> p;
    std::vector<Tri> t;
    compact(R.weld.rep, w.tris, p, t);
    w.pos = std::move(p);
    w.tris = std::move(t);
  }
  R.steps.push_back({"weld",
                     {{"vertices_merged", R.weld.merged},
                      {"clusters", R.weld.clusters},
                      {"chained_clusters", R.weld.chained.size()},
                      {"strict_splits", R.weld.strict_splits},
                      {"unreferenced_vertices_dropped", R.unreferenced_vertices}},
                     weld_seconds});

  // Clean. Splitting T-junctions can recreate a face that is already there (the split
  // of (a, b, c) at p yields (a, p, c), which may exist), and removing copies can open
  // edges that hold T-junctions; so both run until a split finds nothing, which repair
  // of the output then confirms (idempotence).
  t0 = clock::now();
  {
    size_t repeated = 0, zero = 0, dups = 0, odups = 0, tj = 0, tj_added = 0;
    auto clean_faces = [&] {
      const size_t nt = w.tris.size();
      std::vector<uint8_t> keep(nt, 1);
      std::vector<const char*> reason(nt, "");
      for (size_t t = 0; t < nt; ++t) {
        const Tri& f = w.tris[t];
        if (f[0] == f[1] || f[1] == f[2] || f[0] == f[2]) {
          keep[t] = 0;
          reason[t] = "repeated_vertex";
          ++repeated;
        } else if (fp.collinear(w.pos[f[0]], w.pos[f[1]], w.pos[f[2]])) {
          keep[t] = 0;
          reason[t] = "zero_area";
          ++zero;
        }
      }
      std::vector<uint8_t> dup = find_duplicates(w.tris, keep, w.pos.size());
      for (size_t t = 0; t < nt; ++t) {
        if (dup[t] == 1) { keep[t] = 0; reason[t] = "duplicate"; ++dups; }
        if (dup[t] == 2) { keep[t] = 0; reason[t] = "opposite_duplicate"; ++odups; }
      }
      remove_triangles(w, keep, reason, R.removed);
    };
    clean_faces();
    for (int round = 0; round < 16; ++round) {
      size_t added = 0;
      const size_t split = split_t_junctions(w, ex, added);
      if (split == 0) break;
      tj += split;
      tj_added += added;
      clean_faces();
    }
    R.steps.push_back({"clean",
                       {{"repeated_vertex_faces_removed", repeated},
                        {"zero_area_faces_removed", zero},
                        {"duplicate_faces_removed", dups},
                        {"opposite_duplicate_faces_removed", odups},
                        {"t_junctions_split", tj},
                        {"triangles_added_by_splits", tj_added}},
                       seconds_since(t0)});
  }

  // Orient.
  t0 = clock::now();
  OrientStats os = orient(w, ex);
  R.steps.push_back({"orient",
                     {{"faces_flipped_for_consistency", os.consistency_flips},
                      {"components_turned_outward", os.outward_components},
                      {"faces_flipped_outward", os.outward_flips},
                      {"cavities", os.cavities},
                      {"nonorientable_patches_left", os.nonorientable_skipped}},
                     seconds_since(t0)});

  // Fill holes.
  if (opt.fill_holes > 0) {
    t0 = clock::now();
    // Passes until one fills nothing: a fill can change the boundary walk and the
    // geometry later loops are checked against, and repair of the output must find
    // nothing more to fill (idempotence). The report keeps every fill and the last
    // pass's open loops.
    size_t added = 0, longer = 0, filled = 0;
    for (int pass = 0; pass < 8; ++pass) {
      std::vector<HoleRecord> holes;
      longer = 0;
      fill_holes(w, opt.fill_holes, ex, holes, added, longer);
      size_t now = 0;
      for (const HoleRecord& h : holes) now += h.filled;
      filled += now;
      std::vector<HoleRecord> kept;
      for (const HoleRecord& h : R.holes)
        if (h.filled) kept.push_back(h);
      for (const HoleRecord& h : holes)
        if (h.filled || now == 0) kept.push_back(h);
      R.holes = std::move(kept);
      if (now == 0) break;
    }
    OrientStats os2 = filled ? orient(w, ex) : OrientStats{};
    R.steps.push_back({"fill_holes",
                       {{"loops_filled", filled},
                        {"triangles_added", added},
                        {"loops_not_fillable", R.holes.size() - filled},
                        {"loops_longer_than_limit", longer},
                        {"faces_flipped_after_filling", os2.consistency_flips + os2.outward_flips}},
                       seconds_since(t0)});
  }

  // Split non-manifold vertices and edges.
  std::vector<uint32_t> cls(w.pos.size());
  std::iota(cls.begin(), cls.end(), 0u);
  if (opt.split_nonmanifold) {
    t0 = clock::now();
    size_t copies = split_nonmanifold(w, cls);
    R.steps.push_back({"split_nonmanifold", {{"vertex_copies_added", copies}}, seconds_since(t0)});
  }

  // Vertices that removed faces left unused go (in order), as the next run would drop
  // them as unreferenced.
  {
    std::vector<uint32_t> id(w.pos.size(), kNone);
    for (const Tri& t : w.tris)
      for (uint32_t v : t) id[v] = 0;
    uint32_t next = 0;
    for (uint32_t v = 0; v < w.pos.size(); ++v)
      if (id[v] != kNone) {
        id[v] = next;
        w.pos[next] = w.pos[v];
        ++next;
      }
    if (next != w.pos.size()) {
      std::vector<uint32_t> c(next);
      for (uint32_t v = 0; v < cls.size(); ++v)
        if (id[v] != kNone) c[id[v]] = id[cls[v]] != kNone ? id[cls[v]] : id[v];
      cls = std::move(c);
      w.pos.resize(next);
      for (Tri& t : w.tris)
        for (uint32_t& v : t) v = id[v];
    }
  }

  // Output triangles in input face order (stable; hole fillers last), so that the report
  // maps them to input faces by runs.
  {
    const size_t nf = R.input_faces;
    std::vector<uint32_t> off(nf + 2, 0);
    for (uint32_t s : w.src) ++off[(s == kFilledHole ? nf : size_t(s)) + 1];
    for (size_t f = 0; f <= nf; ++f) off[f + 1] += off[f];
    std::vector<Tri> tris(w.tris.size());
    std::vector<uint32_t> src(w.src.size());
    for (size_t t = 0; t < w.tris.size(); ++t) {
      const uint32_t slot = off[w.src[t] == kFilledHole ? nf : size_t(w.src[t])]++;
      tris[slot] = w.tris[t];
      src[slot] = w.src[t];
    }
    w.tris = std::move(tris);
    w.src = std::move(src);
  }

  // After.
  t0 = clock::now();
  R.output.vertices = std::move(w.pos);
  R.output.triangles = std::move(w.tris);
  R.output.double_precision = soup.double_precision;
  R.output_source = std::move(w.src);
  // The analysis depends only on the mesh (and the vertex classes, identity unless
  // split): when repair left the input as it was, the first analysis is the answer.
  bool split_any = false;
  for (size_t v = 0; v < cls.size() && !split_any; ++v) split_any = cls[v] != v;
  const bool unchanged = !split_any && R.output.vertices == before.vertices && R.output.triangles == before.triangles;
  if (unchanged) {
    R.after = R.before;
    R.after.defects.near_duplicate_vertices = 0;
    R.after.seconds.clear();
  } else {
    R.after = analyze_mesh(R.output, ex, &cls);
  }
  if (T > 0 && opt.weld_mode == WeldMode::Strict) {
    // Vertices strict mode refused to merge are still within T of another one.
    std::vector<uint8_t> orig(R.output.vertices.size(), 0);
    for (size_t v = 0; v < cls.size(); ++v) orig[cls[v]] = 1;
    std::vector<uint8_t> in_use(R.output.vertices.size(), 0);
    for (const Tri& t : R.output.triangles)
      for (uint32_t v : t) in_use[cls[v]] = 1;
    for (size_t v = 0; v < orig.size(); ++v) orig[v] = orig[v] && in_use[v] && cls[v] == v;
    R.after.defects.near_duplicate_vertices =
        weld_vertices_exact(R.output.vertices, orig, T, WeldMode::Chain, ex).merged;
  }
  R.output_vertex_class = std::move(cls);
  R.steps.push_back({"analyze_output",
                     {{"self_intersection_pairs_tested", unchanged ? 0 : R.after.self_intersection_pairs_tested},
                      {"reused_input_analysis", unchanged ? 1 : 0}},
                     seconds_since(t0)});

  // Face accounting: every input face is in the output or has a removal record.
  std::vector<uint8_t> present(R.input_faces, 0), recorded(R.input_faces, 0);
  for (uint32_t s : R.output_source)
    if (s != kFilledHole) present[s] = 1;
  for (const RemovedTriangle& r : R.removed) recorded[r.face] = 1;
  for (size_t f = 0; f < R.input_faces; ++f) {
    VG_CHECK(present[f] || recorded[f]);
    if (present[f]) ++R.faces_in_output; else ++R.faces_removed;
  }
  return R;
}

}  // namespace visgate::mesh
