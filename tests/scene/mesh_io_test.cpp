// lib/scene/mesh_io: mesh file import (OBJ, OFF, PLY, STL), errors naming file and line.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>

#include "lib/scene/mesh_io.h"
#include "lib/scene/scene_json.h"
#include "tests/support/scene_files.h"

using namespace visgate;
using namespace visgate::test_support;
namespace fs = std::filesystem;

TEST(MeshFiles, ObjKeepsEveryFaceIncludingNonManifoldAndInconsistentOnes) {
  fs::path d = temp_dir();
  // Three triangles on one edge (0-1), one of them flipped, and a quad.
  std::ofstream(d / "nm.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 2 0 0\nv 2 1 0\nv 3 1 0\nv 3 0 0\n"
                                 "f 1 2 3\nf 2 1 4\nf 1 2 5\nf 6 7 8 9\n";
  auto soup = read_polygon_file((d / "nm.obj").string());
  ASSERT_TRUE(soup.ok()) << soup.error().message;
  ASSERT_EQ(soup->faces.size(), 4u);
  EXPECT_EQ(soup->faces[2], (std::vector<uint32_t>{0, 1, 4}));
  auto tri = triangulate(*soup, "nm.obj");
  ASSERT_TRUE(tri.ok());
  EXPECT_EQ(tri->size(), 5u);  // the quad fans into two
}

TEST(MeshFiles, OffPlyStlAreRead) {
  fs::path d = temp_dir();
  std::ofstream(d / "t.off") << "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
  std::ofstream(d / "t.ply") << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                                "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  std::ofstream(d / "t.stl") << "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
  for (const char* f : {"t.off", "t.ply", "t.stl"}) {
    auto soup = read_polygon_file((d / f).string());
    ASSERT_TRUE(soup.ok()) << f << ": " << soup.error().message;
    EXPECT_GE(soup->faces.size(), 1u) << f;
    auto tri = triangulate(*soup, f);
    ASSERT_TRUE(tri.ok());
    EXPECT_EQ(tri->bounds().hi, Vec3f(1, 1, 0)) << f;
  }
}

// OpenMesh's OFF reader reads the counts after the header line and knows no comments;
// visgate hands it a canonical text (mesh_io.cpp prescan_off), so both spellings of the
// header and commented files give the same soup. Before, "OFF 4 2 0" read as an empty
// mesh (silently) and fuzz_mesh_files oom d7b33115 made it allocate 3 GB.
TEST(MeshFiles, OffCountsOnTheHeaderLineAndCommentsAreRead) {
  fs::path d = temp_dir();
  std::ofstream(d / "a.off") << "OFF 4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
  std::ofstream(d / "b.off") << "# made by hand\nOFF\n\n# counts\n4 2 0\n0 0 0 # origin\n1 0 0\n1 1 0\n0 1 0\n"
                                "# faces\n3 0 1 2\n3 0 2 3\n";
  for (const char* f : {"a.off", "b.off"}) {
    auto soup = read_polygon_file((d / f).string());
    ASSERT_TRUE(soup.ok()) << f << ": " << soup.error().message;
    ASSERT_EQ(soup->vertices.size(), 4u) << f;
    EXPECT_EQ(soup->vertices[2], Vec3d(1, 1, 0)) << f;
    ASSERT_EQ(soup->faces.size(), 2u) << f;
    EXPECT_EQ(soup->faces[1], (std::vector<uint32_t>{0, 2, 3})) << f;
  }
  // The fuzzer's input: counts 0 0 on the header line, then a huge number.
  std::ofstream(d / "oom.off") << "OFF 0 0 24\n0" << std::string(100, '9') << "\n";
  auto oom = read_polygon_file((d / "oom.off").string());
  ASSERT_TRUE(oom.ok()) << oom.error().message;  // a valid empty mesh; the extra line is ignored
  EXPECT_EQ(oom->vertices.size(), 0u);
}

// Numbers the C++ stream reads of OpenMesh's readers would fail on (the stream then
// stops and later values stay uninitialised) are rejected by the pre-scan, naming the
// line and element. fuzz_mesh_files crash 8bf94312: a face size "001e39" was cast to
// size_t (UBSan).
TEST(MeshFiles, NumbersOpenMeshCannotReadAreRejected) {
  fs::path d = temp_dir();
  struct Case { const char* name; std::string text; const char* message; };
  const std::string v3 = "0 0 0\n1 0 0\n0 1 0\n";
  const Case cases[] = {
      {"big.off", "OFF\n3 1 0\n0 0 0\n1e39 0 0\n0 1 0\n3 0 1 2\n", "line 4: vertex 1: '1e39' overflows float32"},
      {"hex.off", "OFF\n3 1 0\n0 0 0\n0x1p3 0 0\n0 1 0\n3 0 1 2\n", "line 4: vertex 1: not a decimal number: '0x1p3'"},
      {"inf.off", "OFF\n3 1 0\n0 0 0\n-inf 0 0\n0 1 0\n3 0 1 2\n", "line 4: vertex 1: coordinate is NaN or infinite"},
      {"size.off", "OFF\n3 1 0\n" + v3 + "001e39 0 1 2\n", "line 6: face 0: bad vertex count"},
      {"neg.off", "OFF\n3 1 0\n" + v3 + "3 0 -1 2\n", "line 6: face 0: vertex index '-1' out of range"},
      {"frac.off", "OFF\n3.0 1 0\n" + v3 + "3 0 1 2\n", "line 2: bad vertex and face counts"},
      {"noff.off", "NOFF\n3 1 0\n0 0 0 0 0 1\n1 0 0\n0 1 0 0 0 1\n3 0 1 2\n", "line 4: vertex 1: needs 6 numbers"},
      {"big.obj", "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n", "line 2: vertex 1: '1e39' overflows float32"},
      {"big.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0 4e38 0\nvertex 0 1 0\nendloop\n"
                  "endfacet\nendsolid t\n", "line 5: vertex 1: '4e38' overflows float32"},
  };
  for (const Case& c : cases) expect_read_error(d, c.name, c.text, c.message);
  // fuzz_mesh_files oom 867bfe69: tokens after a face's indices are not read by OpenMesh
  // as part of that face (no face colours in the header), so they must not become the
  // next face: "0 2147483648 2 0" is an empty face, then the next line's face.
  std::ofstream(d / "extra.off") << "OFF\n3 2 0\n" << v3 << "0 2147483648 2 0\n3 0 1 2 7 7\n";
  auto extra = read_polygon_file((d / "extra.off").string());
  ASSERT_TRUE(extra.ok()) << extra.error().message;
  ASSERT_EQ(extra->faces.size(), 2u);
  EXPECT_TRUE(extra->faces[0].empty());
  EXPECT_EQ(extra->faces[1], (std::vector<uint32_t>{0, 1, 2}));
  // Subnormal and underflowing decimals read as the float stream reads them.
  std::ofstream(d / "tiny.off") << "OFF\n3 1 0\n0 0 0\n1e-50 0 0\n0 1e-40 0\n3 0 1 2\n";
  auto tiny = read_polygon_file((d / "tiny.off").string());
  ASSERT_TRUE(tiny.ok()) << tiny.error().message;
  EXPECT_EQ(tiny->vertices[1].x, 0.0);
  EXPECT_EQ(float(tiny->vertices[2].y), 1e-40f);
}

TEST(MeshFiles, ErrorsNameTheFile) {
  fs::path d = temp_dir();
  auto missing = read_polygon_file((d / "none.obj").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_NE(missing.error().message.find("none.obj"), std::string::npos);
  std::ofstream(d / "x.xyz") << "1 2 3\n";
  EXPECT_FALSE(read_polygon_file((d / "x.xyz").string()).ok());
  std::ofstream(d / "nan.off") << "OFF\n3 1 0\n0 0 0\nnan 0 0\n0 1 0\n3 0 1 2\n";
  auto nan = read_polygon_file((d / "nan.off").string());
  ASSERT_FALSE(nan.ok());
  EXPECT_NE(nan.error().message.find("vertex 1"), std::string::npos) << nan.error().message;
  // fuzz_mesh_files timeout 8e4b251f: OpenMesh's binary OFF reader trusts garbage counts.
  std::ofstream(d / "bin.off", std::ios::binary) << std::string("OFFiBINARY \x01" "0z\n", 15);
  auto bin = read_polygon_file((d / "bin.off").string());
  ASSERT_FALSE(bin.ok());
  EXPECT_NE(bin.error().message.find("bin.off: line 1: binary OFF is not supported"), std::string::npos)
      << bin.error().message;
  // fuzz_mesh_files timeout 4c2e1ebf: an "OFF:" header with a negative count made OpenMesh loop.
  std::ofstream(d / "colon.off") << "OFF:\n-14 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  auto colon = read_polygon_file((d / "colon.off").string());
  ASSERT_FALSE(colon.ok());
  EXPECT_NE(colon.error().message.find("colon.off: line 1: unsupported OFF header 'OFF:'"), std::string::npos)
      << colon.error().message;
}

namespace {

// Binary PLY of a unit right triangle (vertices float x y z, one face as a uchar-counted
// int list), little- or big-endian, with `face_count_override` replacing the list length
// of the face when >= 0.
std::string binary_triangle_ply(bool big_endian, int face_count_override = -1) {
  std::string out = std::string("ply\nformat ") + (big_endian ? "binary_big_endian" : "binary_little_endian") +
                    " 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                    "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
  auto put = [&](const void* p, size_t n) {
    const char* c = static_cast<const char*>(p);
    for (size_t k = 0; k < n; ++k) out += c[big_endian ? n - 1 - k : k];  // host is little-endian (x86-64)
  };
  const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  for (float f : v) put(&f, 4);
  const unsigned char n = face_count_override >= 0 ? (unsigned char)face_count_override : 3;
  out += char(n);
  for (int i : {0, 1, 2}) put(&i, 4);
  return out;
}

}  // namespace

TEST(MeshFiles, BinaryPlyBothEndiannessesAreRead) {
  fs::path d = temp_dir();
  for (bool be : {false, true}) {
    const fs::path f = d / (be ? "be.ply" : "le.ply");
    std::ofstream(f, std::ios::binary) << binary_triangle_ply(be);
    auto soup = read_polygon_file(f.string());
    ASSERT_TRUE(soup.ok()) << soup.error().message;
    ASSERT_EQ(soup->faces.size(), 1u);
    EXPECT_EQ(soup->faces[0], (std::vector<uint32_t>{0, 1, 2}));
    ASSERT_EQ(soup->vertices.size(), 3u);
    EXPECT_EQ(soup->vertices[1].x, 1.0);
    EXPECT_EQ(soup->vertices[2].y, 1.0);
  }
}

TEST(MeshFiles, MalformedPlyHeadersAreRejectedNamingFileAndLine) {
  fs::path d = temp_dir();
  const std::string vtx = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
  const std::string body = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
  const std::string face = "element face 1\nproperty list uchar int vertex_indices\n";
  struct Case {
    const char* name;
    std::string text;
    const char* expect;  // substring of the message after the file name
  };
  const Case cases[] = {
      {"magic", "plx\nformat ascii 1.0\n" + vtx + face + "end_header\n" + body, "line 1: missing 'ply'"},
      {"format", "ply\nformat ascii 2.0\n" + vtx + face + "end_header\n" + body, "line 2: expected 'format"},
      {"binfmt", "ply\nformat binary_middle_endian 1.0\n" + vtx + face + "end_header\n" + body, "line 2: unknown format"},
      // The OpenMesh SEGV of open/fuzz_mesh_files/asan/316a...: a property without a known type.
      {"type", "ply\nformat ascii 1.0\n" + vtx + "property fex_indices\n" + face + "end_header\n" + body,
       "line 7: expected 'property TYPE NAME'"},
      {"unknown", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float128 x\nend_header\n0\n0\n0\n",
       "line 4: property 'x': unknown type 'float128'"},
      {"listcount", "ply\nformat ascii 1.0\n" + vtx + "element face 1\nproperty list float int vertex_indices\nend_header\n" + body,
       "line 8: list 'vertex_indices': count type 'float' is not an integer type"},
      // The OpenMesh out-of-memory of open/fuzz_mesh_files/asan/1f92...: a header that never ends.
      {"noend", "ply\nformat binary_little_endian 1.0\n" + vtx + "element fac 1\nelement fac 1\n", "file ends before 'end_header'"},
      {"keyword", "ply\nformat ascii 1.0\n" + vtx + "elemnt face 1\nend_header\n" + body, "line 7: unknown header keyword 'elemnt'"},
      {"orphan", "ply\nformat ascii 1.0\nproperty float x\nend_header\n", "line 3: property before any element"},
      {"beforefmt", "ply\n" + vtx + "format ascii 1.0\nend_header\n" + body, "line 2: 'element' before the 'format' line"},
      {"count", "ply\nformat ascii 1.0\nelement vertex -3\nproperty float x\nend_header\n", "line 3: expected 'element NAME COUNT'"},
      // Counts bounded by the file: 10^12 vertices in a 200-byte file.
      {"huge", "ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\n"
               "end_header\n" + body, "line 3: element 'vertex' announces 1000000000000 items, the file has room for at most"},
      {"hugebin", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\n"
                  "property float z\nend_header\nabcdefghijkl", "line 3: element 'vertex' announces 4000000000 items, the file has room for at most 1"},
      {"noprops", "ply\nformat ascii 1.0\nelement vertex 3\nend_header\n", "line 3: element 'vertex' has items but no properties"},
      {"short", "ply\nformat ascii 1.0\n" + vtx + face + "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1\n",
       "element 'face' item 0 property 'vertex_indices': file ends early"},
      {"nan", "ply\nformat ascii 1.0\n" + vtx + face + "end_header\n0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
       "line 11: element 'vertex' item 1 property 'y': coordinate is NaN or infinite"},
      {"intfrac", "ply\nformat ascii 1.0\n" + vtx + face + "end_header\n" + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n",
       "line 13: element 'face' item 0 property 'vertex_indices': '1.5' is not an integer of type int"},
      {"uchar", "ply\nformat ascii 1.0\n" + vtx + face + "end_header\n" + "0 0 0\n1 0 0\n0 1 0\n300 0 1 2\n",
       "'300' is not an integer of type uchar"},
  };
  for (const Case& c : cases) {
    const fs::path f = d / (std::string(c.name) + ".ply");
    std::ofstream(f, std::ios::binary) << c.text;
    auto soup = read_polygon_file(f.string());
    ASSERT_FALSE(soup.ok()) << c.name;
    const std::string& m = soup.error().message;
    EXPECT_EQ(m.rfind(f.string() + ": ", 0), 0u) << c.name << ": " << m;
    EXPECT_NE(m.find(c.expect), std::string::npos) << c.name << ": " << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << c.name << ": " << m;
  }
  // Binary: a face list longer than the bytes left (255 ints after 12 bytes).
  const fs::path f = d / "longlist.ply";
  std::ofstream(f, std::ios::binary) << binary_triangle_ply(false, 255);
  auto soup = read_polygon_file(f.string());
  ASSERT_FALSE(soup.ok());
  EXPECT_NE(soup.error().message.find("element 'face' item 0: list 'vertex_indices' of 255 entries does not fit"),
            std::string::npos)
      << soup.error().message;
}

TEST(MeshFiles, ObjFaceReferencesAreCheckedBeforeOpenMesh) {
  // fuzz_mesh_files crash 93b7431b: `f /1 2 3` (an empty vertex part) made OpenMesh's
  // OBJ reader assert. Every reference form with an integer vertex part still reads.
  fs::path d = temp_dir();
  const std::string verts = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
  // fuzz_mesh_files crash ee5ddf7f: `f  42949672951 #4 /1`. OpenMesh reads each number as
  // an int and skips one that overflows, which left the face without a vertex before `/1`.
  for (const char* bad : {"f /1 2 3", "f 1 2 3/1/1/1", "f 1 x 3", "f 1 - 3", "f  42949672951 #4 /1 =?4",
                          "f 1 2 2147483648", "f 1 2 -2147483649", "f 1 2/99999999999 3", "f 1 2 0000000000000000000004294967296"})
    expect_read_error(d, "bad.obj", verts + bad + "\n", "line 6: face 0: bad vertex reference");
  // fuzz_mesh_files crash 19564d18: `f   #4 /1(f0`. OpenMesh reads past a `#` and skips
  // tokens without a numeric vertex part, so this face had no vertex and it asserted.
  for (const char* empty : {"f", "f   #4 /1(f0", "f # 1 2 3"})
    expect_read_error(d, "bad.obj", verts + empty + "\n", "line 6: face 0: no vertex references");
  for (const char* good : {"f 1 2 3", "f 1/1 2/1 3/1", "f 1//1 2//1 3//1", "f 1/1/1 2/1/1 3/1/1", "f -3 -2 -1 # c",
                           "f 0000000000000000001 2 3", "f 1 2 3 # 42949672951 /1"}) {
    std::ofstream(d / "good.obj") << verts << good << "\n";
    auto soup = read_polygon_file((d / "good.obj").string());
    ASSERT_TRUE(soup.ok()) << good << ": " << soup.error().message;
    ASSERT_EQ(soup->faces.size(), 1u) << good;
    EXPECT_EQ(soup->faces[0], (std::vector<uint32_t>{0, 1, 2})) << good;
  }
}

// OpenMesh's OBJ reader removes every repeated vertex of a face (`f 1 2 2` vanished,
// `f 1 2 1 3` became the triangle 1 2 3) and reads on past a `#` (`f 1 2 3 # 4` became a
// quad); a line starting with a form feed hid a vertex and shifted later indices. The
// faces are now read as the file states them, like the same faces in an OFF file.
TEST(MeshFiles, ObjFacesAreReadAsTheFileStatesThem) {
  fs::path d = temp_dir();
  const std::string verts = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n";
  std::ofstream(d / "f.obj") << verts << "f 1 2 2\nf 1 2 1 3\nf 1 2 3 # 4\nf -4 -3 -1 #\nf 4/1 3//2 2/3/4\n";
  auto soup = read_polygon_file((d / "f.obj").string());
  ASSERT_TRUE(soup.ok()) << soup.error().message;
  const std::vector<std::vector<uint32_t>> want = {{0, 1, 1}, {0, 1, 0, 2}, {0, 1, 2}, {0, 1, 3}, {3, 2, 1}};
  EXPECT_EQ(soup->faces, want);
  std::ofstream(d / "f.off") << "OFF\n4 2 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 1\n4 0 1 0 2\n";
  auto off = read_polygon_file((d / "f.off").string());
  ASSERT_TRUE(off.ok()) << off.error().message;
  EXPECT_EQ(off->faces, (std::vector<std::vector<uint32_t>>{want[0], want[1]}));
  // Forward references are legal OBJ (every vertex is known before faces are resolved).
  std::ofstream(d / "fwd.obj") << "f 1 2 3\n" << verts;
  auto fwd = read_polygon_file((d / "fwd.obj").string());
  ASSERT_TRUE(fwd.ok()) << fwd.error().message;
  EXPECT_EQ(fwd->faces, (std::vector<std::vector<uint32_t>>{{0, 1, 2}}));

  struct Case { const char* text; const char* message; };
  for (const Case& c : {Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 9 9\n", "line 4: face 0: vertex index '9' out of range (3 vertices)"},
                        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -1 -2 -4\n", "line 4: face 0: vertex index '-4' out of range"},
                        Case{"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", "line 4: face 0: vertex index '0' out of range"},
                        Case{"\fv 5 5 5\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", "line 1: starts with a form feed"}})
    expect_read_error(d, "bad.obj", c.text, c.message);
}

// OpenMesh's STL readers drop every facet whose corners are not three distinct
// positions, so a file's degenerate facets never reached the repair's report; its ASCII
// reader takes the three lines after any line containing "outer" as vertices, whatever
// they say (`outer loop` then `endloop` left the coordinates uninitialised). Facets are
// now rebuilt from the file, degenerate ones kept, and such files are refused.
TEST(MeshFiles, StlFacetsAreReadAsTheFileStatesThem) {
  fs::path d = temp_dir();
  auto facet = [](const char* a, const char* b, const char* c) {
    return std::string("facet normal 0 0 1\nouter loop\nvertex ") + a + "\nvertex " + b + "\nvertex " + c +
           "\nendloop\nendfacet\n";
  };
  std::ofstream(d / "a.stl") << "solid t\n" << facet("0 0 0", "1 0 0", "1 0 0") << facet("0 0 0", "1 0 0", "0 1 0")
                             << "endsolid t\n";
  auto a = read_polygon_file((d / "a.stl").string());
  ASSERT_TRUE(a.ok()) << a.error().message;
  EXPECT_EQ(a->vertices.size(), 3u);
  EXPECT_EQ(a->faces, (std::vector<std::vector<uint32_t>>{{0, 1, 1}, {0, 1, 2}}));

  // The same two facets in binary STL.
  {
    std::string bin(80, ' ');
    const uint32_t n = 2;
    bin.append(reinterpret_cast<const char*>(&n), 4);
    const float tri[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0}, {0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}};
    for (const auto& t : tri) {
      bin.append(reinterpret_cast<const char*>(t), 48);
      bin.append(2, '\0');
    }
    std::ofstream(d / "b.stl", std::ios::binary) << bin;
  }
  auto b = read_polygon_file((d / "b.stl").string());
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(b->faces, a->faces);

  struct Case { std::string text; const char* message; };
  for (const Case& c : {Case{"solid outer_wall\n" + facet("0 0 0", "1 0 0", "0 1 0") + "endsolid\n",
                             "line 2: facet 0: expected 'vertex x y z'"},
                        Case{"solid t\nfacet normal 0 0 1\nouter loop\nendloop\nendfacet\nendsolid\n",
                             "line 4: facet 0: expected 'vertex x y z'"},
                        Case{"solid t\nvertex 0 0 0\n" + facet("0 0 0", "1 0 0", "0 1 0") + "endsolid\n",
                             "line 2: vertex 0 outside an 'outer loop'"},
                        Case{"solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n", "facet 0: file ends inside"}})
    expect_read_error(d, "bad.stl", c.text, c.message);
}

TEST(MeshFiles, SceneReferencesMeshFilesRelativeToTheJson) {
  fs::path d = temp_dir();
  std::ofstream(d / "tri.obj") << "v -1 -1 1\nv 1 -1 1\nv 0 1 1\nf 1 2 3\n";
  std::ofstream(d / "s.json") << R"({"format":"visgate-scene","version":1,"meshes":[{"file":"tri.obj"}],)"
                                 R"("lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]],"samples":4}],"receivers":[{"p":[0,0,0]}]})";
  auto s = read_scene_file((d / "s.json").string());
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->mesh.size(), 1u);
  std::ofstream(d / "s2.json") << R"({"format":"visgate-scene","version":1,"meshes":[{"file":"gone.obj"}],)"
                                  R"("lights":[{"polygon":[[-1,-1,2],[-1,1,2],[1,1,2],[1,-1,2]],"samples":4}],"receivers":[{"p":[0,0,0]}]})";
  auto s2 = read_scene_file((d / "s2.json").string());
  ASSERT_FALSE(s2.ok());
  EXPECT_NE(s2.error().message.find("meshes[0].file"), std::string::npos) << s2.error().message;
}
