// Scene JSON (format "visgate-scene", version 1; DESIGN section 6): reader and writer
// with a bit-exact round trip. Every JSON number is converted to float32 from its own
// text with strtof (correctly rounded, never through double), and strings holding
// decimal or C99 hex-floats are accepted wherever a coordinate is. Errors name the file
// and the element, e.g. "s.json: meshes[0].vertices[12][1]: coordinate is NaN or infinite".
#pragma once

#include <string>

#include "lib/scene/scene.h"

namespace visgate {

struct SceneLimits {
  size_t max_triangles = 50'000'000;
  size_t max_receivers = 50'000'000;
  size_t max_relations = size_t(1) << 40;
};

// Reads a scene file; mesh file paths are relative to the file's folder.
Result<Scene> read_scene_file(const std::string& path, const SceneLimits& limits = {});
// Parses scene JSON text; `origin` names it in messages, `base_dir` resolves mesh files.
Result<Scene> read_scene_json(const std::string& text, const std::string& origin,
                              const std::string& base_dir, const SceneLimits& limits = {});

struct SceneWriteOptions {
  bool hex = false;  // write coordinates as hex-float strings instead of 9-digit decimals
  // Every relation's light point stated: each light gets "relation_points" (per receiver,
  // its samples' positions; not for explicit samples with jitter 1, which already state
  // them) and receivers are always a list. The form exec: methods read (lib/external/
  // exec_method.h), so that they need not reimplement the sample patterns.
  bool relation_points = false;
};
// Self-contained JSON: meshes inline (one mesh), lights with their inputs, receivers as
// a grid when the scene has one (and relation_points is off), else as a list.
std::string write_scene_json(const Scene& scene, const SceneWriteOptions& opt = {});

}  // namespace visgate
