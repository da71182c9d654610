// Per-receiver shading (paper 002 section 4.4, Algorithm 2 lines 9-11; Figure 8 column
// "Q"): the visible fragments of the light from one receiver of a group, then the
// fraction, the samples' bits and the Lambert irradiance over them [NN85]. The near
// polygons are subtracted from the light first (subtract.h), then Algorithm 1 (section
// 4.2, LazyBsp::query) runs on what they leave; receivers and triangles that rounding
// cannot place take the exact near-plane path (subtract_triangle_exact).
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <limits>

#include "lib/plucker/group_state.h"
#include "lib/plucker/pyramid_side.h"
#include "lib/plucker/subtract.h"

namespace visgate::plucker {

namespace {

// Side of the (local, double) point r against a near polygon's triangle plane: +1, -1, or
// 0 when undecided. Decided against dot_err plus the rounding of the local frame: every
// local point is within u_d |x|_inf of its exact translation (to_local_d), which moves
// det[t1 - t0, t2 - t0, r - t0] by at most 2 delta (|e1|_1 |e2|_1 + (|e1|_1 + |e2|_1)
// |r - base|_1) with delta = 2 u_d max |coordinate|, so a decided sign is the sign of
// the exact world configuration (the inputs as given).
int near_side(const NearPoly& np, const Vec3d& r, double rmax) {
  const Vec3d& base = nearest_base(np.t[0], np.t[1], np.t[2], r);
  Vec3d d = r - base;
  double s = dot(d, np.n);
  double d1 = std::abs(d.x) + std::abs(d.y) + std::abs(d.z);
  double delta = 2.0 * kUnitRoundoffD * std::max(rmax, np.tmax);
  double bound = dot_err(d, np.n, np.err) + 2.0 * delta * (np.e1 * np.e2 + (np.e1 + np.e2) * d1);
  return s > bound ? 1 : (s < -bound ? -1 : 0);
}

// The translation to the local frame is exact in double unless exponents differ by
// more than 29, else rounded at u_d: 4 u_d of the coordinates is far above it.
constexpr double kUd = kUnitRoundoffD;

// Per receiver, what the near polygons' pyramid test reads of the pyramid's side plane j
// (pyramid_planes), side by side in one array: n = pyramid[j], its point l = light
// vertex j, w the weights of dot_err(d, pyramid[j], pyramid_err[j]) = sum |d_i| w_i and
// c = 4 u_d |pyramid[j]|_1 of the shift. Per thread, like the group's other scratch (one
// receiver at a time).
struct PyramidWeights {
  using Plane = PyramidPlane;
  std::vector<Plane> p;
};
PyramidWeights& pyramid_weights() {
  thread_local PyramidWeights pw;
  return pw;
}
// Per near polygon of the group, the pyramid plane that last rejected it (a start for
// the next receiver's test; any value is correct: the test's answer does not depend on
// the order of the planes). Per thread; sized by shade_float.
std::vector<uint8_t>& near_hint() {
  thread_local std::vector<uint8_t> h;
  return h;
}
// Per near block of the group (GroupState::NearBlock), the pyramid plane that last
// rejected it in block_outside (a start, as near_hint). Per thread; sized by shade_float.
std::vector<uint8_t>& block_hint() {
  thread_local std::vector<uint8_t> h;
  return h;
}
// Per interior occluder of the group, the edge that failed last in covered() (a start,
// as near_hint). Per thread; sized by cover_planes.
std::vector<uint8_t>& cover_hint() {
  thread_local std::vector<uint8_t> h;
  return h;
}
// Per interior occluder of the group and this receiver r: a circular double cone about
// the line through r along `axis` (about unit) that holds every line from r through the
// occluder, as the square of a cosine below the least cosine between the axis and the
// occluder's vertices seen from r (cover_planes; 0 bounds nothing). Per thread, as
// cover_hint.
struct CoverCone {
  Vec3d axis;
  double cos2 = 0.0;
};
std::vector<CoverCone>& cover_cones() {
  thread_local std::vector<CoverCone> c;
  return c;
}

// det[x - p, a - p, b - p] strictly positive as side_sign (lines.h) decides it: (x - base)
// . N > dot_err(x - base, N, err), base = nearest_base(p, a, b, x), with w_i = err_i + 8
// u_d |N_i| (dot_err's weights, given). The same operations in the same order, so the
// same answer, with the difference to the base taken from nearest_base's three 1-norms
// instead of computed again, and the bound (>= 0) left out for a value not above 0.
// dp = x - p and its 1-norm np are given (covered() tries each x against many planes
// through the same p = r).
[[gnu::always_inline]] inline bool plane_positive(const Vec3d& dp, double np, const Vec3d& a, const Vec3d& b,
                                                  const Vec3d& x, const Vec3d& nrm, const Vec3d& w) {
  const Vec3d da = x - a, db = x - b;
  const double na = norm1(da), nb = norm1(db);
  const Vec3d& d = (np <= na && np <= nb) ? dp : (na <= nb ? da : db);
  const double s = dot(d, nrm);
  if (!(s > 0.0)) return false;
  return s > std::abs(d.x) * w.x + std::abs(d.y) * w.y + std::abs(d.z) * w.z;
}

// dot_err's weights (lines.h) of a plane's error bound err and normal nrm: w_i = err_i +
// 8 u_d |nrm_i|, each as dot_err computes it.
inline Vec3d dot_err_weights(const Vec3d& nrm, const Vec3d& err) {
  constexpr double k = 8.0 * kUnitRoundoffD;
  return Vec3d(err.x + k * std::abs(nrm.x), err.y + k * std::abs(nrm.y), err.z + k * std::abs(nrm.z));
}

class ReceiverShading {
 public:
  ReceiverShading(GroupState& gs, LazyBsp& bsp, size_t gk, BspCounters& near_counters, Totals& tot)
      : gs_(gs),
        bsp_(bsp),
        nc_(near_counters),
        tot_(tot),
        scene_(*gs.ctx->scene),
        lf_(*gs.lf),
        i_(size_t((*gs.group)[gk])),
        rec_(scene_.receivers[i_]),
        r_(gs.rloc[gk]),
        rmax_(max_component(vabs(r_))),
        pw_(pyramid_weights()),
        near_hint_(near_hint()),
        block_hint_(block_hint()),
        cover_hint_(cover_hint()),
        cover_cones_(cover_cones()) {}

  void run();

