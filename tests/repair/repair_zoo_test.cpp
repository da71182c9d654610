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

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

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


void expect_idempotent(const PolygonSoup& s, const RepairOptions& o, const std::string& what);

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
  expect_idempotent(s, {}, "inward cavity");
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
  expect_idempotent(s, {}, "outward cavity");
  expect_idempotent(t, {}, "both shells inside out");
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
  expect_idempotent(s, {}, "island in a cavity");
  expect_idempotent(t, {}, "sibling cavities");
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
  expect_idempotent(s, {}, "touching octahedral void");
  expect_idempotent(t, {}, "void level with the outer edges");
  // Shells that cross (a cube half inside another): whatever orientation the parity of
  // one vertex gives, a second run must not change it.
  PolygonSoup c;
  add_box(c, {0, 0, 0}, {4, 4, 4});
  add_box(c, {2, 1, 1}, {6, 3, 3}, true);
  expect_idempotent(c, {}, "crossing shells");
}

// The nesting cases generated far from the origin and at extreme scales: every
// coordinate is c * 2^k + offset, exact in double, so each outcome is the hand-worked one
// (volumes 56, 160 and 200 in units of 2^3k, measured after moving back to the origin).
TEST(RepairNesting, GeneratedCasesFarFromOriginAndAtExtremeScales) {
  struct Case {
    const char* name;
    std::vector<std::tuple<Vec3d, Vec3d, bool>> boxes;  // lo, hi, inward
    size_t cavities;
    double volume;
  };
  const std::vector<Case> cases = {
      {"hollow", {{{0, 0, 0}, {4, 4, 4}, true}, {{1, 1, 1}, {3, 3, 3}, false}}, 1, 56},
      {"island", {{{0, 0, 0}, {6, 6, 6}, false}, {{1, 1, 1}, {5, 5, 5}, false}, {{2, 2, 2}, {4, 4, 4}, true}}, 1, 160},
      {"siblings", {{{0, 0, 0}, {6, 6, 6}, true}, {{1, 1, 1}, {3, 3, 3}, false}, {{3.5, 1, 1}, {5.5, 3, 3}, true}}, 2, 200},
  };
  for (const Case& c : cases)
    for (int k : {-60, 0, 60})
      for (double offset : {0.0, 0x1p30, -0x1p45}) {
        const double scale = std::ldexp(1.0, k), off = offset * scale;
        PolygonSoup s;
        for (const auto& [lo, hi, inward] : c.boxes) add_box(s, lo * scale + Vec3d(off, off, off), hi * scale + Vec3d(off, off, off), inward);
        const std::string what = std::string(c.name) + " scale 2^" + std::to_string(k) + " offset " + std::to_string(offset);
        RepairResult r = run(s);
        EXPECT_EQ(r.after.cavities, c.cavities) << what;
        EXPECT_EQ(r.after.defects.total(), 0u) << what;
        IndexedMesh m = r.output;
        for (Vec3d& v : m.vertices) v = (v - Vec3d(off, off, off)) / scale;  // exact: inverse of the above
        EXPECT_EQ(volume(m), c.volume) << what;
        expect_idempotent(s, {}, what);
      }
}

// ------------------------------------------------------------------------------------
// Idempotence as a property: repair of the written output is byte-identical, and
// `--check` of the output (the analysis of the file read back) agrees with the report's
// "after" counts.

