// The textbook Möller-Trumbore caster (mt_caster.h) as an exec: program:
//   visgate check --family shared-edge-fan --count 4 --methods exec:./mt_caster_exec
// visgate runs it as `mt_caster_exec SCENE RESULT`: it reads the explicit scene JSON
// (docs/external-methods.md: inline mesh, receivers as a list, every light point stated)
// and writes the result JSON (format "visgate-result"). Only nlohmann_json is needed;
// coordinates are parsed with strtof from their text, so each is the scene's float32.
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "mt_caster.h"

using nlohmann::json;

namespace {

// A coordinate: a JSON number (read from its text with strtof) or a decimal/hex string.
float coord(const json& j) {
  if (j.is_string()) return std::strtof(j.get<std::string>().c_str(), nullptr);
  return std::strtof(j.dump().c_str(), nullptr);
}
mt_caster::V3 vec(const json& j) { return {coord(j[0]), coord(j[1]), coord(j[2])}; }

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    std::fprintf(stderr, "usage: mt_caster_exec SCENE RESULT\n");
    return 2;
  }
  std::ifstream in(argv[1]);
  json scene = json::parse(in);

  // Blockers: every mesh concatenated.
  std::vector<float> vertices;
  std::vector<uint32_t> triangles;
  for (const auto& m : scene["meshes"]) {
    const uint32_t base = uint32_t(vertices.size() / 3);
    for (const auto& v : m["vertices"]) {
      const mt_caster::V3 p = vec(v);
      vertices.insert(vertices.end(), {p.x, p.y, p.z});
    }
    for (const auto& t : m["triangles"])
      for (int k = 0; k < 3; ++k) triangles.push_back(base + t[k].get<uint32_t>());
  }
  std::vector<mt_caster::V3> receivers;
  for (const auto& r : scene["receivers"]) receivers.push_back(vec(r["p"]));

  json out;
  out["format"] = "visgate-result";
  out["version"] = 1;
  out["method"] = "mt-caster";
  json recs = json::array();
  for (size_t i = 0; i < receivers.size(); ++i) {
    std::string visible;
    for (const auto& light : scene["lights"]) {
      // Relation (i, j): relation_points[i][j] when given, else explicit_samples[j].
      const int samples = light["samples"].get<int>();
      for (int j = 0; j < samples; ++j) {
        const json& p = light.contains("relation_points") ? light["relation_points"][i][j] : light["explicit_samples"][j];
        visible += mt_caster::occluded(vertices.data(), triangles.data(), triangles.size() / 3, receivers[i], vec(p)) ? '0' : '1';
      }
    }
    recs.push_back({{"visible", visible}});
  }
  out["receivers"] = recs;
  std::ofstream(argv[2]) << out.dump() << "\n";
  return 0;
}
