// The differential harness (tools/harness): SHA-1 against the FIPS 180 test vectors,
// shards, report JSON round trip and merging, the metamorphic transforms (exactness
// checked coordinate by coordinate, and the oracle's invariance), the minimiser on real
// brute-force failures (at most 3 triangles, the signature kept, idempotent), corpus
// classes on hand-built cases, and corpus entries' round trip and replay.
#include <gtest/gtest.h>

#include <filesystem>

#include "lib/scene/families.h"
#include "tests/support/family_scene.h"
#include "oracle/comparator.h"
#include "tools/harness/check.h"
#include "tools/harness/corpus.h"
#include "tools/harness/minimize.h"
#include "tools/harness/sha1.h"
#include "tools/harness/store.h"

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

TEST(Sha1, MatchesFips180TestVectors) {
  EXPECT_EQ(sha1_hex(""), "da39a3ee5e6b4b0d3255bfef95601890afd80709");
  EXPECT_EQ(sha1_hex("abc"), "a9993e364706816aba3e25717850c26c9cd0d89d");
  EXPECT_EQ(sha1_hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "84983e441c3bd26ebaae4aa1f95129e5e54670f1");
  EXPECT_EQ(sha1_hex(std::string(1000000, 'a')), "34aa973cd4c4daa4f61eeb2bdbad27316534016f");
  // Lengths around the padding boundary (55, 56, 64 bytes); digests from coreutils sha1sum.
  EXPECT_EQ(sha1_hex(std::string(55, 'a')), "c1c8bbdc22796e28c0e15163d20899b65621d65a");
  EXPECT_EQ(sha1_hex(std::string(56, 'a')), "c2db330f6083854c99d4b5bfb6e8f29f201be699");
  EXPECT_EQ(sha1_hex(std::string(64, 'a')), "0098ba824b5c16427bd7a1122a5a442a25ec644d");
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

// The first brute relation mismatch at tau 0 in a family's seeds 1..8.
bool find_brute_mismatch(const std::string& f, Scene& scene, oracle::Mismatch& found) {
  auto brute = make_solver("brute");
  for (uint64_t seed = 1; seed <= 8; ++seed) {
    scene = family(f, seed);
    auto exact = oracle::run_relation_oracle(scene, 1);
    auto cmp = oracle::compare_relations(scene, brute->solve(scene, SolveOptions{}), exact, 0.0);
    for (const auto& m : cmp.mismatches)
      if (m.direction == oracle::Direction::FalseVisible || m.direction == oracle::Direction::FalseBlocked) {
        found = m;
        return true;
      }
  }
  return false;
}

TEST(Minimize, ShrinksBruteFailuresToAtMostThreeTrianglesIdempotently) {
  namespace fs = std::filesystem;
  for (const char* f : {"shared-edge-fan", "sliver-soup"}) {
    Scene scene;
    oracle::Mismatch m;
    ASSERT_TRUE(find_brute_mismatch(f, scene, m)) << f << ": no brute mismatch at tau 0 in seeds 1..8";
    CaseSpec spec;
    spec.method = "brute";
    spec.receiver = m.receiver;
    spec.light = m.light;
    spec.sample = m.sample;
    spec.tau = 0.0;
    auto res = minimize_case(scene, spec);
    ASSERT_TRUE(res.ok()) << res.error().message;
    EXPECT_LE(res->scene.mesh.size(), 3u) << f;
    EXPECT_EQ(res->scene.receivers.size(), 1u);
    EXPECT_EQ(res->scene.lights[0].samples, 1);
    EXPECT_EQ(res->verdict.direction, oracle::direction_name(m.direction));
    // Independent re-check of the minimal case: the oracle and brute still disagree.
    CaseSpec local;
    local.method = "brute";
    local.tau = 0.0;
    auto v = judge_relation(res->scene, local);
    ASSERT_TRUE(v.ok());
    EXPECT_EQ(v->direction, res->verdict.direction);
    // Store, read back, minimise again: the same entry.
    std::string root = testing::TempDir() + "harness_test_min";
    fs::remove_all(root);
    CaseInfo base;
    base.family = f;
    base.source_scene = scene.name;
    auto st = minimize_and_store(scene, spec, base, root);
    ASSERT_TRUE(st.ok()) << st.error().message;
    auto e = read_corpus_entry(st->path);
    ASSERT_TRUE(e.ok()) << e.error().message;
    CaseSpec again;
    again.method = "brute";
    again.tau = 0.0;
    again.direction = e->info.direction;
    auto st2 = minimize_and_store(e->scene, again, e->info, root);
    ASSERT_TRUE(st2.ok()) << st2.error().message;
    EXPECT_EQ(st2->path, st->path) << f << ": re-minimising changed the case";
    EXPECT_EQ(list_corpus(root).size(), 1u);
    ReplayResult r = replay_entry(*e);
    EXPECT_TRUE(r.ok) << r.message;  // stored open, brute still fails it
    fs::remove_all(root);
  }
}

// A fragment method that ignores every blocker: its one fragment is the whole light,
// every sample visible, fraction 1. Independent of the oracle it is checked against.
class SeeThrough : public Solver {
 public:
  std::string name() const override { return "see-through"; }
  bool reports_fragments() const override { return true; }
  bool normalises_scale() const override { return false; }

 protected:
  SolveResult solve_scene(const Scene& scene, const SolveOptions&) override {
    SolveResult r = make_empty_result(scene);
    for (auto& rr : r.receivers) {
      for (size_t b = 0; b < scene.samples_per_receiver(); ++b) rr.set_visible(b, true);
      rr.visible_fraction.assign(scene.lights.size(), 1.0f);
      rr.fragments.assign(scene.lights.size(), {});
      for (size_t l = 0; l < scene.lights.size(); ++l) rr.fragments[l].push_back(scene.lights[l].polygon);
    }
    return r;
  }
};

// A fraction mismatch (no sample of the scene wrong: its 4 samples miss the blocker)
// becomes the relation mismatch of a light point behind the blocker, on any light plane
// (axis-aligned near the origin, tilted far from it).
TEST(Minimize, FractionMismatchHasALatticeWitnessBehindTheBlocker) {
  for (bool far : {false, true}) {
    Scene s;
    s.name = far ? "far-tilted" : "unit";
    const Vec3f off = far ? Vec3f(4.5e5f, -3.25e5f, 1.5e5f) : Vec3f(0, 0, 0);
    Light l;
    if (far)
      l.polygon = {off + Vec3f(-1, -1, 2), off + Vec3f(1, -1, 2.5f), off + Vec3f(1, 1, 2.5f), off + Vec3f(-1, 1, 2)};
    else
      l.polygon = {Vec3f(-1, -1, 2), Vec3f(1, -1, 2), Vec3f(1, 1, 2), Vec3f(-1, 1, 2)};
    l.samples = 4;
    l.pattern = SamplePattern::Explicit;
    l.jitter = 1;
    l.explicit_samples = {l.polygon[0] * 0.9f + l.polygon[2] * 0.1f, l.polygon[1] * 0.9f + l.polygon[3] * 0.1f,
                          l.polygon[2] * 0.9f + l.polygon[0] * 0.1f, l.polygon[3] * 0.9f + l.polygon[1] * 0.1f};
    s.lights.push_back(l);
    // A small blocker halfway up, over the receiver: it hides the light's centre only.
    s.mesh.vertices = {off + Vec3f(-0.2f, -0.2f, 1), off + Vec3f(0.2f, -0.2f, 1), off + Vec3f(0, 0.25f, 1)};
    s.mesh.triangles = {{0, 1, 2}};
    s.receivers.push_back({off, Vec3f(0, 0, 1)});
    ASSERT_TRUE(finish_scene(s).ok());
    SeeThrough see;
    SolveResult res = see.solve(s, SolveOptions{});
    auto exact = oracle::run_relation_oracle(s, 1);
    EXPECT_EQ(oracle::compare_relations(s, res, exact, 1e-5).mismatch_count(), 0u) << s.name;
    auto reg = oracle::compare_regions(s, res, {0}, 1e-5);
    bool fraction = false;  // (the whole-light fragment's interior point may be blocked too)
    for (const auto& m : reg.mismatches) fraction |= m.direction == oracle::Direction::FractionError;
    EXPECT_TRUE(fraction) << s.name;

    auto lat = light_lattice_scene(s, 0, 0, 16);
    ASSERT_TRUE(lat.ok());
    EXPECT_GT(lat->lights[0].samples, 100);  // most of the 256 cells of a near-square light
    for (const Vec3f& q : lat->lights[0].explicit_samples) {
      // On the light's plane up to the float rounding of the point.
      const Vec3d a = to_double(l.polygon[0]), n = cross(to_double(l.polygon[1]) - a, to_double(l.polygon[3]) - a);
      EXPECT_LE(std::abs(dot(to_double(q) - a, n)) / length(n), 0x1p-20 * (far ? 4.5e5 : 1.0)) << s.name;
    }

    auto w = find_fraction_witness(s, see, SolveOptions{}, 0, 0, 1e-5);
    ASSERT_TRUE(w.has_value()) << s.name;
    EXPECT_EQ(w->direction, "false-visible");
    const Light& wl = w->scene.lights[0];
    oracle::RelationAnswer a = oracle::classify_segment(w->scene, w->scene.receivers[0].p,
                                                        sample_position(wl, int(w->sample), 0));
    EXPECT_EQ(a.cls, oracle::RelationClass::Blocked) << s.name;
    EXPECT_GE(a.margin, 1e-5) << s.name;
  }
}

}  // namespace
}  // namespace visgate::harness
