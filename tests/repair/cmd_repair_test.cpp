// tools/visgate/cmd_repair.cpp: `visgate repair` run as a process (VISGATE_BIN): malformed
// input (exit 2, nothing written), files without faces, byte-order marks, Blender-style
// PLY headers, extension-less files, shortest float output, --in-place, the report and
// its exit codes.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <nlohmann/json.hpp>

#include "tests/support/repair_fixtures.h"
#include "lib/repair/sha256.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;
namespace fs = std::filesystem;

namespace {

std::string utf16(const std::string& ascii, bool little_endian) {
  std::string out = little_endian ? std::string("\xFF\xFE", 2) : std::string("\xFE\xFF", 2);
  for (char c : ascii) {
    if (little_endian) { out.push_back(c); out.push_back('\0'); }
    else { out.push_back('\0'); out.push_back(c); }
  }
  return out;
}

}  // namespace

TEST(RepairCli, MalformedInputExitsTwoAndWritesNothing) {
  auto dir = temp_dir();
  struct Bad { const char* name; std::string text; const char* names; };
  std::vector<Bad> bad = {
      {"idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", "face 0"},
      {"nan.obj", "v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n", "vertex 1"},
      {"inf.off", "OFF\n3 1 0\n0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n", "vertex 1"},
      {"short.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n", "short.off"},
      {"trunc.stl", std::string(80, ' ') + std::string("\x05\x00\x00\x00", 4) + std::string(20, '\0'), "trunc.stl"},
      {"mesh.xyz", "1 2 3\n", "xyz"},
  };
  for (const Bad& b : bad) {
    write_text(dir / b.name, b.text);
    auto out = dir / "out.obj";
    std::string err;
    EXPECT_EQ(run_cli("repair " + (dir / b.name).string() + " -o " + out.string(), &err), 2) << b.name << ": " << err;
    EXPECT_FALSE(std::filesystem::exists(out)) << b.name;
    EXPECT_NE(err.find(b.names), std::string::npos) << b.name << ": " << err;
    EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << b.name << ": one line: " << err;
  }
  std::string err;
  EXPECT_EQ(run_cli("repair " + (dir / "missing.obj").string() + " -o " + (dir / "o.obj").string(), &err), 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "o.obj"));
  std::filesystem::remove_all(dir);
}

TEST(RepairCli, NeverOverwritesTheInputWithoutInPlace) {
  auto dir = temp_dir();
  auto in = dir / "t.obj";
  std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 3 4\n";  // inside out
  write_text(in, text);
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + in.string()), 2);
  EXPECT_EQ(read_all(in), text);
  EXPECT_EQ(run_cli("repair " + in.string()), 2);  // no -o, no --in-place
  EXPECT_EQ(read_all(in), text);
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + (dir / "x.obj").string() + " --weld-mode=loose"), 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.obj"));
  // --check writes nothing and reports the inward component: exit 1.
  EXPECT_EQ(run_cli("repair --check " + in.string()), 1);
  EXPECT_EQ(read_all(in), text);
  // --in-place repairs it: exit 0, and a re-check is clean.
  EXPECT_EQ(run_cli("repair " + in.string() + " --in-place"), 0);
  EXPECT_NE(read_all(in), text);
  EXPECT_EQ(run_cli("repair --check " + in.string()), 0);
  std::filesystem::remove_all(dir);
}

// Double data through the CLI: every coordinate comes back bit for bit (17 digits), the
// attributes the output cannot hold are in the report and on stderr, and a report path
// that is a folder is refused before anything is written.
TEST(RepairCli, DoubleDataAndAttributesSurviveTheRoundTrip) {
  auto dir = temp_dir();
  auto in = dir / "d.obj";
  write_text(in, "v 0.1 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1.0000000000000002\nvn 0 0 1\nvt 0.5 0.5\n"
                 "f 1/1/1 3/1/1 2/1/1\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  for (const char* ext : {".ply", ".obj", ".off"}) {
    auto out = dir / (std::string("o") + ext);
    auto rep = dir / "r.json";
    std::string err;
    ASSERT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + rep.string(), &err), 0) << err;
    EXPECT_NE(err.find("attributes not kept: vertex_normals=1 texcoords=1 face_corner_references=1"), std::string::npos)
        << err;
    auto j = nlohmann::json::parse(read_all(rep));
    EXPECT_EQ(j["input"]["attributes_not_kept"]["vertex_normals"], 1);
    EXPECT_EQ(j["input"]["attributes_not_kept"]["texcoords"], 1);
    EXPECT_EQ(j["input"]["double_coordinates_restored"], 2);
    EXPECT_EQ(j["output"]["coordinate_digits"], 17);
    EXPECT_EQ(j["faces"]["output_source_runs"], nlohmann::json::parse("[[0, 0, 4, 1]]"));
    // Read the vertex lines back with strtod: the doubles, bit for bit. OBJ: "v" lines;
    // OFF: the 4 lines after "OFF" and the counts; PLY: the 4 lines after end_header.
    std::ifstream f(out);
    std::vector<double> xs;
    const std::string e(ext);
    int skip = e == ".off" ? 2 : -1;
    int left = e == ".obj" ? 1 << 30 : 4;
    for (std::string line; std::getline(f, line) && left > 0;) {
      if (e == ".ply" && skip < 0) {
        if (line == "end_header") skip = 0;
        continue;
      }
      if (skip > 0) {
        --skip;
        continue;
      }
      std::istringstream ls(line);
      if (e == ".obj") {
        std::string kw;
        if (!(ls >> kw) || kw != "v") continue;
      }
      std::string x, y, z;
      ASSERT_TRUE(bool(ls >> x >> y >> z)) << ext << ": " << line;
      for (const std::string* t : {&x, &y, &z}) xs.push_back(std::strtod(t->c_str(), nullptr));
      --left;
    }
    ASSERT_EQ(xs.size(), 12u) << ext;
    EXPECT_EQ(xs[0], 0.1) << ext;
    EXPECT_EQ(xs[11], 1.0000000000000002) << ext;
  }
  // A report path that is a folder: exit 2, no mesh, no temporary file left.
  std::filesystem::create_directories(dir / "rep");
  auto out = dir / "never.obj";
  std::string err;
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + (dir / "rep").string(), &err), 2);
  EXPECT_FALSE(std::filesystem::exists(out));
  for (const auto& e : std::filesystem::directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".visgate-tmp"), std::string::npos) << e.path();
  // ASCII STL double data cannot be kept: exit 2 naming the vertex, nothing written.
  auto stl = dir / "d.stl";
  write_text(stl, "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 0.10000000000000001 0\n"
                  "endloop\nendfacet\nendsolid t\n");
  EXPECT_EQ(run_cli("repair " + stl.string() + " -o " + out.string(), &err), 2);
  EXPECT_NE(err.find("vertex 2"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(out));
  std::filesystem::remove_all(dir);
}

