// tools/harness/check: shards, the report JSON round trip and merging, the metamorphic
// transforms the check runs (exactness checked coordinate by coordinate, and the
// oracle's invariance), and the receiver bit counts the check compares.
#include <gtest/gtest.h>

#include "oracle/relation_oracle.h"
#include "tests/support/family_scene.h"
#include "tools/harness/check.h"

namespace visgate::harness {
namespace {

using visgate::test_support::family;

TEST(ReceiverBits, CountVisibleEqualsTheBitByBitCountOnEveryRange) {
  // Every [begin, end) of 200 random bits (four words, ranges within one word, across
  // word boundaries, empty) against counting visible(b) one bit at a time.
  ReceiverResult rr;
  rr.visible_bits.assign(4, 0);
  uint64_t h = 0x9e3779b97f4a7c15ull;
  for (size_t b = 0; b < 200; ++b) {
    h ^= h << 13, h ^= h >> 7, h ^= h << 17;
    rr.set_visible(b, (h & 3) != 0);
  }
  for (size_t begin = 0; begin <= 200; ++begin)
    for (size_t end = begin; end <= 200; ++end) {
      size_t n = 0;
      for (size_t b = begin; b < end; ++b) n += rr.visible(b);
      ASSERT_EQ(rr.count_visible(begin, end), n) << begin << " " << end;
    }
}

TEST(Shard, ParsesKOfNAndRejectsEverythingElse) {
  auto s = parse_shard("2/5");
  ASSERT_TRUE(s.ok());
  EXPECT_EQ(s->first, 2);
  EXPECT_EQ(s->second, 5);
  for (const char* bad : {"0/3", "4/3", "1/0", "a/b", "1/2x", "3", "", "-1/2"}) EXPECT_FALSE(parse_shard(bad).ok()) << bad;
}

TEST(Metamorphic, ScalingByAPowerOfTwoIsExact) {
  Scene s = family("random-soup", 3, 50, 16, 4);
  Scene t = scaled_scene(s, 5);
  for (size_t i = 0; i < s.mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(double(t.mesh.vertices[i][k]), 32.0 * double(s.mesh.vertices[i][k]));
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (int j = 0; j < s.lights[0].samples; ++j)
      for (int k = 0; k < 3; ++k)
        EXPECT_EQ(double(sample_position(t.lights[0], j, i)[k]), 32.0 * double(sample_position(s.lights[0], j, i)[k]));
}

TEST(Metamorphic, TranslationIsExactAndKeepsTheOraclesAnswers) {
  for (const char* f : {"grid-snapped", "random-soup", "shared-edge-fan"}) {
    Scene s = family(f, 2, 60, 16, 8);
    Vec3d off;
    Scene t = translated_scene(s, &off);
    EXPECT_NE(off.x, 0.0) << f;
    for (size_t i = 0; i < s.mesh.vertices.size(); ++i)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(double(t.mesh.vertices[i][k]), double(s.mesh.vertices[i][k]) + off[k]);
    for (size_t i = 0; i < s.receivers.size(); ++i)
      for (int k = 0; k < 3; ++k) EXPECT_EQ(double(t.receivers[i].p[k]), double(s.receivers[i].p[k]) + off[k]);
    auto a = oracle::run_relation_oracle(s, 1), b = oracle::run_relation_oracle(t, 1);
    EXPECT_EQ(a.classes, b.classes) << f;
  }
}

// A coordinate far above the rest (fuzz_plucker 944ae82f: mesh vertices at 2^78 and
// 2^98 beside a scene at -4.6e5) must not admit an offset that swallows the small ones:
// every translated coordinate is the exact sum, and the oracle's classes are unchanged.
TEST(Metamorphic, TranslationNeverRoundsAwaySmallCoordinates) {
  Scene s = family("random-soup", 4, 40, 8, 4);
  s.mesh.vertices[0].x = 0x1.fe67f6p+98f;
  s.mesh.vertices[1].y = 0x1.fffffep+78f;
  s.mesh.vertices[2].z = -0x1p-60f;
  Vec3d off;
  Scene t = translated_scene(s, &off);
  for (size_t i = 0; i < s.mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k)
      EXPECT_EQ(double(t.mesh.vertices[i][k]) - off[k], double(s.mesh.vertices[i][k])) << i << " " << k;
  for (size_t i = 0; i < s.receivers.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(double(t.receivers[i].p[k]) - off[k], double(s.receivers[i].p[k]));
  auto a = oracle::run_relation_oracle(s, 1), b = oracle::run_relation_oracle(t, 1);
  EXPECT_EQ(a.classes, b.classes);
}

TEST(Check, RowsAccountForEveryRelationAndReportsRoundTrip) {
  CheckConfig cfg;
  cfg.methods = {MethodSpec{"brute", SolveOptions{}, ""}, MethodSpec{"embree", SolveOptions{}, ""}};
  cfg.tau = 1e-5;
  cfg.threads = 1;
  CheckReport whole, part1, part2;
  for (auto* r : {&whole, &part1, &part2}) {
    r->tau = cfg.tau;
    r->methods = {"brute", "embree"};
  }
  part1.shards = {"1/2"};
  part2.shards = {"2/2"};
  whole.shards = {"1/1"};
  Scene a = family("grid-snapped", 1, 40, 16, 8), b = family("torus", 1, 128, 16, 8);
  SceneOrigin oa{"grid-snapped", 1, {}, ""}, ob{"torus", 1, {}, ""};
  check_scene(a, oa, cfg, whole);
  check_scene(b, ob, cfg, whole);
  check_scene(a, oa, cfg, part1);
  check_scene(b, ob, cfg, part2);
  for (const auto& [key, row] : whole.rows) {
    if (key.second == "oracle") continue;
    EXPECT_EQ(row.relations, key.first == "torus" ? b.relation_count() : a.relation_count());
    EXPECT_EQ(row.agree + row.disagree + row.degenerate, row.relations) << key.first << " " << key.second;
    size_t hist = 0, rel = 0;
    for (size_t d = 0; d < kDecades; ++d) hist += row.disagreements[d], rel += row.relations_per_decade[d];
    EXPECT_EQ(hist, row.disagree);
    EXPECT_EQ(rel, row.relations - row.degenerate);
  }
  // JSON round trip, then merging the two shards gives the whole run's rows.
  auto p1 = report_from_json(report_to_json(part1), "part1");
  auto p2 = report_from_json(report_to_json(part2), "part2");
  ASSERT_TRUE(p1.ok()) << p1.error().message;
  ASSERT_TRUE(p2.ok()) << p2.error().message;
  EXPECT_EQ(report_to_json(*p1), report_to_json(part1));
  CheckReport merged;
  ASSERT_TRUE(merge_report(merged, *p1).ok());
  ASSERT_TRUE(merge_report(merged, *p2).ok());
  ASSERT_EQ(merged.rows.size(), whole.rows.size());
  for (const auto& [key, row] : whole.rows) {
    const Row& m = merged.rows.at(key);
    EXPECT_EQ(m.relations, row.relations);
    EXPECT_EQ(m.disagree, row.disagree);
    EXPECT_EQ(m.mismatches(), row.mismatches());
    EXPECT_EQ(m.disagreements, row.disagreements);
  }
  EXPECT_EQ(merged.scenes.size(), 2u);
  EXPECT_FALSE(merge_report(merged, *p1).ok());  // shard 1/2 twice
  CheckReport other = part1;
  other.tau = 0;
  other.shards = {"3/3"};
  EXPECT_FALSE(merge_report(merged, other).ok());
}

}  // namespace
}  // namespace visgate::harness
