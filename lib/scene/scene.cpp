// Scene model: light validation and sampling (paper 000 section 4.11), receiver grids,
// the relation hash of DESIGN section 3.
#include "lib/scene/scene.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "lib/geom/expansion.h"
#include "lib/geom/lanes.h"
#include "lib/geom/predicates.h"
#include "lib/scene/rng.h"

namespace visgate {

AABB TriangleSoup::bounds() const {
  // Three lanes at a time (lib/geom/lanes.h): the floats of AABB::extend per corner.
  LanesBox b;
  for (const auto& t : triangles)
    for (int k = 0; k < 3; ++k) b.add(vertices[t[k]]);
  return b.box();
}

void TriangleSoup::append(const TriangleSoup& other) {
  uint32_t base = uint32_t(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  for (auto t : other.triangles) triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
}

size_t Scene::samples_per_receiver() const {
  size_t n = 0;
  for (const auto& l : lights) n += size_t(l.samples);
  return n;
}

size_t Scene::light_offset(size_t light) const {
  size_t n = 0;
  for (size_t k = 0; k < light; ++k) n += size_t(lights[k].samples);
  return n;
}

AABB Scene::bounds() const { return bounds(mesh.bounds()); }

AABB Scene::bounds(const AABB& mesh_box) const {
  AABB b = mesh_box;
  for (const auto& l : lights)
    for (const auto& p : l.polygon) b.extend(p);
  for (const auto& r : receivers) b.extend(r.p);
  return b;
}

uint64_t relation_hash(uint64_t receiver, uint64_t sample, uint64_t seed) {
  return relation_hash_step(relation_hash_prefix(receiver, seed), sample);
}

namespace {

std::string fmt_index(const std::string& where, const char* field, size_t i) {
  return where + "." + field + "[" + std::to_string(i) + "]";
}

// Largest divisor of n not above sqrt(n): the stratification grid is nx x (n / nx).
int strata_columns(int n) {
  int best = 1;
  for (int d = 1; d * d <= n; ++d)
    if (n % d == 0) best = d;
  return best;
}

}  // namespace

Status prepare_light(Light& light, const std::string& where) {
  const auto& P = light.polygon;
  const size_t n = P.size();
  if (n < 3) return Error{where + ".polygon: needs at least 3 vertices, has " + std::to_string(n)};
  for (size_t i = 0; i < n; ++i)
    if (!is_finite(P[i])) return Error{fmt_index(where, "polygon", i) + ": coordinate is NaN or infinite"};
  if (light.samples < 1) return Error{where + ".samples: must be at least 1"};
  if (light.samples > (1 << 20)) return Error{where + ".samples: " + std::to_string(light.samples) + " exceeds the limit 1048576"};
  if (light.jitter < 1 || light.jitter > 64) return Error{where + ".jitter: must be in 1..64"};

  // The Newell normal exactly (products of two floats are exact in double, summed by
  // expansion arithmetic), rounded per component, and the centroid in double. Summed in
  // double, cancellation can give a collinear light a non-zero normal along an axis whose
  // exact component is 0 (test SceneJson.RejectsOutOfRangeIndicesAndBadLights).
  // Zero is zero area; the area, the normal and the exact checks below use the exact
  // normal.
  Vec3d ne(0, 0, 0), c(0, 0, 0);
  for (int k = 0; k < 3; ++k) ne[k] = expansion::estimate(expansion::newell_component(P.data(), n, k));
  for (size_t i = 0; i < n; ++i) c += to_double(P[i]);
  c = c / double(n);
  double twice_area = length(ne);
  AABB box;
  for (const auto& p : P) box.extend(p);
  double extent = box.diagonal();
  if (!(twice_area > 0.0) || twice_area <= 1e-12 * extent * extent)
    return Error{where + ".polygon: zero area"};
  Vec3d unit = ne / twice_area;
  // Planarity.
  for (size_t i = 0; i < n; ++i) {
    double dist = std::abs(dot(unit, to_double(P[i]) - c));
    if (dist > 1e-5 * extent)
      return Error{fmt_index(where, "polygon", i) + ": not in the light's plane (distance " +
                   std::to_string(dist) + ", tolerance 1e-5 of the light's extent)"};
  }
  // Convexity and orientation: every turn counter-clockwise about the normal and the
  // turning angles summing to one full turn (rejects stars that wind twice).
  double turning = 0.0;
  for (size_t i = 0; i < n; ++i) {
    Vec3d a = to_double(P[(i + n - 1) % n]), b = to_double(P[i]), d = to_double(P[(i + 1) % n]);
    Vec3d e0 = b - a, e1 = d - b;
    if (length(e0) == 0.0) return Error{fmt_index(where, "polygon", i) + ": repeats the previous vertex"};
    double s = dot(cross(e0, e1), unit);
    double cosang = dot(e0, e1);
    if (s < -1e-9 * length(e0) * length(e1))
      return Error{fmt_index(where, "polygon", i) + ": polygon is not convex (reflex vertex)"};
    turning += std::atan2(s, cosang);
  }
  if (std::abs(turning - 2 * std::numbers::pi) > 1e-3)
    return Error{where + ".polygon: not a simple convex polygon (winds " + std::to_string(turning / (2 * std::numbers::pi)) + " times)"};
  // Convexity exactly, in the frame the region oracle uses (oracle/region_oracle.h "Exact
  // frame": the float vertices with the axis of the largest Newell component dropped).
  // The tolerance above admits a turn of -1e-9 |e0| |e1|, which on a sliver light can
  // pass a polygon whose exact frame polygon self-intersects (test
  // SceneJson.RejectsOutOfRangeIndicesAndBadLights). Every axis whose Newell component is within half of
  // the largest is checked, so the oracle's exact choice is among them whatever double
  // rounding did to the normal; a corner may be exactly straight (the oracle drops it),
  // never turned against the normal.
  {
    const double big = std::max({std::abs(ne.x), std::abs(ne.y), std::abs(ne.z)});
    for (int k = 0; k < 3; ++k) {
      if (std::abs(ne[k]) < 0.5 * big) continue;
      const int i1 = (k + 1) % 3, i2 = (k + 2) % 3, want = ne[k] > 0 ? 1 : -1;
      for (size_t i = 0; i < n; ++i) {
        const Vec3f &a = P[(i + n - 1) % n], &b = P[i], &d = P[(i + 1) % n];
        const int o = to_int(orient2d_exact(a[i1], a[i2], b[i1], b[i2], d[i1], d[i2]));
        if (o == -want)
          return Error{fmt_index(where, "polygon", i) + ": polygon is not convex (reflex vertex in exact arithmetic)"};
      }
    }
  }

  light.normal = Vec3f(unit);
  light.area = 0.5 * twice_area;

  // Samples.
  const int N = light.samples, K = light.jitter;
  light.jitter_points.assign(size_t(N) * K, Vec3f{});
  light.jitter_boxes.assign(size_t(N), AABB{});
  if (light.pattern == SamplePattern::Explicit || !light.explicit_samples.empty()) {
    light.pattern = SamplePattern::Explicit;
    if (K != 1) return Error{where + ".jitter: must be 1 with explicit_samples"};
    if (int(light.explicit_samples.size()) != N)
      return Error{where + ".explicit_samples: has " + std::to_string(light.explicit_samples.size()) +
                   " points, samples says " + std::to_string(N)};
    for (int j = 0; j < N; ++j) {
      if (!is_finite(light.explicit_samples[j]))
        return Error{fmt_index(where, "explicit_samples", size_t(j)) + ": coordinate is NaN or infinite"};
      light.jitter_points[j] = light.explicit_samples[j];
      light.jitter_boxes[j].extend(light.explicit_samples[j]);
    }
    return {};
  }

  // Area-preserving map from the unit square onto the polygon: the first coordinate
  // picks a fan triangle (p0, pk, pk+1) by its share of the area and is rescaled within
  // it; then (s, t) -> p0 (1 - sqrt s) + pk sqrt(s)(1 - t) + pk+1 sqrt(s) t, which is
  // uniform on the triangle. Strata of the square map to equal-area cells.
  std::vector<double> cdf(n - 1, 0.0);
  double acc = 0.0;
  Vec3d p0 = to_double(P[0]);
  for (size_t k = 1; k + 1 < n; ++k) {
    acc += 0.5 * length(cross(to_double(P[k]) - p0, to_double(P[k + 1]) - p0));
    cdf[k] = acc;
  }
  auto map = [&](double s, double t) {
    double target = s * acc;
    size_t k = 1;
    while (k + 2 < n && target > cdf[k]) ++k;
    double lo = cdf[k - 1], hi = cdf[k];
    double ss = hi > lo ? std::clamp((target - lo) / (hi - lo), 0.0, 1.0) : 0.0;
    double r = std::sqrt(ss);
    Vec3d q = p0 * (1 - r) + to_double(P[k]) * (r * (1 - t)) + to_double(P[k + 1]) * (r * t);
    return Vec3f(q);
  };
  const int nx = strata_columns(N), ny = N / nx;
  Rng rng(light.seed);
  for (int j = 0; j < N; ++j) {
    int cx = j % nx, cy = j / nx;
    for (int k = 0; k < K; ++k) {
      double s, t;
      switch (light.pattern) {
        case SamplePattern::Random: s = rng.uniform(); t = rng.uniform(); break;
        case SamplePattern::Grid: s = (cx + 0.5) / nx; t = (cy + 0.5) / ny; break;
        default: s = (cx + rng.uniform()) / nx; t = (cy + rng.uniform()) / ny; break;
      }
      Vec3f q = map(s, t);
      light.jitter_points[size_t(j) * K + k] = q;
      light.jitter_boxes[j].extend(q);
    }
  }
  return {};
}

std::vector<Receiver> grid_receivers(const ReceiverGrid& g) {
  std::vector<Receiver> out;
  out.reserve(size_t(g.nu) * size_t(g.nv));
  Vec3d o = to_double(g.origin), u = to_double(g.u), v = to_double(g.v), nrm = to_double(g.normal);
  double len = length(nrm);
  Vec3f unit_n = len > 0 ? Vec3f(nrm / len) : Vec3f(0, 0, 1);
  for (int b = 0; b < g.nv; ++b)
    for (int a = 0; a < g.nu; ++a) {
      Vec3d p = o + u * ((a + 0.5) / g.nu) + v * ((b + 0.5) / g.nv) + (len > 0 ? nrm / len : nrm) * double(g.offset);
      out.push_back({Vec3f(p), unit_n});
    }
  return out;
}

}  // namespace visgate
