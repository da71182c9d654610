// Structure-aware scene decoder for the fuzz targets; see byte_decoder.h for the byte layout.
#include "lib/scene/byte_decoder.h"

#include <fuzzer/FuzzedDataProvider.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdlib>
#include <limits>

#include "lib/scene/exact_transform.h"
#include "lib/scene/families.h"

namespace visgate::fuzz {

namespace {

Error fail(const std::string& what) { return Error{"decoded scene: " + what}; }

// Light point inputs the decoder may touch: polygon vertices and explicit samples.
Status prepare_lights(Scene& s) {
  for (size_t l = 0; l < s.lights.size(); ++l) {
    Status st = prepare_light(s.lights[l], "decoded scene: lights[" + std::to_string(l) + "]");
    if (!st) return st;
  }
  return {};
}

// Raw mode: every coordinate is an integer grid index times a power-of-two step plus a
// power-of-two-aligned origin, so all of them are exact floats and exact coincidences
// (shared vertices, vertex on a segment, coplanar faces) are one byte away.
// Grid units: blockers in [-16,16]^2 x [1,31], receivers in [-16,16]^2 x [0,2], lights
// in the plane z = 32 emitting down.
Result<Scene> decode_raw(FuzzedDataProvider& in, const DecodeLimits& lim) {
  Scene s;
  s.name = "fuzz-raw";
  // Step 2^e, e in [-12, 4]: from sub-millimetre grids to units of 16.
  const double step = std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-12, 4));
  // Origin: 0 or far away (2^10 .. 2^20 grid-aligned), the far-origin degeneracies of
  // DESIGN section 7.
  const int far = in.ConsumeIntegralInRange<int>(0, 3);
  const double origin = far == 0 ? 0.0 : std::ldexp(1.0, 5 + 5 * far) * step;
  auto P = [&](int x, int y, int z) {
    return Vec3f(Vec3d(origin + x * step, origin + y * step, origin + z * step));
  };

  // Blockers: a small vertex pool indexed by the triangles, so edges are shared.
  const int max_tri = int(std::max<size_t>(1, lim.max_triangles));
  const int n_tri = in.ConsumeIntegralInRange<int>(0, max_tri);
  const int n_vert = in.ConsumeIntegralInRange<int>(3, std::min(3 * max_tri, 32));
  for (int v = 0; v < n_vert; ++v) {
    int x = in.ConsumeIntegralInRange<int>(-16, 16);
    int y = in.ConsumeIntegralInRange<int>(-16, 16);
    int z = in.ConsumeIntegralInRange<int>(1, 31);
    s.mesh.vertices.push_back(P(x, y, z));
  }
  for (int t = 0; t < n_tri; ++t) {
    std::array<uint32_t, 3> tri{};
    for (auto& i : tri) i = in.ConsumeIntegralInRange<uint32_t>(0, uint32_t(n_vert - 1));
    s.mesh.triangles.push_back(tri);
  }

  // Lights: squares (or explicit sample points) in the plane z = 32.
  const int n_lights = in.ConsumeIntegralInRange<int>(1, int(std::max<size_t>(1, lim.max_lights)));
  for (int l = 0; l < n_lights; ++l) {
    const int cx = in.ConsumeIntegralInRange<int>(-8, 8), cy = in.ConsumeIntegralInRange<int>(-8, 8);
    const int h = in.ConsumeIntegralInRange<int>(1, 8);
    Light L;
    // Counter-clockwise seen from below (emitting side): normal -z.
    L.polygon = {P(cx - h, cy - h, 32), P(cx - h, cy + h, 32), P(cx + h, cy + h, 32), P(cx + h, cy - h, 32)};
    L.samples = in.ConsumeIntegralInRange<int>(1, std::max(1, lim.max_samples));
    L.seed = in.ConsumeIntegral<uint8_t>();
    switch (in.ConsumeIntegralInRange<int>(0, 3)) {
      case 0: L.pattern = SamplePattern::Stratified; break;
      case 1: L.pattern = SamplePattern::Random; break;
      case 2: L.pattern = SamplePattern::Grid; break;
      default:
        L.pattern = SamplePattern::Explicit;
        for (int j = 0; j < L.samples; ++j) {
          int x = in.ConsumeIntegralInRange<int>(-h, h), y = in.ConsumeIntegralInRange<int>(-h, h);
          L.explicit_samples.push_back(P(cx + x, cy + y, 32));
        }
        break;
    }
    L.jitter = L.pattern == SamplePattern::Explicit ? 1 : in.ConsumeIntegralInRange<int>(1, 4);
    s.lights.push_back(std::move(L));
  }

