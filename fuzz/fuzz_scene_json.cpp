// fuzz_scene_json: the scene JSON reader (lib/scene/scene_json.h, DESIGN section 6).
// Arbitrary bytes must give a Scene or an Error value, never a crash, hang, leak or
// exception. A scene that reads must survive the writer: written in hex-float and in
// 9-digit decimal it reads back bit-identical (DESIGN section 2). Small SceneLimits keep
// every run fast; mesh "file" references resolve against a folder that does not exist.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

#include "lib/scene/scene_json.h"

namespace {

bool same_bits(const visgate::Vec3f& a, const visgate::Vec3f& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

bool same_points(const std::vector<visgate::Vec3f>& a, const std::vector<visgate::Vec3f>& b) {
  if (a.size() != b.size()) return false;
  for (size_t i = 0; i < a.size(); ++i)
    if (!same_bits(a[i], b[i])) return false;
  return true;
}

// What the round trip must keep: every input field of the scene, bit for bit.
std::string first_difference(const visgate::Scene& a, const visgate::Scene& b) {
  if (a.name != b.name) return "name";
  if (!same_points(a.mesh.vertices, b.mesh.vertices)) return "mesh vertices";
  if (a.mesh.triangles != b.mesh.triangles) return "mesh triangles";
  if (a.lights.size() != b.lights.size()) return "light count";
  for (size_t l = 0; l < a.lights.size(); ++l) {
    const auto &x = a.lights[l], &y = b.lights[l];
    if (!same_points(x.polygon, y.polygon)) return "lights[" + std::to_string(l) + "].polygon";
    if (x.samples != y.samples || x.jitter != y.jitter || x.seed != y.seed || x.pattern != y.pattern)
      return "lights[" + std::to_string(l) + "] parameters";
    if (!same_points(x.explicit_samples, y.explicit_samples)) return "lights[" + std::to_string(l) + "].explicit_samples";
    if (!same_points(x.jitter_points, y.jitter_points)) return "lights[" + std::to_string(l) + "] jitter points";
  }
  if (a.receivers.size() != b.receivers.size()) return "receiver count";
  for (size_t i = 0; i < a.receivers.size(); ++i)
    if (!same_bits(a.receivers[i].p, b.receivers[i].p) || !same_bits(a.receivers[i].n, b.receivers[i].n))
      return "receivers[" + std::to_string(i) + "]";
  if (a.grid.has_value() != b.grid.has_value()) return "receiver grid";
  return "";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace visgate;
  // Caps sized so a run stays in milliseconds: the relation limit also bounds a light's
  // samples, so at most 2^14 * 64 jitter points are generated.
  SceneLimits limits;
  limits.max_triangles = 4096;
  limits.max_receivers = 4096;
  limits.max_relations = 1 << 14;
  const std::string text(reinterpret_cast<const char*>(data), size);
  const std::string base = "/nonexistent-visgate-fuzz";
  auto scene = read_scene_json(text, "fuzz.json", base, limits);
  if (!scene) return 0;
  for (bool hex : {true, false}) {
    const std::string written = write_scene_json(*scene, SceneWriteOptions{hex});
    auto again = read_scene_json(written, "rewritten.json", base, limits);
    std::string diff = again ? first_difference(*scene, *again) : "read error: " + again.error().message;
    if (!diff.empty()) {
      std::fprintf(stderr, "fuzz_scene_json: %s round trip differs: %s\nwritten:\n%s\n", hex ? "hex" : "decimal",
                   diff.c_str(), written.c_str());
      std::abort();
    }
  }
  return 0;
}