TEST(RepairCli, ReportHasHashesCountsAndExitCodes) {
  auto dir = temp_dir();
  auto in = dir / "m.obj";
  // Tetrahedron with a flipped face plus a separate pierced pair (cannot be fixed).
  write_text(in,
             "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
             "v 5 0 0\nv 7 0 0\nv 5 2 0\nv 5.5 0.5 -1\nv 5.5 0.5 1\nv 8 3 0\n"
             "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 4 3\n"
             "f 5 6 7\nf 8 9 10\n");
  auto out = dir / "r.ply";
  auto rep = dir / "r.json";
  std::string err;
  EXPECT_EQ(run_cli("repair " + in.string() + " -o " + out.string() + " --report " + rep.string(), &err), 1) << err;
  EXPECT_NE(err.find("self_intersections"), std::string::npos) << err;
  ASSERT_TRUE(std::filesystem::exists(out));
  auto j = nlohmann::json::parse(read_all(rep));
  EXPECT_EQ(j["format"], "visgate-repair-report");
  EXPECT_EQ(j["exit_code"], 1);
  EXPECT_EQ(j["input"]["sha256"], sha256_hex(read_all(in)));
  EXPECT_EQ(j["output"]["sha256"], sha256_hex(read_all(out)));
  // Independent check of the hash where the system has sha256sum.
  std::string cmd = "sha256sum " + in.string() + " > " + (dir / "sum.txt").string() + " 2>/dev/null";
  if (std::system(cmd.c_str()) == 0) {
    EXPECT_EQ(read_all(dir / "sum.txt").substr(0, 64), j["input"]["sha256"]);
  }
  EXPECT_EQ(j["defects"]["before"]["inconsistent_edges"], 3);
  EXPECT_EQ(j["defects"]["after"]["inconsistent_edges"], 0);
  EXPECT_EQ(j["defects"]["before"]["self_intersections"], 1);
  EXPECT_EQ(j["defects"]["after"]["self_intersections"], 1);
  EXPECT_EQ(j["topology"]["after"]["self_intersections"][0]["input_faces"], nlohmann::json({4, 5}));
  EXPECT_EQ(j["remaining"], nlohmann::json({"boundary_loops", "self_intersections"}));
  EXPECT_EQ(j["faces"]["input"], 6);
  EXPECT_EQ(j["faces"]["in_output"], 6);
  EXPECT_EQ(j["options"]["weld_mode"], "chain");
  bool saw_orient = false;
  for (const auto& s : j["steps"])
    if (s["name"] == "orient") {
      saw_orient = true;
      EXPECT_EQ(s["changes"]["faces_flipped_for_consistency"], 1);
      EXPECT_GE(s["seconds"].get<double>(), 0.0);
    }
  EXPECT_TRUE(saw_orient);
  // The output reads back with every coordinate intact.
  auto back = read_polygon_file(out.string());
  ASSERT_TRUE(back.ok());
  EXPECT_EQ(back->faces.size(), 6u);
  EXPECT_EQ(back->vertices[7], Vec3d(5.5, 0.5, -1));
  std::filesystem::remove_all(dir);
}

// A file that yields no face is bad input (exit 2, nothing written), whatever
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

// Byte-order marks. UTF-8 and ASCII-only UTF-16 (both byte orders) read as the
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

// `f 1 2 3 4` with its cycle listed 117 times is the quad, once. Six such
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

// A PLY header line without a keyword (Blender 2.4x) is accepted with a
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

// Float coordinates come back as the user wrote them (shortest round trip).
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

// --in-place keeps the mode, replaces the target of a symbolic link (the link
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