 private:
  bool is_extreme() const;
  bool subtract_exact(uint32_t t);
  void shade_exact();
  void shade_float();
  void pyramid_planes();
  // all_ and the runs (FragmentRuns) made anew over the fragments' boxes.
  void bound_all() {
    gs_.runs.build(gs_.boxes);
    all_ = UVBox{};
    for (const UVBox& b : gs_.runs.size() != 0 ? gs_.runs.box : gs_.boxes) all_.extend(b);
  }
  // After a subtraction in place: all_ grown by the new fragments' boxes (gs_.tmp_boxes)
  // instead of made anew. It then holds every fragment's box, and it only rejects a
  // polygon whose shadow box misses it (subtract_near, subtract_merged), which then misses
  // every fragment's box: subtract_polygon would change nothing, so the larger union
  // changes no answer, only how soon a polygon is let go.
  void extend_all() {
    for (const UVBox& b : gs_.tmp_boxes) all_.extend(b);
  }
  bool exact_once(uint32_t t);
  void cover_planes();
  bool block_outside(const GroupState::NearBlock& b, uint8_t& hint) const;
  bool covered(const NearPoly& np);
  CoverCone cover_cone(const Occluder& o) const;
  bool exact_near(const NearPoly& np);
  // Inlined into shade_float's loop over the near polygons (a call per polygon and
  // receiver costs measurably on columns).
  [[gnu::always_inline]] inline void subtract_near(const NearPoly& np, uint32_t idx);
  bool subtract_merged(const NearPoly& np, uint32_t k, int side_r);
  void report_fragments(double& area, double& irr);
  void sample_bits();

