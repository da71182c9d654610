// tools/harness/corpus: corpus classes of hand-built cases, and corpus entries' round
// trip and replay by status.
#include <gtest/gtest.h>

#include <filesystem>

#include "lib/scene/families.h"
#include "tools/harness/corpus.h"

namespace visgate::harness {
namespace {

// A hand-built scene: one triangle, one receiver, one explicit sample.
Scene one_relation(const std::vector<std::array<Vec3f, 3>>& tris, const Vec3f& r, const Vec3f& l) {
  Scene s;
  s.name = "hand";
  for (const auto& t : tris) {
    uint32_t b = uint32_t(s.mesh.vertices.size());
    for (const auto& v : t) s.mesh.vertices.push_back(v);
    s.mesh.triangles.push_back({b, b + 1, b + 2});
  }
  Light light = make_square_light_down(Vec3d(0, 0, 2), 0.5, 1, 1);
  light.jitter = 1;
  light.explicit_samples = {l};
  EXPECT_TRUE(prepare_light(light, "hand").ok());
  s.lights.push_back(light);
  s.receivers.push_back(Receiver{r, Vec3f(0, 0, 1)});
  return s;
}

TEST(CorpusClass, HandBuiltCasesGetTheirGeometricClass) {
  Vec3f r(0, 0, 0), l(0, 0, 2);
  // Vertex exactly on the segment.
  EXPECT_EQ(classify_case(one_relation({{Vec3f(0, 0, 1), Vec3f(1, 0, 1), Vec3f(0, 1, 1)}}, r, l), 0, 0, 0, "x"),
            "vertex-on-segment");
  // Edge crossing the segment.
  EXPECT_EQ(classify_case(one_relation({{Vec3f(-1, 0, 1), Vec3f(1, 0, 1), Vec3f(0, 1, 1)}}, r, l), 0, 0, 0, "x"),
            "edge-on-segment");
  // Segment inside the triangle's plane.
  EXPECT_EQ(classify_case(one_relation({{Vec3f(-1, 0, 0.5f), Vec3f(1, 0, 0.5f), Vec3f(0, 0, 1.5f)}}, r, l), 0, 0, 0, "x"),
            "coplanar");
  // Crossing just above the receiver.
  EXPECT_EQ(classify_case(one_relation({{Vec3f(-1, -1, 1e-7f), Vec3f(1, -1, 1e-7f), Vec3f(0, 1, 1e-7f)}}, r, l), 0, 0, 0,
                          "x"),
            "near-endpoint");
  // A clean crossing.
  EXPECT_EQ(classify_case(one_relation({{Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)}}, r, l), 0, 0, 0, "x"),
            "other");
  EXPECT_EQ(classify_case(one_relation({{Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)}}, r, l), 0, 0, 0, "torus"),
            "torus");
}

TEST(Corpus, EntryRoundTripsAndReplaysByStatus) {
  namespace fs = std::filesystem;
  std::string root = testing::TempDir() + "harness_test_corpus";
  fs::remove_all(root);
  // brute answers this clean crossing correctly (exact: blocked, large margin).
  Scene s = one_relation({{Vec3f(-1, -1, 1), Vec3f(1, -1, 1), Vec3f(0, 1, 1)}}, Vec3f(0, 0, 0), Vec3f(0, 0, 2));
  CaseInfo info;
  info.method = "brute";
  info.expected = 'b';
  info.class_name = "other";
  info.status = "fixed";
  info.note = "hand-built clean crossing";
  auto path = write_corpus_entry(root, s, info);
  ASSERT_TRUE(path.ok()) << path.error().message;
  EXPECT_EQ(fs::path(*path).parent_path(), fs::path(root) / "brute" / "other");
  auto again = write_corpus_entry(root, s, info);
  EXPECT_EQ(*again, *path);  // content-addressed: same content, same file
  auto e = read_corpus_entry(*path);
  ASSERT_TRUE(e.ok()) << e.error().message;
  EXPECT_EQ(corpus_entry_text(e->scene, e->info), corpus_entry_text(s, info));
  ReplayResult r = replay_entry(*e);
  EXPECT_TRUE(r.ok) << r.message;
  EXPECT_EQ(r.exact, 'b');
  // The same relation marked open: brute passes it, so the replay must flag it.
  e->info.status = "open";
  r = replay_entry(*e);
  EXPECT_FALSE(r.ok);
  EXPECT_NE(r.message.find("switch its status to \"fixed\""), std::string::npos);
  // A wrong expected class is reported as an oracle change.
  e->info.status = "fixed";
  e->info.expected = 'v';
  EXPECT_FALSE(replay_entry(*e).ok);
  EXPECT_EQ(list_corpus(root).size(), 1u);
  fs::remove_all(root);
}


}  // namespace
}  // namespace visgate::harness
