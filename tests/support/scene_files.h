// Helpers for the lib/scene suites: float bits, small scenes and scene texts, a
// per-process temporary folder, and the expected read error of a polygon file.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "lib/scene/families.h"
#include "lib/scene/mesh_io.h"
#include "lib/scene/scene.h"

namespace visgate::test_support {

inline uint32_t bits(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

inline Scene small_scene(const std::vector<Vec3f>& verts) {
  Scene s;
  s.name = "t";
  s.mesh.vertices = verts;
  for (uint32_t i = 0; i + 2 < verts.size(); i += 3) s.mesh.triangles.push_back({i, i + 1, i + 2});
  s.lights.push_back(make_square_light_down(Vec3d(0, 0, 2), 0.5, 4, 1));
  s.receivers.push_back({Vec3f(0, 0, 0), Vec3f(0, 0, 1)});
  EXPECT_TRUE(finish_scene(s).ok());
  return s;
}

inline std::string scene_with_vertex(const std::string& coord) {
  return R"({"format":"visgate-scene","version":1,"meshes":[{"vertices":[[0,0,1],[1,0,1],[0,)" + coord +
         R"(,1]],"triangles":[[0,1,2]]}],"lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]],"samples":4}],"receivers":[{"p":[0,0,0],"n":[0,0,1]}]})";
}

inline std::filesystem::path temp_dir() {
  std::filesystem::path d = std::filesystem::temp_directory_path() / ("visgate_scene_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

// Writes `text` to d/name and checks that reading it fails with a message holding
// "name: message" (the file, then the line and element).
inline void expect_read_error(const std::filesystem::path& d, const std::string& name, const std::string& text, const std::string& message) {
  SCOPED_TRACE(name + ": " + text);
  std::ofstream(d / name, std::ios::binary) << text;
  auto r = read_polygon_file((d / name).string());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find(name + ": " + message), std::string::npos) << r.error().message;
}


}  // namespace visgate::test_support
