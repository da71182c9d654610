// Exact scene transforms (see exact_transform.h).
#include "lib/scene/exact_transform.h"

#include <algorithm>
#include <bit>
#include <climits>
#include <cmath>
#include <cstdint>
#include <vector>

namespace visgate {

namespace {

// Every point of the scene, including what prepare_light derived and the grid's corner.
template <class S, class F>
void for_each_point(S& s, F&& f) {
  for (auto& v : s.mesh.vertices) f(v);
  for (auto& l : s.lights) {
    for (auto& v : l.polygon) f(v);
    for (auto& v : l.jitter_points) f(v);
    for (auto& v : l.explicit_samples) f(v);
  }
  for (auto& r : s.receivers) f(r.p);
  if (s.grid) f(s.grid->origin);
}

// Every vector that scales with the scene but is not a point: the grid's spans.
template <class S, class F>
void for_each_span(S& s, F&& f) {
  if (s.grid) {
    f(s.grid->u);
    f(s.grid->v);
  }
}

void rebuild_boxes(Light& l) {
  for (int j = 0; j < l.samples && size_t(j) < l.jitter_boxes.size(); ++j) {
    AABB b;
    for (int k = 0; k < l.jitter; ++k) b.extend(l.jitter_point(j, k));
    l.jitter_boxes[size_t(j)] = b;
  }
}

// Exponent of the highest and of the lowest set bit of a finite non-zero float.
void bit_range(float x, int& top, int& low) {
  const uint32_t u = std::bit_cast<uint32_t>(x);
  const int biased = int((u >> 23) & 0xFFu);
  uint32_t mant = u & 0x7FFFFFu;
  int e0 = -149;  // weight of mantissa bit 0
  if (biased != 0) {
    mant |= 0x800000u;
    e0 = biased - 127 - 23;
  }
  low = e0 + std::countr_zero(mant);
  top = e0 + (31 - std::countl_zero(mant));
}

float scale_float(float x, int exponent) { return float(std::ldexp(double(x), exponent)); }

Vec3f scale_vec(const Vec3f& v, int exponent) {
  return {scale_float(v.x, exponent), scale_float(v.y, exponent), scale_float(v.z, exponent)};
}

// True when c + t is exactly a float for every coordinate c on axis k.
bool exact_on_axis(const Scene& s, int k, double t) {
  bool ok = true;
  for_each_point(s, [&](const Vec3f& v) {
    if (!ok) return;
    // v + t must be exact in double before float(x) == x means anything: a power of two
    // far above |v| would swallow v. Knuth's TwoSum gives the exact rounding error of
    // the sum; it is zero iff the sum is exact.
    const double a = double(v[k]);
    const double x = a + t, bv = x - a, err = (a - (x - bv)) + (t - bv);
    ok = err == 0.0 && double(float(x)) == x;
  });
  return ok;
}

}  // namespace

double scene_extent(const Scene& scene) {
  Vec3d lo(INFINITY, INFINITY, INFINITY), hi(-INFINITY, -INFINITY, -INFINITY);
  for_each_point(scene, [&](const Vec3f& p) {
    for (int k = 0; k < 3; ++k) {
      lo[k] = std::min(lo[k], double(p[k]));
      hi[k] = std::max(hi[k], double(p[k]));
    }
  });
  double e = 0.0;
  for (int k = 0; k < 3; ++k)
    if (hi[k] >= lo[k]) e = std::max(e, hi[k] - lo[k]);
  return e;
}

ScaleRange exact_scale_range(const Scene& scene) {
  // x 2^k is exact iff its lowest set bit stays at or above 2^-149 and its highest at or
  // below 2^127.
  int lo = INT_MIN / 2, hi = INT_MAX / 2;
  auto visit = [&](const Vec3f& v) {
    for (int k = 0; k < 3; ++k) {
      if (v[k] == 0.0f || !std::isfinite(v[k])) continue;
      int top = 0, low = 0;
      bit_range(v[k], top, low);
      lo = std::max(lo, -149 - low);
      hi = std::min(hi, 127 - top);
    }
  };
  for_each_point(scene, visit);
  for_each_span(scene, visit);
  if (scene.grid && scene.grid->offset != 0.0f) visit(Vec3f(scene.grid->offset, 0.0f, 0.0f));
  return {lo, hi};
}

double typical_relation_length(const Scene& scene) {
  if (scene.lights.empty() || scene.receivers.empty()) return 0.0;
  std::vector<Vec3d> centroids;
  for (const auto& l : scene.lights) {
    Vec3d c(0, 0, 0);
    for (const auto& p : l.polygon) c += to_double(p);
    centroids.push_back(c / double(std::max<size_t>(1, l.polygon.size())));
  }
  // Every k-th receiver, so that at most about 4096 pairs are measured.
  const size_t n = scene.receivers.size();
  const size_t step = std::max<size_t>(1, n * centroids.size() / 4096);
  std::vector<double> len;
  for (size_t i = 0; i < n; i += step)
    for (const auto& c : centroids) len.push_back(length(c - to_double(scene.receivers[i].p)));
  auto mid = len.begin() + std::ptrdiff_t(len.size() / 2);
  std::nth_element(len.begin(), mid, len.end());
  return *mid;
}

double typical_light_size(const Scene& scene) {
  std::vector<double> size;
  for (const auto& l : scene.lights) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, e = 0.0;
    for (const auto& p : l.polygon)
      for (int k = 0; k < 3; ++k) lo[k] = std::min(lo[k], double(p[k])), hi[k] = std::max(hi[k], double(p[k]));
    for (int k = 0; k < 3; ++k)
      if (hi[k] >= lo[k]) e = std::max(e, hi[k] - lo[k]);
    size.push_back(e);
  }
  if (size.empty()) return 0.0;
  auto mid = size.begin() + std::ptrdiff_t(size.size() / 2);
  std::nth_element(size.begin(), mid, size.end());
  return *mid;
}

