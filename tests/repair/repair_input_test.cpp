// lib/repair/repair_input.cpp: the input audit. Attributes the reader does not keep are
// counted by name, and double coordinates (which the reader rounds to float32) are
// restored exactly.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <map>

#include "tests/support/binary_bytes.h"
#include "tests/support/repair_fixtures.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;

namespace {

// Reads `bytes` as file `name` and audits it; the audit's counts as a map.
struct Audited {
  PolygonSoup soup;
  InputAudit audit;
  std::map<std::string, size_t> counts;
};
Audited audit_bytes(const std::string& name, const std::string& bytes) {
  Audited a;
  const std::string path = write_file(name, bytes);
  auto soup = read_polygon_file(path);
  EXPECT_TRUE(soup.ok()) << name << ": " << (soup.ok() ? "" : soup.error().message);
  if (!soup.ok()) return a;
  a.soup = std::move(*soup);
  auto r = audit_input(path, bytes, a.soup);
  EXPECT_TRUE(r.ok()) << name << ": " << (r.ok() ? "" : r.error().message);
  if (!r.ok()) return a;
  a.audit = *r;
  for (const auto& [k, v] : r->not_kept) a.counts[k] = v;
  return a;
}

const char* kTetObjFaces = "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

}  // namespace

TEST(RepairInput, AttributesAreCountedNotDropped) {
  {
    // OBJ: 4 normals, 3 texture coordinates, a material, a group, a polyline, corner
    // references on two faces, and a smoothing statement.
    Audited a = audit_bytes("a.obj",
                            "mtllib m.mtl\no thing\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
                            "vn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 0 1\n"
                            "g side\nusemtl red\ns 1\nf 1/1/1 3/3/3 2/2/2\nf 1//1 2//2 4//4\nf 1 4 3\nf 2 3 4\nl 1 2\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"material_libraries", 1}, {"objects", 1}, {"vertex_normals", 4},
                                                        {"texcoords", 3}, {"groups", 1}, {"materials", 1},
                                                        {"smoothing_groups", 1}, {"face_corner_references", 2},
                                                        {"line_elements", 1}}));
    EXPECT_FALSE(a.audit.double_data);
  }
  {
    // PLY: per-vertex normal (nx ny nz: one attribute) and colour, a per-vertex
    // "quality", a face colour, and an extra element.
    Audited a = audit_bytes("a.ply",
                            "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
                            "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\nproperty uchar green\n"
                            "property uchar blue\nproperty float quality\nelement face 4\nproperty list uchar int vertex_indices\n"
                            "property uchar red\nproperty uchar green\nproperty uchar blue\nelement edge 1\nproperty int vertex1\n"
                            "property int vertex2\nend_header\n"
                            "0 0 0 0 0 1 1 2 3 0.5\n1 0 0 0 0 1 1 2 3 0.5\n0 1 0 0 0 1 1 2 3 0.5\n0 0 1 0 0 1 1 2 3 0.5\n"
                            "3 0 2 1 9 9 9\n3 0 1 3 9 9 9\n3 0 3 2 9 9 9\n3 1 2 3 9 9 9\n0 1\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"vertex_normals", 4}, {"vertex_colors", 4},
                                                        {"ply_property vertex.quality", 4}, {"face_colors", 4},
                                                        {"ply_element edge", 1}}));
  }
  {
    // OFF with vertex colours (COFF) and a face colour on one face line.
    Audited a = audit_bytes("a.off",
                            "COFF\n4 4 0\n0 0 0 255 0 0 255\n1 0 0 255 0 0 255\n0 1 0 255 0 0 255\n0 0 1 255 0 0 255\n"
                            "3 0 2 1\n3 0 1 3 1 1 1\n3 0 3 2\n3 1 2 3\n");
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"vertex_colors", 4}, {"face_colors", 1}}));
  }
  {
    // Binary STL: two facets with normals, one with a non-zero attribute word (colour
    // in some dialects); ASCII STL: facet normals.
    std::string b(80, ' ');
    put_bin<uint32_t>(b, 2, false);
    const float f[2][12] = {{0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1, 0}, {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0}};
    for (int t = 0; t < 2; ++t) {
      for (float x : f[t]) put_bin<float>(b, x, false);
      put_bin<uint16_t>(b, uint16_t(t == 0 ? 0x801f : 0), false);
    }
    Audited a = audit_bytes("a.stl", b);
    EXPECT_EQ(a.counts, (std::map<std::string, size_t>{{"face_normals", 1}, {"facet_attribute_words", 1}}));
    Audited t = audit_bytes("t.stl",
                            "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\n"
                            "endfacet\nendsolid t\n");
    EXPECT_EQ(t.counts, (std::map<std::string, size_t>{{"face_normals", 1}}));
  }
  std::filesystem::remove_all(temp_dir());
}

