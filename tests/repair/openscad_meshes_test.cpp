// The whole of repair on OpenSCAD's regression meshes (Debian openscad-testing-data,
// tools/fetch-openscad-data.sh; skipped when not fetched): files the reader refuses are
// bad input; on every other file hole filling adds no self-intersection, duplicate or
// non-manifold edge, repair is idempotent, and the check of the output agrees with the
// report.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <map>

#include "tests/support/repair_fixtures.h"

using namespace visgate;
using namespace visgate::mesh;
using namespace visgate::test;
namespace fs = std::filesystem;

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
