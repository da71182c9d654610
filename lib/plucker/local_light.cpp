// A light in its local frame; see local_light.h.
#include "lib/plucker/local_light.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "lib/geom/expansion.h"
#include "lib/geom/predicates.h"

namespace visgate::plucker {

namespace {

// Exact planarity: the vertex pair spanning the largest float area with vertex 0, then
// every vertex exactly on the plane of the three.
void decide_planarity(const Light& light, LocalLight& f) {
  const auto& v = light.polygon;
  float widest = 0.0f;
  for (size_t a = 1; a < v.size(); ++a)
    for (size_t b = a + 1; b < v.size(); ++b) {
      float ar = norm1(cross(v[a] - v[0], v[b] - v[0]));
      if (ar > widest) widest = ar, f.p1 = int(a), f.p2 = int(b);
    }
  Vec3f c = cross(v[size_t(f.p1)] - v[0], v[size_t(f.p2)] - v[0]);
  float cn = dot(c, f.n), bound = 16.0f * kUnitRoundoffF * norm1(v[size_t(f.p1)] - v[0]) * norm1(v[size_t(f.p2)] - v[0]);
  f.planar = std::abs(cn) > bound;
  f.emit_sign = cn > 0.0f ? 1 : -1;
  for (size_t k = 0; k < v.size() && f.planar; ++k)
    f.planar = orient3d_exact(v[0], v[size_t(f.p1)], v[size_t(f.p2)], v[k]) == Sign::Zero;
}

// A light whose float vertices are not coplanar (DESIGN allows 1e-5 of its extent) is,
// for the region oracle, the polygon of its vertices' (u, v) coordinates lifted along the
// dropped axis onto the plane of its Newell normal through its centroid
// (oracle/region_oracle.h "Exact frame"). The fragments start from that polygon (in
// double), not from the float vertices, and the light plane every slab test uses
// (h(x) = n . (x - p0)) passes through the lifted origin vertex p0 (tests
// NonPlanarLightIsTheOraclesLiftedPolygon, NonPlanarLightIsLiftedAlongTheOraclesAxis).
// The (u, v) coordinates, hence point-in-fragment of the samples, are unchanged.
void lift_onto_newell_plane(const Light& light, LocalLight& f) {
  // The dropped axis is the region oracle's, decided on the exact Newell normal
  // (exact_orient.h newell_dominant_axis), not the float normal's largest component.
  const int axis = newell_dominant_axis(light.polygon.data(), int(light.polygon.size()));
  if (axis != 3 - f.axes.u - f.axes.v) {
    f.axes.u = (axis + 1) % 3;
    f.axes.v = (axis + 2) % 3;
    f.axes.flip = f.n[axis] < 0.0f;
  }
  // The Newell normal is translation invariant, so it is taken on the local coordinates.
  Vec3d nn(0, 0, 0), cc(0, 0, 0);
  const size_t m = f.poly.size();
  for (size_t k = 0; k < m; ++k) {
    nn += cross(f.poly[k], f.poly[(k + 1) % m]);
    cc += f.poly[k];
  }
  cc = cc / double(m);
  const int u = f.axes.u, v = f.axes.v, w = 3 - u - v;
  if (nn[w] == 0.0) return;
  for (Vec3d& p : f.poly) p[w] = cc[w] - (nn[u] * (p[u] - cc[u]) + nn[v] * (p[v] - cc[v])) / nn[w];
  Vec3d p0d(0, 0, 0);
  for (size_t k = 0; k < m; ++k)
    if (light.polygon[k] == f.origin) p0d = f.poly[k];
  f.p0 = Vec3f(p0d);
  // The slab tests in double against the lifted plane: the float normal's rounding
  // (u |x| over the light) is too coarse at the far end of a long light. The lifted
  // vertices are on it to double rounding; plane_tol bounds that (4 u_d |nd|_1
  // |p - p0|_1, doubled) and the float evaluation of the receivers' and samples' sides
  // (kDotErr terms).
  f.nd = nn / length(nn);
  f.h0 = dot(f.nd, p0d);
  double tol = 0.0;
  for (const Vec3d& p : f.poly) {
    f.box.extend(Vec3f(p));
    Vec3d d = p - p0d;
    tol = std::max(tol, std::abs(dot(f.nd, d)) + 8.0 * kUnitRoundoffD * norm1(f.nd) * norm1(d));
  }
  f.plane_tol = float(tol) * 2.0f;
  f.extent = max_component(f.box.extent());
}

// Light points (DESIGN section 6 allows explicit samples anywhere): a point on the
// light's plane (|h| within the rounding bound used for receivers) and inside the light
// polygon (point_in_fragment's boundary bound) is decided by point-in-fragment; any
// other point by segment tests (plucker_solver.h "Light points").
void place_samples(const Light& light, LocalLight& f) {
  f.samples.resize(light.jitter_points.size());
  f.on_light.resize(light.jitter_points.size());
  for (size_t k = 0; k < light.jitter_points.size(); ++k) {
    f.samples[k] = to_local_d(light.jitter_points[k], f.origin);
    Vec3f d = to_local(light.jitter_points[k], f.origin) - f.p0;
    float h = dot(f.n, d);
    float tol = f.plane_tol + kDotErr * norm1(f.n) * norm1(d);
    f.on_light[k] = std::abs(h) <= tol && point_in_fragment(f.axes, f.poly.data(), int(f.poly.size()), f.samples[k]);
  }
}

}  // namespace

LocalLight make_local_light(const Light& light, const Vec3d& focus) {
  LocalLight f;
  f.light = &light;
  f.origin = light.polygon[0];
  double best = std::numeric_limits<double>::infinity();
  for (const Vec3f& v : light.polygon) {
    double d = max_component(vabs(to_double(v) - focus));
    if (d < best) best = d, f.origin = v;
  }
  f.poly.reserve(light.polygon.size());
  for (const Vec3f& v : light.polygon) f.poly.push_back(to_local_d(v, f.origin));
  f.n = light.normal;
  f.p0 = Vec3f(0, 0, 0);  // the origin vertex, on the light
  for (const Vec3f& v : light.polygon) {
    Vec3f d = to_local(v, f.origin);
    f.box.extend(d);
    float h = std::abs(dot(f.n, d)) + kDotErr * norm1(f.n) * norm1(d);
    f.plane_tol = std::max(f.plane_tol, h);
  }
  f.axes = UVAxes::from_normal(f.n);
  f.extent = max_component(f.box.extent());
  decide_planarity(light, f);
  if (!f.planar) lift_onto_newell_plane(light, f);
  if (f.planar || f.nd == Vec3d(0, 0, 0)) f.nd = to_double(f.n);
  f.lift = LiftedLight(light.polygon.data(), int(light.polygon.size()), f.axes.u, f.axes.v);
  f.plane = LightPlane{f.n, f.plane_tol, f.extent, f.axes, f.nd, f.h0};
  f.bounds = LightBounds::of(f.poly.data(), int(f.poly.size()));
  place_samples(light, f);
  return f;
}

bool segment_blocked_by_scene(const Scene& scene, const Vec3f& origin, const Vec3f& r, const Vec3f& s) {
  for (size_t t = 0; t < scene.mesh.size(); ++t)
    if (segment_blocked(r, s, to_local(scene.mesh.corner(t, 0), origin), to_local(scene.mesh.corner(t, 1), origin),
                        to_local(scene.mesh.corner(t, 2), origin)))
      return true;
  return false;
}

}  // namespace visgate::plucker
