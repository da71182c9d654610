// Light frame and expanded light polygon (see light_frame.h).
#include "lib/ssv/light_frame.h"

#include <cmath>

#include "lib/base/check.h"

namespace visgate::ssv {

namespace {

// True when p is inside the polygon by at least `margin` (distance) from every edge.
bool strictly_inside(const std::vector<Vec2f>& poly, const Vec2f& p, double margin) {
  const size_t n = poly.size();
  for (size_t i = 0; i < n; ++i) {
    const Vec2f& a = poly[i];
    const Vec2f& b = poly[(i + 1) % n];
    double eu = double(b.u) - a.u, ev = double(b.v) - a.v;
    double c = eu * (double(p.v) - a.v) - ev * (double(p.u) - a.u);
    if (!(c > margin * std::sqrt(eu * eu + ev * ev))) return false;
  }
  return true;
}

}  // namespace

LightFrame make_light_frame(const Light& light) {
  LightFrame f;
  size_t n = light.polygon.size();
  VG_CHECK(n >= 3);
  Vec3d c(0, 0, 0);
  AABB box;
  for (const auto& p : light.polygon) {
    c += to_double(p);
    box.extend(p);
  }
  f.origin = c / double(n);
  f.extent = box.diagonal();
  f.N = normalize(to_double(light.normal));
  // U along the longest polygon edge with its normal component removed.
  Vec3d e(0, 0, 0);
  for (size_t i = 0; i < n; ++i) {
    Vec3d d = to_double(light.polygon[(i + 1) % n]) - to_double(light.polygon[i]);
    d = d - f.N * dot(d, f.N);
    if (length(d) > length(e)) e = d;
  }
  f.U = normalize(e);
  f.V = cross(f.N, f.U);

  // The polygon in the frame without (nearly) coincident vertices: an edge shorter than
  // 2^-20 of the extent has no usable direction (the side plane through the receiver
  // and such an edge can get a zero normal in double). Dropping such a vertex changes the
  // polygon by a sliver of that width; L' below must still hold every jitter point.
  std::vector<Vec2f> base;
  const double min_edge = 0x1p-20 * f.extent;
  for (size_t i = 0; i < n; ++i) {
    Vec3d d = to_double(light.polygon[i]) - f.origin;
    const Vec2f p{float(dot(d, f.U)), float(dot(d, f.V))};
    auto far_from = [&](const Vec2f& q) { return std::hypot(double(p.u) - q.u, double(p.v) - q.v) >= min_edge; };
    if (base.empty() || far_from(base.back())) base.push_back(p);
  }
  while (base.size() > 1) {
    const Vec2f& a = base.back();
    const Vec2f& b = base.front();
    if (std::hypot(double(a.u) - b.u, double(a.v) - b.v) >= min_edge) break;
    base.pop_back();
  }
  n = base.size();
  f.jitter_uv.resize(light.jitter_points.size());
  for (size_t k = 0; k < light.jitter_points.size(); ++k) {
    Vec3f q = f.to_local_f(light.jitter_points[k]);
    f.jitter_uv[k] = {q.x, q.y};
    f.max_jitter_h = std::max(f.max_jitter_h, std::abs(q.z));
  }

  // Scale about the vertex average (the frame origin) until every jitter point is inside
  // by 1e-4 of the light's extent: a margin far above the float rounding of the frame
  // coordinates (about 1e-7 relative) and far below any sample spacing that matters.
  // Samples of the built-in patterns lie in L (scale 1.001 suffices); explicit samples
  // may lie anywhere in the light's plane. Beyond a scale of 4 (a sample more than about
  // one light extent outside L: fuzzed scenes put one at 1e36) L' would blow up the
  // pyramid and with it the precision of every clipped piece, so the frame is marked
  // unusable and the solver answers that light by rays.
  double scale = 1.001;
  const double margin = 1e-4 * f.extent;
  f.usable = false;
  f.poly = base;
  while (n >= 3 && scale <= 4.0) {
    f.poly.resize(n);
    for (size_t i = 0; i < n; ++i) f.poly[i] = {float(base[i].u * scale), float(base[i].v * scale)};
    bool ok = true;
    for (const Vec2f& p : f.jitter_uv)
      if (!strictly_inside(f.poly, p, margin)) {
        ok = false;
        break;
      }
    if (ok) {
      f.usable = true;
      break;
    }
    scale *= 1.25;
  }
  f.poly_world.resize(n);
  f.right_chain.resize(n);
  for (size_t i = 0; i < n; ++i) {
    f.poly_world[i] = f.origin + f.U * double(f.poly[i].u) + f.V * double(f.poly[i].v);
    f.right_chain[i] = f.poly[(i + 1) % n].v > f.poly[i].v ? 1 : 0;
  }
  return f;
}

}  // namespace visgate::ssv
