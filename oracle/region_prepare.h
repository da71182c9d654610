// Internal to the region oracle: the exact light frame, the per-pair preparation (the
// receiver's side, the pyramid, the double cull and the fast-path classification) and
// the exact clip, shared by visible_region (region_oracle.cpp) and the certified
// fraction bound (fraction_bound.cpp). region_oracle.h documents what they compute.
#pragma once

#include <CGAL/Exact_predicates_exact_constructions_kernel.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_2.h>

#include <array>
#include <climits>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "oracle/region_oracle.h"

namespace visgate::oracle {

namespace region {

using EK = CGAL::Epeck;
using FT = EK::FT;
using Pt2 = EK::Point_2;
using Poly = CGAL::Polygon_2<EK>;
using V3 = Vec3<FT>;
using IK = CGAL::Epick;

inline V3 exact3(const Vec3f& v) { return V3(FT(double(v.x)), FT(double(v.y)), FT(double(v.z))); }
inline IK::Point_3 ipt(const Vec3f& v) { return IK::Point_3(double(v.x), double(v.y), double(v.z)); }
// Double nearest (within one ulp) to an exact value. CGAL::to_double on a lazy number
// may return its interval's midpoint with a relative error up to 1e-5
// (Lazy_exact_nt's default relative precision of to_double), which is far too coarse
// for the culling bounds and the reported fraction: always go through the exact value.
inline double to_double_exact(const FT& x) { return CGAL::to_double(x.exact()); }
inline Vec3d approx(const V3& v) { return Vec3d(to_double_exact(v.x), to_double_exact(v.y), to_double_exact(v.z)); }

// Collapses the lazy-evaluation DAG behind a value: computes it exactly once and keeps
// only the result, so the Boolean operations do not re-walk clipping expressions.
inline FT squash(const FT& x) {
  x.exact();
  return x;
}

// GMP rationals, the exact type behind FT: the frame and the pyramid planes are computed
// on them directly and wrapped in FT once (one constant node each). Built as a lazy DAG
// and squashed, the same values would cost one node and one rational per operation.
using Q = FT::ET;

// The exact light frame of region_oracle.h.
struct ExactLight {
  V3 n;                    // exact Newell normal (emitting side)
  FT d0;                   // plane: n . x = d0
  int k = 2, i1 = 0, i2 = 1;  // dropped axis and the two kept ones
  std::vector<IK::Point_2> dpolygon;  // light polygon in the frame, counter-clockwise
                                      // (float coordinates: exact doubles)
  bool reversed = false;   // the frame's CCW runs against the light's own order
  std::vector<V3> lifted;  // vertices of the convex hull of `polygon`, lifted to the plane
                           // (constants: their exact() is the rational they were made from)
  double scale = 1.0;      // 3D area = frame area * scale (|n| / |n_k|)

  // dpolygon as an exact polygon and its doubled area, made at first use: only
  // visible_region's Boolean operations and its fraction need them (the certified bound,
  // which answers most pairs, reads dpolygon; building the lazy polygon and its area was
  // a fifth of the frame's allocations under ASan).
  const Poly& polygon() const {
    if (!polygon_made_) {
      std::vector<Pt2> pts;
      for (const IK::Point_2& p : dpolygon) pts.emplace_back(FT(p.x()), FT(p.y()));
      polygon_ = Poly(pts.begin(), pts.end());
      area2_ = polygon_.area();
      polygon_made_ = true;
    }
    return polygon_;
  }
  const FT& area2() const {
    polygon();
    return area2_;
  }

  V3 lift(const Pt2& p) const {
    V3 x;
    x[i1] = p.x();
    x[i2] = p.y();
    x[k] = (d0 - n[i1] * p.x() - n[i2] * p.y()) / n[k];
    return x;
  }
  FT height(const V3& x) const { return dot(n, x) - d0; }

