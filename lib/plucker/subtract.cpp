// Subtracting a polygon's shadow from light fragments; see subtract.h.
#include "lib/plucker/subtract.h"

#include <algorithm>
#include <cmath>
#include <cstring>
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

// Fragment f (in run `run`) replaced by fragments [a, b) of the pieces (subtract_polygon).
struct Replacement {
  uint32_t f, a, b, run;
};

// Runs of kRun of the fragments [lo, hi) appended to len and box, each with the union of
// its fragments' boxes (fragment f's box: box_of(f)). Not inlined: FragmentRuns::build
// runs for every short list too (rooms), where a caller holding this loop pays its setup.
template <class BoxOf>
[[gnu::noinline]] void append_runs(const BoxOf& box_of, size_t lo, size_t hi, std::vector<uint32_t>& len, std::vector<UVBox>& box) {
  for (size_t c = lo; c < hi; c += FragmentRuns::kRun) {
    const size_t e = std::min(hi, c + FragmentRuns::kRun);
    UVBox u;
    for (size_t f = c; f < e; ++f) u.extend(box_of(f));
    len.push_back(uint32_t(e - c));
    box.push_back(u);
  }
}

// The runs made anew where some grew past 2 kRun (`boxes` the list's, by Span::box):
// emptied runs dropped, long ones cut into runs of kRun with their boxes' unions (a long
// run costs every polygon that meets its box a scan of all of it), the others kept.
void cut_long_runs(FragmentRuns& runs, const FragmentList& frags, const std::vector<UVBox>& boxes) {
  auto box_of = [&](size_t f) -> const UVBox& { return boxes[frags.polys[f].box]; };
  thread_local std::vector<uint32_t> len;
  thread_local std::vector<UVBox> box;
  len.clear();
  box.clear();
  size_t f0 = 0;
  for (size_t j = 0; j < runs.size(); f0 += runs.len[j], ++j) {
    if (runs.len[j] == 0) continue;
    if (runs.len[j] > 2 * FragmentRuns::kRun) {
      append_runs(box_of, f0, f0 + runs.len[j], len, box);
    } else {
      len.push_back(runs.len[j]);
      box.push_back(runs.box[j]);
    }
  }
  runs.len.swap(len);
  runs.box.swap(box);
}