namespace {

// One folder per test process, removed when the process ends.
fs::path temp_dir() {
  struct Dir {
    fs::path p = fs::temp_directory_path() / ("visgate-repair-zoo-" + std::to_string(::getpid()));
    Dir() { fs::create_directories(p); }
    ~Dir() {
      std::error_code ec;
      fs::remove_all(p, ec);
    }
  };
  static const Dir d;
  return d.p;
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
  // Read back as the CLI reads: the audit restores double coordinates.
  auto back = read_polygon_file(p.string());
  ASSERT_TRUE(back.ok()) << what << ": " << back.error().message;
  ASSERT_TRUE(audit_input(p.string(), *b1, *back).ok()) << what;
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

// ------------------------------------------------------------------------------------
// Issue 36 defects 2 and 3: hole filling is checked exactly, and orientation runs after.

namespace {

const HoleRecord* only_hole(const RepairResult& r) {
  EXPECT_EQ(r.holes.size(), 1u);
  return r.holes.empty() ? nullptr : &r.holes[0];
}

// Open tube of `n` segments, radius 1, from z = 0 to z = 1, with a bottom cap (a fan
// around the centre) when `cap`; sides outward.
PolygonSoup tube(uint32_t n, bool cap) {
  PolygonSoup s;
  for (uint32_t i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    s.vertices.push_back({std::cos(a), std::sin(a), 0});
    s.vertices.push_back({std::cos(a), std::sin(a), 1});
  }
  for (uint32_t i = 0; i < n; ++i) {
    const uint32_t j = (i + 1) % n;
    s.faces.push_back({2 * i, 2 * j, 2 * j + 1});
    s.faces.push_back({2 * i, 2 * j + 1, 2 * i + 1});
  }
  if (cap) {
    s.vertices.push_back({0, 0, 0});
    const uint32_t c = 2 * n;
    for (uint32_t i = 0; i < n; ++i) s.faces.push_back({c, 2 * ((i + 1) % n), 2 * i});
  }
  return s;
}

}  // namespace

TEST(RepairFill, SingleTriangleIsNotClosedByItsOwnCopy) {
  PolygonSoup s;
  s.vertices = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  s.faces = {{0, 1, 2}};
  RepairOptions o;
  o.fill_holes = 10;
  RepairResult r = run(s, o);
  const HoleRecord* h = only_hole(r);
  ASSERT_TRUE(h);
  EXPECT_FALSE(h->filled);
  EXPECT_STREQ(h->reason, "opposite_duplicate_face");
  EXPECT_EQ(r.output.triangles.size(), 1u);
  EXPECT_EQ(r.after.defects.boundary_loops, 1u);
  EXPECT_EQ(r.after.defects.opposite_duplicate_faces, 0u);
  expect_idempotent(s, o, "single triangle");
}

// A flat 4 x 4 sheet: any fill of its 16-edge rim lies on the sheet.
TEST(RepairFill, FlatSheetIsNotCoveredByASecondLayer) {
  PolygonSoup s;
  for (int y = 0; y <= 4; ++y)
    for (int x = 0; x <= 4; ++x) s.vertices.push_back({double(x), double(y), 0});
  for (uint32_t y = 0; y < 4; ++y)
    for (uint32_t x = 0; x < 4; ++x) {
      const uint32_t a = 5 * y + x;
      s.faces.push_back({a, a + 1, a + 6});
      s.faces.push_back({a, a + 6, a + 5});
    }
  RepairOptions o;
  o.fill_holes = 100;
  RepairResult r = run(s, o);
  const HoleRecord* h = only_hole(r);
  ASSERT_TRUE(h);
  EXPECT_EQ(h->edges, 16u);
  EXPECT_FALSE(h->filled);
  EXPECT_EQ(r.output.triangles.size(), 32u);
  EXPECT_EQ(r.after.defects.self_intersections, 0u);
  expect_idempotent(s, o, "flat sheet");
}

// A cylinder with one 136-edge rim: the minimum-area fill is a valid cap; the closed
// result faces outward, with the volume of the prism over the 136-gon.
TEST(RepairFill, LongRimOfACylinderIsCappedCleanly) {
  const uint32_t n = 136;
  PolygonSoup s = tube(n, true);
  RepairOptions o;
  o.fill_holes = 200;
  RepairResult r = run(s, o);
  const HoleRecord* h = only_hole(r);
  ASSERT_TRUE(h);
  EXPECT_TRUE(h->filled) << (h->reason ? h->reason : "");
  EXPECT_EQ(h->triangles, n - 2);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_NEAR(volume(r.output), 0.5 * n * std::sin(2 * M_PI / n), 1e-9);
  expect_idempotent(s, o, "capped cylinder");
}

// A hole next to other geometry: a tetrahedron pokes out of the cube through the hole,
// so a cap would cut it. The loop stays open and no intersection is created.
TEST(RepairFill, FillThatWouldCutNearbyGeometryIsRefused) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  s.faces.erase(s.faces.end() - 2, s.faces.end());  // the +z side
  const uint32_t b = uint32_t(s.vertices.size());
  s.vertices.insert(s.vertices.end(), {{1, 1, 2}, {3, 1, 2}, {2, 3, 2}, {2, 2, 5}});
  const uint32_t f[4][3] = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {2, 0, 3}};
  for (const auto& t : f) s.faces.push_back({b + t[0], b + t[1], b + t[2]});
  RepairOptions o;
  o.fill_holes = 4;
  RepairResult r = run(s, o);
  const HoleRecord* h = only_hole(r);
  ASSERT_TRUE(h);
  EXPECT_FALSE(h->filled);
  EXPECT_STREQ(h->reason, "self_intersection");
  EXPECT_EQ(r.after.defects.self_intersections, 0u);
  EXPECT_EQ(r.after.defects.boundary_loops, 1u);
  expect_idempotent(s, o, "hole next to a tetrahedron");
}

