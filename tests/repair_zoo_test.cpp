// `visgate repair` on the defects of issue 36, each built here with its expected outcome
// worked out by hand (volumes, counts) or checked by a property (idempotence: repairing
// the output changes nothing; `--check` of the output agrees with the report's "after"
// counts): hollow solids and nested or touching shells, hole filling next to other
// geometry, T-junction splits, repeated vertex cycles, byte-order marks, Blender-style
// PLY headers, files without faces, shortest float output and --in-place on links. The
// OpenSCAD regression meshes (tools/fetch-openscad-data.sh) run when fetched.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "lib/mesh/mesh_write.h"
#include "lib/mesh/repair.h"
#include "lib/mesh/repair_input.h"
#include "lib/mesh/repair_report.h"
#include "lib/scene/mesh_io.h"
#include "oracle/exact_predicates.h"

using namespace visgate;
using namespace visgate::mesh;
namespace fs = std::filesystem;

namespace {

const oracle::CgalExactPredicates kEx;

RepairResult run(const PolygonSoup& s, RepairOptions o = {}) {
  auto r = repair_mesh(s, o, kEx);
  EXPECT_TRUE(r.ok()) << (r.ok() ? "" : r.error().message);
  return r.ok() ? std::move(*r) : RepairResult{};
}

// Axis-aligned box [lo, hi] as 12 triangles, outward (or inward with `inward`), its
// vertices appended to `s`.
void add_box(PolygonSoup& s, Vec3d lo, Vec3d hi, bool inward = false) {
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
double volume(const IndexedMesh& m) {
  double v = 0;
  for (const auto& t : m.triangles) {
    const Vec3d &a = m.vertices[t[0]], &b = m.vertices[t[1]], &c = m.vertices[t[2]];
    v += dot(a, cross(b, c));
  }
  return v / 6;
}

IndexedMesh as_indexed(const PolygonSoup& s) {
  IndexedMesh m;
  m.vertices = s.vertices;
  for (const auto& f : s.faces) m.triangles.push_back({f[0], f[1], f[2]});
  return m;
}

PolygonSoup as_soup(const IndexedMesh& m) {
  PolygonSoup s;
  s.vertices = m.vertices;
  for (const auto& t : m.triangles) s.faces.push_back({t[0], t[1], t[2]});
  s.double_precision = m.double_precision;
  return s;
}

}  // namespace

// ------------------------------------------------------------------------------------
// Issue 36 defect 1: cavities. A 4-cube holding a 2-cube void bounds 64 - 8 = 56.

TEST(RepairNesting, InwardCavityIsKeptAndClean) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  add_box(s, {1, 1, 1}, {3, 3, 3}, /*inward=*/true);
  EXPECT_EQ(volume(as_indexed(s)), 56.0);
  RepairResult r = run(s);
  EXPECT_EQ(r.before.defects.inward_components, 0u);
  EXPECT_EQ(r.before.cavities, 1u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 56.0);
}

TEST(RepairNesting, OutwardCavityIsTurnedInward) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  add_box(s, {1, 1, 1}, {3, 3, 3});
  RepairResult r = run(s);
  EXPECT_EQ(r.before.defects.inward_components, 1u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 56.0);
  // Both shells inside out: the solid is still the hollow cube.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4}, true);
  add_box(t, {1, 1, 1}, {3, 3, 3});
  RepairResult u = run(t);
  EXPECT_EQ(u.before.defects.inward_components, 2u);
  EXPECT_EQ(u.after.defects.total(), 0u);
  EXPECT_EQ(volume(u.output), 56.0);
}

// An island in the void: depth 2 faces outward again, 216 - 64 + 8 = 160; two side by
// side cavities, 216 - 8 - 8 = 200. Every shell here is listed first with the wrong
// sense.
TEST(RepairNesting, IslandInACavityAndSiblingCavities) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {6, 6, 6}, true);
  add_box(s, {1, 1, 1}, {5, 5, 5});
  add_box(s, {2, 2, 2}, {4, 4, 4}, true);
  RepairResult r = run(s);
  EXPECT_EQ(r.before.defects.inward_components, 3u);
  EXPECT_EQ(r.after.cavities, 1u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 160.0);
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {6, 6, 6});
  add_box(t, {1, 1, 1}, {3, 3, 3});
  add_box(t, {3.5, 1, 1}, {5.5, 3, 3});
  RepairResult u = run(t);
  EXPECT_EQ(u.after.cavities, 2u);
  EXPECT_EQ(u.after.defects.total(), 0u);
  EXPECT_EQ(volume(u.output), 200.0);
  // Two separate solids are not cavities of each other, though one box holds the other's.
  PolygonSoup w;
  add_box(w, {0, 0, 0}, {1, 1, 1}, true);
  add_box(w, {2, 0, 0}, {3, 1, 1}, true);
  RepairResult x = run(w);
  EXPECT_EQ(x.after.cavities, 0u);
  EXPECT_EQ(volume(x.output), 2.0);
}

