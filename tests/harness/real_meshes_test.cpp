// The production methods on real meshes nobody here generated: CGAL's example data
// (Debian libcgal-demo, tools/fetch-cgal-data.sh; skipped when not fetched), the
// scanned Stanford bunny (75k triangles), the armadillo and the elephant, each as a
// `file:` scene, checked like `visgate check` does: every relation against the exact
// oracle and the exact 2^k copies (metamorphic), plucker-bsp's fractions against the
// region oracle.
#include <gtest/gtest.h>

#include <filesystem>

#include "tests/support/family_scene.h"
#include "tools/harness/check.h"

namespace visgate::harness {
namespace {

namespace fs = std::filesystem;
using visgate::test_support::family;

fs::path cgal_meshes() {
  if (const char* e = std::getenv("VISGATE_CGAL_DATA_DIR")) return e;
  const char* src = std::getenv("VISGATE_SOURCE_DIR");
  return fs::path(src ? src : VISGATE_TEST_SOURCE_DIR) / ".cache" / "cgal-data" / "meshes";
}

TEST(RealMeshes, ScannedAndModelledMeshesMatchTheOracleAtEveryScale) {
  const fs::path dir = cgal_meshes();
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    GTEST_SKIP() << dir << " is absent: run tools/fetch-cgal-data.sh to fetch CGAL's example meshes";
  CheckConfig cfg;
  // iss by default casts these scenes' few relations as leaf rays (dense_rays); its
  // shafts on the dense meshes are checked with dense_rays=off.
  SolveOptions shafts;
  shafts.opts = {{"dense_rays", "off"}};
  cfg.methods = {MethodSpec{"iss", SolveOptions{}, ""}, MethodSpec{"iss", shafts, "iss#shafts"},
                 MethodSpec{"ssv", SolveOptions{}, ""}, MethodSpec{"plucker-bsp", SolveOptions{}, ""}};
  cfg.threads = 0;
  cfg.scale_exponents = {-40};
  cfg.region_pairs = 16;
  CheckReport report;
  report.tau = cfg.tau;
  report.methods = {"iss", "iss#shafts", "ssv", "plucker-bsp"};
  size_t checked = 0;
  for (const char* name : {"bunny00.off", "armadillo.off", "refined_elephant.off"}) {
    const fs::path f = dir / name;
    if (!fs::exists(f, ec)) {
      ADD_FAILURE() << f << " is missing from the fetched data";
      continue;
    }
    // 6x6 receivers below the mesh, 8 samples of the light above it: penumbra through
    // the whole silhouette band of a dense closed surface.
    const Scene s = family("file:" + f.string(), 1, -1, 36, 8);
    ASSERT_GT(s.mesh.size(), 50000u) << name;
    check_scene(s, SceneOrigin{"file", 1, {}, f.string()}, cfg, report);
    ++checked;
  }
  EXPECT_EQ(checked, 3u);
  EXPECT_TRUE(report.errors.empty()) << report.errors.front();
  for (const auto& [key, row] : report.rows) {
    if (key.second == "oracle") continue;
    EXPECT_EQ(row.mismatches(), 0u) << key.first << " " << key.second;
    EXPECT_GT(row.relations, 0u) << key.first << " " << key.second;
  }
  for (const auto& m : report.mismatches)
    ADD_FAILURE() << m.method << " " << m.scene << " receiver " << m.receiver << " light " << m.light << " sample "
                  << m.sample << " " << m.direction << " margin " << m.margin;
}

}  // namespace
}  // namespace visgate::harness