// Two holes that meet at a vertex form one boundary walk through it twice: they are
// filled as two holes. (The cube loses triangle (0, 4, 6) of its -x side and (4, 5, 7)
// of its +z side; the boundary walk runs 0 4 5 7 4 6.)
TEST(RepairFill, HolesMeetingAtAVertexAreFilledApart) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {1, 1, 1});
  s.faces.erase(s.faces.begin() + 10);
  s.faces.erase(s.faces.begin());
  EXPECT_EQ(run(s).before.boundary_loops.size(), 1u);
  RepairOptions o;
  o.fill_holes = 8;
  RepairResult r = run(s, o);
  EXPECT_EQ(r.holes.size(), 2u);
  for (const HoleRecord& h : r.holes) EXPECT_TRUE(h.filled) << (h.reason ? h.reason : "");
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 1.0);
  expect_idempotent(s, o, "holes meeting at a vertex");
}

// Defect 3: an inside-out open box is closed by filling and must then face outward.
TEST(RepairFill, ComponentsClosedByFillingAreOrientedAfterwards) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {1, 1, 1}, /*inward=*/true);
  s.faces.erase(s.faces.end() - 2, s.faces.end());
  RepairOptions o;
  o.fill_holes = 4;
  RepairResult r = run(s, o);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 1.0);
  // And a hollow one: the cavity's open box is filled, then turned inward.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4});
  add_box(t, {1, 1, 1}, {3, 3, 3});
  t.faces.erase(t.faces.end() - 2, t.faces.end());
  RepairResult u = run(t, o);
  EXPECT_EQ(u.after.defects.total(), 0u);
  EXPECT_EQ(volume(u.output), 56.0);
  expect_idempotent(t, o, "hollow box filled");
}

// ------------------------------------------------------------------------------------
// Input handling through the CLI (defects 5 to 9), run as a process.

namespace {

int run_cli(const std::string& args, std::string* err = nullptr) {
  const fs::path e = temp_dir() / "stderr.txt";
  const std::string cmd = std::string(VISGATE_BIN) + " " + args + " 2>" + e.string();
  const int rc = std::system(cmd.c_str());
  if (err) *err = read_all(e);
  return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
}

const char* kTetObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

std::string utf16(const std::string& ascii, bool little_endian) {
  std::string out = little_endian ? std::string("\xFF\xFE", 2) : std::string("\xFE\xFF", 2);
  for (char c : ascii) {
    if (little_endian) { out.push_back(c); out.push_back('\0'); }
    else { out.push_back('\0'); out.push_back(c); }
  }
  return out;
}

}  // namespace