  // Receivers: grid points near the floor, facing up.
  const int n_rec = in.ConsumeIntegralInRange<int>(1, int(std::max<size_t>(1, lim.max_receivers)));
  for (int i = 0; i < n_rec; ++i) {
    int x = in.ConsumeIntegralInRange<int>(-16, 16), y = in.ConsumeIntegralInRange<int>(-16, 16);
    int z = in.ConsumeIntegralInRange<int>(0, 2);
    s.receivers.push_back({P(x, y, z), Vec3f(0, 0, 1)});
  }
  return s;
}

// Family mode: a DESIGN section 7 family with small parameters, cut down to the caps.
Result<Scene> decode_family(FuzzedDataProvider& in, const std::string& family, const DecodeLimits& lim) {
  FamilyParams p;
  p.seed = in.ConsumeIntegral<uint16_t>();
  p.triangles = in.ConsumeIntegralInRange<long>(1, long(std::max<size_t>(1, lim.max_triangles)));
  p.receivers = in.ConsumeIntegralInRange<long>(1, long(std::max<size_t>(1, lim.max_receivers)));
  p.samples = in.ConsumeIntegralInRange<long>(1, std::max(1, lim.max_samples));
  static constexpr double kLightScales[] = {1.0, 0.25, 2.0, 1e-3, 4.0};
  p.light_scale = in.PickValueInArray(kLightScales);
  auto gen = generate_family(family, p);
  if (!gen) return fail("family " + family + ": " + gen.error().message);
  Scene s = std::move(*gen);

  // Triangles: a window of at most max_triangles, unused vertices dropped (first-use
  // order) so the scene's bounds are those of what is solved.
  const size_t n = s.mesh.triangles.size();
  if (n > lim.max_triangles) {
    size_t start = in.ConsumeIntegralInRange<size_t>(0, n - lim.max_triangles);
    s.mesh.triangles.erase(s.mesh.triangles.begin() + long(start + lim.max_triangles), s.mesh.triangles.end());
    s.mesh.triangles.erase(s.mesh.triangles.begin(), s.mesh.triangles.begin() + long(start));
  }
  {
    std::vector<uint32_t> remap(s.mesh.vertices.size(), UINT32_MAX);
    std::vector<Vec3f> kept;
    for (auto& t : s.mesh.triangles)
      for (auto& i : t) {
        if (remap[i] == UINT32_MAX) {
          remap[i] = uint32_t(kept.size());
          kept.push_back(s.mesh.vertices[i]);
        }
        i = remap[i];
      }
    s.mesh.vertices = std::move(kept);
  }

  // Lights: the first max_lights, samples capped (explicit samples truncated alike).
  if (s.lights.size() > lim.max_lights) s.lights.resize(std::max<size_t>(1, lim.max_lights));
  for (auto& L : s.lights) {
    if (L.samples > lim.max_samples) {
      L.samples = std::max(1, lim.max_samples);
      if (L.explicit_samples.size() > size_t(L.samples)) L.explicit_samples.resize(size_t(L.samples));
    }
  }

  // Receivers: an explicit list (the grid, if any, is dropped), a window of at most
  // max_receivers.
  s.grid.reset();
  if (s.receivers.size() > lim.max_receivers) {
    size_t start = in.ConsumeIntegralInRange<size_t>(0, s.receivers.size() - lim.max_receivers);
    s.receivers = std::vector<Receiver>(s.receivers.begin() + long(start),
                                        s.receivers.begin() + long(start + lim.max_receivers));
  }
  return s;
}

// Every coordinate the decoder may change, addressed as (kind, element, axis).
enum class Kind { MeshVertex, ReceiverPoint, ReceiverNormal, LightVertex, ExplicitSample };

float* coordinate(Scene& s, Kind kind, size_t index, int axis) {
  auto pick = [&](std::vector<Vec3f>& v) -> float* { return v.empty() ? nullptr : &v[index % v.size()][axis]; };
  switch (kind) {
    case Kind::MeshVertex: return pick(s.mesh.vertices);
    case Kind::ReceiverPoint:
      return s.receivers.empty() ? nullptr : &s.receivers[index % s.receivers.size()].p[axis];
    case Kind::ReceiverNormal:
      return s.receivers.empty() ? nullptr : &s.receivers[index % s.receivers.size()].n[axis];
    case Kind::LightVertex: return s.lights.empty() ? nullptr : pick(s.lights[index % s.lights.size()].polygon);
    case Kind::ExplicitSample:
      return s.lights.empty() ? nullptr : pick(s.lights[index % s.lights.size()].explicit_samples);
  }
  return nullptr;
}

