// Fixtures the repair tests share (tests/repair/*_test.cpp): the exact predicates, small
// meshes with hand-derived properties (tetrahedron, unit cube, boxes), report helpers,
// files in a per-test folder, the idempotence property and the CLI run as a process.
//
// Files go to a folder per test under one per-process folder, removed when the process
// ends; with VISGATE_TEST_KEEP_FILES set they stay (to run other binaries on them).
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "lib/repair/cgal_predicates.h"
#include "lib/repair/mesh_write.h"
#include "lib/repair/repair.h"
#include "lib/repair/repair_input.h"
#include "lib/scene/mesh_io.h"
#include "lib/scene/shapes.h"

namespace visgate::test {

inline const mesh::CgalExactPredicates kEx;

inline PolygonSoup make_soup(std::vector<Vec3d> v, std::vector<std::vector<uint32_t>> f) {
  PolygonSoup s;
  s.vertices = std::move(v);
  s.faces = std::move(f);
  return s;
}

inline mesh::RepairResult run(const PolygonSoup& s, mesh::RepairOptions o = {}) {
  auto r = mesh::repair_mesh(s, o, kEx);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(*r) : mesh::RepairResult{};
}

// Expected defect counts: every field not named is zero.
inline void expect_defects(const mesh::DefectCounts& got, const std::vector<std::pair<std::string, size_t>>& nonzero,
                           const char* when) {
  for (const auto& [name, n] : got.items()) {
    size_t want = 0;
    for (const auto& [k, v] : nonzero)
      if (k == name) want = v;
    EXPECT_EQ(n, want) << when << ": " << name;
  }
}

// The count `key` of step `step` in the report.
inline size_t step_change(const mesh::RepairResult& r, const std::string& step, const std::string& key) {
  for (const auto& s : r.steps)
    if (s.name == step)
      for (const auto& [k, v] : s.changes)
        if (k == key) return v;
  ADD_FAILURE() << "no step " << step << " / " << key;
  return 0;
}

// The removal records, in order: (input face, reason).
inline void expect_removed(const mesh::RepairResult& r, const std::vector<std::pair<uint32_t, std::string>>& want) {
  ASSERT_EQ(r.removed.size(), want.size());
  for (size_t i = 0; i < want.size(); ++i) {
    EXPECT_EQ(r.removed[i].face, want[i].first) << "record " << i;
    EXPECT_EQ(r.removed[i].reason, want[i].second) << "record " << i;
  }
}

// A double `k` ulps from x.
inline double ulps(double x, int k) {
  for (; k > 0; --k) x = std::nextafter(x, INFINITY);
  for (; k < 0; ++k) x = std::nextafter(x, -INFINITY);
  return x;
}

// Tetrahedron A(0,0,0) B(1,0,0) C(0,1,0) D(0,0,1) with outward faces (normals -z, -y, -x
// and (1,1,1)).
inline const Vec3d kA(0, 0, 0), kB(1, 0, 0), kC(0, 1, 0), kD(0, 0, 1);
inline std::vector<std::vector<uint32_t>> tet_faces() { return {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}; }
inline PolygonSoup tet() { return make_soup({kA, kB, kC, kD}, tet_faces()); }
// The same tetrahedron as an OBJ file.
inline const char* const kTetObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

// Unit cube, outward, as shapes::add_box builds it (8 corners, 12 triangles).
inline PolygonSoup cube() {
  TriangleSoup t;
  shapes::add_box(t, Vec3d(0, 0, 0), Vec3d(1, 1, 1));
  PolygonSoup s;
  for (const auto& v : t.vertices) s.vertices.push_back(Vec3d(v));
  for (const auto& f : t.triangles) s.faces.push_back({f[0], f[1], f[2]});
  return s;
}

// Axis-aligned box [lo, hi] as 12 triangles, outward (or inward with `inward`), its
// vertices appended to `s`.
inline void add_box(PolygonSoup& s, Vec3d lo, Vec3d hi, bool inward = false) {
  const uint32_t b = uint32_t(s.vertices.size());
  for (int i = 0; i < 8; ++i)
    s.vertices.push_back(Vec3d(i & 1 ? hi.x : lo.x, i & 2 ? hi.y : lo.y, i & 4 ? hi.z : lo.z));
  // Quads with outward normals: -x, +x, -y, +y, -z, +z.
  const uint32_t q[6][4] = {{0, 4, 6, 2}, {1, 3, 7, 5}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 2, 3, 1}, {4, 5, 7, 6}};
  for (const auto& f : q) {
    std::vector<uint32_t> t1{b + f[0], b + f[1], b + f[2]}, t2{b + f[0], b + f[2], b + f[3]};
    if (inward) {
      std::swap(t1[1], t1[2]);
      std::swap(t2[1], t2[2]);
    }
    s.faces.push_back(t1);
    s.faces.push_back(t2);
  }
}

