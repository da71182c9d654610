// Self-intersection tests (see self_intersection.h).
#include "lib/repair/self_intersection.h"

#include <algorithm>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include "lib/mesh/box_tree.h"

namespace visgate::mesh {

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

}  // namespace visgate::mesh