// Replaces, for each entry of `repl` (increasing f), fragment f of `frags` (and its box)
// by the pieces [a, b) (and their boxes), keeping every other fragment's vertices and box
// where they are: the same fragments in the same order as copying the list with the
// pieces in place of each f, without copying the vertices or the boxes. The spans between
// the entries are moved in place, each stretch by the pieces added and fragments dropped
// before it (memmove; those before the first entry stay). The pieces' vertices go to the
// end of frags.verts and their boxes to the end of `boxes`; the replaced fragments' stay
// there as garbage until more than half of either is, and then that one is written back
// in the list's order again (same values). The runs follow: each replaced fragment's run
// grown by its pieces' boxes (pieces of a fragment lie in it up to rounding, so it still
// holds its fragments') and its length changed, runs grown long cut anew (cut_long_runs).
void replace_fragments(FragmentList& frags, std::vector<UVBox>& boxes, FragmentRuns& runs, const FragmentList& pieces,
                       const std::vector<UVBox>& piece_boxes, const std::vector<Replacement>& repl) {
  using Span = FragmentList::Span;
  static_assert(std::is_trivially_copyable_v<Span>);
  const uint32_t base = uint32_t(frags.verts.size());
  frags.verts.insert(frags.verts.end(), pieces.verts.begin(), pieces.verts.end());  // pieces: back to back
  const uint32_t bbase = uint32_t(boxes.size());
  boxes.insert(boxes.end(), piece_boxes.begin(), piece_boxes.end());  // piece j's box: bbase + j
  const size_t n = frags.polys.size();
  size_t nn = n;  // the new size
  const bool indexed = runs.size() != 0;
  bool cut = false;
  for (const Replacement& rp : repl) {
    frags.garbage += frags.polys[rp.f].second;
    nn = nn + (rp.b - rp.a) - 1;  // the replaced fragment is one of nn: no wrap
    if (!indexed) continue;
    for (uint32_t j = rp.a; j < rp.b; ++j) runs.box[rp.run].extend(piece_boxes[j]);
    uint32_t& len = runs.len[rp.run];
    len = len + (rp.b - rp.a) - 1;
    cut |= len > 2 * FragmentRuns::kRun;
  }
  if (nn > n) frags.polys.resize(nn);
  // Stretch k: the fragments after entry k - 1 (from 0 for k = 0) up to entry k (to n for
  // the last), moved by its shift s_k: the pieces added minus the fragments replaced
  // before it (d(k) per entry). Moving those that go left first, from the front, then
  // those that go right, from the back, reads every stretch before anything is written
  // over it: between stretches i < k the shift changes by at least -(entries between) =
  // -(the gap between them).
  const size_t ns = repl.size() + 1;
  auto d = [&](size_t k) { return int64_t(repl[k].b) - int64_t(repl[k].a) - 1; };
  auto move = [&](size_t k, int64_t sk) {
    const size_t lo = k == 0 ? 0 : size_t(repl[k - 1].f) + 1, hi = k + 1 == ns ? n : size_t(repl[k].f);
    if (hi <= lo) return;
    const size_t to = size_t(int64_t(lo) + sk), len = hi - lo;
    Span* sp = frags.polys.data();
    if (len > 8) {
      std::memmove(sp + to, sp + lo, len * sizeof(Span));
    } else if (to < lo) {  // a few: copied in the direction that reads before it writes
      for (size_t i = 0; i < len; ++i) sp[to + i] = sp[lo + i];
    } else {
      for (size_t i = len; i-- > 0;) sp[to + i] = sp[lo + i];
    }
  };
  int64_t sk = 0;
  for (size_t k = 0; k < ns; ++k) {
    if (sk < 0) move(k, sk);
    if (k + 1 < ns) sk += d(k);
  }
  for (size_t k = ns; k-- > 0;) {  // sk: s_k, from the last stretch's (the total)
    if (sk > 0) move(k, sk);
    if (k > 0) sk -= d(k - 1);
  }
  for (const Replacement& rp : repl) {  // sk: the shift before rp, from 0
    Span* sp = frags.polys.data() + (int64_t(rp.f) + sk);
    for (uint32_t j = rp.a; j < rp.b; ++j)
      *sp++ = Span(base + pieces.polys[j].first, pieces.polys[j].second, bbase + j);
    sk += int64_t(rp.b) - int64_t(rp.a) - 1;
  }
  if (nn < n) frags.polys.resize(nn);
  if (boxes.size() > 1024 && boxes.size() > 2 * nn) {  // the live boxes back in the list's order
    thread_local std::vector<UVBox> live;
    live.resize(nn);
    for (size_t k = 0; k < nn; ++k) {
      live[k] = boxes[frags.polys[k].box];
      frags.polys[k].box = uint32_t(k);
    }
    boxes.swap(live);
  }
  if (cut) cut_long_runs(runs, frags, boxes);
  if (!indexed && nn > FragmentRuns::kIndexFrom) {
    runs.len.clear();
    runs.box.clear();
    append_runs([&](size_t f) -> const UVBox& { return boxes[frags.polys[f].box]; }, 0, nn, runs.len, runs.box);
  }
  if (frags.garbage > 1024 && 2 * frags.garbage > frags.verts.size()) {
    thread_local std::vector<Vec3d> verts;
    verts.clear();
    for (Span& p : frags.polys) {
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
                      FragmentRuns& runs, FragmentList& pieces, std::vector<UVBox>& piece_boxes,
                      std::vector<Vec3d>& cur, std::vector<Vec3d>& pos, std::vector<Vec3d>& neg, BspCounters& c,
                      bool defer_cuts) {
  VG_DCHECK((runs.size() == 0 || runs.count() == frags.size()) && boxes.size() >= frags.size());
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
  // Fragments whose box misses q's shadow box are passed over, whole runs of them at
  // once where the run's box misses it (FragmentRuns; the list changes only after the
  // loop below).
  const UVBox* bx = boxes.data();
  const FragmentList::Span* ps = frags.polys.data();
  // A fragment whose box meets it may still lie on the negative side of one edge plane.
  // Else every edge's class is kept (positive[m]): split_fragment finds the same on the
  // fragment itself (fragment.h), so the walk below skips those edges until its first split.
  bool positive[std::size(planes)];
  auto edge_misses = [&](size_t f) {
    for (int mi = 0; mi < nq; ++mi) {
      const int m = hint + mi < nq ? hint + mi : hint + mi - nq;
      if (skip[m]) continue;
      SplitResult s = classify_fragment(plane(m), frags.data(f), frags.count(f));
      positive[m] = s == SplitResult::Positive;
      if (s == SplitResult::OnLine) ++c.on_line;  // undecided: the caller re-shades r exactly
      if (s == SplitResult::Negative || s == SplitResult::OnLine) {
        hint = m;
        return true;
      }
    }
    return false;
  };
  // With defer_cuts, edge m's cut of what is left of a fragment (R) is put off when its
  // chord (R on m's plane) lies beyond the next edge's plane (split_fragment's side
  // plane): then no point of R's chord lies on q's edge m itself (q convex: its edge is
  // the part of m's line inside both neighbours' planes), so once the next edge has cut
  // R, what is left mostly lies inside m's plane (Positive: no cut) and the piece beyond
  // m's line, which q's shadow does not reach there, is not split off. A choice of order
  // only: the put-off cuts are still made, last, and the walk's result holds for any
  // order of q's edges.
  bool met = false;  // some fragment not missed
  pieces.clear();
  piece_boxes.clear();
  thread_local std::vector<Replacement> repl;
  repl.clear();
  // Without runs, one range of every fragment.
  const bool indexed = runs.size() != 0;
  const size_t nr = indexed ? runs.size() : 1;
  size_t f_end = 0;
  for (size_t j = 0; j < nr; ++j) {
    const size_t f0 = f_end;  // run j's first fragment
    f_end = indexed ? f0 + runs.len[j] : frags.size();
    if (indexed && !qbox.overlaps(runs.box[j])) continue;
    for (size_t f = f0;; ++f) {
      while (f < f_end && !qbox.overlaps(bx[ps[f].box])) ++f;  // a loop of its own: most boxes miss
      if (f == f_end) break;
      if (edge_misses(f)) continue;
      met = true;
      // The piece still walked: the fragment itself until the first split, then `cur`.
      // The pieces are written into pos and neg (room for 2n each, fragment.h); the
      // buffers only grow. The visible pieces split off go to `pieces`.
      const Vec3d* cp = frags.data(f);
      int cn = frags.count(f);
      const size_t first_piece = pieces.size();
      bool alive = true, whole = false, split = false;  // split: cp is a piece, not the fragment
      uint32_t deferred = 0;  // bit m: edge m's cut put off to the end (defer_cuts)
      // Steps 0..nq-1 walk the edges in order, steps nq..2nq-1 the put-off ones again.
      for (int t = 0; t < 2 * nq && alive; ++t) {
        const bool first = t < nq;
        const int m = first ? t : t - nq;
        if (first ? (skip[m] || (!split && positive[m])) : !(deferred >> m & 1u)) continue;
        if (pos.size() < size_t(2 * cn)) pos.resize(size_t(2 * cn));
        if (neg.size() < size_t(2 * cn)) neg.resize(size_t(2 * cn));
        int np = 0, nn = 0;
        SplitResult s;
        bool off = false;
        if (first && defer_cuts && m + 1 < nq && !skip[m + 1]) {
          // The side plane of the next edge, whose cut comes later. (Also the previous
          // edge's where its cut comes later, for m = 0 or a put-off one: more tests, and
          // more pieces, measured.)
          s = split_fragment(plane(m), plane(m + 1), cp, cn, pos.data(), np, neg.data(), nn, off);
        } else if (!first && classify_fragment(plane(m), cp, cn) == SplitResult::Positive) {
          s = SplitResult::Positive;  // as split_fragment finds it, without its value array
        } else {
          s = split_fragment(plane(m), cp, cn, pos.data(), np, neg.data(), nn);
        }
        switch (s) {
          case SplitResult::Positive: break;
          case SplitResult::OnLine: ++c.on_line; [[fallthrough]];
          case SplitResult::Negative:  // what is left misses q: nothing of the fragment is hidden
            whole = true;
            alive = false;
            break;
          case SplitResult::ZeroArea: ++c.zero_area; alive = false; break;
          case SplitResult::Both:
            if (off) {
              deferred |= 1u << m;
              ++c.deferred_cuts;
              break;
            }
            ++c.splits;
            if (nn != 0) pieces.add(neg.data(), size_t(nn));
            if (np == 0) {
              alive = false;
            } else {
              cur.swap(pos);
              cp = cur.data();
              cn = np;
              split = true;
            }
            break;
        }
        if (first && t + 1 == nq && deferred == 0) break;
      }
      // Kept whole: the pieces split off it are taken back (a shadow beside a fragment
      // still cuts it along the planes through q's edges). Else what is left after the
      // last edge is positive against every edge, stabs q: blocked, dropped.
      if (whole) {
        pieces.truncate(first_piece);
        continue;
      }
      // The pieces' boxes once they are kept (a fifth of the pieces are taken back).
      for (size_t k = first_piece; k < pieces.size(); ++k)
        piece_boxes.push_back(UVBox::of(axes, pieces.data(k), pieces.count(k)));
      repl.push_back({uint32_t(f), uint32_t(first_piece), uint32_t(pieces.size()), uint32_t(j)});
    }
  }
  if (!repl.empty()) replace_fragments(frags, boxes, runs, pieces, piece_boxes, repl);
  return met;
}

void FragmentRuns::build(const std::vector<UVBox>& boxes) {
  len.clear();
  box.clear();
  if (boxes.size() > kIndexFrom)
    append_runs([&](size_t f) -> const UVBox& { return boxes[f]; }, 0, boxes.size(), len, box);
}

size_t FragmentRuns::count() const {
  size_t n = 0;
  for (uint32_t l : len) n += l;
  return n;
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