// Snaps every input coordinate to multiples of 2^e (exact: a power-of-two grid).
void snap_scene(Scene& s, int e) {
  auto snap = [e](Vec3f& v) {
    for (int k = 0; k < 3; ++k) {
      double q = std::ldexp(std::nearbyint(std::ldexp(double(v[k]), -e)), e);
      v[k] = float(q);  // |q| <= |v| + 2^e: finite for finite input unless at FLT_MAX
    }
  };
  for (auto& v : s.mesh.vertices) snap(v);
  for (auto& r : s.receivers) snap(r.p);
  for (auto& L : s.lights) {
    for (auto& v : L.polygon) snap(v);
    for (auto& v : L.explicit_samples) snap(v);
  }
}

// One perturbation of one coordinate.
void perturb(FuzzedDataProvider& in, Scene& s) {
  const Kind kind = Kind(in.ConsumeIntegralInRange<int>(0, 4));
  const size_t index = in.ConsumeIntegral<uint16_t>();
  const int axis = in.ConsumeIntegralInRange<int>(0, 2);
  float* c = coordinate(s, kind, index, axis);
  const int op = in.ConsumeIntegralInRange<int>(0, 5);
  if (!c) return;
  switch (op) {
    case 0:  // raw IEEE bits: NaN, Inf, subnormals, huge values
      *c = std::bit_cast<float>(in.ConsumeIntegral<uint32_t>());
      break;
    case 1:  // flip some of the 8 lowest mantissa bits
      *c = std::bit_cast<float>(std::bit_cast<uint32_t>(*c) ^ in.ConsumeIntegralInRange<uint32_t>(1, 0xFF));
      break;
    case 2: {  // a few ulps up or down
      int steps = in.ConsumeIntegralInRange<int>(-4, 4);
      for (; steps > 0; --steps) *c = std::nextafter(*c, std::numeric_limits<float>::infinity());
      for (; steps < 0; ++steps) *c = std::nextafter(*c, -std::numeric_limits<float>::infinity());
      break;
    }
    case 3: {  // copy a coordinate of another element: exact coincidences
      const Kind from = Kind(in.ConsumeIntegralInRange<int>(0, 4));
      // Separate statements: the order in which function arguments are evaluated is
      // unspecified (g++ and clang differ), and the bytes must decode the same scene in
      // every build (the replay build is g++, the fuzzers clang).
      const uint16_t from_index = in.ConsumeIntegral<uint16_t>();
      const int from_axis = in.ConsumeIntegralInRange<int>(0, 2);
      float* src = coordinate(s, from, from_index, from_axis);
      if (src) *c = *src;
      break;
    }
    case 4:  // sign flip (also -0 against +0)
      *c = -*c;
      break;
    default: {  // a signed power of two, down to the smallest subnormal 2^-149
      int e = in.ConsumeIntegralInRange<int>(-149, 20);
      *c = in.ConsumeBool() ? -std::ldexp(1.0f, e) : std::ldexp(1.0f, e);
      break;
    }
  }
}

Status check_finite(const Scene& s) {
  auto bad = [](const Vec3f& v) { return !is_finite(v); };
  for (size_t i = 0; i < s.mesh.vertices.size(); ++i)
    if (bad(s.mesh.vertices[i])) return fail("mesh vertex " + std::to_string(i) + ": coordinate is NaN or infinite");
  for (size_t i = 0; i < s.receivers.size(); ++i) {
    if (bad(s.receivers[i].p)) return fail("receivers[" + std::to_string(i) + "].p: coordinate is NaN or infinite");
    if (bad(s.receivers[i].n)) return fail("receivers[" + std::to_string(i) + "].n: coordinate is NaN or infinite");
  }
  for (size_t l = 0; l < s.lights.size(); ++l) {
    for (size_t i = 0; i < s.lights[l].polygon.size(); ++i)
      if (bad(s.lights[l].polygon[i]))
        return fail("lights[" + std::to_string(l) + "].polygon[" + std::to_string(i) + "]: coordinate is NaN or infinite");
    for (size_t i = 0; i < s.lights[l].explicit_samples.size(); ++i)
      if (bad(s.lights[l].explicit_samples[i]))
        return fail("lights[" + std::to_string(l) + "].explicit_samples[" + std::to_string(i) +
                    "]: coordinate is NaN or infinite");
  }
  return {};
}

}  // namespace