  GroupState& gs_;
  LazyBsp& bsp_;
  BspCounters& nc_;
  Totals& tot_;
  const Scene& scene_;
  const LocalLight& lf_;
  const size_t i_;  // the receiver's index in the scene
  const Receiver& rec_;
  const Vec3d& r_;  // local
  const double rmax_;
  UVBox all_;        // holds the fragments' boxes: their union (bound_all) or more (extend_all)
  Vec3d plo_{}, phi_{};  // the box of r's pyramid (r and the light), grown
  uint32_t serial_ = 0;  // this receiver's mark in GroupState::near_done (0: no merging)
  PyramidWeights& pw_;           // this thread's (pyramid_weights)
  std::vector<uint8_t>& near_hint_;  // this thread's (near_hint)
  std::vector<uint8_t>& block_hint_;  // this thread's (block_hint)
  // covered(): per interior occluder, the edge that failed last (cover_planes sizes it;
  // this thread's, as near_hint_).
  std::vector<uint8_t>& cover_hint_;
  size_t cover_last_ = 0;  // covered(): the interior occluder that covered the last polygon
  std::vector<CoverCone>& cover_cones_;  // covered(): per interior occluder (cover_planes)
};

// Extreme receivers: seen from r the light is at a grazing angle (r 2^20 times farther
// from the light than from its plane), where even double planes through r move shadow
// edges by more than the tolerance (test ReceiverAtAGrazingAngle). Far receivers too:
// every double quantity through r (r + t (v - r), planes through r) carries an absolute
// rounding of about 2^-53 |r - origin|, which stays below 2^-33 of the light's extent,
// far under the fraction tolerance, only while r is within 2^20 extents of the light
// (test ReceiverFarFromTheLight). The extent that counts is the light's width (area
// over its longest side) when that is smaller.
// For a long light the grazing bound is tighter by its aspect (extent over width): a
// shadow line running along the long axis meets the light's long edge at an angle of
// about width / extent, so a lateral error moves where it ends by extent / width times
// that (test GrazingReceiverOfALongLightTakesTheExactPath). Such a receiver is shaded by
// the exact path alone: every candidate triangle of the group subtracted exactly, no
// tree and no near polygons.
bool ReceiverShading::is_extreme() const {
  const double hr = double(gs_.sigma) * (dot(lf_.nd, r_) - lf_.h0);
  const double far = std::max(max_component(vabs(r_ - lf_.bounds.centroid)), double(lf_.extent));
  const double aspect = std::max(1.0, double(lf_.extent) / gs_.light_width);
  return !(far * aspect <= 0x1p20 * hr) || !(far <= 0x1p20 * gs_.light_width);
}

// Subtracts triangle t exactly from the fragments (boxes follow); false, subtracting
// nothing, when the receiver lies in its plane.
bool ReceiverShading::subtract_exact(uint32_t t) {
  const Vec3f wtri[3] = {scene_.mesh.corner(t, 0), scene_.mesh.corner(t, 1), scene_.mesh.corner(t, 2)};
  const int side_exact = to_int(orient3d_exact(wtri[0], wtri[1], wtri[2], rec_.p));
  if (side_exact == 0) return false;
  ++tot_.exact_triangles;
  subtract_triangle_exact(rec_.p, wtri, side_exact, lf_.origin, lf_.axes, lf_.lift, gs_.frags, gs_.tmp,
                          gs_.tmp_boxes, gs_.cur);
  std::swap(gs_.frags, gs_.tmp);
  std::swap(gs_.boxes, gs_.tmp_boxes);
  return true;
}

// Every candidate triangle of the group, exactly, from the whole light.
void ReceiverShading::shade_exact() {
  ++tot_.exact_receivers;
  gs_.frags.clear();
  gs_.frags.add(lf_.poly.data(), lf_.poly.size());
  gs_.boxes.assign(1, UVBox::of(lf_.axes, lf_.poly.data(), int(lf_.poly.size())));
  const std::vector<uint32_t>* cand = &gs_.cand;
  if (!gs_.cand_skipped.empty()) {  // with the subtrees selection left out, in index order
    gs_.cand_all = gs_.cand;
    for (const TriangleTree::Range& r : gs_.cand_skipped) gs_.ctx->tree->append_items(r, gs_.cand_all);
    std::sort(gs_.cand_all.begin(), gs_.cand_all.end());
    cand = &gs_.cand_all;
  }
  for (uint32_t t : *cand) {
    if (gs_.frags.size() == 0) break;
    subtract_exact(t);
  }
}

// Side planes of the pyramid (r, light), oriented so the light's centroid is positive: a
// near polygon entirely on the negative side of one misses every segment from r to the
// light. Each plane through r and light edge (l_j, l_j+1) has N = edge_plane_normal (its
// two shortest of l_j - r, l_j+1 - r, l_j+1 - l_j: for a receiver far from a small light
// the textbook (l_j - r) x (l_j+1 - r) crosses two nearly parallel long vectors) and is
// evaluated through l_j: (x - l_j) . N, rejected only below -16 dot_err (16 times its
// error bound). A plane only culls when the whole light is on its positive side (then it
// supports the pyramid, whatever edge it came from): an edge far shorter than the
// rounding of its lifted ends has no direction, and its plane is dropped (a zero normal
// culls nothing; test PyramidPlaneOfAnEdgeShorterThanItsRoundingCullsNothing).
void ReceiverShading::pyramid_planes() {
  const size_t m = lf_.poly.size();
  gs_.pyramid.resize(m);
  gs_.pyramid_err.resize(m);
  PyramidWeights& pw = pw_;
  pw.p.resize(m);
  for (size_t j = 0; j < m; ++j) {
    Vec3d err;
    Vec3d nrm = edge_plane_normal_err(r_, lf_.poly[j], lf_.poly[(j + 1) % m], err);
    if (dot(nrm, lf_.bounds.centroid - lf_.poly[j]) < 0.0) nrm = -nrm;
    for (size_t k = 0; k < m; ++k) {
      const Vec3d d = lf_.poly[k] - lf_.poly[j];
      if (dot(nrm, d) < -16.0 * dot_err(d, nrm, err)) {
        nrm = Vec3d(0, 0, 0);
        err = Vec3d(0, 0, 0);
        break;
      }
    }
    gs_.pyramid[j] = nrm;
    gs_.pyramid_err[j] = err;
    constexpr double k8 = 8.0 * kUnitRoundoffD;  // lines.h dot_err's factor
    PyramidWeights::Plane& pp = pw.p[j];
    pp.n = nrm;
    pp.l = lf_.poly[j];
    pp.w = Vec3d(err.x + k8 * std::abs(nrm.x), err.y + k8 * std::abs(nrm.y), err.z + k8 * std::abs(nrm.z));
    pp.c = 4.0 * kUd * (std::abs(nrm.x) + std::abs(nrm.y) + std::abs(nrm.z));
    pp.set_lanes();
  }
}

// The planes through r and the edges of the group's interior occluders
// (interior_occluders.h; in the tree, one-sided with r strictly on their negative side):
// none when r's translation to the local frame was rounded.
void ReceiverShading::cover_planes() {
  gs_.cover_n.clear();
  gs_.cover_err.clear();
  gs_.cover_at.clear();
  cover_hint_.assign(gs_.interior.size(), 0);
  cover_cones_.clear();
  if (gs_.interior.empty() || !translates_exactly(rec_.p, lf_.origin)) return;
  for (const Occluder& o : gs_.interior) {
    gs_.cover_at.push_back(uint32_t(gs_.cover_n.size()));
    for (int m = 0; m < o.n; ++m) {
      Vec3d err;
      gs_.cover_n.push_back(edge_plane_normal_err(r_, o.v[m], o.v[(m + 1) % o.n], err));
      gs_.cover_err.push_back(dot_err_weights(gs_.cover_n.back(), err));  // covered() reads the weights
    }
    cover_cones_.push_back(cover_cone(o));
  }
}

// The cone of covered()'s pre-reject for occluder o (CoverCone): axis u = (c - r) / |c - r|,
// c the vertices' mean, and cos2 = C^2 with C = min_k u . w_k / |w_k| - 2^-30 (w_k = v_k - r),
// or 0 when C <= 2^-20 (a cone of half-angle 90 degrees or more is not convex; C^2 d . d
// stays normal in covered). Every computed cosine is within 16 u_d of the exact cosine
// between the stored u and w_k, so the exact least cosine C* exceeds C + 2^-31: the
// convex cone {y: u . y >= C* |u| |y|} holds every
// w_k and so every direction from r through the occluder, and its mirror image every
// direction of a line from r through it.
CoverCone ReceiverShading::cover_cone(const Occluder& o) const {
  CoverCone cc;
  Vec3d c(0, 0, 0);
  for (int k = 0; k < o.n; ++k) c += o.v[k];
  const Vec3d a = c / double(o.n) - r_;
  const double la = length(a);
  if (!(la > 0.0) || o.n < 3) return cc;
  cc.axis = a / la;
  double cmin = std::numeric_limits<double>::infinity();
  for (int k = 0; k < o.n; ++k) {
    const Vec3d w = o.v[k] - r_;
    const double lw = length(w);
    if (!(lw > 0.0)) return CoverCone{};
    cmin = std::min(cmin, dot(cc.axis, w) / lw);
  }
  const double cl = cmin - 0x1p-30;
  cc.cos2 = cl > 0x1p-20 ? cl * cl : 0.0;
  return cc;
}

// True when every line from r through the near polygon's triangle (local, exact) is
// strictly positive against every edge of one interior occluder: each such line stabs
// it, from r's side, so the segment from r to the light passes through it (it lies
// strictly between the group's receivers and the light) and the tree hides what the
// triangle would. Signs det[x - r, a - r, b - r] decided against dot_err (lines.h).
// The edges of each occluder are tried from the one that failed last for it
// (cover_hint_): the polygons come in spatial order, and near the silhouette most of
// them pass every edge but one. For the same reason the occluders are tried from the one
// that covered the last polygon (cover_last_; the answer is whether any covers it, so
// the order changes nothing but the work: measured on the bunny, 11 occluders).
// Before the plane tests, an occluder is let go when a vertex x of the triangle lies off
// its cone (cover_cone): (u . d)^2 < C^2 (d . d), d = x - r, computed. The computed
// values err by less than 16 u_d relative to |u| |d| (a vertex with d . d below 2^-900 is
// not tried: no underflow), far below the cone's 2^-31 margin, so the exact |cos| between d
// and u is below C*: the line from r through x misses the occluder, and some plane test
// (each decided exactly, as side_sign) would have failed. The answer is unchanged; only
// the edge hint of an occluder so let go is not moved.
bool ReceiverShading::covered(const NearPoly& np) {
  if (gs_.cover_n.empty()) return false;  // no planes: nothing is taken as covered
  Vec3d d[3];
  double dd[3], d1[3];
  for (int k = 0; k < 3; ++k) {
    d[k] = np.t[k] - r_;
    d1[k] = norm1(d[k]);
    dd[k] = dot(d[k], d[k]);
    if (!(dd[k] >= 0x1p-900)) dd[k] = 0.0;  // (u . d)^2 < 0 never holds: not tried
  }
  const CoverCone* cones = cover_cones_.data();
  const size_t no = gs_.interior.size();
  for (size_t oj = 0; oj < no; ++oj) {
    const size_t oi = cover_last_ + oj < no ? cover_last_ + oj : cover_last_ + oj - no;
    const CoverCone& cc = cones[oi];
    bool off = false;
    for (int k = 0; k < 3 && !off; ++k) {
      const double t = dot(cc.axis, d[k]);
      off = t * t < cc.cos2 * dd[k];
    }
    if (off) continue;
    const Occluder& o = gs_.interior[oi];
    const size_t e = gs_.cover_at[oi];
    uint8_t& hint = cover_hint_[oi];
    bool all = true;
    for (int mi = 0; mi < o.n && all; ++mi) {
      const int m = (hint + mi) % o.n;
      const Vec3d& nrm = gs_.cover_n[e + size_t(m)];
      const Vec3d& w = gs_.cover_err[e + size_t(m)];
      const Vec3d &a = o.v[m], &b = o.v[m + 1 == o.n ? 0 : m + 1];
      for (int k = 0; k < 3 && all; ++k) all = plane_positive(d[k], d1[k], a, b, np.t[k], nrm, w);
      if (!all) hint = uint8_t(m);
    }
    if (all) {
      cover_last_ = oi;
      return true;
    }
  }
  return false;
}

// A near polygon's whole triangle, exactly, once for this receiver; true when it was
// subtracted (false: already done, or r lies in its plane).
bool ReceiverShading::exact_once(uint32_t t) {
  std::vector<uint32_t>& done = gs_.exact_done;
  if (std::find(done.begin(), done.end(), t) != done.end()) return false;
  done.push_back(t);
  if (!subtract_exact(t)) return false;
  bound_all();
  return true;
}

// A near polygon's triangles (all of a patch), exactly.
bool ReceiverShading::exact_near(const NearPoly& np) {
  if (np.patch < 0) return exact_once(np.triangle);
  bool done = false;
  for (uint32_t pt : gs_.ctx->tree->patch_triangles(np.patch)) done = exact_once(pt) || done;
  return done;
}

// True when every polygon of the block would be rejected by subtract_near's box or
// pyramid test: the block's box misses the pyramid's box, or all of its 8 corners are
// outside one side plane by the margin subtract_near asks of each vertex (16 times the
// evaluation bound plus the shift for the local frame's rounding, taken at the block's
// largest coordinate). The plane value is linear, so a vertex inside the box is
// further outside than the box's largest corner value, whose exact value is below
// -shift.
bool ReceiverShading::block_outside(const GroupState::NearBlock& b, uint8_t& hint) const {
  if (b.hi.x < plo_.x || b.lo.x > phi_.x || b.hi.y < plo_.y || b.lo.y > phi_.y || b.hi.z < plo_.z || b.lo.z > phi_.z)
    return true;
  // The planes from the one that rejected this block for the group's previous receiver
  // (the answer does not depend on their order); the margin's and the bound's
  // per-receiver parts precomputed (pyramid_planes: shift = 4 u_d |pn|_1 (pmax + extent +
  // r_max), dot_err(d, pn, err) = sum |d_i| w_i), bit for bit.
  const size_t m = lf_.poly.size();
  const size_t first = hint < m ? hint : 0;
  for (size_t ji = 0; ji < m; ++ji) {
    const size_t j = first + ji < m ? first + ji : first + ji - m;
    const PyramidWeights::Plane& pp = pw_.p[j];
    const double shift = pp.c * (b.pmax + double(lf_.extent) + rmax_);
    const Vec3d dl = b.lo - pp.l, dh = b.hi - pp.l;  // corner - l_j, per component
    bool outside = true;
    for (int c = 0; c < 8 && outside; ++c)
      outside = outside_side(pp, Vec3d((c & 1) ? dh.x : dl.x, (c & 2) ? dh.y : dl.y, (c & 4) ? dh.z : dl.z), shift);
    if (outside) {
      hint = uint8_t(j);
      return true;
    }
  }
  return false;
}

// One near polygon against this receiver: rejected by the receiver's slab and pyramid,
// sent to the exact path where rounding cannot place it, else clipped to the slab and
// its shadow subtracted from the fragments (subtract_polygon).
void ReceiverShading::subtract_near(const NearPoly& np, uint32_t idx) {
  if (serial_ != 0 && gs_.near_done[idx] == serial_) return;  // subtracted in a merged polygon already
  if (np.hi.x < plo_.x || np.lo.x > phi_.x || np.hi.y < plo_.y || np.lo.y > phi_.y || np.hi.z < plo_.z ||
      np.lo.z > phi_.z)
    return;
  const Vec3d* pv = gs_.near_verts.data() + np.begin;
  // Cheap rejections first, conservative also against the rounding of the local
  // frame (a point moves by u |x| when translated; see the exact path below): the side
  // planes of this receiver's pyramid, then its slab (g . p > g . r somewhere, else the
  // polygon is at or behind its g-plane). Either rejection alone returns, so their order
  // and the order of the planes do not change what is rejected: the pyramid goes first
  // (it rejects about three in four near polygons on columns, the slab almost none), from
  // the plane that rejected this polygon for the group's previous receiver (neighbouring
  // receivers are mostly rejected by the same plane).
  const double pmax = np.pmax;
  {
    const double reach = pmax + double(lf_.extent) + rmax_;
    const PyramidWeights::Plane* planes = pw_.p.data();
    const size_t m = lf_.poly.size();
    uint8_t& hint = near_hint_[idx];
    const size_t first = hint < m ? hint : 0;
    for (size_t ji = 0; ji < m; ++ji) {
      const size_t j = first + ji < m ? first + ji : first + ji - m;
      const PyramidWeights::Plane& pp = planes[j];
      // block_outside's test and margin (outside_side), their per-receiver parts
      // precomputed (pyramid_planes): shift = 4 u_d |pn|_1 (pmax + extent + r_max),
      // dot_err(d, pn, err) = sum |d_i| (err_i + 8 u_d |pn_i|), bit for bit.
      if (all_outside(pp, pv, np.count, pp.c * reach)) {
        hint = uint8_t(j);
        return;
      }
    }
  }
  std::vector<double>& vals = gs_.vals;
  const Vec3d& gd = gs_.g;
  vals.resize(np.count);
  double maxv = -1.0;
  for (uint32_t k = 0; k < np.count; ++k) {
    vals[k] = dot(gd, pv[k] - r_);
    maxv = std::max(maxv, vals[k]);
  }
  const double gn1 = std::abs(gd.x) + std::abs(gd.y) + std::abs(gd.z);
  if (maxv < -4.0 * kUd * gn1 * (pmax + rmax_)) return;
  bool all_above = false;  // every vertex above r's level beyond rounding (set below)
  // The side of r against the triangle's plane (near_side: decided on the local double
  // coordinates with a bound that covers their rounding, so it is the side in the
  // inputs as given). A receiver within rounding of the plane (but not on it) sees the
  // triangle across a sliver of space that rounding cannot resolve, and what the
  // triangle hides can be the whole light (tests ReceiverWithinRoundingOfAFace,
  // ReceiverASubnormalDistanceFromAFace): such a triangle is subtracted exactly, whole,
  // once per receiver (subtract_triangle_exact). Exactly on the plane the triangle
  // cannot meet an open segment from r properly (it only touches or contains it):
  // skipped.
  int side_r = near_side(np, r_, rmax_);
  if (side_r == 0) {
    exact_near(np);
    return;
  }
  // A closed surface's triangle crossed from r only on the dropped side (keep_side), or
  // whose every line from r stabs an interior occluder of the tree: nothing for r.
  if (np.keep_side != 0 && side_r != np.keep_side) return;
  if (np.exact_local && covered(np)) return;
  // Vertices within the rounding of r's level count as on it: just above it, a vertex
  // next to one below makes a clip point within rounding of itself, and the plane
  // through r and that edge of ulps takes any direction about the line from r (test
  // NearPolygonVertexWithinRoundingOfTheReceiversLevelCountsAsOnIt). On the level such
  // a vertex starts or ends only edges along the level (skipped below) or edges to
  // well-separated points. A vertex further above the level but still close to it
  // (within 2^-24 of the coordinates) has clip points whose rounding turns their planes
  // about a point far beyond the light by an angle the light can see; and a triangle
  // whose only part above the level is within its rounding may still hide much of the
  // light from a receiver right under it (test
  // TriangleAboveTheReceiversLevelOnlyByRoundingGoesExact). Both go to the exact path
  // (`level_triangles`; none on the built-in families, whose vertices are at a
  // receiver's level exactly or far from it).
  {
    const double on_tol = 4.0 * kUd * gn1 * (pmax + rmax_), near_tol = 0x1p-24 * gn1 * (pmax + rmax_);
    const bool above = maxv > 0.0;
    bool near_level = false;
    maxv = 0.0;
    all_above = true;
    for (double& v : vals) {
      if (std::abs(v) <= on_tol) v = 0.0;
      near_level |= v > 0.0 && v <= near_tol;
      all_above &= v > 0.0;
      maxv = std::max(maxv, v);
    }
    if (maxv <= 0.0 && !above) return;  // float path: at or behind r's g-plane
    if (maxv <= 0.0 || near_level) {    // above it only by rounding, or close to it
      if (exact_near(np)) ++tot_.level_triangles;
      return;
    }
  }
  // The clip into grow-only buffers (room for 2 count vertices), its size kept in nq.
  std::vector<Vec3d>& q = gs_.q;
  std::vector<uint8_t>&on_level = gs_.on_level, &skip = gs_.skip;
  const size_t room = 2 * size_t(np.count);
  if (q.size() < room) q.resize(room);
  if (on_level.size() < room) on_level.resize(room);
  if (skip.size() < room) skip.resize(room);
  // Every vertex above r's level: the clip keeps the polygon as it is, none on the level
  // (on_level is left unwritten; the skips below are all 0 then).
  // Oriented so that r is on the negative side (bsp.h Occluder): the polygon read in
  // place when it is its own clip and already so oriented, else q (reversed when r is
  // on its positive side).
  size_t nq = 0;
  const Vec3d* qp = q.data();
  if (all_above) {
    if (np.count >= 3) {
      nq = np.count;
      if (side_r > 0) std::reverse_copy(pv, pv + nq, q.begin());
      else qp = pv;
    }
  } else {
    nq = size_t(clip_by_values(pv, vals.data(), int(np.count), true, q.data(), on_level.data()));
    if (side_r > 0) {
      std::reverse(q.begin(), q.begin() + std::ptrdiff_t(nq));
      std::reverse(on_level.begin(), on_level.begin() + std::ptrdiff_t(nq));
    }
  }
  if (nq == 0) return;
  // An edge of q at r's own level (both ends on the clip plane g . p = g . r) lies in the
  // level plane through r, so the plane through r and that edge is the level plane
  // itself, and every light point is strictly beyond it, on q's side: the edge cannot cut
  // a light line away and is skipped. Testing it would be wrong near degeneracy: when r
  // is within rounding of the triangle's plane, the edge passes within rounding of r and
  // float calls r "on its line" (test ReceiverWithinRoundingOfAFace).
  // (None on the level when every vertex is above it: on_level was not written then.)
  const uint8_t* sp = skip.data();
  if (all_above) {
    if (gs_.no_skip.size() < nq) gs_.no_skip.resize(nq, 0);
    sp = gs_.no_skip.data();
  } else {
    for (size_t k = 0; k < nq; ++k) skip[k] = on_level[k] && on_level[k + 1 == nq ? 0 : k + 1];
  }
  // The planes through r and q's edges are only as good as q's vertices: a vertex
  // rounded by u of its coordinates, at a distance d from r, turns such a plane by up to
  // u |q| / d. A vertex that close to r (the clip at r's level of an edge passing within
  // 2^-24 of the coordinates of r) sends the triangle to the exact path (test
  // NearPolygonClippedNextToTheReceiverGoesExact).
  bool too_close = false;
  for (size_t k = 0; k < nq && !too_close; ++k) {
    if (sp[k] && sp[k == 0 ? nq - 1 : k - 1]) continue;  // starts and ends no tested edge
    const double d = max_component(vabs(qp[k] - r_)), scale = std::max(max_component(vabs(qp[k])), rmax_);
    too_close = !(d > 0x1p-24 * scale);
  }
  if (too_close) {
    if (exact_near(np)) ++tot_.close_triangles;
    return;
  }
  if (serial_ != 0 && subtract_merged(np, idx, side_r)) return;
  // Its shadow's box against the fragments' boxes: disjoint boxes, nothing to cut.
  UVBox qbox = shadow_box(lf_.plane, r_, qp, nq);
  if (!qbox.overlaps(all_)) return;
  if (subtract_polygon(r_, qp, int(nq), sp, qbox, lf_.axes, lf_.bounds, gs_.frags, gs_.boxes,
                       gs_.runs, gs_.tmp, gs_.tmp_boxes, gs_.cur, gs_.pos, gs_.neg, nc_))
    extend_all();
}

// Near triangles of a closed surface glued along edges (ClosedSurfaces::neighbors)
// subtracted as one convex polygon when r sees their union convex: the union of their
// shadows from r is then the light points whose line from r is inside every plane
// through r and a polygon edge, without the cuts along the planes through r and the
// inner edges (which separate subtractions make across the visible fragments beyond
// them). Grown from np = A one triangle at a time: B glued to the polygon along its
// edge p_i -> p_i+1 (B traverses it the other way), with third vertex d, is added when
// the turns seen from r (sign det[p - r, q - r, w - r], decided strictly against
// dot_err as covered's test) at p_i, d and p_i+1 in the new polygon have the sign of
// the others. A convex polygon stays convex so: d lies outside edge i (B's turn) and
// the exterior angles, each strictly between 0 and pi, keep their sum (B's angles sum
// to pi), so the turning number stays one; and the polygon is the union of its
// triangles' projections. Conditions on each triangle (else it is left out; with none
// added, false and nothing done): its near polygon is the whole triangle (exact local
// coordinates, like r), every vertex above r's level beyond near_tol (between r and the
// light: no clip), none within 2^-24 of r's scale of r; B comes later in the list than
// np and is not in a polygon yet (near_done marks it for r). Each edge keeps its own
// triangle's orientation, the one subtract_polygon needs (np's side side_r).
bool ReceiverShading::subtract_merged(const NearPoly& np, uint32_t k, int side_r) {
  auto whole = [&](const NearPoly& p) {
    if (p.count != 3 || !p.exact_local || p.patch >= 0) return false;
    const Vec3d* v = gs_.near_verts.data() + p.begin;
    return v[0] == p.t[0] && v[1] == p.t[1] && v[2] == p.t[2];
  };
  const Vec3d& gd = gs_.g;
  const double gn1 = std::abs(gd.x) + std::abs(gd.y) + std::abs(gd.z);
  auto vertex_ok = [&](const Vec3d& v) {  // above r's level, not too close to r
    const double pm = max_component(vabs(v)), scale = std::max(pm, rmax_);
    return dot(gd, v - r_) > 0x1p-24 * gn1 * (pm + rmax_) && max_component(vabs(v - r_)) > 0x1p-24 * scale;
  };
  auto turn = [&](const Vec3d& p, const Vec3d& q, const Vec3d& w) {
    Vec3d err;
    const Vec3d nrm = edge_plane_normal_err(r_, p, q, err);
    const Vec3d dd = w - nearest_base(r_, p, q, w);
    const double sv = dot(dd, nrm), bound = dot_err(dd, nrm, err);
    return sv > bound ? 1 : (sv < -bound ? -1 : 0);
  };
  if (!whole(np) || !vertex_ok(np.t[0]) || !vertex_ok(np.t[1]) || !vertex_ok(np.t[2])) return false;
  const int sign = turn(np.t[0], np.t[1], np.t[2]);
  if (sign == 0) return false;
  constexpr int kMax = 8;  // polygon corners (10, kMaxOccluderVertices, measured no better)
  static_assert(kMax <= kMaxOccluderVertices, "subtract_polygon's planes");
  Vec3d poly[kMax];
  uint32_t owner[kMax];  // per edge i (poly[i] -> poly[i + 1]): the near triangle it belongs to
  int n = 3;
  for (int i = 0; i < 3; ++i) poly[i] = np.t[i], owner[i] = k;
  int nm = 0;  // triangles added
  bool grown = true;
  while (grown && n < kMax) {
    grown = false;
    for (int i = 0; i < n && !grown; ++i) {
      const Vec3d &a = poly[i], &b = poly[(i + 1) % n];
      for (const int32_t nb : gs_.ctx->closed->neighbors(gs_.near[owner[i]].triangle)) {
        if (nb < 0) continue;
        const int32_t k2 = gs_.near_of_tri[size_t(nb)];
        if (k2 <= int32_t(k) || gs_.near_done[size_t(k2)] == serial_) continue;
        const NearPoly& b2 = gs_.near[size_t(k2)];
        int jb = -1;  // B's edge b -> a (first: the owner's other neighbours fail it, mostly at one compare)
        for (int j = 0; j < 3; ++j)
          if (b2.t[j] == b && b2.t[(j + 1) % 3] == a) jb = j;
        if (jb < 0 || !whole(b2)) continue;
        const Vec3d& d = b2.t[(jb + 2) % 3];
        if (!vertex_ok(d)) continue;
        const Vec3d &prev = poly[(i + n - 1) % n], &next = poly[(i + 2) % n];
        if (turn(prev, a, d) != sign || turn(a, d, b) != sign || turn(d, b, next) != sign) continue;
        for (int m = n; m > i + 1; --m) poly[m] = poly[m - 1], owner[m] = owner[m - 1];
        poly[i + 1] = d;
        owner[i] = owner[i + 1] = uint32_t(k2);  // a -> d and d -> b are B's edges
        ++n;
        ++nm;
        gs_.near_done[size_t(k2)] = serial_;
        grown = true;
        break;
      }
    }
  }
  if (nm == 0) return false;
  tot_.near_merged += uint64_t(nm);
  std::vector<Vec3d>& q = gs_.q;
  q.assign(poly, poly + n);
  if (side_r > 0) std::reverse(q.begin(), q.end());  // as np alone: r on the negative side
  gs_.skip.assign(size_t(n), 0);
  const UVBox qbox = shadow_box(lf_.plane, r_, q.data(), q.size());
  if (!qbox.overlaps(all_)) return true;
  if (subtract_polygon(r_, q.data(), n, gs_.skip.data(), qbox, lf_.axes, lf_.bounds, gs_.frags, gs_.boxes, gs_.runs,
                       gs_.tmp, gs_.tmp_boxes, gs_.cur, gs_.pos, gs_.neg, nc_))
    extend_all();
  return true;
}

// The float path: a light the tree hides as a whole from r needs nothing else
// (LazyBsp::hides_all: a walk without splits). Otherwise the near polygons first,
// subtracted from the whole light: they are the closest to r, so their shadows are the
// largest, and the BSP is then walked (and developed) only for what they leave visible
// (measured on columns: about 30% fewer instructions than the BSP first; rooms needs the
// hides_all walk for lights on other storeys).
void ReceiverShading::shade_float() {
  FragmentList& frags = gs_.frags;
  frags.clear();
  const auto th = std::chrono::steady_clock::now();
  const bool hidden = bsp_.hides_all(r_);
  tot_.tree_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - th).count();
  if (!hidden) frags.add(lf_.poly.data(), lf_.poly.size());
  pyramid_planes();
  // The region surfaces' shadows first, on the whole light (silhouette_region.h); an
  // undecided one counts as an undecided plane: run() shades r again exactly.
  if (!gs_.sil.surfaces.empty() && frags.size() != 0 &&
      !subtract_silhouette_regions(scene_.mesh, *gs_.ctx->surface_trees, gs_.sil, rec_.p, r_, lf_.origin, lf_.poly,
                                   gs_.pyramid, gs_.pyramid_err, lf_.bounds, lf_.plane, frags, tot_.sil)) {
    ++nc_.on_line;
    return;
  }
  if (near_hint_.size() < gs_.near.size()) near_hint_.resize(gs_.near.size(), 0);
  gs_.boxes.clear();
  for (size_t f = 0; f < frags.size(); ++f) gs_.boxes.push_back(UVBox::of(lf_.axes, frags.data(f), frags.count(f)));
  bound_all();
  gs_.exact_done.clear();
  // Far-reaching triangles and those within rounding of the light plane (occluder
  // selection), exactly.
  for (uint32_t t : gs_.exact_tris) {
    if (frags.size() == 0) break;
    if (!subtract_exact(t)) continue;
    bound_all();
  }
  // The box of this receiver's pyramid (r and the light), grown by 2^-20 of its
  // size: a near polygon whose box misses it misses every segment from r to the light.
  plo_ = vmin(r_, to_double(lf_.box.lo));
  phi_ = vmax(r_, to_double(lf_.box.hi));
  {
    const double grow_p = 0x1p-20 * (max_component(phi_ - plo_) + max_component(vmax(vabs(plo_), vabs(phi_))));
    plo_ = plo_ - Vec3d(grow_p, grow_p, grow_p);
    phi_ = phi_ + Vec3d(grow_p, grow_p, grow_p);
  }
  cover_planes();
  serial_ = 0;
  if (!gs_.near_done.empty() && translates_exactly(rec_.p, lf_.origin)) {
    if (++gs_.near_serial == 0) {  // wrapped: the old marks could match again
      std::fill(gs_.near_done.begin(), gs_.near_done.end(), 0u);
      gs_.near_serial = 1;
    }
    serial_ = gs_.near_serial;
  }
  const bool tree_first = !gs_.interior.empty();
  auto tree_query = [&]() {
    const auto tb = std::chrono::steady_clock::now();
    if (gs_.frags.size() > 0) {
      bsp_.query(r_, gs_.frags, gs_.tmp);
      std::swap(gs_.frags, gs_.tmp);
      // The boxes only for the near polygons that follow; run() makes them anew after
      // the last step.
      if (tree_first) {
        gs_.boxes.clear();
        for (size_t f = 0; f < frags.size(); ++f)
          gs_.boxes.push_back(UVBox::of(lf_.axes, frags.data(f), frags.count(f)));
        bound_all();
      }
    }
    const double tbs = std::chrono::duration<double>(std::chrono::steady_clock::now() - tb).count();
    tot_.bsp_query_s += tbs;
    tot_.tree_s += tbs;
  };
  // With interior occluders the tree hides most of a closed surface's shadow at once, so
  // it goes first and the near polygons (the silhouette's band) cut only what it leaves.
  if (tree_first) tree_query();
  if (gs_.near_blocks.empty()) {
    const NearPoly* near = gs_.near.data();  // the list does not change while r is shaded
    const uint32_t nn = uint32_t(gs_.near.size());
    for (uint32_t k = 0; k < nn; ++k) {
      if (gs_.frags.size() == 0) break;
      subtract_near(near[k], k);
    }
  } else {
    // The polygons of the blocks this receiver's pyramid may meet, in the list's order:
    // those of the other blocks would each be rejected by subtract_near's first tests.
    // Marked in a bit set over the list and taken in increasing index (no sort).
    std::vector<uint64_t>& pick = gs_.near_pick_bits;
    pick.assign((gs_.near.size() + 63) / 64, 0);
    if (block_hint_.size() < gs_.near_blocks.size()) block_hint_.resize(gs_.near_blocks.size(), 0);
    for (size_t bi = 0; bi < gs_.near_blocks.size(); ++bi) {
      const GroupState::NearBlock& b = gs_.near_blocks[bi];
      if (block_outside(b, block_hint_[bi])) continue;
      for (uint32_t e = b.begin; e < b.begin + b.count; ++e) {
        const uint32_t k = gs_.near_spatial[e];
        pick[k >> 6] |= uint64_t(1) << (k & 63);
      }
    }
    for (size_t wi = 0; wi < pick.size() && gs_.frags.size() != 0; ++wi) {
      for (uint64_t word = pick[wi]; word != 0; word &= word - 1) {
        if (gs_.frags.size() == 0) break;
        const uint32_t k = uint32_t(wi * 64 + size_t(std::countr_zero(word)));
        subtract_near(gs_.near[k], k);
      }
    }
  }
  // Algorithm 1 on the pieces the near polygons left visible.
  if (!tree_first) tree_query();
}

// Fragments reported in world coordinates: one float rounding per vertex
// (plucker_solver.h). A fragment thinner than the float spacing there is not reported
// when its rounded polygon no longer holds its own interior point (the centroid of its
// largest fan triangle, as the comparator takes it): rounded slivers far from the origin
// can put that point into blocked space, far beyond tau. The fraction and the bits use
// the double fragments and are unaffected. Sums the fragments' areas and irradiance.
void ReceiverShading::report_fragments(double& area, double& irr) {
  const FragmentList& frags = gs_.frags;
  ReceiverResult& rr = gs_.ctx->result->receivers[i_];
  auto& out = rr.fragments[gs_.li];
  out.clear();
  out.reserve(frags.size());
  area = 0.0;
  irr = 0.0;
  const Vec3d od = to_double(lf_.origin);
  const double h_r = dot(lf_.nd, r_) - lf_.h0;  // r's height over the light's plane (below)
  for (size_t f = 0; f < frags.size(); ++f) {
    area += polygon_area(frags.data(f), frags.count(f));
    irr += lambert_irradiance(r_, rec_.n, frags.data(f), frags.count(f));
    const Vec3d* fv = frags.data(f);
    const size_t fn = size_t(frags.count(f));
    Polygon3f wf(fn);
    for (size_t k = 0; k < fn; ++k) wf[k] = Vec3f(fv[k] + od);
    double best = 0.0;
    Vec3d inside{};
    if (fn >= 3) {  // the fan (wf[0], wf[k], wf[k + 1]), each vertex widened to double once
      const Vec3d a = to_double(wf[0]);
      Vec3d b = to_double(wf[1]);
      for (size_t k = 1; k + 1 < fn; ++k) {
        const Vec3d c = to_double(wf[k + 1]);
        double ar = length(cross(b - a, c - a));
        if (ar > best) best = ar, inside = to_double(Vec3f((a + b + c) / 3.0));
        b = c;
      }
    }
    // The comparator's segment runs from r to that rounded point, which rounding also
    // moved off the light's plane (by up to half the spacing): its test is the point
    // where the segment meets the plane, the central projection from r, not the point
    // with an axis dropped (test
    // ReportedFragmentsHoldTheComparatorsPointWhereItsSegmentMeetsTheLight).
    Vec3d pl = inside - od;
    const double h_p = dot(lf_.nd, pl) - lf_.h0;
    if (h_r != h_p) pl = r_ + (pl - r_) * (h_r / (h_r - h_p));
    if (best > 0.0 && point_in_fragment(lf_.axes, frags.data(f), frags.count(f), pl)) {
      out.push_back(std::move(wf));
    } else {
      ++tot_.unreported_slivers;
    }
  }
}

// The samples' bits. A sample is visible when it lies in the box of a fragment grown by
// 2^-38 of the light's extent and in the fragment by point_in_fragment with a vertex
// slack of 2^-40 of the extent (fragment.h: the fragments are double, so this is about
// 2^13 ulps of the coordinates, far above the rounding of the interpolated vertices and
// far below tau). The box bounds what the slack accepts near short edges; together they
// accept exactly the points within about 2^-38 of the extent of a fragment.
// Many samples and fragments: the fragments bucketed by their grown boxes (UVBoxGrid),
// so a sample tests only its cell's fragments, a subset holding every fragment whose box
// holds the sample: the same test.
void ReceiverShading::sample_bits() {
  const Light& light = scene_.lights[gs_.li];
  const FragmentList& frags = gs_.frags;
  std::vector<UVBox>& boxes = gs_.boxes;
  UVBoxGrid& cells = gs_.sample_grid;
  ReceiverResult& rr = gs_.ctx->result->receivers[i_];
  const size_t off = gs_.light_offset;
  const double grow = double(lf_.extent) * 0x1p-38;
  const double slack = double(lf_.extent) * 0x1p-40;
  for (UVBox& b : boxes) b = UVBox{b.ulo - grow, b.uhi + grow, b.vlo - grow, b.vhi + grow};
  const size_t nf = frags.size();
  const bool bucketed = nf > 8 && light.samples > 32;
  if (bucketed) {
    UVBox gb;
    for (const UVBox& b : boxes) gb.extend(b);
    cells.build(gb, std::clamp(int(std::sqrt(double(nf))), 2, 16), nf,
                [&](size_t f) -> const UVBox& { return boxes[f]; });
  }
  for (int j = 0; j < light.samples; ++j) {
    size_t k = sample_index(light, j, i_);
    bool vis = false;
    if (lf_.on_light[k]) {
      const Vec3d& sp = lf_.samples[k];
      const double su = sp[lf_.axes.u], sv = sp[lf_.axes.v];
      if (bucketed) {
        for (const uint32_t f : cells.at(su, sv)) {
          if (!boxes[f].contains(su, sv)) continue;
          if (point_in_fragment(lf_.axes, frags.data(f), frags.count(f), sp, slack)) {
            vis = true;
            break;
          }
        }
      } else {
        // The box test alone in the loop (most fragments' boxes miss the sample).
        for (size_t f = 0; f < nf; ++f) {
          if (!boxes[f].contains(su, sv)) continue;
          if (point_in_fragment(lf_.axes, frags.data(f), frags.count(f), sp, slack)) {
            vis = true;
            break;
          }
        }
      }
    } else {
      // Off the light polygon (explicit samples): the segment r -> sample itself.
      vis = !gs_.ctx->tree->segment_blocked(scene_.mesh, lf_.origin, to_local(rec_.p, lf_.origin),
                                              Vec3f(lf_.samples[k]));
      ++tot_.segment_relations;
    }
    rr.set_visible(off + size_t(j), vis);
  }
}

void ReceiverShading::run() {
  // Plane tests this receiver's float path could not decide (on_line: r within rounding
  // of the line of an occluder's or near polygon's edge) before and after it.
  const uint64_t undecided0 = bsp_.counters().on_line + nc_.on_line;
  if (is_extreme()) {
    shade_exact();
  } else {
    shade_float();
    // An undecided plane was taken as "outside that edge" (bsp.cpp, subtract_polygon):
    // right when r is exactly on the edge's line (the line lies in the triangle's plane,
    // so r does too and the triangle is edge-on to it, hiding nothing), but a guess
    // within rounding of it (test OccluderEdgeUndecidedInFloatIsShadedExactly). Such a
    // receiver is shaded again by the exact path (rare: for tree occluders the group's
    // receivers are strictly on one side of the plane, so only rounding gets here).
    if (bsp_.counters().on_line + nc_.on_line != undecided0) {
      ++tot_.undecided_receivers;
      shade_exact();
    }
  }
  gs_.boxes.clear();
  for (size_t f = 0; f < gs_.frags.size(); ++f)
    gs_.boxes.push_back(UVBox::of(lf_.axes, gs_.frags.data(f), gs_.frags.count(f)));
  // Fragments, fraction, bits by point-in-fragment, irradiance.
  double area = 0.0, irr = 0.0;
  report_fragments(area, irr);
  const Light& light = scene_.lights[gs_.li];
  gs_.ctx->result->receivers[i_].visible_fraction[gs_.li] = float(std::min(1.0, area / light.area));
  sample_bits();
  if (gs_.ctx->irradiance) (*gs_.ctx->irradiance)[i_ * scene_.lights.size() + gs_.li] = irr;
  tot_.irradiance += irr;
  tot_.fragments += gs_.frags.size();
}

}  // namespace

void shade_receiver(GroupState& gs, LazyBsp& bsp, size_t gk, BspCounters& near_counters, Totals& tot) {
  ReceiverShading(gs, bsp, gk, near_counters, tot).run();
}

void shade_fallback(const SolveContext& ctx, size_t li, const LocalLight& lf, size_t i, Totals& tot) {
  const Scene& scene = *ctx.scene;
  const Light& light = scene.lights[li];
  ReceiverResult& rr = ctx.result->receivers[i];
  size_t off = scene.light_offset(li);
  const Vec3f r = to_local(scene.receivers[i].p, lf.origin);
  int vis = 0;
  for (int j = 0; j < light.samples; ++j) {
    bool blocked = ctx.tree->segment_blocked(scene.mesh, lf.origin, r, Vec3f(lf.samples[sample_index(light, j, i)]));
    rr.set_visible(off + size_t(j), !blocked);
    vis += !blocked;
  }
  tot.segment_relations += size_t(light.samples);
  rr.visible_fraction[li] = float(double(vis) / double(light.samples));
  rr.fragments[li].clear();
  ++tot.fallback;
}

}  // namespace visgate::plucker
