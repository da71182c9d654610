// Candidate silhouette edges from the edge hierarchy (see edge_tree.h).
#include "lib/ssv/edge_tree.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace visgate::ssv {

EdgeFrustum::EdgeFrustum(const LightFrame& frame, const Vec3f& receiver) : r(to_double(receiver)) {
  const auto& L = frame.poly_world;
  n[count] = frame.N;  // the light plane, h >= 0
  d[count] = dot(frame.N, frame.origin);
  ++count;
  box.extend(r);
  for (const Vec3d& p : L) box.extend(p);
  // The side planes, oriented with the frame origin (L's vertex average, inside L') on
  // the positive side.
  for (size_t i = 0; i < L.size() && count < kMaxPlanes; ++i) {
    const Vec3d a = L[i] - r, b = L[(i + 1) % L.size()] - r;
    Vec3d nrm = cross(a, b);
    const double len = length(nrm);
    if (!(len > 1e-12 * length(a) * length(b))) continue;
    nrm = nrm / len;
    if (dot(nrm, frame.origin - r) < 0.0) nrm = -nrm;
    n[count] = nrm;
    d[count] = dot(nrm, r);
    ++count;
  }
}

EdgeTree::EdgeTree(const accel::Bvh<float>& bvh, const std::vector<Edge>& edges, const mesh::PreparedMesh& m,
                   const std::vector<TrianglePlane>& planes, double M)
    : bvh_(&bvh), abs_margin_(1e-9 * M) {
  bounds_.resize(bvh.node_count());
  // Pre-order layout: children after their parent, so a reverse pass is bottom-up.
  for (size_t k = bvh.node_count(); k-- > 0;) {
    const auto& nd = bvh.node(uint32_t(k));
    NodeBounds& b = bounds_[k];
    for (int c = 0; c < 3; ++c) {
      b.tlo[c] = b.nlo[c] = INFINITY;
      b.thi[c] = b.nhi[c] = -INFINITY;
    }
    b.single = 0;
    auto merge = [&b](const NodeBounds& o) {
      for (int c = 0; c < 3; ++c) {
        b.tlo[c] = std::min(b.tlo[c], o.tlo[c]);
        b.thi[c] = std::max(b.thi[c], o.thi[c]);
        b.nlo[c] = std::min(b.nlo[c], o.nlo[c]);
        b.nhi[c] = std::max(b.nhi[c], o.nhi[c]);
      }
      b.single |= o.single;
    };
    if (!bvh.is_leaf(nd)) {
      merge(bounds_[bvh.left(uint32_t(k))]);
      merge(bounds_[bvh.right(uint32_t(k))]);
      continue;
    }
    for (uint32_t e : bvh.leaf_items(nd)) {
      const Edge& ed = edges[e];
      if (ed.t2 < 0) b.single = 1;
      for (int32_t t : {ed.t1, ed.t2}) {
        if (t < 0) continue;
        const TrianglePlane& p = planes[size_t(t)];
        if (!(p.nn > 0.0)) b.single = 1;  // no plane: never proven weight 0
        for (int c = 0; c < 3; ++c) {
          for (int v = 0; v < 3; ++v) {
            const float x = m.corner(size_t(t), v)[c];
            b.tlo[c] = std::min(b.tlo[c], x);
            b.thi[c] = std::max(b.thi[c], x);
          }
          // Outwards: the double unit normal lies in [nlo, nhi].
          const double u = p.unit[c];
          float lo = float(u), hi = float(u);
          if (double(lo) > u) lo = std::nextafter(lo, -INFINITY);
          if (double(hi) < u) hi = std::nextafter(hi, INFINITY);
          b.nlo[c] = std::min(b.nlo[c], lo);
          b.nhi[c] = std::max(b.nhi[c], hi);
        }
      }
    }
  }
}

namespace {

// Largest value of dot(n, x) - d over the box.
inline double box_max(const Vec3d& n, double d, const float* lo, const float* hi) {
  double s = -d;
  for (int c = 0; c < 3; ++c) s += n[c] * double(n[c] >= 0.0 ? hi[c] : lo[c]);
  return s;
}

inline bool outside_frustum(const EdgeFrustum& f, const float* lo, const float* hi, double eps) {
  for (int c = 0; c < 3; ++c)
    if (double(hi[c]) < f.box.lo[c] - eps || double(lo[c]) > f.box.hi[c] + eps) return true;
  for (int i = 0; i < f.count; ++i)
    if (box_max(f.n[i], f.d[i], lo, hi) < -eps) return true;
  return false;
}

}  // namespace

void EdgeTree::query(const EdgeFrustum& f, const LightFrame& frame, float eps, std::vector<uint32_t>& out) const {
  out.clear();
  if (empty()) return;
  const accel::Bvh<float>& bvh = *bvh_;
  const double e = double(eps);
  const double h0 = dot(frame.N, frame.origin);
  std::array<uint32_t, accel::Bvh<float>::kMaxStack> stack;
  size_t top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const uint32_t i = stack[--top];
    const auto& nd = bvh.node(i);
    if (outside_frustum(f, &nd.box.lo.x, &nd.box.hi.x, e)) continue;
    const NodeBounds& b = bounds_[i];
    // Every incident triangle active (each vertex's frame height > 0, with the rounding
    // of to_local far below the margin) and r strictly on one side of all their planes.
    if (!b.single && box_max(-frame.N, -h0, b.tlo, b.thi) < -abs_margin_) {
      double flo = 0.0, fhi = 0.0, far2 = 0.0;
      for (int c = 0; c < 3; ++c) {
        // n_c (r_c - a_c) with n_c in [nlo, nhi], r_c - a_c in [dlo, dhi].
        const double dlo = f.r[c] - double(b.thi[c]), dhi = f.r[c] - double(b.tlo[c]);
        const double p0 = double(b.nlo[c]) * dlo, p1 = double(b.nlo[c]) * dhi, p2 = double(b.nhi[c]) * dlo,
                     p3 = double(b.nhi[c]) * dhi;
        flo += std::min(std::min(p0, p1), std::min(p2, p3));
        fhi += std::max(std::max(p0, p1), std::max(p2, p3));
        far2 += std::max(dlo * dlo, dhi * dhi);
      }
      const double margin = 0x1p-19 * std::sqrt(far2) + abs_margin_;
      if (flo > margin || fhi < -margin) continue;
    }
    if (bvh.is_leaf(nd)) {
      for (uint32_t k = nd.first; k < nd.first + nd.count; ++k) {
        const AABB& ib = bvh.item_box(k);
        if (!outside_frustum(f, &ib.lo.x, &ib.hi.x, e)) out.push_back(bvh.item(k));
      }
      continue;
    }
    stack[top++] = bvh.right(i);
    stack[top++] = bvh.left(i);
  }
  std::sort(out.begin(), out.end());
}

}  // namespace visgate::ssv
