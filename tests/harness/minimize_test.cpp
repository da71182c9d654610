// tools/harness/minimize and store: the minimiser on real brute-force failures (at most
// 3 triangles, the signature kept, idempotent) and the fraction witness of a fragment
// method's fraction mismatch.
#include <gtest/gtest.h>

#include <filesystem>

#include "oracle/comparator.h"
#include "tests/support/family_scene.h"
#include "tools/harness/corpus.h"
#include "tools/harness/minimize.h"
#include "tools/harness/store.h"

namespace visgate::harness {
namespace {

using visgate::test_support::family;

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