// Touching shells: an octahedral void whose lowest vertex lies on the cube's floor (the
// parity test must not start at that vertex) and a void whose face lies in the plane of
// the outer shell's faces along the ray. Octahedron of radius 1: volume 4/3.
TEST(RepairNesting, TouchingShellsAndRaysThroughEdges) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  const uint32_t b = uint32_t(s.vertices.size());
  s.vertices.insert(s.vertices.end(), {{2, 2, 0}, {2, 2, 2}, {1, 2, 1}, {3, 2, 1}, {2, 1, 1}, {2, 3, 1}});
  // Outward octahedron (bottom 0, top 1, -x 2, +x 3, -y 4, +y 5), listed outward: the
  // cavity must be turned.
  const uint32_t f[8][3] = {{0, 3, 4}, {0, 5, 3}, {0, 2, 5}, {0, 4, 2}, {1, 4, 3}, {1, 3, 5}, {1, 5, 2}, {1, 2, 4}};
  for (const auto& t : f) s.faces.push_back({b + t[0], b + t[1], b + t[2]});
  EXPECT_EQ(volume(as_indexed(s)), 64.0 + 4.0 / 3.0);
  RepairResult r = run(s);
  EXPECT_EQ(r.after.cavities, 1u);
  EXPECT_EQ(r.after.defects.inward_components, 0u);
  EXPECT_NEAR(volume(r.output), 64.0 - 4.0 / 3.0, 1e-12);
  // The vertex on the floor is a contact: reported as a self-intersection, not hidden.
  EXPECT_GT(r.after.defects.self_intersections, 0u);
  // A void at the same height as the outer cube's vertices and edges: the +x ray from
  // each of its vertices runs through the outer shell's edges and vertices.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4});
  add_box(t, {1, 0.5, 0.5}, {3, 4 - 0.5, 4 - 0.5});
  // The +x ray from (1, 0.5, 0.5) crosses the diagonal of the +x face's triangles only
  // if those run through (y, z) = (0.5, 0.5); the box's diagonals (0,0)-(4,4) do.
  RepairResult u = run(t);
  EXPECT_EQ(u.after.cavities, 1u);
  EXPECT_EQ(u.after.defects.total(), 0u);
  EXPECT_EQ(volume(u.output), 64.0 - 2 * 3 * 3);
}

// ------------------------------------------------------------------------------------
// Idempotence as a property: repair of the written output is byte-identical, and
// `--check` of the output (the analysis of the file read back) agrees with the report's
// "after" counts.

namespace {

fs::path temp_dir() {
  static fs::path d = [] {
    fs::path p = fs::temp_directory_path() / ("visgate-repair-zoo-" + std::to_string(::getpid()));
    fs::create_directories(p);
    return p;
  }();
  return d;
}

void write_text(const fs::path& p, const std::string& s) {
  std::ofstream out(p, std::ios::binary);
  out << s;
}
std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Repairs `s`, writes OBJ, reads it back, repairs again: the bytes must not change and
// the check of the written file must report the first run's "after" counts.
void expect_idempotent(const PolygonSoup& s, const RepairOptions& o, const std::string& what) {
  RepairResult r1 = run(s, o);
  auto b1 = encode_mesh(r1.output, MeshFormat::Obj, "x.obj");
  ASSERT_TRUE(b1.ok()) << what;
  const fs::path p = temp_dir() / "idem.obj";
  write_text(p, *b1);
  auto back = read_polygon_file(p.string());
  ASSERT_TRUE(back.ok()) << what << ": " << back.error().message;
  if (back->faces.empty()) return;  // everything removed: nothing to read back
  RepairResult r2 = run(*back, o);
  auto b2 = encode_mesh(r2.output, MeshFormat::Obj, "x.obj");
  ASSERT_TRUE(b2.ok());
  EXPECT_EQ(*b1, *b2) << what << ": repair(repair(x)) != repair(x)";
  RepairOptions check = o;
  check.check_only = true;
  check.fill_holes = 0;
  RepairResult c = run(*back, check);
  const auto after = r1.after.defects.items(), checked = c.before.defects.items();
  for (size_t i = 0; i < after.size(); ++i)
    EXPECT_EQ(after[i].second, checked[i].second) << what << ": --check of the output disagrees on " << after[i].first;
}

}  // namespace

// Issue 36 defect 4: the split of (a, b, c) at p on ab yields (a, p, c), a copy (in the
// opposite sense) of a face already there; the copy goes and a second run changes
// nothing.
TEST(RepairTJunction, SplitDoesNotLeaveADuplicateFace) {
  PolygonSoup s;
  s.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {1, 0, 0}};  // a, b, c, p (p inside ab)
  s.faces = {{0, 1, 2}, {0, 2, 3}};
  RepairResult r = run(s);
  EXPECT_EQ(r.before.defects.t_junctions, 1u);
  EXPECT_EQ(r.after.defects.duplicate_faces + r.after.defects.opposite_duplicate_faces, 0u);
  EXPECT_EQ(r.after.defects.t_junctions, 0u);
  expect_idempotent(s, {}, "t-junction duplicate");
  // The same inside a closed mesh: a tetrahedron whose base is split at a point of an
  // edge only on one side, with an extra copy of one half.
  PolygonSoup t;
  t.vertices = {{0, 0, 0}, {2, 0, 0}, {0, 2, 0}, {0, 0, 2}, {1, 0, 0}};
  t.faces = {{0, 2, 1}, {0, 4, 3}, {4, 1, 3}, {0, 3, 2}, {1, 2, 3}, {0, 2, 4}};
  RepairResult u = run(t);
  EXPECT_EQ(u.after.defects.duplicate_faces + u.after.defects.opposite_duplicate_faces, 0u);
  expect_idempotent(t, {}, "closed t-junction duplicate");
}