// Signed volume, exact for the small integer and half-integer coordinates used here.
inline double volume(const mesh::IndexedMesh& m) {
  double v = 0;
  for (const auto& t : m.triangles) {
    const Vec3d &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    v += dot(a, cross(b, c));
  }
  return v / 6;
}

inline mesh::IndexedMesh as_indexed(const PolygonSoup& s) {
  mesh::IndexedMesh m;
  m.vertices = s.vertices;
  for (const auto& f : s.faces) m.triangles.push_back({f[0], f[1], f[2]});
  return m;
}

// The folder of the running test (created on first use).
inline std::filesystem::path temp_dir() {
  namespace fs = std::filesystem;
  struct Dir {
    fs::path p = fs::temp_directory_path() / ("visgate-repair-test-" + std::to_string(::getpid()));
    ~Dir() {
      std::error_code ec;
      if (!std::getenv("VISGATE_TEST_KEEP_FILES")) fs::remove_all(p, ec);
    }
  };
  static const Dir d;
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  const fs::path p = info ? d.p / (std::string(info->test_suite_name()) + "." + info->name()) : d.p;
  fs::create_directories(p);
  return p;
}

inline void write_text(const std::filesystem::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}
// Writes `bytes` to file `name` in the test's folder; its path.
inline std::string write_file(const std::string& name, const std::string& bytes) {
  const std::filesystem::path p = temp_dir() / name;
  write_text(p, bytes);
  return p.string();
}
inline std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Idempotence as a property: repairs `s`, writes OBJ, reads it back as the CLI reads
// (the audit restores double coordinates), repairs again: the bytes must not change, and
// `--check` of the written file must report the first run's "after" counts.
inline void expect_idempotent(const PolygonSoup& s, const mesh::RepairOptions& o, const std::string& what) {
  mesh::RepairResult r1 = run(s, o);
  auto b1 = mesh::encode_mesh(r1.output, mesh::MeshFormat::Obj, "x.obj");
  ASSERT_TRUE(b1.ok()) << what;
  const std::filesystem::path p = temp_dir() / "idem.obj";
  write_text(p, *b1);
  auto back = read_polygon_file(p.string());
  ASSERT_TRUE(back.ok()) << what << ": " << back.error().message;
  ASSERT_TRUE(mesh::audit_input(p.string(), *b1, *back).ok()) << what;
  if (back->faces.empty()) return;  // everything removed: nothing to read back
  mesh::RepairResult r2 = run(*back, o);
  auto b2 = mesh::encode_mesh(r2.output, mesh::MeshFormat::Obj, "x.obj");
  ASSERT_TRUE(b2.ok());
  EXPECT_EQ(*b1, *b2) << what << ": repair(repair(x)) != repair(x)";
  mesh::RepairOptions check = o;
  check.check_only = true;
  check.fill_holes = 0;
  mesh::RepairResult c = run(*back, check);
  const auto after = r1.after.defects.items(), checked = c.before.defects.items();
  for (size_t i = 0; i < after.size(); ++i)
    EXPECT_EQ(after[i].second, checked[i].second) << what << ": --check of the output disagrees on " << after[i].first;
}

#ifdef VISGATE_BIN
// `visgate ARGS` (VISGATE_BIN is the built binary) with stderr in *err; its exit code.
inline int run_cli(const std::string& args, std::string* err = nullptr) {
  const std::filesystem::path e = temp_dir() / "stderr.txt";
  const std::string cmd = std::string(VISGATE_BIN) + " " + args + " 2>" + e.string();
  const int rc = std::system(cmd.c_str());
  if (err) *err = read_all(e);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}
#endif

}  // namespace visgate::test
