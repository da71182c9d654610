// Projection and depth-complexity integration (see integrate.h for the derivation).
#include "lib/ssv/integrate.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "lib/geom/check.h"

namespace visgate::ssv {

JitterOrder make_jitter_order(const std::vector<Vec2f>& uv, int samples) {
  JitterOrder o;
  const uint32_t n = uint32_t(uv.size());
  o.by_v.resize(n);
  std::iota(o.by_v.begin(), o.by_v.end(), 0u);
  std::sort(o.by_v.begin(), o.by_v.end(),
            [&](uint32_t a, uint32_t b) { return uv[a].v < uv[b].v || (uv[a].v == uv[b].v && a < b); });
  // ceil(sqrt(N)) strips of equal jitter-point count: about sqrt(N) samples each.
  const uint32_t strips = uint32_t(std::max(1, int(std::ceil(std::sqrt(double(samples))))));
  for (uint32_t s = 0; s <= strips; ++s) o.strip_start.push_back(uint32_t(uint64_t(n) * s / strips));
  o.by_u = o.by_v;
  for (uint32_t s = 0; s < strips; ++s)
    std::sort(o.by_u.begin() + o.strip_start[s], o.by_u.begin() + o.strip_start[s + 1],
              [&](uint32_t a, uint32_t b) { return uv[a].u < uv[b].u || (uv[a].u == uv[b].u && a < b); });
  return o;
}

void DepthCounter::reset(const std::vector<Vec2f>& uv, double extent) {
  uv_ = uv;
  extent_ = extent;
  const int n = int(uv_.size());
  const int strip = std::max(1, int(std::ceil(std::sqrt(double(n)))));
  vorder_.resize(size_t(n));
  std::iota(vorder_.begin(), vorder_.end(), 0);
  std::sort(vorder_.begin(), vorder_.end(), [&](int a, int b) {
    return uv_[size_t(a)].v < uv_[size_t(b)].v || (uv_[size_t(a)].v == uv_[size_t(b)].v && a < b);
  });
  strip_start_.clear();
  for (int start = 0; start < n; start += strip) strip_start_.push_back(start);
  strip_start_.push_back(n);
  sorder_ = vorder_;
  for (size_t s = 0; s + 1 < strip_start_.size(); ++s)
    std::sort(sorder_.begin() + strip_start_[s], sorder_.begin() + strip_start_[s + 1], [&](int a, int b) {
      return uv_[size_t(a)].u < uv_[size_t(b)].u || (uv_[size_t(a)].u == uv_[size_t(b)].u && a < b);
    });
  finish_reset();
}

void DepthCounter::reset(const std::vector<Vec2f>& jitter_uv, const JitterOrder& order, const std::vector<uint32_t>& pick,
                         const std::vector<uint32_t>& owner, double extent) {
  extent_ = extent;
  const size_t n = pick.size();
  uv_.resize(n);
  for (size_t j = 0; j < n; ++j) uv_[j] = jitter_uv[pick[j]];
  // Filter the light's orders by the receiver's picks (branch-free: every entry is
  // written, the count advances only for picked points; one slot of slack at the end);
  // empty strips are skipped.
  vorder_.resize(n + 1);
  sorder_.resize(n + 1);
  strip_start_.clear();
  int* vo = vorder_.data();
  int* so = sorder_.data();
  const uint32_t* own = owner.data();
  size_t nv = 0, ns = 0;
  for (size_t s = 0; s + 1 < order.strip_start.size(); ++s) {
    const size_t before = nv;
    const uint32_t k0 = order.strip_start[s], k1 = order.strip_start[s + 1];
    for (uint32_t k = k0; k < k1; ++k) {
      const uint32_t o = own[order.by_v[k]];
      vo[nv] = int(o) - 1;
      nv += o != 0;
    }
    for (uint32_t k = k0; k < k1; ++k) {
      const uint32_t o = own[order.by_u[k]];
      so[ns] = int(o) - 1;
      ns += o != 0;
    }
    if (nv != before) strip_start_.push_back(int(before));
  }
  strip_start_.push_back(int(n));
  VG_CHECK(nv == n && ns == n);
  vorder_.resize(n);
  sorder_.resize(n);
  finish_reset();
}

void DepthCounter::finish_reset() {
  const size_t n = uv_.size();
  vsorted_.resize(n);
  vrank_.resize(n);
  for (size_t k = 0; k < n; ++k) {
    vsorted_[k] = uv_[size_t(vorder_[k])].v;
    vrank_[size_t(vorder_[k])] = int(k);
  }
  usorted_.resize(n);
  spos_.resize(n);
  for (size_t k = 0; k < n; ++k) {
    usorted_[k] = uv_[size_t(sorder_[k])].u;
    spos_[size_t(sorder_[k])] = int(k);
  }
  direct_.assign(n, 0);
  diffv_.assign(n + 1, 0);
  diffs_.assign(n + 1, 0);
}

void DepthCounter::add_piece(const Vec2f& P, const Vec2f& Q, int w) {
  if (P.v == Q.v || w == 0) return;
  const bool up = Q.v > P.v;
  const Vec2f lo = up ? P : Q, hi = up ? Q : P;
  const int c = up ? w : -w;
  // Samples with v in [lo.v, hi.v).
  const int kb = int(std::lower_bound(vsorted_.begin(), vsorted_.end(), lo.v) - vsorted_.begin());
  const int ke = int(std::lower_bound(vsorted_.begin(), vsorted_.end(), hi.v) - vsorted_.begin());
  if (kb >= ke) return;
  const Vec2f d{hi.u - lo.u, hi.v - lo.v};
  auto left = [&](int j) {
    const Vec2f& s = uv_[size_t(j)];
    return cross2(d, Vec2f{s.u - lo.u, s.v - lo.v}) > 0.0f;
  };
  // Bulk margin: the float cross product above errs only for samples within a few
  // float32 ulps (about 1e-7 relative to the coordinates' magnitude) of the line; 1e-6 of
  // the magnitudes keeps every bulk-classified sample clear of that band.
  const double margin =
      1e-6 * (extent_ + std::abs(lo.u) + std::abs(lo.v) + std::abs(hi.u) + std::abs(hi.v));
  const double slope = double(d.u) / double(d.v);
  const int strips = int(strip_start_.size()) - 1;
  int s0 = int(std::upper_bound(strip_start_.begin(), strip_start_.end(), kb) - strip_start_.begin()) - 1;
  for (int s = s0; s < strips && strip_start_[size_t(s)] < ke; ++s) {
    const int start = strip_start_[size_t(s)], end = strip_start_[size_t(s) + 1];
    if (start >= kb && end <= ke) {
      // Whole strip inside the v-range: the line's u-range over the strip's v-range.
      double xa = lo.u + (double(vsorted_[size_t(start)]) - lo.v) * slope;
      double xb = lo.u + (double(vsorted_[size_t(end - 1)]) - lo.v) * slope;
      float x0 = float(std::min(xa, xb) - margin), x1 = float(std::max(xa, xb) + margin);
      auto first = usorted_.begin() + start, last = usorted_.begin() + end;
      const int ia = int(std::lower_bound(first, last, x0) - usorted_.begin());
      const int ib = int(std::upper_bound(first, last, x1) - usorted_.begin());
      diffs_[size_t(start)] += c;
      diffs_[size_t(ia)] -= c;
      for (int k = ia; k < ib; ++k) {
        int j = sorder_[size_t(k)];
        if (left(j)) direct_[size_t(j)] += c;
      }
    } else {
      for (int k = std::max(start, kb); k < std::min(end, ke); ++k) {
        int j = vorder_[size_t(k)];
        if (left(j)) direct_[size_t(j)] += c;
      }
    }
  }
}

void DepthCounter::add_step(float vc, int w) {
  const size_t k = size_t(std::lower_bound(vsorted_.begin(), vsorted_.end(), vc) - vsorted_.begin());
  diffv_[k] += w;
}

void DepthCounter::finish(std::vector<int32_t>& depth) {
  const size_t n = uv_.size();
  for (size_t k = 1; k <= n; ++k) {
    diffv_[k] += diffv_[k - 1];
    diffs_[k] += diffs_[k - 1];
  }
  depth.resize(n);
  for (size_t j = 0; j < n; ++j)
    depth[j] = direct_[j] + diffv_[size_t(vrank_[j])] + diffs_[size_t(spos_[j])];
}

void ReceiverIntegrator::begin(const Vec3f& receiver, const std::vector<Vec2f>& samples_uv) {
  set_receiver(receiver);
  counter_.reset(samples_uv, frame_.extent);
}

void ReceiverIntegrator::begin(const Vec3f& receiver, const JitterOrder& order, const std::vector<uint32_t>& pick,
                               const std::vector<uint32_t>& owner) {
  set_receiver(receiver);
  counter_.reset(frame_.jitter_uv, order, pick, owner, frame_.extent);
}

void ReceiverIntegrator::set_receiver(const Vec3f& receiver) {
  r_world_ = to_double(receiver);
  r_ = frame_.to_frame_d(receiver);
  VG_CHECK(r_.z > 0.0);
  pieces_.clear();
  doubtful_ = false;
  // Clearance threshold. The pieces are clipped and projected in double from unrounded
  // frame coordinates and rounded once to float, like the samples' (u, v): with |u|, |v|
  // below 2E on L' (E the light's extent) each is within 2^-23 E of its exact value, and
  // the counter's float cross products add a few 2^-23 E more. Embree's robust test
  // decides the reference segment in float relative to its origin r, an angular error
  // of a few ulps: a few 2^-23 |q - r| in the light plane, and |q - r| <= S = E + |r_u| +
  // |r_v| + h_r. 2^-16 S is above both by a factor of 32 and far below the spacing of
  // any sample pattern that matters (256 samples on a light of extent E are about E / 16
  // apart; a light 1e-3 wide seen from 3 away still has samples 2.5e-4 apart against a
  // threshold of 4.6e-5).
  clear_min_ = 0x1p-16 * (frame_.extent + std::abs(r_.x) + std::abs(r_.y) + r_.z);
  const size_t n = frame_.poly.size();
  side_.resize(n);
  // Plane through r and the edge (L'_i, L'_i+1), oriented with L's interior positive:
  // the frame origin (vertex average) is inside L'.
  for (size_t i = 0; i < n; ++i) {
    const Vec2f& p = frame_.poly[i];
    const Vec2f& q = frame_.poly[(i + 1) % n];
    const Vec3d a(p.u, p.v, 0.0), b(q.u, q.v, 0.0);
    Vec3d nrm = cross(a - r_, b - r_);
    if (dot(nrm, Vec3d(0, 0, 0) - r_) < 0.0) nrm = -nrm;
    side_[i] = nrm;
  }
}

int ReceiverIntegrator::facing(size_t t) const {
  const auto& v = m_.triangles[t].v;
  if (!(fp_[v[0]].z > 0.0 || fp_[v[1]].z > 0.0 || fp_[v[2]].z > 0.0)) return 0;
  Vec3d a = to_double(m_.corner(t, 0)), b = to_double(m_.corner(t, 1)), c = to_double(m_.corner(t, 2));
  double f = dot(cross(b - a, c - a), r_world_ - a);
  return (f > 0.0) - (f < 0.0);
}

int ReceiverIntegrator::edge_weight(const Edge& e) const {
  int w = facing(size_t(e.t1));
  if (e.t2 >= 0) w -= facing(size_t(e.t2));
  return w;
}

Vec3d ReceiverIntegrator::cut_point(uint32_t i, uint32_t j) const {
  if (fp_[i].z == 0.0) return fp_[i];
  if (fp_[j].z == 0.0) return fp_[j];
  if (i > j) std::swap(i, j);
  const Vec3d& p = fp_[i];
  const Vec3d& q = fp_[j];
  const double t = p.z / (p.z - q.z);
  Vec3d x = p + (q - p) * t;
  x.z = 0.0;
  return x;
}

bool ReceiverIntegrator::add_edge(const Edge& e, int w) {
  const Vec3d& a = fp_[e.a];
  const Vec3d& b = fp_[e.b];
  if (a.z < 0.0 && b.z < 0.0) return false;
  const Vec3d A = a.z < 0.0 ? cut_point(e.a, e.b) : a;
  const Vec3d B = b.z < 0.0 ? cut_point(e.a, e.b) : b;
  return add_segment(A, B, w);
}

bool ReceiverIntegrator::add_cut(size_t t) {
  const auto& v = m_.triangles[t].v;
  bool pos = false, neg = false;
  for (uint32_t i : v) {
    pos |= fp_[i].z > 0.0;
    neg |= fp_[i].z < 0.0;
  }
  if (!pos || !neg) return false;
  Vec3d E{}, F{};
  for (int k = 0; k < 3; ++k) {
    uint32_t p = v[size_t(k)], q = v[size_t((k + 1) % 3)];
    if (fp_[p].z >= 0.0 && fp_[q].z < 0.0) E = cut_point(p, q);
    if (fp_[p].z < 0.0 && fp_[q].z >= 0.0) F = cut_point(p, q);
  }
  int w = facing(t);
  if (w == 0) return false;
  return add_segment(E, F, w);
}

bool ReceiverIntegrator::add_segment(const Vec3d& a, const Vec3d& b, int w) {
  // Clip to the pyramid from r over L' (h >= 0 is already done): Liang-Barsky on the
  // side planes, remembering which plane cut each end. Double precision: the side
  // planes of a light that is small against its distance to the receiver are nearly
  // parallel, and a float normal cross(a - r, b - r) of two almost equal vectors loses
  // most of its bits (a 1e-3 light seen from distance 2 got a normal with relative error
  // 1e-4, which moved the clipped ends 15% of the light inwards and dropped counts). In
  // double every step below errs by about 1e-16 of the frame magnitudes, far below the
  // float rounding of the inputs. A point on a side plane (f = 0) counts as outside, so
  // a piece that starts or ends exactly on the boundary of L' records that plane (rule 2
  // needs the step of a right-chain contact).
  double t0 = 0.0, t1 = 1.0;
  int enter = -1, exit = -1;
  for (size_t i = 0; i < side_.size(); ++i) {
    const double fa = dot(side_[i], a - r_), fb = dot(side_[i], b - r_);
    if (fa <= 0.0 && fb <= 0.0) return false;
    if (fa > 0.0 && fb > 0.0) continue;
    const double t = fa / (fa - fb);
    if (fa <= 0.0) {
      if (t >= t0) { t0 = t; enter = int(i); }
    } else {
      if (t <= t1) { t1 = t; exit = int(i); }
    }
  }
  if (!(t0 < t1)) return false;
  const Vec3d a2 = enter >= 0 ? a + (b - a) * t0 : a;
  const Vec3d b2 = exit >= 0 ? a + (b - a) * t1 : b;
  // Central projection from r onto h = 0. Inside the pyramid only its apex r reaches the
  // receiver's height, so a point at or above it is an edge through (within rounding of)
  // the receiver: the projection is undefined and the receiver is marked doubtful.
  auto project = [&](const Vec3d& x, Vec2f& out) {
    const double den = r_.z - x.z;
    if (!(den > 0.0)) return false;
    const double s = r_.z / den;
    out = {float(r_.x + (x.x - r_.x) * s), float(r_.y + (x.y - r_.y) * s)};
    return std::isfinite(out.u) && std::isfinite(out.v);
  };
  Vec2f P, Q;
  if (!project(a2, P) || !project(b2, Q)) {
    doubtful_ = true;
    return false;
  }
  counter_.add_piece(P, Q, w);
  pieces_.push_back(P);
  pieces_.push_back(Q);
  if (enter >= 0 && frame_.right_chain[size_t(enter)]) counter_.add_step(P.v, -w);
  if (exit >= 0 && frame_.right_chain[size_t(exit)]) counter_.add_step(Q.v, w);
  return true;
}

double ReceiverIntegrator::clearance(size_t j) const {
  const Vec2f& sf = counter_.sample_uv(j);
  const double su = sf.u, sv = sf.v;
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k + 1 < pieces_.size(); k += 2) {
    // Distance from the sample to the segment P Q.
    const double pu = pieces_[k].u, pv = pieces_[k].v;
    const double du = double(pieces_[k + 1].u) - pu, dv = double(pieces_[k + 1].v) - pv;
    const double len2 = du * du + dv * dv;
    double t = len2 > 0.0 ? ((su - pu) * du + (sv - pv) * dv) / len2 : 0.0;
    t = std::clamp(t, 0.0, 1.0);
    const double eu = su - (pu + t * du), ev = sv - (pv + t * dv);
    best = std::min(best, eu * eu + ev * ev);
  }
  return std::sqrt(best);
}

}  // namespace visgate::ssv
