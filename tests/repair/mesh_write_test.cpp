// lib/repair/mesh_write.cpp: every format written and read back with the importer, bit for
// bit.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "tests/support/repair_fixtures.h"
#include "lib/scene/rng.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

namespace {

IndexedMesh random_float_mesh(uint64_t seed) {
  IndexedMesh m;
  Rng rng(seed);
  for (int i = 0; i < 200; ++i) {
    auto coord = [&]() {
      double scale = std::ldexp(1.0, int(rng.below(80)) - 40);
      float f = float((rng.uniform() - 0.5) * scale);
      return double(f);
    };
    m.vertices.push_back({coord(), coord(), coord()});
  }
  m.vertices[0] = {-0.0, double(1e-38f), double(3.4e38f)};  // negative zero, tiny and huge floats
  m.vertices[1] = {double(0x1p-149f), -double(0x1.fffffep+127f), 0.1f};
  for (uint32_t i = 0; i + 2 < 200; ++i) m.triangles.push_back({i, i + 1, i + 2});
  return m;
}

void expect_same_triangles(const IndexedMesh& m, const PolygonSoup& back, bool by_index) {
  ASSERT_EQ(back.faces.size(), m.triangles.size());
  if (by_index) {
    ASSERT_EQ(back.vertices.size(), m.vertices.size());
  }
  for (size_t t = 0; t < m.triangles.size(); ++t) {
    ASSERT_EQ(back.faces[t].size(), 3u);
    for (int k = 0; k < 3; ++k) {
      const Vec3d& want = m.vertices[m.triangles[t][size_t(k)]];
      const Vec3d& got = back.vertices[back.faces[t][size_t(k)]];
      for (int a = 0; a < 3; ++a) {
        uint64_t wb, gb;
        std::memcpy(&wb, &want[a], 8);
        std::memcpy(&gb, &got[a], 8);
        EXPECT_EQ(wb, gb) << "triangle " << t << " corner " << k << " axis " << a;
      }
      if (by_index) {
        EXPECT_EQ(back.faces[t][size_t(k)], m.triangles[t][size_t(k)]);
      }
    }
  }
}

}  // namespace

TEST(RepairRoundTrip, FloatCoordinatesBitExactInEveryFormat) {
  auto dir = temp_dir();
  IndexedMesh m = random_float_mesh(7);
  struct Case { const char* name; MeshFormat f; bool by_index; };
  for (const Case& c : {Case{"m.obj", MeshFormat::Obj, true}, Case{"m.off", MeshFormat::Off, true},
                        Case{"m.ply", MeshFormat::Ply, true}, Case{"m.stl", MeshFormat::StlBinary, false},
                        Case{"a.stl", MeshFormat::StlAscii, false}}) {
    std::string path = (dir / c.name).string();
    ASSERT_TRUE(write_mesh_file(m, c.f, path).ok()) << c.name;
    auto back = read_polygon_file(path);
    ASSERT_TRUE(back.ok()) << c.name << ": " << back.error().message;
    SCOPED_TRACE(c.name);
    expect_same_triangles(m, *back, c.by_index);
  }
  std::filesystem::remove_all(dir);
}

// Double data is written with 17 digits and a "double" PLY property. The importer
// (OpenMesh's PLY reader) hands PLY coordinates over as float, so this test reads the
// text back with strtod itself.
TEST(RepairRoundTrip, DoubleCoordinatesBitExactInPlyText) {
  auto dir = temp_dir();
  IndexedMesh m = random_float_mesh(9);
  Rng rng(3);
  for (auto& v : m.vertices) v = v + Vec3d(rng.uniform() * 1e-9, 0.1, 1.0 / 3.0);  // not floats any more
  m.double_precision = true;
  std::string path = (dir / "d.ply").string();
  ASSERT_TRUE(write_mesh_file(m, MeshFormat::Ply, path).ok());
  std::ifstream in(path);
  std::string line;
  PolygonSoup back;
  bool header = true;
  while (std::getline(in, line)) {
    if (header) {
      if (line == "property double x") back.double_precision = true;
      header = line != "end_header";
      continue;
    }
    std::istringstream ls(line);
    if (back.vertices.size() < m.vertices.size()) {
      std::string a, b, c;
      ls >> a >> b >> c;
      back.vertices.push_back({std::strtod(a.c_str(), nullptr), std::strtod(b.c_str(), nullptr),
                               std::strtod(c.c_str(), nullptr)});
    } else {
      uint32_t n, x, y, z;
      ls >> n >> x >> y >> z;
      EXPECT_EQ(n, 3u);
      back.faces.push_back({x, y, z});
    }
  }
  EXPECT_TRUE(back.double_precision);
  expect_same_triangles(m, back, true);
  // Binary STL cannot hold them: refused, nothing written.
  std::string stl = (dir / "d.stl").string();
  EXPECT_FALSE(write_mesh_file(m, MeshFormat::StlBinary, stl).ok());
  EXPECT_FALSE(std::filesystem::exists(stl));
  std::filesystem::remove_all(dir);
}

// Repair output written and read back, then repaired again: nothing changes (idempotent).
TEST(RepairRoundTrip, RepairedMeshReadsBackAndIsAFixedPoint) {
  auto dir = temp_dir();
  PolygonSoup s = tet();
  for (auto& f : s.faces) std::swap(f[1], f[2]);
  RepairResult r = run(s);
  std::string path = (dir / "t.obj").string();
  ASSERT_TRUE(write_mesh_file(r.output, MeshFormat::Obj, path).ok());
  auto back = read_polygon_file(path);
  ASSERT_TRUE(back.ok());
  RepairResult again = run(*back);
  expect_defects(again.before.defects, {}, "re-read");
  EXPECT_EQ(again.output.triangles, r.output.triangles);
  EXPECT_EQ(again.output.vertices, r.output.vertices);
  std::filesystem::remove_all(dir);
}