const std::vector<std::string>& decoder_modes() {
  // DESIGN section 7 order without `rooms`: its fixed building (about 4.5k triangles
  // whatever the triangle target) costs 7.6 ms to generate, a hundred times any other
  // family, and the cut-down window is boxes that `columns` and raw mode already give.
  static const std::vector<std::string> modes = {
      "random-soup", "torus",      "pouch",   "double-surface", "grid-snapped", "far-origin",
      "shared-edge-fan", "sliver-soup", "on-surface", "columns", "foliage", "raw"};
  return modes;
}

Result<Scene> decode_scene(const uint8_t* data, size_t size, const DecodeLimits& limits) {
  FuzzedDataProvider in(data, size);
  const auto& modes = decoder_modes();
  const std::string& mode = modes[in.ConsumeIntegralInRange<size_t>(0, modes.size() - 1)];
  Result<Scene> base = mode == "raw" ? decode_raw(in, limits) : decode_family(in, mode, limits);
  if (!base) return base.error();
  Scene s = std::move(*base);

  // Grid snapping: multiples of 2^e, e in [-8, 2].
  if (in.ConsumeProbability<float>() < 0.25f) snap_scene(s, in.ConsumeIntegralInRange<int>(-8, 2));

  const size_t n_perturb = in.ConsumeIntegralInRange<size_t>(0, limits.max_perturbations);
  for (size_t k = 0; k < n_perturb; ++k) perturb(in, s);

  Status fin = check_finite(s);
  if (!fin) return fin.error();
  if (s.lights.empty()) return fail("no lights");
  if (s.receivers.empty()) return fail("no receivers");

  // Exact transforms of the input (DESIGN section 2, "Scale"; lib/scene/exact_transform.h):
  // one of the 48 axis maps, then 2^k with k in [-120, 124] clamped to where the copy is
  // exact, both before the lights are sampled so that the scene's JSON reproduces it. An
  // exhausted input decodes to the identity and k = 0.
  const unsigned map = in.ConsumeIntegralInRange<unsigned>(0, 47);
  if (map != 0) s = axis_mapped_scene(s, axis_map(map));
  const int v = in.ConsumeIntegralInRange<int>(0, 244);
  int k = v <= 124 ? v : 124 - v;
  k = std::clamp(k, limits.min_scale_exponent, limits.max_scale_exponent);
  const ScaleRange range = exact_scale_range(s);
  k = std::clamp(k, range.lo, range.hi);
  if (k != 0 && range.contains(k)) s = scaled_scene(s, k);

  Status st = prepare_lights(s);
  if (!st) return st.error();

  // Relation cap: drop receivers from the end.
  const size_t per_receiver = s.samples_per_receiver();
  if (per_receiver > limits.max_relations) return fail(std::to_string(per_receiver) + " samples per receiver exceed the cap");
  const size_t keep = std::max<size_t>(1, limits.max_relations / per_receiver);
  if (s.receivers.size() > keep) s.receivers.resize(keep);
  return s;
}

Result<DecodedCase> decode_case(const uint8_t* data, size_t size, const DecodeLimits& limits) {
  DecodedCase c;
  const size_t head = std::min(size, kOptionSelectorBytes);
  for (size_t k = 0; k < head; ++k) c.option_selector |= uint32_t(data[k]) << (8 * k);
  auto scene = decode_scene(data + head, size - head, limits);
  if (!scene) return scene.error();
  c.scene = std::move(*scene);
  return c;
}

DecodeLimits target_limits(const std::string& target) { return method_limits(target_method(target)); }

DecodeLimits method_limits(const std::string& method) {
  DecodeLimits lim;
  if (method == "plucker-bsp") lim.max_triangles = 24;
  // Embree answers scenes as given and its robust mode loses blocked relations at
  // extents near 2^-37 and below (bench stability's scale axis charts it): fuzz_embree
  // looks for its other failures at scale 1.
  if (method == "embree-robust") lim.min_scale_exponent = lim.max_scale_exponent = 0;
  return lim;
}

std::string target_method(const std::string& target) {
  if (target == "fuzz_iss") return "iss";
  if (target == "fuzz_ssv") return "ssv";
  if (target == "fuzz_plucker") return "plucker-bsp";
  if (target == "fuzz_embree") return "embree-robust";
  // Your own method (fuzz_plugin.cpp): the library VISGATE_FUZZ_PLUGIN names; "" without it.
  if (target == "fuzz_plugin") {
    const char* path = std::getenv("VISGATE_FUZZ_PLUGIN");
    return path && *path ? std::string("plugin:") + path : std::string();
  }
  return "";
}

}  // namespace visgate::fuzz