 private:
  mutable Poly polygon_;
  mutable FT area2_;
  mutable bool polygon_made_ = false;
};

// The exact light frame of `light` (region_oracle.h "Exact frame").
ExactLight make_exact_light(const Light& light);

// The ends (from, to) a clip forms the crossing on edge (i, j) from: i first, unless both
// ends are tagged triangle vertices (an index into `tag_points`, >= 0) and j's float point
// is lexicographically smaller. Two triangles sharing an edge then form its crossing from
// the same vertex, whichever way they walk it (clip below and the certified bound's
// interval clip use this one rule, so their points agree).
std::pair<size_t, size_t> crossing_ends(size_t i, size_t j, int tag_i, int tag_j, const Vec3f* tag_points);

// Sutherland-Hodgman step, exact: keeps the part of the convex polygon with
// dot(m, x) - e >= 0. New points are squashed (their lazy DAGs collapsed to exact values)
// unless `squash_new` is false: the certified bound needs their intervals (and exact
// signs where the intervals do not decide), not their exact values.
// `tags` (optional, parallel to poly, updated): kept vertices keep their tag (an index
// into `tag_points`, the triangle's float vertices), new ones get `new_tag` (negative). A new point on an
// edge between two tagged vertices is formed from the lexicographically smaller one, so
// two triangles sharing that edge form the same lazy expression for it (the same
// interval, hence the same double point in the certified bound).
std::vector<V3> clip(const std::vector<V3>& poly, const V3& m, const FT& e, bool squash_new = true,
                     std::vector<int>* tags = nullptr, const Vec3f* tag_points = nullptr, int new_tag = -1);

// The double-precision pre-pass (region_oracle.h "Fast paths"). Every value is a
// polynomial of exactly representable inputs (float coordinates, and the light's exact
// plane and lifted vertices rounded to the nearest double) evaluated in double, and its
// sign is trusted only beyond a forward error bound; anything not certain is Unknown and
// goes to the exact path, so the pre-pass never changes an answer.
//
// Bounds (u = 2^-53): g(x) = n . x - d0 from n and d0 rounded once (relative u each):
// 3 products and 3 sums, |err| < 8u (|n|_1 |x|_inf + |d0|) (rounding of the inputs
// included, generously). orient(p, q, x) = det[p - r, q - r, x - r] from double
// differences: Shewchuk's orient3d errboundA (7 + 56u) u of the permanent
// |p-r|_1-style sum; a light vertex x rounded by at most u |x|_inf moves it by at most
// |(p - r) x (q - r)|_1 u |x|_inf. Both are doubled below.
struct FastPass {
  Vec3d r, n;
  double d0 = 0, sgn = 1, gr = 0, gr_err = 0;
  std::vector<Vec3d> L;  // the exact light's hull vertices, rounded to double
  double lmax = 0;       // largest |coordinate| of L

  double g(const Vec3d& x, double& err) const {
    double v = sgn * (dot(n, x) - d0);
    err = 16.0 * 0x1p-53 * ((std::abs(n.x) + std::abs(n.y) + std::abs(n.z)) * max_component(vabs(x)) + std::abs(d0));
    return v;
  }
  // det[p - r, q - r, x - r] and its error bound; `x_rounded` adds the light-vertex term.
  double orient(const Vec3d& p, const Vec3d& q, const Vec3d& x, bool x_rounded, double& err) const {
    Vec3d a = p - r, b = q - r, c = x - r;
    Vec3d ab = cross(a, b);
    double v = dot(ab, c);
    double perm = std::abs(c.x) * (std::abs(a.y * b.z) + std::abs(a.z * b.y)) +
                  std::abs(c.y) * (std::abs(a.z * b.x) + std::abs(a.x * b.z)) +
                  std::abs(c.z) * (std::abs(a.x * b.y) + std::abs(a.y * b.x));
    err = 2.0 * (7.0 + 56.0 * 0x1p-53) * 0x1p-53 * perm;
    if (x_rounded)
      err += 2.0 * (std::abs(ab.x) + std::abs(ab.y) + std::abs(ab.z)) * 0x1p-53 * max_component(vabs(x));
    return v;
  }
};

// Everything visible_region and visible_fraction_bound share: the exact frame, the
// receiver's side, the pyramid planes, the double cull and the fast-path classification.
struct Prepared {
  // The light's frame: the cache's (RegionCache) or own_frame, never copied (a frame
  // holds lazy exact numbers and vectors; copying it per pair was an allocation each).
  const ExactLight* frame = nullptr;
  std::unique_ptr<ExactLight> own_frame;
  V3 r;
  FT h_r, g_r;
  CGAL::Sign side = CGAL::ZERO;
  V3 gn;                                 // the light plane as the half-space g >= 0
  FT ge;
  FastPass fp;
  std::vector<uint32_t> unknown;  // culled triangles the fast paths left undecided
  bool covered = false;           // a Cover triangle: fraction 0

