// Triangle hierarchy for occluder selection; see triangle_tree.h.
#include "lib/plucker/triangle_tree.h"

#include <algorithm>
#include <cmath>
#include <cstddef>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "lib/geom/predicates.h"
#include "lib/mesh/prepare.h"
#include "lib/plucker/exact_orient.h"
#include "lib/plucker/lines.h"

namespace visgate::plucker {

namespace {

// Whether the segment p0 -> p1 may meet the box [lo, hi]: false only when a separating
// axis of the two (the box's three axes and the segment direction crossed with each)
// separates them by more than 2^-40 of the squared scale. The inputs are floats, so the
// double half-sums and products below carry errors of a few 2^-53 of scale (squared for
// the cross axes): a false never drops a segment that meets the box.
// Not segment_misses_box negated (interior_occluders.cpp): that one is exact, cross axes only; both keep every met box.
bool segment_meets_box(const Vec3f& p0, const Vec3f& p1, const Vec3f& lo, const Vec3f& hi) {
  const Vec3d a = to_double(p0), b = to_double(p1), l = to_double(lo), u = to_double(hi);
  const Vec3d c = (l + u) * 0.5, e = (u - l) * 0.5, h = (b - a) * 0.5, m = (a + b) * 0.5 - c;
  const double scale = std::max({max_component(vabs(a)), max_component(vabs(b)), max_component(vabs(l)),
                                 max_component(vabs(u)), 1e-30});
  const double tol1 = 0x1p-40 * scale, tol2 = tol1 * scale;
  for (int k = 0; k < 3; ++k)
    if (std::abs(m[k]) > e[k] + std::abs(h[k]) + tol1) return false;
  for (int k = 0; k < 3; ++k) {
    const int i = (k + 1) % 3, j = (k + 2) % 3;
    if (std::abs(m[i] * h[j] - m[j] * h[i]) > e[i] * std::abs(h[j]) + e[j] * std::abs(h[i]) + tol2) return false;
  }
  return true;
}

#if defined(__SSE2__)
// A corner as (x, y, z, 0), read without passing its 12 bytes.
inline __m128 load_corner(const Vec3f& v) {
  static_assert(sizeof(Vec3f) == 12 && offsetof(Vec3f, y) == 4 && offsetof(Vec3f, z) == 8);
  const __m128 xy = _mm_castsi128_ps(_mm_loadu_si64(&v.x));  // unaligned 8 bytes
  return _mm_movelh_ps(xy, _mm_load_ss(&v.z));
}
#endif

// AABB() extended by a, b, c: lo = std::min(lo, x) keeps lo on ties, as _mm_min_ps(x, lo)
// does (likewise max), and the first extend gives a itself (min(+inf, a) is a): the same
// bits, zeros' signs included, in about a third of the scalar instructions.
inline AABB corner_box(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
#if defined(__SSE2__)
  const __m128 pa = load_corner(a), pb = load_corner(b), pc = load_corner(c);
  const __m128 lo = _mm_min_ps(pc, _mm_min_ps(pb, pa)), hi = _mm_max_ps(pc, _mm_max_ps(pb, pa));
  alignas(16) float l[4], h[4];
  _mm_store_ps(l, lo);
  _mm_store_ps(h, hi);
  AABB box;
  box.lo = Vec3f(l[0], l[1], l[2]);
  box.hi = Vec3f(h[0], h[1], h[2]);
  return box;
#else
  AABB box;
  box.extend(a);
  box.extend(b);
  box.extend(c);
  return box;
#endif
}

}  // namespace

AABB triangle_box(const TriangleSoup& mesh, uint32_t t) {
  const auto& c = mesh.triangles[t];
  return corner_box(mesh.vertices[c[0]], mesh.vertices[c[1]], mesh.vertices[c[2]]);
}

std::vector<AABB> triangle_boxes(const TriangleSoup& mesh, const std::vector<uint32_t>* tris) {
  const size_t n = tris ? tris->size() : mesh.size();
  std::vector<AABB> box(n);
  for (size_t i = 0; i < n; ++i) box[i] = triangle_box(mesh, tris ? (*tris)[i] : uint32_t(i));
  return box;
}

TriangleTree::TriangleTree(const TriangleSoup& mesh, const mesh::PreparedMesh& pm) : bvh_(triangle_boxes(mesh), kRule) {
  find_patches(mesh, pm);
}

void TriangleTree::find_patches(const TriangleSoup& mesh, const mesh::PreparedMesh& pm) {
  // Welded vertices and neighbours across edges of exactly two triangles that traverse
  // them in opposite directions (lib/mesh/prepare.h, paper 000 section 4.2): so every
  // triangle of a patch has the winding of the one it was grown from, and the polygon
  // has the orientation of each of them. Degenerate triangles are not in `pm`.
  const size_t n = pm.triangles.size();
  const auto& pos = pm.vertex_pos;
  // The edge (k, k + 1) of prepared triangle t with ends {a, b}.
  auto corner_of = [&](uint32_t t, uint32_t a, uint32_t b) {
    const auto& v = pm.triangles[t].v;
    for (int k = 0; k < 3; ++k) {
      const uint32_t x = v[size_t(k)], y = v[size_t((k + 1) % 3)];
      if ((x == a && y == b) || (x == b && y == a)) return k;
    }
    return -1;
  };

  std::vector<int32_t> patch_of(mesh.size(), -1);  // by input triangle
  std::vector<uint8_t> taken(n, 0);               // by prepared triangle
  // lonely[t]: t's search below found no coplanar untaken neighbour. Coplanarity of two
  // glued triangles is one exact predicate of their four corners (symmetric), and taken
  // is never undone, so a later t' need not test its lonely lower neighbour again: that
  // search tested t' (untaken then, as now) and found it off t's plane.
  std::vector<uint8_t> lonely(n, 0);
  // The growing polygon: vertex ids, and per edge i (poly[i] -> poly[i + 1]) the prepared
  // triangle that has it; its prepared triangles.
  std::vector<uint32_t> poly, owner, members, order;
  for (uint32_t t = 0; t < n; ++t) {
    if (taken[t]) continue;
    const auto& c = pm.triangles[t].v;
    const auto& nbs = pm.triangles[t].neighbors;
    auto to_test = [&](int32_t nb) { return nb >= 0 && !taken[size_t(nb)] && !(uint32_t(nb) < t && lonely[size_t(nb)]); };
    if (!to_test(nbs[0]) && !to_test(nbs[1]) && !to_test(nbs[2])) {
      lonely[t] = 1;
      continue;
    }
    const Vec3f &a = pos[c[0]], &b = pos[c[1]], &cc = pos[c[2]];
    const Vec3d nn = cross(to_double(b) - to_double(a), to_double(cc) - to_double(a));
    // The first growth crosses an edge of t to an untaken neighbour with its third vertex
    // in t's plane: without one (smooth surfaces: every triangle) t stays alone, and the
    // sorted edge loop below is skipped (same patches; a quarter of a scan solve's
    // hierarchy time went there).
    // A third vertex that plane_side_filtered (t's normal nn, shared) places off the
    // plane is not in it; the others by the exact sign.
    const double s12 = norm1(to_double(b) - to_double(a)) * norm1(to_double(cc) - to_double(a));
    bool coplanar_neighbour = false;
    for (int k = 0; k < 3 && !coplanar_neighbour; ++k) {
      const int32_t nb = nbs[size_t(k)];
      if (!to_test(nb)) continue;
      // nb holds t's edge k (c[k], c[k + 1]); its third vertex x is in t's plane, and
      // counts unless it is t's third corner too (nb then has t's three vertices).
      const auto& nv = pm.triangles[size_t(nb)].v;
      const uint32_t e0 = c[size_t(k)], e1 = c[size_t((k + 1) % 3)];
      const uint32_t x = nv[0] != e0 && nv[0] != e1 ? nv[0] : (nv[1] != e0 && nv[1] != e1 ? nv[1] : nv[2]);
      coplanar_neighbour = x != c[size_t((k + 2) % 3)] && x != e0 && x != e1 &&
                           plane_side_filtered(to_double(a), nn, s12, SumPoint(pos[x])) == 0 &&
                           !is_certain(orient3d_filtered(a, b, cc, SumPoint(pos[x]))) &&
                           to_int(orient3d_exact(a, b, cc, pos[x])) == 0;
    }
    if (!coplanar_neighbour) {
      lonely[t] = 1;
      continue;
    }
    // The dominant axis of t's normal is dropped; t's projected orientation s is then
    // nonzero unless t is degenerate, and every turn of the polygon must have that sign.
    const int w = std::abs(nn.x) >= std::abs(nn.y) ? (std::abs(nn.x) >= std::abs(nn.z) ? 0 : 2)
                                                   : (std::abs(nn.y) >= std::abs(nn.z) ? 1 : 2);
    const int u = (w + 1) % 3, v = (w + 2) % 3;
    auto turn = [&](uint32_t x, uint32_t y, uint32_t z) {
      const Vec3f &p = pos[x], &q = pos[y], &r = pos[z];
      return to_int(orient2d_exact(p[u], p[v], q[u], q[v], r[u], r[v]));
    };
    const int s = turn(c[0], c[1], c[2]);
    if (s == 0) continue;
    poly.assign(c.begin(), c.end());
    owner.assign(3, t);
    members.assign(1, t);
    // Grown across one edge at a time, the longest first (merging across a long edge
    // removes the most inner edge: the diagonal of a rectangle, the chords of a fan),
    // until no edge grows it.
    bool grown = true;
    while (grown && int(poly.size()) < kMaxPatchVertices) {
      grown = false;
      order.resize(poly.size());
      for (size_t i = 0; i < poly.size(); ++i) order[i] = uint32_t(i);
      auto len2 = [&](uint32_t i) {
        const Vec3d e = to_double(pos[poly[(i + 1) % poly.size()]]) - to_double(pos[poly[i]]);
        return dot(e, e);
      };
      std::stable_sort(order.begin(), order.end(), [&](uint32_t x, uint32_t y) { return len2(x) > len2(y); });
      for (size_t oi = 0; oi < order.size() && !grown; ++oi) {
        const size_t i = order[oi];
        const uint32_t pa = poly[i], pb = poly[(i + 1) % poly.size()];
        const int k = corner_of(owner[i], pa, pb);
        const int32_t nb = k < 0 ? -1 : pm.triangles[owner[i]].neighbors[size_t(k)];
        if (nb < 0 || taken[size_t(nb)] || std::find(members.begin(), members.end(), uint32_t(nb)) != members.end())
          continue;
        const uint32_t q = uint32_t(nb);
        uint32_t d = pa;
        for (uint32_t x : pm.triangles[q].v)
          if (x != pa && x != pb) d = x;
        if (d == pa || std::find(poly.begin(), poly.end(), d) != poly.end()) continue;
        // d strictly across pa -> pb, and the turns at pa and at pb strictly convex: the
        // new polygon is the old one (convex, on the other side of pa -> pb) and q.
        // The 2D turns first (cheaper); they mean something once d is in the plane.
        const uint32_t prev = poly[(i + poly.size() - 1) % poly.size()], next = poly[(i + 2) % poly.size()];
        if (turn(pa, d, pb) != s || turn(prev, pa, d) != s || turn(d, pb, next) != s) continue;
        if (to_int(orient3d_exact(a, b, cc, pos[d])) != 0) continue;
        poly.insert(poly.begin() + ptrdiff_t(i) + 1, d);
        owner[i] = q;
        owner.insert(owner.begin() + ptrdiff_t(i) + 1, q);
        members.push_back(q);
        grown = true;
      }
    }
    if (members.size() < 2) continue;
    for (uint32_t& m : members) {
      taken[m] = 1;
      m = pm.triangles[m].source;
    }
    std::sort(members.begin(), members.end());
    Patch pt;
    pt.tri_begin = uint32_t(patch_tris_.size());
    pt.tri_count = uint32_t(members.size());
    pt.poly_begin = uint32_t(patch_poly_.size());
    pt.poly_count = uint32_t(poly.size());
    for (uint32_t m : members) {
      patch_tris_.push_back(m);
      patch_of[m] = int32_t(patches_.size());
    }
    for (uint32_t id : poly) patch_poly_.push_back(pos[id]);
    patches_.push_back(pt);
  }
  if (!patches_.empty()) patch_of_ = std::move(patch_of);
}

bool TriangleTree::segment_blocked(const TriangleSoup& mesh, const Vec3f& origin, const Vec3f& r,
                                   const Vec3f& s) const {
  bool blocked = false;
  // No early exit from the traversal: the leaves after a hit are skipped by `enter`.
  bvh_.for_each_leaf(
      [&](const AABB& b) { return !blocked && segment_meets_box(r, s, b.lo - origin, b.hi - origin); },
      [&](const accel::Bvh<float>::Node& leaf) {
        for (uint32_t t : bvh_.leaf_items(leaf)) {
          if (blocked) return;
          blocked = plucker::segment_blocked(r, s, mesh.corner(t, 0) - origin, mesh.corner(t, 1) - origin,
                                             mesh.corner(t, 2) - origin);
        }
      });
  return blocked;
}

void TriangleTree::candidates(const Shaft& shaft, const Vec3f& origin, std::vector<uint32_t>& out) const {
  out.clear();
  bvh_.for_each_leaf([&](const AABB& b) { return !shaft.culls_box(b.lo - origin, b.hi - origin); },
                     [&](const accel::Bvh<float>::Node& leaf) {
                       const auto items = bvh_.leaf_items(leaf);
                       out.insert(out.end(), items.begin(), items.end());
                     });
  std::sort(out.begin(), out.end());
}

}  // namespace visgate::plucker
