// Empty shafts (paper 000 section 4.12): an empty shaft between nodes free of triangles
// is all visible; the extension for receivers on a floor or a sloped surface.
#include <algorithm>
#include <cstdint>
#include <vector>

#include "lib/iss/traversal.h"

namespace visgate::iss {

// The light node's bits are gathered once into word masks (over the words its samples
// span), then ORed into each receiver's words: the same bits as setting each relation's
// bit (section 4.13, avoid work; a bit per relation was 56M instructions on columns).
void Traversal::record_visible(int r, int l) {
  const TreeNode& R = rn(r);
  const TreeNode& L = ln(l);
  const auto& ro = rtree_->order();
  const auto& lo = ltree_->order();
  if (L.begin == L.end) return;
  size_t first = SIZE_MAX, last = 0;
  for (uint32_t b = L.begin; b < L.end; ++b) {
    first = std::min(first, size_t(lo[b]));
    last = std::max(last, size_t(lo[b]));
  }
  const size_t w0 = (light_offset_ + first) >> 6, nw = ((light_offset_ + last) >> 6) - w0 + 1;
  std::vector<uint64_t>& masks = visible_masks_;
  masks.assign(nw, 0);
  for (uint32_t b = L.begin; b < L.end; ++b) {
    const size_t bit = light_offset_ + lo[b];
    masks[(bit >> 6) - w0] |= uint64_t(1) << (bit & 63);
  }
  for (uint32_t a = R.begin; a < R.end; ++a) {
    uint64_t* words = result_.receivers[ro[a]].visible_bits.data() + w0;
    for (size_t w = 0; w < nw; ++w) words[w] |= masks[w];
  }
  n_empty_ += double(R.size()) * double(L.size());
}

// Extension of the empty-shaft rule (section 4.12, the sloped-floor case): a triangle
// in the receiver node's inside list cannot meet an open segment from one of the
// node's points to the light box when all those points lie on one closed side of its
// plane and the whole light box strictly on the same side: every interior point of
// such a segment is then strictly on that side. Receivers lying on a floor (columns)
// or on a table top therefore no longer disable the rule. Evaluated in double with the
// plane tolerance of shaft.h on both sides, so a receiver within that tolerance of the
// plane counts as on it: wrong only for relations within double rounding of touching
// (the oracle margin makes those undecidable anyway, iss_solver.h). The per-node
// classification is computed once (the receiver tree is shared by all lights), with
// an O(1) box test before the scan of the points and an exit at the first point on
// the other side.
bool Traversal::node_triangles_face_away(int r, const AABB& light_box) {
  TreeNode& R = rn(r);
  if (R.sides_state == 0) {
    ScopedTimer t(times_[kTree]);
    R.sides_state = 2;
    const auto& ord = rtree_->order();
    AABBd rb = to_double(R.box);
    for (uint32_t tri : R.inside) {
      ConservativePlane pl = plane_through(to_double(mesh_.corner(tri, 0)), to_double(mesh_.corner(tri, 1)),
                                 to_double(mesh_.corner(tri, 2)), scale_);
      if (pl.n == Vec3d(0, 0, 0)) { R.sides_state = 1; break; }  // degenerate: no plane
      double mn = 1e300, mx = -1e300;
      for (int i = 0; i < 8; ++i) {
        double e = pl.eval(Vec3d(i & 1 ? rb.hi.x : rb.lo.x, i & 2 ? rb.hi.y : rb.lo.y, i & 4 ? rb.hi.z : rb.lo.z));
        mn = std::min(mn, e);
        mx = std::max(mx, e);
      }
      bool neg = mx <= pl.tol, pos = mn >= -pl.tol;
      if (!neg && !pos) {  // the box straddles the plane: look at the points
        neg = pos = true;
        for (uint32_t k = R.begin; k < R.end && (neg || pos); ++k) {
          double e = pl.eval(to_double(scene_.receivers[ord[k]].p));
          if (e > pl.tol) neg = false;
          if (e < -pl.tol) pos = false;
        }
      }
      if (!neg && !pos) { R.sides_state = 1; break; }
      if (neg && pos) {
        R.flat.push_back(pl);
        continue;
      }
      if (!neg) { pl.n = pl.n * -1.0; pl.d = -pl.d; }
      R.sides.push_back(pl);
    }
    if (R.sides_state == 1) {
      R.sides = {};
      R.flat = {};
    }
  }
  if (R.sides_state != 2) return false;
  AABBd lb = to_double(light_box);
  auto box_max = [&](const ConservativePlane& pl) {
    return pl.eval(Vec3d(pl.n.x > 0 ? lb.hi.x : lb.lo.x, pl.n.y > 0 ? lb.hi.y : lb.lo.y, pl.n.z > 0 ? lb.hi.z : lb.lo.z));
  };
  auto box_min = [&](const ConservativePlane& pl) {
    return pl.eval(Vec3d(pl.n.x > 0 ? lb.lo.x : lb.hi.x, pl.n.y > 0 ? lb.lo.y : lb.hi.y, pl.n.z > 0 ? lb.lo.z : lb.hi.z));
  };
  // The light box strictly on the points' (non-positive) side of every one-sided
  // plane, and strictly on either side of every plane that contains the points.
  for (const ConservativePlane& pl : R.sides)
    if (!(box_max(pl) < -pl.tol)) return false;
  for (const ConservativePlane& pl : R.flat)
    if (!(box_max(pl) < -pl.tol) && !(box_min(pl) > pl.tol)) return false;
  return true;
}

}  // namespace visgate::iss