// Defect 5: a file that yields no face is bad input (exit 2, nothing written), whatever
// its format.
TEST(RepairInputFiles, NoFacesIsExitTwoInEveryFormat) {
  const std::vector<std::pair<std::string, std::string>> files = {
      {"empty.obj", ""},
      {"empty.off", ""},
      {"empty.ply", ""},
      {"empty.stl", ""},
      {"points.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n"},
      {"lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\n"},
      {"points.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n"},
      {"points.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                     "end_header\n0 0 0\n1 0 0\n0 1 0\n"},
      {"edges.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2 0 1\n"},
      {"empty_solid.stl", "solid x\nendsolid x\n"},
  };
  for (const auto& [name, text] : files) {
    write_text(temp_dir() / name, text);
    const fs::path out = temp_dir() / "nofaces_out.obj";
    std::string err;
    EXPECT_EQ(run_cli("repair " + (temp_dir() / name).string() + " -o " + out.string(), &err), 2) << name << ": " << err;
    EXPECT_FALSE(fs::exists(out)) << name;
    EXPECT_NE(err.find(name), std::string::npos) << name << ": " << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << name << ": " << err;
    EXPECT_NE(err.find("no faces"), std::string::npos) << name << ": " << err;
  }
}

// Defect 5: byte-order marks. UTF-8 and ASCII-only UTF-16 (both byte orders) read as the
// plain file; UTF-16 with a non-ASCII character is refused by name.
TEST(RepairInputFiles, ByteOrderMarksAreDecodedOrRefusedByName) {
  const fs::path plain = temp_dir() / "plain.obj";
  write_text(plain, kTetObj);
  auto want = read_polygon_file(plain.string());
  ASSERT_TRUE(want.ok());
  const std::vector<std::pair<std::string, std::string>> files = {
      {"bom8.obj", "\xEF\xBB\xBF" + std::string(kTetObj)},
      {"bom16le.obj", utf16(kTetObj, true)},
      {"bom16be.obj", utf16(kTetObj, false)},
      {"bom16.off", utf16("OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", true)},
  };
  for (const auto& [name, text] : files) {
    write_text(temp_dir() / name, text);
    auto got = read_polygon_file((temp_dir() / name).string());
    ASSERT_TRUE(got.ok()) << name << ": " << got.error().message;
    EXPECT_EQ(got->vertices, want->vertices) << name;
    EXPECT_EQ(got->faces, want->faces) << name;
    EXPECT_EQ(run_cli("repair --check " + (temp_dir() / name).string()), 0) << name;
  }
  // "# café" then the tetrahedron: U+00E9 is not ASCII.
  write_text(temp_dir() / "bom16x.obj", utf16(std::string("# caf\xE9\n") + kTetObj, true));
  std::string err;
  EXPECT_EQ(run_cli("repair --check " + (temp_dir() / "bom16x.obj").string(), &err), 2);
  EXPECT_NE(err.find("UTF-16"), std::string::npos) << err;
  EXPECT_NE(err.find("bom16x.obj"), std::string::npos) << err;
}

// Defect 6: `f 1 2 3 4` with its cycle listed 117 times is the quad, once. Six such
// quads make a clean unit cube.
TEST(RepairInputFiles, RepeatedVertexCycleIsCollapsed) {
  std::string obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n";
  const int quads[6][4] = {{1, 4, 3, 2}, {5, 6, 7, 8}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 4, 8, 7}, {4, 1, 5, 8}};
  for (const auto& q : quads) {
    obj += "f";
    for (int k = 0; k < 117; ++k)
      for (int v : q) {
        obj += ' ';
        obj += char('0' + v);
      }
    obj += "\n";
  }
  write_text(temp_dir() / "cycles.obj", obj);
  auto soup = read_polygon_file((temp_dir() / "cycles.obj").string());
  ASSERT_TRUE(soup.ok());
  RepairResult r = run(*soup);
  EXPECT_EQ(r.repeated_cycles_collapsed, 6u);
  EXPECT_EQ(r.output.triangles.size(), 12u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(volume(r.output), 1.0);
  expect_idempotent(*soup, {}, "repeated cycles");
  // Not a repetition: a period that does not divide, or a single cycle, is kept.
  PolygonSoup p;
  p.vertices = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  p.faces = {{0, 1, 2, 3, 0, 1, 2}};
  EXPECT_EQ(run(p).repeated_cycles_collapsed, 0u);
}

// Defect 7: a PLY header line without a keyword (Blender 2.4x) is accepted with a
// warning that names it; a misspelt keyword is still refused.
TEST(RepairInputFiles, UnknownPlyHeaderLineIsAWarning) {
  const std::string ply = "ply\nformat ascii 1.0\nCreated by Blender3D\nelement vertex 4\nproperty float x\n"
                          "property float y\nproperty float z\nelement face 4\nproperty list uchar int vertex_indices\n"
                          "end_header\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  write_text(temp_dir() / "blender.ply", ply);
  auto soup = read_polygon_file((temp_dir() / "blender.ply").string());
  ASSERT_TRUE(soup.ok()) << soup.error().message;
  ASSERT_EQ(soup->warnings.size(), 1u);
  EXPECT_NE(soup->warnings[0].find("line 3"), std::string::npos);
  EXPECT_NE(soup->warnings[0].find("Created by Blender3D"), std::string::npos);
  std::string err;
  EXPECT_EQ(run_cli("repair --check " + (temp_dir() / "blender.ply").string(), &err), 0) << err;
  EXPECT_NE(err.find("warning"), std::string::npos) << err;
  EXPECT_NE(err.find("Created by Blender3D"), std::string::npos) << err;
}

// Files without an extension are read by their content.
TEST(RepairInputFiles, ExtensionlessFilesAreRecognisedByContent) {
  const fs::path plain = temp_dir() / "tet_plain.obj";
  write_text(plain, kTetObj);
  auto want = read_polygon_file(plain.string());
  ASSERT_TRUE(want.ok());
  // The same tetrahedron as OBJ, OFF, PLY, ASCII and binary STL, written by the writer.
  IndexedMesh m;
  m.vertices = want->vertices;
  for (const auto& f : want->faces) m.triangles.push_back({f[0], f[1], f[2]});
  const std::pair<MeshFormat, const char*> formats[] = {{MeshFormat::Obj, "obj"},
                                                        {MeshFormat::Off, "off"},
                                                        {MeshFormat::Ply, "ply"},
                                                        {MeshFormat::StlAscii, "stla"},
                                                        {MeshFormat::StlBinary, "stlb"}};
  for (const auto& [f, name] : formats) {
    auto bytes = encode_mesh(m, f, "x");
    ASSERT_TRUE(bytes.ok());
    const fs::path p = temp_dir() / (std::string("noext_") + name);
    write_text(p, *bytes);
    auto got = read_polygon_file(p.string());
    ASSERT_TRUE(got.ok()) << name << ": " << got.error().message;
    EXPECT_EQ(got->faces.size(), 4u) << name;
    EXPECT_EQ(run_cli("repair --check " + p.string()), 0) << name;
  }
  // --in-place keeps the format the content had (here OFF).
  const fs::path off = temp_dir() / "noext_inplace";
  write_text(off, "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 1 3\n3 0 3 2\n3 1 2 3\n");
  EXPECT_EQ(run_cli("repair --in-place " + off.string()), 0);
  EXPECT_EQ(read_all(off).rfind("OFF\n", 0), 0u) << read_all(off);
  write_text(temp_dir() / "noext_junk", "hello world\n");
  std::string err;
  EXPECT_EQ(run_cli("repair --check " + (temp_dir() / "noext_junk").string(), &err), 2);
  EXPECT_NE(err.find("noext_junk"), std::string::npos) << err;
}

// Defect 8: float coordinates come back as the user wrote them (shortest round trip).
TEST(RepairOutput, FloatCoordinatesKeepTheirShortestDecimals) {
  const std::string in = "v 0.262933 0 0\nv 1 0.1 0\nv 0 1 3.4028235e38\nv 0 0 1e-7\n"
                         "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
  write_text(temp_dir() / "decimals.obj", in);
  const fs::path out = temp_dir() / "decimals_out.obj";
  run_cli("repair " + (temp_dir() / "decimals.obj").string() + " -o " + out.string());
  const std::string text = read_all(out);
  EXPECT_NE(text.find("v 0.262933 0 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("v 1 0.1 0\n"), std::string::npos) << text;
  EXPECT_NE(text.find("3.4028235e+38"), std::string::npos) << text;
  // Every written value reads back to the same float.
  auto a = read_polygon_file((temp_dir() / "decimals.obj").string());
  auto b = read_polygon_file(out.string());
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->vertices, b->vertices);
}

// Defect 9: --in-place keeps the mode, replaces the target of a symbolic link (the link
// stays a link) and warns that other hard links keep the old content.
TEST(RepairInPlace, KeepsModeFollowsLinksAndWarnsAboutHardLinks) {
  const std::string inside_out = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 3 4\n";
  const fs::path f = temp_dir() / "mode.obj";
  write_text(f, inside_out);
  ASSERT_EQ(::chmod(f.c_str(), 0640), 0);
  EXPECT_EQ(run_cli("repair --in-place " + f.string()), 0);
  struct stat st {};
  ASSERT_EQ(::stat(f.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0640u);
  EXPECT_NE(read_all(f), inside_out);

  const fs::path target = temp_dir() / "target.obj", link = temp_dir() / "link.obj";
  write_text(target, inside_out);
  fs::remove(link);
  fs::create_symlink(target, link);
  EXPECT_EQ(run_cli("repair --in-place " + link.string()), 0);
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_NE(read_all(target), inside_out);
  EXPECT_EQ(run_cli("repair --check " + target.string()), 0);

  const fs::path one = temp_dir() / "one.obj", two = temp_dir() / "two.obj";
  write_text(one, inside_out);
  fs::remove(two);
  fs::create_hard_link(one, two);
  std::string err;
  EXPECT_EQ(run_cli("repair --in-place " + one.string(), &err), 0);
  EXPECT_NE(err.find("hard link"), std::string::npos) << err;
  EXPECT_NE(read_all(one), inside_out);
  EXPECT_EQ(read_all(two), inside_out);  // replaced atomically: the other name keeps the old file
}

// ------------------------------------------------------------------------------------
// OpenSCAD's regression meshes (Debian openscad-testing-data, tools/fetch-openscad-data.sh):
// files the reader refuses are bad input; on every other file hole filling adds no
// self-intersection, duplicate or non-manifold edge, repair is idempotent, and the check
// of the output agrees with the report (so exit 0 only where the output checks clean).

namespace {

fs::path openscad_dir() {
  if (const char* e = std::getenv("VISGATE_OPENSCAD_DIR")) return e;
  const char* src = std::getenv("VISGATE_SOURCE_DIR");
  return fs::path(src ? src : VISGATE_TEST_SOURCE_DIR) / ".cache" / "openscad-testing-data" / "stl";
}

}  // namespace

TEST(RepairOpenScad, RegressionMeshesAreRepairedHonestly) {
  const fs::path dir = openscad_dir();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    GTEST_SKIP() << dir << " is absent: run tools/fetch-openscad-data.sh to fetch OpenSCAD's regression meshes";
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir)) files.push_back(e.path());
  std::sort(files.begin(), files.end());
  size_t read = 0, holes_filled = 0;
  std::map<std::string, size_t> open_reasons;
  for (const fs::path& f : files) {
    auto soup = read_polygon_file(f.string());
    if (!soup) {
      EXPECT_EQ(soup.error().message.rfind(f.string() + ": ", 0), 0u) << soup.error().message;
      continue;
    }
    auto plain = repair_mesh(*soup, {}, kEx);
    if (!plain) {
      EXPECT_NE(plain.error().message.find("no faces"), std::string::npos) << f << ": " << plain.error().message;
      continue;
    }
    ++read;
    RepairOptions fill;
    fill.fill_holes = 1000;
    RepairResult filled = run(*soup, fill);
    const DefectCounts &a = plain->after.defects, &b = filled.after.defects;
    EXPECT_LE(b.self_intersections, a.self_intersections) << f;
    EXPECT_LE(b.duplicate_faces + b.opposite_duplicate_faces, a.duplicate_faces + a.opposite_duplicate_faces) << f;
    EXPECT_LE(b.nonmanifold_edges, a.nonmanifold_edges) << f;
    expect_idempotent(*soup, {}, f.filename().string());
    expect_idempotent(*soup, fill, f.filename().string() + " --fill-holes");
    // Holes punched into real geometry (every fifth face removed): fills next to the
    // rest of the part must pass the same checks.
    PolygonSoup punched = *soup;
    punched.faces.clear();
    for (size_t i = 0; i < soup->faces.size(); ++i)
      if (i % 5 != 0) punched.faces.push_back(soup->faces[i]);
    if (punched.faces.empty()) continue;
    RepairResult p0 = run(punched), p1 = run(punched, fill);
    EXPECT_LE(p1.after.defects.self_intersections, p0.after.defects.self_intersections) << f;
    EXPECT_LE(p1.after.defects.duplicate_faces + p1.after.defects.opposite_duplicate_faces,
              p0.after.defects.duplicate_faces + p0.after.defects.opposite_duplicate_faces) << f;
    EXPECT_LE(p1.after.defects.nonmanifold_edges, p0.after.defects.nonmanifold_edges) << f;
    for (const HoleRecord& h : p1.holes) {
      holes_filled += h.filled;
      if (!h.filled) ++open_reasons[h.reason ? h.reason : "?"];
    }
    expect_idempotent(punched, fill, f.filename().string() + " punched --fill-holes");
  }
  std::printf("OpenSCAD meshes: %zu read; punched holes: %zu filled; left open:", read, holes_filled);
  for (const auto& [why, n] : open_reasons) std::printf(" %s=%zu", why.c_str(), n);
  std::printf("\n");
  EXPECT_GT(read, 10u) << "fewer regression meshes read than fetched";
}

// ------------------------------------------------------------------------------------
// Defect 10 (speed, measured by `visgate bench repair`): when no step changed the mesh,
// the output's analysis is the input's, not a second self-intersection pass; when a step
// did change it, the output is analysed anew.

namespace {

size_t step_value(const RepairResult& r, const std::string& step, const std::string& key) {
  for (const auto& s : r.steps)
    if (s.name == step)
      for (const auto& [k, v] : s.changes)
        if (k == key) return v;
  ADD_FAILURE() << "no step " << step << " / " << key;
  return 0;
}

}  // namespace

TEST(RepairSpeed, UnchangedMeshReusesTheInputAnalysis) {
  PolygonSoup s;
  add_box(s, {0, 0, 0}, {4, 4, 4});
  add_box(s, {1, 1, 1}, {3, 3, 3}, true);
  RepairResult r = run(s);
  EXPECT_EQ(step_value(r, "analyze_output", "reused_input_analysis"), 1u);
  EXPECT_EQ(step_value(r, "analyze_output", "self_intersection_pairs_tested"), 0u);
  EXPECT_EQ(r.after.defects.total(), 0u);
  EXPECT_EQ(r.after.cavities, 1u);
  // A changed mesh (the cavity listed outward) is analysed again.
  PolygonSoup t;
  add_box(t, {0, 0, 0}, {4, 4, 4});
  add_box(t, {1, 1, 1}, {3, 3, 3});
  RepairResult u = run(t);
  EXPECT_EQ(step_value(u, "analyze_output", "reused_input_analysis"), 0u);
  EXPECT_EQ(u.after.self_intersection_pairs_tested, u.before.self_intersection_pairs_tested);
  EXPECT_EQ(u.after.defects.total(), 0u);
}
