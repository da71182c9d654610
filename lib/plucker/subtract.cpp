// Subtracting a polygon's shadow from light fragments; see subtract.h.
#include "lib/plucker/subtract.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <type_traits>

#include "lib/base/check.h"

namespace visgate::plucker {

namespace {

// Keeps fragment f of `in` whole in `out` (box `box` in `out_boxes`), after taking back
// the pieces `out` received from index `first` on: a subtraction that split the fragment
// and then found nothing of it hidden returns the fragment instead of its pieces (a
// shadow beside a fragment still cuts it along the planes through its edges). With
// first == out.size() it only keeps the fragment.
void keep_whole(const FragmentList& in, size_t f, const UVBox& box, size_t first, FragmentList& out,
                std::vector<UVBox>& out_boxes) {
  out.truncate(first);
  out_boxes.resize(first);
  out.add(in.data(f), size_t(in.count(f)));
  out_boxes.push_back(box);
}

// Fragment f replaced by fragments [a, b) of the pieces (subtract_polygon).
struct Replacement {
  uint32_t f, a, b;
};

// Replaces, for each entry of `repl` (increasing f), fragment f of `frags` (and its box)
// by the pieces [a, b) (and their boxes), keeping every other fragment's vertices where
// they are: the same fragments in the same order as copying the list with the pieces in
// place of each f, without copying the vertices. One for one, a fragment is overwritten;
// else the spans and boxes are written anew in one pass (runs between the entries copied
// at once: memmoves; per entry a moved tail cost more, on lists of thousands). The
// pieces' vertices go to the end of frags.verts; the replaced fragments' stay there as
// garbage until more than half of the vertices are, and then the list is written back to
// back again (same values, same order).
void replace_fragments(FragmentList& frags, std::vector<UVBox>& boxes, const FragmentList& pieces,
                       const std::vector<UVBox>& piece_boxes, const std::vector<Replacement>& repl) {
  static_assert(std::is_trivially_copyable_v<FragmentList::Span> && std::is_trivially_copyable_v<UVBox>);
  const uint32_t base = uint32_t(frags.verts.size());
  frags.verts.insert(frags.verts.end(), pieces.verts.begin(), pieces.verts.end());  // pieces: back to back
  auto piece = [&](uint32_t j) { return FragmentList::Span(base + pieces.polys[j].first, pieces.polys[j].second); };
  bool one_each = true;
  for (const Replacement& rp : repl) one_each &= rp.b == rp.a + 1;
  if (one_each) {
    for (const Replacement& rp : repl) {
      frags.garbage += frags.polys[rp.f].second;
      frags.polys[rp.f] = piece(rp.a);
      boxes[rp.f] = piece_boxes[rp.a];
    }
  } else {
    thread_local std::vector<FragmentList::Span> polys;
    thread_local std::vector<UVBox> nboxes;
    polys.clear();
    nboxes.clear();
    size_t f0 = 0;
    for (const Replacement& rp : repl) {
      polys.insert(polys.end(), frags.polys.begin() + std::ptrdiff_t(f0), frags.polys.begin() + rp.f);
      nboxes.insert(nboxes.end(), boxes.begin() + std::ptrdiff_t(f0), boxes.begin() + rp.f);
      frags.garbage += frags.polys[rp.f].second;
      for (uint32_t j = rp.a; j < rp.b; ++j) polys.push_back(piece(j));
      nboxes.insert(nboxes.end(), piece_boxes.begin() + rp.a, piece_boxes.begin() + rp.b);
      f0 = size_t(rp.f) + 1;
    }
    polys.insert(polys.end(), frags.polys.begin() + std::ptrdiff_t(f0), frags.polys.end());
    nboxes.insert(nboxes.end(), boxes.begin() + std::ptrdiff_t(f0), boxes.end());
    frags.polys.swap(polys);
    boxes.swap(nboxes);
  }
  if (frags.garbage > 1024 && 2 * frags.garbage > frags.verts.size()) {
    thread_local std::vector<Vec3d> verts;
    verts.clear();
    for (FragmentList::Span& p : frags.polys) {
      const uint32_t at = uint32_t(verts.size());
      verts.insert(verts.end(), frags.verts.begin() + p.first, frags.verts.begin() + p.first + p.second);
      p.first = at;
    }
    frags.verts.swap(verts);
    frags.garbage = 0;
  }
}

}  // namespace

bool subtract_polygon(const Vec3d& r, const Vec3d* q, int nq, const uint8_t* skip, const UVBox& qbox,
                      const UVAxes& axes, const LightBounds& light, FragmentList& frags, std::vector<UVBox>& boxes,
                      FragmentList& pieces, std::vector<UVBox>& piece_boxes, std::vector<Vec3d>& cur,
                      std::vector<Vec3d>& pos, std::vector<Vec3d>& neg, BspCounters& c) {
  // The planes through r and q's edges, once for every fragment (fragment.h node_plane),
  // each computed when first needed (a polygon whose shadow misses every fragment mostly
  // needs one: the edge that separates them all). Per thread rather than per call:
  // constructing them per call costs measurably on columns.
  static thread_local NodePlane planes[2 * kMaxOccluderVertices + 2];
  VG_CHECK(nq <= int(std::size(planes)));
  uint32_t have = 0;  // bit k: planes[k] computed for this call
  double dr = 0.0;    // light.dist1(r), with the first plane
  static_assert(std::size(planes) <= 32);
  auto plane = [&](int m) -> const NodePlane& {
    if (!(have >> m & 1u)) {
      if (have == 0) dr = light.dist1(r);
      const int m1 = m + 1 == nq ? 0 : m + 1;
      planes[m] = node_plane(r, q[m], q[m1], light, dr, light.dist1(q[m]), light.dist1(q[m1]));
      have |= 1u << m;
    }
    return planes[m];
  };
  int hint = 0;
  // A fragment entirely on the negative side of one edge plane misses q: kept whole,
  // without the splits the walk below would make before reaching that edge. Tried
  // from the edge that separated the previous fragment (neighbours mostly share it).
  // Fragments whose box misses q's shadow box are passed over in a loop of their own
  // (on lists of thousands of fragments this scan is most of a call).
  const size_t nf = frags.size();  // the list changes only after the loop below
  const UVBox* bx = boxes.data();
  auto next_met = [&](size_t f) {
    while (f < nf && !qbox.overlaps(bx[f])) ++f;
    return f;
  };
  // A fragment whose box meets it may still lie on the negative side of one edge plane.
  auto edge_misses = [&](size_t f) {
    for (int mi = 0; mi < nq; ++mi) {
      const int m = hint + mi < nq ? hint + mi : hint + mi - nq;
      if (skip[m]) continue;
      SplitResult s = classify_fragment(plane(m), frags.data(f), frags.count(f));
      if (s == SplitResult::OnLine) ++c.on_line;  // undecided: the caller re-shades r exactly
      if (s == SplitResult::Negative || s == SplitResult::OnLine) {
        hint = m;
        return true;
      }
    }
    return false;
  };
  bool met = false;  // some fragment not missed
  pieces.clear();
  piece_boxes.clear();
  thread_local std::vector<Replacement> repl;
  repl.clear();
  for (size_t f = next_met(0); f < nf; f = next_met(f + 1)) {
    if (edge_misses(f)) continue;
    met = true;
    // The piece still walked: the fragment itself until the first split, then `cur`.
    // The pieces are written into pos and neg (room for 2n each, fragment.h); the
    // buffers only grow. The visible pieces split off go to `pieces`.
    const Vec3d* cp = frags.data(f);
    int cn = frags.count(f);
    const size_t first_piece = pieces.size();
    bool alive = true, whole = false;
    for (int m = 0; m < nq && alive; ++m) {
      if (skip[m]) continue;
      if (pos.size() < size_t(2 * cn)) pos.resize(size_t(2 * cn));
      if (neg.size() < size_t(2 * cn)) neg.resize(size_t(2 * cn));
      int np = 0, nn = 0;
      SplitResult s = split_fragment(plane(m), cp, cn, pos.data(), np, neg.data(), nn);
      switch (s) {
        case SplitResult::Positive: break;
        case SplitResult::OnLine: ++c.on_line; [[fallthrough]];
        case SplitResult::Negative:  // what is left misses q: nothing of the fragment is hidden
          whole = true;
          alive = false;
          break;
        case SplitResult::ZeroArea: ++c.zero_area; alive = false; break;
        case SplitResult::Both:
          ++c.splits;
          if (nn != 0) {
            pieces.add(neg.data(), size_t(nn));
            piece_boxes.push_back(UVBox::of(axes, neg.data(), nn));
          }
          if (np == 0) {
            alive = false;
          } else {
            cur.swap(pos);
            cp = cur.data();
            cn = np;
          }
          break;
      }
    }
    // Kept whole: the pieces split off it are taken back (a shadow beside a fragment
    // still cuts it along the planes through q's edges). Else what is left after the
    // last edge is positive against every edge, stabs q: blocked, dropped.
    if (whole) {
      pieces.truncate(first_piece);
      piece_boxes.resize(first_piece);
      continue;
    }
    repl.push_back({uint32_t(f), uint32_t(first_piece), uint32_t(pieces.size())});
  }
  if (!repl.empty()) replace_fragments(frags, boxes, pieces, piece_boxes, repl);
  return met;
}

void subtract_triangle_exact(const Vec3f& rw, const Vec3f tw[3], int sigma, const Vec3f& origin,
                             const UVAxes& axes, const LiftedLight& lift, const FragmentList& in, FragmentList& out,
                             std::vector<UVBox>& out_boxes, std::vector<Vec3d>& cur) {
  out.clear();
  out_boxes.clear();
  // Scratch reused across calls (one set per thread): the exact path runs once per
  // candidate triangle and fragment list.
  thread_local std::vector<double> w;
  thread_local std::vector<Vec3d> inside, outside;
  // w > 0 inside plane k's half-space of the blocked set. The planes: the triangle's
  // (orient3d(t0, t1, t2, x)) and those through rw and each edge (det[x - rw, t_e - rw,
  // t_e+1 - rw] = orient3d(rw, t_e, t_e+1, x), cyclic columns), evaluated at the exact
  // lifted light point of x's (u, v) (LiftedLight: a vertex kept in 3D lies its rounding
  // off the light's plane, which decides the side for a receiver that close to the
  // plane), with accurate values: the clip below interpolates with them.
  LiftedPlane planes[4] = {lift.plane(tw[0], tw[1], tw[2]), lift.plane(rw, tw[0], tw[1]),
                                  lift.plane(rw, tw[1], tw[2]), lift.plane(rw, tw[2], tw[0])};
  const int lu = lift.u(), lv = lift.v();
  // accurate: within 2^-30 (clip interpolation); else only the sign is exact.
  auto value = [&](int k, const Vec3d& x, bool accurate) {
    ExactOrient o = accurate ? lift.value(planes[k], origin[lu], x[lu], origin[lv], x[lv])
                             : lift.sign(planes[k], origin[lu], x[lu], origin[lv], x[lv]);
    if (o.sign == 0) return 0.0;
    double v = std::abs(o.value);
    if (!(v > 0.0)) v = std::numeric_limits<double>::min();
    return -double(sigma) * double(o.sign) * v;
  };
  for (size_t f = 0; f < in.size(); ++f) {
    cur.assign(in.data(f), in.data(f) + in.count(f));
    // The pieces split off this fragment start here; when nothing of it turns out hidden
    // they are taken back and the fragment kept whole (below).
    const size_t first_piece = out.size();
    bool blocked = true;
    for (int k = 0; k < 4; ++k) {
      w.resize(cur.size());
      bool pos = false, neg = false;
      for (size_t j = 0; j < cur.size(); ++j) {
        w[j] = value(k, cur[j], false);
        pos |= w[j] > 0.0;
        neg |= w[j] < 0.0;
      }
      if (!pos) {  // all of it outside this half-space: not hidden
        blocked = false;
        break;
      }
      if (!neg) continue;
      // A split interpolates with the values: those within 2^-30 (signs unchanged).
      for (size_t j = 0; j < cur.size(); ++j) w[j] = value(k, cur[j], true);
      // Split: the outside part is kept, the inside part goes on to the next plane.
      clip_by_values(cur.data(), w.data(), int(cur.size()), false, outside);
      clip_by_values(cur.data(), w.data(), int(cur.size()), true, inside);
      if (!outside.empty()) {
        out.add(outside.data(), outside.size());
        out_boxes.push_back(UVBox::of(axes, outside.data(), int(outside.size())));
      }
      cur.swap(inside);
      if (cur.empty()) break;
    }
    if (!blocked || cur.empty()) {
      // Nothing of the fragment is hidden: the pieces split off it (outside one plane or
      // another) make up the whole fragment, which is kept instead, unsplit; else every
      // triangle whose shadow misses a fragment would still cut it along the planes
      // through its edges (test ShadowBesideAFragmentLeavesItWhole).
      keep_whole(in, f, UVBox::of(axes, in.data(f), in.count(f)), first_piece, out, out_boxes);
    }
    // Otherwise what is left is inside all four half-spaces: hidden, dropped.
  }
}


}  // namespace visgate::plucker