double unit_length(const Scene& scene) {
  // The larger of the two: receivers sitting on a light (relation lengths near 0) must
  // not blow the scene up towards overflow.
  const double e = std::max(typical_relation_length(scene), typical_light_size(scene));
  return e > 0.0 && std::isfinite(e) ? e : scene_extent(scene);
}

int unit_scale_exponent(const Scene& scene) {
  double e = unit_length(scene);
  if (!(e > 0.0) || !std::isfinite(e)) e = scene_extent(scene);
  if (!(e > 0.0) || !std::isfinite(e)) return 0;
  int exp2 = 0;
  std::frexp(e, &exp2);  // e in [2^(exp2 - 1), 2^exp2)
  const ScaleRange range = exact_scale_range(scene);
  return std::clamp(kUnitExponent + 1 - exp2, range.lo, range.hi);
}

Scene scaled_scene(const Scene& src, int exponent) {
  Scene s = src;
  if (exponent == 0) return s;
  // While |exponent| <= 600 a float's value times 2^exponent neither overflows nor
  // underflows in double (floats lie in [2^-149, 2^128)), so the product is exact, equal
  // to ldexp's, and its one rounding to float is scale_float's: the same bits without a
  // libm call per coordinate (perf: 6M of iss's instructions on scan 75k).
  const bool by_factor = exponent >= -600 && exponent <= 600;
  const double factor = std::ldexp(1.0, exponent);
  auto scale = [&](Vec3f& v) {
    v = by_factor ? Vec3f(float(double(v.x) * factor), float(double(v.y) * factor), float(double(v.z) * factor))
                  : scale_vec(v, exponent);
  };
  for_each_point(s, scale);
  for_each_span(s, scale);
  if (s.grid) s.grid->offset = scale_float(s.grid->offset, exponent);
  for (auto& l : s.lights) {
    l.area = std::ldexp(l.area, 2 * exponent);
    rebuild_boxes(l);
  }
  return s;
}

bool AxisMap::reverses_handedness() const {
  // The permutation's parity: an odd one (one transposition or none but a cycle of two)
  // reverses, and so does each mirror.
  int inversions = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) inversions += axis[i] > axis[j];
  return ((inversions & 1) != 0) != (sign[0] * sign[1] * sign[2] < 0);
}

AxisMap axis_map(unsigned index) {
  static constexpr std::array<std::array<int, 3>, 6> perms{
      {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}}};
  AxisMap m;
  index %= 48u;
  m.axis = perms[index / 8u];
  for (int k = 0; k < 3; ++k) m.sign[k] = (index >> k) & 1u ? -1 : 1;
  return m;
}

Scene axis_mapped_scene(const Scene& src, const AxisMap& map) {
  Scene s = src;
  auto apply = [&](Vec3f& v) {
    const Vec3f o = v;
    for (int i = 0; i < 3; ++i) v[i] = map.sign[i] < 0 ? -o[map.axis[i]] : o[map.axis[i]];
  };
  for_each_point(s, apply);
  for_each_span(s, apply);
  for (auto& r : s.receivers) apply(r.n);
  if (s.grid) apply(s.grid->normal);
  const bool reverse = map.reverses_handedness();
  for (auto& l : s.lights) {
    apply(l.normal);
    if (reverse) std::reverse(l.polygon.begin(), l.polygon.end());
    rebuild_boxes(l);
  }
  if (reverse)
    for (auto& t : s.mesh.triangles) std::swap(t[1], t[2]);
  return s;
}

Scene translated_scene(const Scene& src, Vec3d* offset) {
  Scene s = src;
  AABB b = s.bounds();
  Vec3d off(0, 0, 0);
  for (int k = 0; k < 3; ++k) {
    double extent = std::max({double(b.hi[k]) - double(b.lo[k]), std::abs(double(b.lo[k])), std::abs(double(b.hi[k])), 1e-30});
    int top = int(std::floor(std::log2(extent)));
    // Largest power-of-two offset (either sign) that keeps every coordinate exact,
    // trying 40 binades below the extent.
    for (int e = top; e > top - 40 && off[k] == 0.0; --e)
      for (double sign : {1.0, -1.0})
        if (off[k] == 0.0 && exact_on_axis(s, k, sign * std::ldexp(1.0, e))) off[k] = sign * std::ldexp(1.0, e);
  }
  for_each_point(s, [&](Vec3f& v) { v = Vec3f(to_double(v) + off); });
  for (auto& l : s.lights) rebuild_boxes(l);
  s.name = src.name + "-translated";
  if (offset) *offset = off;
  return s;
}

}  // namespace visgate
