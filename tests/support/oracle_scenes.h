// Test fixtures of the oracle suites (tests/oracle/*_test.cpp): scenes built by hand
// (soups, quads, square lights with explicit samples), small generated scenes, and the
// scenes of the certified-bound tests (families plus decoded fuzz inputs). Nothing in the
// oracle suites trusts the oracles' own output: classes come from the definitions on
// inputs built by construction, from an independent reference with CGAL's exact
// constructions, from invariance under exact transforms, from hand-computed areas and
// form factors, and from an independent double-precision point-sampling estimate.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "lib/scene/byte_decoder.h"
#include "lib/scene/families.h"
#include "oracle/relation_oracle.h"

namespace visgate::oracle::test_support {

using RC = RelationClass;

// The families the region oracle's fast-path and certified-bound tests run on: every
// family the harness fuzzes and gates, except the large ones.
inline constexpr const char* kRegionFamilies[] = {"random-soup", "grid-snapped", "sliver-soup", "on-surface", "far-origin",
                                           "shared-edge-fan", "torus", "pouch", "columns"};

// A small generated scene of the region-oracle tests: 9 receivers, 4 samples per light.
inline Result<Scene> small_family_scene(const char* fam, uint64_t seed, long triangles) {
  FamilyParams p;
  p.seed = seed;
  p.receivers = 9;
  p.samples = 4;
  p.triangles = triangles;
  return generate_family(fam, p);
}

inline Scene soup_scene(const std::vector<std::array<Vec3f, 3>>& tris) {
  Scene s;
  s.name = "test";
  for (const auto& t : tris) {
    uint32_t base = uint32_t(s.mesh.vertices.size());
    for (const Vec3f& v : t) s.mesh.vertices.push_back(v);
    s.mesh.triangles.push_back({base, base + 1, base + 2});
  }
  return s;
}

inline Light explicit_light(const std::vector<Vec3f>& polygon, const std::vector<Vec3f>& samples) {
  Light l;
  l.polygon = polygon;
  l.samples = int(samples.size());
  l.pattern = SamplePattern::Explicit;
  l.jitter = 1;
  l.explicit_samples = samples;
  Status st = prepare_light(l, "test light");
  EXPECT_TRUE(st.ok()) << st.error().message;
  return l;
}

// Square light [x0, x1] x [y0, y1] at height z, emitting downwards (counter-clockwise
// seen from below), with one explicit sample at its centre.
inline Light square_light_down(float x0, float x1, float y0, float y1, float z) {
  std::vector<Vec3f> poly = {{x0, y0, z}, {x0, y1, z}, {x1, y1, z}, {x1, y0, z}};
  return explicit_light(poly, {{(x0 + x1) / 2, (y0 + y1) / 2, z}});
}

inline void add_quad(Scene& s, Vec3f a, Vec3f b, Vec3f c, Vec3f d) {
  uint32_t base = uint32_t(s.mesh.vertices.size());
  for (const Vec3f& v : {a, b, c, d}) s.mesh.vertices.push_back(v);
  s.mesh.triangles.push_back({base, base + 1, base + 2});
  s.mesh.triangles.push_back({base, base + 2, base + 3});
}

inline RC cls(const Scene& s, Vec3f p, Vec3f q) { return classify_segment(s, p, q).cls; }

// Small-integer coordinates make exact degeneracies (shared planes, vertices on
// segments, collinear edges) frequent.
inline Vec3f grid_point(std::mt19937& g, int range) {
  std::uniform_int_distribution<int> d(-range, range);
  return Vec3f(float(d(g)), float(d(g)), float(d(g)));
}

// A grid soup scene with one light of explicit samples on a grid and a few receivers.
inline Scene grid_scene(uint32_t seed, int triangles, int receivers, int samples) {
  std::mt19937 g(seed);
  std::vector<std::array<Vec3f, 3>> tris;
  for (int t = 0; t < triangles; ++t) {
    Vec3f a = grid_point(g, 3), b = grid_point(g, 3), c = grid_point(g, 3);
    tris.push_back({a, b, c});
  }
  Scene s = soup_scene(tris);
  std::vector<Vec3f> smp;
  for (int j = 0; j < samples; ++j) smp.push_back(Vec3f(float(int(g() % 9) - 4), float(int(g() % 9) - 4), 4.0f));
  s.lights.push_back(explicit_light({{-4, -4, 4}, {-4, 4, 4}, {4, 4, 4}, {4, -4, 4}}, smp));
  for (int i = 0; i < receivers; ++i) s.receivers.push_back({grid_point(g, 3), {0, 0, 1}});
  return s;
}

// Scenes for the certified fraction bound: the families of the fast-path test and every
// decoded seed of fuzz_plucker plus every 8th of fuzz_iss (the same decoder).
inline std::vector<Scene> bound_scenes() {
  std::vector<Scene> out;
  for (const char* fam : kRegionFamilies)
    for (uint64_t seed = 1; seed <= 2; ++seed) {
      auto scene = small_family_scene(fam, seed, 60);
      if (scene.ok()) out.push_back(std::move(*scene));
    }
  const char* src = std::getenv("VISGATE_SOURCE_DIR");
  if (!src) src = VISGATE_TEST_SOURCE_DIR;
  for (const char* dir : {"corpus/fuzz/fuzz_plucker", "corpus/fuzz/fuzz_iss"}) {
    std::filesystem::path d = std::filesystem::path(src) / dir;
    if (!std::filesystem::is_directory(d)) continue;
    std::vector<std::filesystem::path> files;
    for (const auto& e : std::filesystem::directory_iterator(d)) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    size_t step = std::string(dir).find("iss") != std::string::npos ? 8 : 1;
    for (size_t k = 0; k < files.size(); k += step) {
      std::ifstream in(files[k], std::ios::binary);
      std::vector<uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      auto c = visgate::fuzz::decode_case(bytes.data(), bytes.size(), visgate::fuzz::DecodeLimits{});
      if (c) out.push_back(std::move(c->scene));
    }
  }
  return out;
}

}  // namespace visgate::oracle::test_support