TEST(RepairInput, DoubleCoordinatesAreKeptExactly) {
  const Vec3d want[4] = {{0.1, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1.0000000000000002}};
  auto expect_exact = [&](const Audited& a, const char* what) {
    ASSERT_EQ(a.soup.vertices.size(), 4u) << what;
    EXPECT_TRUE(a.audit.double_data) << what;
    EXPECT_TRUE(a.soup.double_precision) << what;
    EXPECT_EQ(a.audit.coordinates_restored, 2u) << what;
    for (int i = 0; i < 4; ++i) EXPECT_EQ(a.soup.vertices[size_t(i)], want[i]) << what << " vertex " << i;
  };
  // Text: 1.0000000000000002 has 17 significant digits and is not a float, so the file
  // holds double data, and 0.1 is read as the double 0.1 too.
  expect_exact(audit_bytes("d.obj", std::string("v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.0000000000000002\n") + kTetObjFaces),
               "obj");
  expect_exact(audit_bytes("d.off", "OFF\n4 4 0\n0.1 0 0\n1 0 0\n0 1 0\n# comment\n0 0 1.0000000000000002\n"
                                    "3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"),
               "off");
  const std::string ply_head = "element vertex 4\nproperty double x\nproperty double y\nproperty double z\n"
                               "element face 4\nproperty list uchar int vertex_indices\nend_header\n";
  expect_exact(audit_bytes("d.ply", "ply\nformat ascii 1.0\n" + ply_head +
                                        "0.1 0 0\n1 0 0\n0 1 0\n0 0 1.0000000000000002\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"),
               "ply ascii");
  for (bool big : {false, true}) {
    std::string b = std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") + " 1.0\n" + ply_head;
    for (const Vec3d& v : want)
      for (int k = 0; k < 3; ++k) put_bin<double>(b, v[k], big);
    const int f[4][3] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
    for (const auto& t : f) {
      b.push_back(3);
      for (int k = 0; k < 3; ++k) put_bin<int32_t>(b, t[k], big);
    }
    expect_exact(audit_bytes(big ? "be.ply" : "le.ply", b), big ? "ply big-endian" : "ply little-endian");
  }
  // Float data (at most 9 significant digits) stays float: 0.1 is the float 0.1f.
  Audited fl = audit_bytes("f.obj", std::string("v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.00000012\n") + kTetObjFaces);
  EXPECT_FALSE(fl.audit.double_data);
  EXPECT_EQ(fl.soup.vertices[0].x, double(0.1f));
  // ASCII STL with double data cannot be kept (the reader merges corners by their float
  // positions): refused, naming the file, line and vertex.
  const std::string stl = write_file("d.stl",
                                     "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                     "vertex 0 0.10000000000000001 0\nendloop\nendfacet\nendsolid t\n");
  auto soup = read_polygon_file(stl);
  ASSERT_TRUE(soup.ok());
  auto r = audit_input(stl, "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                            "vertex 0 0.10000000000000001 0\nendloop\nendfacet\nendsolid t\n",
                       *soup);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("d.stl: line 6: vertex 2"), std::string::npos) << r.error().message;
  std::filesystem::remove_all(temp_dir());
}