  const ExactLight& f() const { return *frame; }
  FT g_of(const V3& x) const { return side == CGAL::POSITIVE ? f().height(x) : -f().height(x); }

  // The pyramid's side planes through r and consecutive hull vertices, inwards (m . x >= e
  // inside), made at first use: only triangles reaching the receiver's level and far
  // shadows of the certified bound are clipped to them.
  const std::vector<std::pair<V3, FT>>& sides() const {
    if (!sides_made) {
      const Q rq[3] = {r[0].exact(), r[1].exact(), r[2].exact()};
      auto minus_r = [&](const V3& x) {
        return std::array<Q, 3>{x[0].exact() - rq[0], x[1].exact() - rq[1], x[2].exact() - rq[2]};
      };
      const std::vector<V3>& lifted = f().lifted;
      const size_t hn = lifted.size();
      for (size_t j = 0; j < hn; ++j) {
        const std::array<Q, 3> a = minus_r(lifted[j]), b = minus_r(lifted[(j + 1) % hn]),
                               c = minus_r(lifted[(j + 2) % hn]);
        Q m[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
        if (sgn(m[0] * c[0] + m[1] * c[1] + m[2] * c[2]) < 0)
          for (Q& x : m) x = -x;
        sides_.emplace_back(V3(FT(m[0]), FT(m[1]), FT(m[2])), FT(Q(m[0] * rq[0] + m[1] * rq[1] + m[2] * rq[2])));
      }
      sides_made = true;
    }
    return sides_;
  }

 private:
  mutable std::vector<std::pair<V3, FT>> sides_;
  mutable bool sides_made = false;
};

// Fills `p` up to the fast-path classification; false when the receiver is on the light
// plane (edge_on: nothing else is filled).
bool prepare(const Scene& scene, size_t receiver, size_t light_index, bool fast_paths, Prepared& p,
             const ExactLight* frame = nullptr);

}  // namespace region

struct RegionCache::Impl {
  using ExactLight = region::ExactLight;
  using Prepared = region::Prepared;
  const Scene* scene = nullptr;
  std::vector<std::unique_ptr<ExactLight>> frames;  // per light, made at first use
  // The last pair prepared with fast paths (visible_fraction_bound's), for the
  // visible_region of the same pair that may follow.
  Prepared last;
  size_t last_receiver = SIZE_MAX, last_light = SIZE_MAX;
  bool last_off_plane = false;

  const ExactLight& frame(size_t l) {
    if (frames[l] == nullptr) frames[l] = std::make_unique<ExactLight>(region::make_exact_light(scene->lights[l]));
    return *frames[l];
  }
  // prepare() for (receiver, light), through the cache; the result stays in `last`.
  bool prepare_last(size_t receiver, size_t light) {
    if (receiver != last_receiver || light != last_light) {
      last = Prepared{};
      last_receiver = SIZE_MAX;  // until filled
      last_off_plane = region::prepare(*scene, receiver, light, true, last, &frame(light));
      last_receiver = receiver;
      last_light = light;
    }
    return last_off_plane;
  }
};

}  // namespace visgate::oracle
